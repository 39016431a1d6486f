"""Gaussian fits and surface distances of a ``dask.array.Array`` of points, block by block.

Every pass of a fit maps a per-chunk kernel (:mod:`pcmm_geo.fit.scale.chunked`) over the
blocks of the array and adds the small results up in a binary tree of tasks; only those
sums (a few dozen numbers per block) travel to the caller.  The array is never
materialised, so a cloud larger than memory -- or one generated block by block -- is fitted
with the memory of a few blocks.  The computation runs on whatever dask scheduler is
active: threads by default, a ``dask.distributed`` cluster when a client is active.

Passes per fit (:mod:`pcmm_geo.fit.scale.fits`): line and plane 2 (moments, residual
statistics); sphere 1 + the Gauss-Newton passes (typically 2-3); cylinder 1 + a fit of a
strided subsample (the start) + the Gauss-Newton passes.  ``residuals`` of the
results stay lazy dask arrays; ``rms`` and ``form`` are computed in the last pass.
Weights are not supported for dask input.  Like :mod:`~pcmm_geo.fit.scale.fits`, the
functions return the fields of the result (the element modules build the result object).
"""

from __future__ import annotations

import math
import uuid
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError, TooFewPointsError
from pcmm_geo.fit.scale.chunked import IllConditionedSteps, Kernel, Reducer, Sums, reduce_chunks
from pcmm_geo.fit.scale.fits import (
    Source,
    fit_cylinder_scaled,
    fit_line_scaled,
    fit_plane_scaled,
    fit_sphere_scaled,
)

FloatArray = NDArray[np.float64]

# ---------------------------------------------------------------------- plumbing


def as_dask_points(points: Any, *, element: str, min_points: int, name: str = "points") -> Any:
    """Check a dask array of points: shape (N, 3), numeric, at least ``min_points`` rows; float64, one column chunk."""
    if points.ndim != 2 or points.shape[1] != 3:
        raise InvalidInputError(name, "shape (N, 3)", f"shape {points.shape}")
    if not np.issubdtype(points.dtype, np.number):
        raise InvalidInputError(name, "an array of numbers", f"dtype {points.dtype}")
    if math.isnan(points.shape[0]):
        points = points.compute_chunk_sizes()
    if points.shape[0] < min_points:
        raise TooFewPointsError(element, min_points, int(points.shape[0]))
    if points.dtype != np.float64:
        points = points.astype(np.float64)
    if len(points.chunks[1]) > 1:
        points = points.rechunk({1: -1})
    return points


def _block_sums(block: Any, kernel: Kernel, args: tuple) -> Sums:
    return reduce_chunks(np.asarray(block, dtype=np.float64), kernel, args)


def _add(left: Sums, right: Sums) -> Sums:
    return left + right


def reduce_blocks(points: Any, kernel: Kernel, args: tuple) -> Sums:
    """One pass: ``kernel`` over every block (in chunks), the partial sums added in a binary tree of tasks."""
    import dask

    tasks = [dask.delayed(_block_sums)(block, kernel, args) for block in points.to_delayed().ravel()]
    while len(tasks) > 1:
        tasks = [dask.delayed(_add)(tasks[i], tasks[i + 1]) if i + 1 < len(tasks) else tasks[i]
                 for i in range(0, len(tasks), 2)]
    (total,) = dask.compute(tasks[0])
    return total


def dask_reducer(points: Any) -> Reducer:
    """The reducer of a dask array (per-row outputs are not written: residuals stay lazy)."""

    def reduce(kernel: Kernel, args: tuple, out: FloatArray | None) -> Sums:
        del out
        return reduce_blocks(points, kernel, args)

    return reduce


def _no_weights(weights: Any) -> None:
    if weights is not None:
        raise InvalidInputError("weights", "no weights with a dask array of points (not supported)", "weights")


def lazy_rows(points: Any, function: Any, *args: Any, columns: int | None = None) -> Any:
    """``function(block, *args)`` per block: (rows,) or (rows, columns) results, lazily."""
    name = f"pcmm-{function.__name__.strip('_')}-{uuid.uuid4().hex}"
    if columns is None:
        return points.map_blocks(function, *args, drop_axis=1, dtype=np.float64, name=name)
    return points.map_blocks(function, *args, chunks=(points.chunks[0], (columns,)), dtype=np.float64, name=name)


# ---------------------------------------------------------------------- fits


def dask_source(points: Any) -> Source:
    """A checked dask array of points as a :class:`~pcmm_geo.fit.scale.fits.Source` (lazy rows)."""

    def first_row() -> FloatArray:
        return np.asarray(points[:1].compute(), dtype=np.float64)[0]

    def every(stride: int) -> FloatArray:
        return np.asarray(points[::stride].compute(), dtype=np.float64)

    def rows(function: Any, *args: Any, columns: int | None = None) -> Any:
        return lazy_rows(points, function, *args, columns=columns)

    return Source(reduce=dask_reducer(points), first_row=first_row, every=every, rows=rows, lazy=True)


def _degenerate(element: str, what: str) -> DegenerateGeometryError:
    return DegenerateGeometryError(element, f"points are (nearly) {what}; no unique {element} fits them")


def fit_plane_dask(points: Any, *, weights: Any = None) -> dict[str, Any]:
    """:func:`pcmm_geo.fit.fit_plane` of a dask array (two passes; lazy residuals)."""
    _no_weights(weights)
    try:
        return fit_plane_scaled(dask_source(as_dask_points(points, element="plane", min_points=3)))
    except IllConditionedSteps:
        raise _degenerate("plane", "collinear") from None


def fit_line_dask(points: Any, *, weights: Any = None) -> dict[str, Any]:
    """:func:`pcmm_geo.fit.fit_line` of a dask array of 3-D points (two passes; lazy residuals)."""
    _no_weights(weights)
    return fit_line_scaled(dask_source(as_dask_points(points, element="line", min_points=2)))


def fit_sphere_dask(points: Any, *, radius: float | None = None, weights: Any = None) -> tuple[Any, Any]:
    """:func:`pcmm_geo.fit.fit_sphere` of a dask array (moments, then Gauss-Newton passes; lazy residuals)."""
    _no_weights(weights)
    pts = as_dask_points(points, element="sphere", min_points=4 if radius is None else 3)
    try:
        return fit_sphere_scaled(dask_source(pts), radius)
    except IllConditionedSteps:
        raise _degenerate("sphere", "coplanar") from None


def fit_cylinder_dask(points: Any, *, radius: float | None = None, weights: Any = None, axis_hint: Any = None,
                      **passed: Any) -> dict[str, Any]:
    """:func:`pcmm_geo.fit.fit_cylinder` of a dask array (subsample start, Gauss-Newton passes; lazy residuals)."""
    _no_weights(weights)
    pts = as_dask_points(points, element="cylinder", min_points=5 if radius is None else 4)
    try:
        return fit_cylinder_scaled(dask_source(pts), radius, axis_hint, **passed)
    except IllConditionedSteps:
        raise _degenerate("cylinder", "coplanar") from None
