"""Gaussian line, plane, sphere and cylinder from passes over a :class:`Source` of points.

The same code fits an in-memory array in cache-sized chunks (:func:`numpy_source`) and a
dask array block by block (:func:`pcmm_geo.fit.scale.dask.dask_source`):

* **plane, line** -- one moment pass (centroid and scatter matrix; its eigenvectors are the
  principal directions), then the residuals (numpy: computed; dask: lazy, with rms and form
  from one statistics pass);
* **sphere** -- :func:`pcmm_geo.fit.scale.sphere.fit_nsphere_chunked`;
* **cylinder** -- the in-memory fit of a strided subsample of at most ``SUBSAMPLE_ROWS``
  points (multi-start, robust, cheap) starts Gauss-Newton passes over all points whose
  normal equations are accumulated chunk by chunk.

The functions return the fields of the element's result class (the element modules, which
import this one, build it: no import goes back up).  Near-degenerate data raise
:class:`~pcmm_geo.fit.scale.chunked.IllConditionedSteps`: the in-memory callers then use
their orthogonal-decomposition path, the dask callers report degenerate geometry.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError
from pcmm_geo.fit._kernels import _tall
from pcmm_geo.fit._kernels._core import TOL, rotation_to_z
from pcmm_geo.fit._kernels._inputs import check_point_extremes
from pcmm_geo.fit.scale.chunked import (
    IllConditionedSteps,
    Moments,
    NormalEquations,
    Reducer,
    Sums,
    covariance_from_gram,
    gauss_newton,
    in_memory,
    map_chunks,
    moments,
    pack_normal_equations,
)
from pcmm_geo.fit.scale.sphere import SphereSolution, fit_nsphere_chunked

FloatArray = NDArray[np.float64]

#: points of the strided subsample whose in-memory fit starts the cylinder iteration (at most; fewer than
#: ``_tall.TALL_ROWS``, so that the subsample is fitted by the orthogonal routines, not by this module again)
SUBSAMPLE_ROWS = 19_999
#: a singular-value ratio below this (from a Gram matrix, so not below ~1e-8) is not trusted
_GRAM_DEGENERATE = 1e-7


@dataclass(frozen=True)
class Source:
    """Points to fit, seen through passes.

    Attributes
    ----------
    reduce : callable
        One pass of a chunk kernel (see :mod:`~pcmm_geo.fit.scale.chunked`).
    first_row : callable
        ``() -> (3,)`` the first point (the shift that conditions the sums).
    every : callable
        ``(stride) -> (M, 3)`` every ``stride``-th point, in memory.
    rows : callable
        ``(function, *args, columns=None)``: ``function(points, *args)`` row by row -- a numpy
        array in memory, a lazy dask array for dask input.
    lazy : bool
        True for dask input: residual statistics then need a pass of their own.
    check : callable or None
        ``(lower, upper)``: the value checks of in-memory points from the coordinate extremes of
        the moment pass (:func:`~pcmm_geo.fit._kernels._inputs.check_point_extremes`, which
        names the row of a bad value); None for dask input.
    """

    reduce: Reducer
    first_row: Callable[[], FloatArray]
    every: Callable[[int], FloatArray]
    rows: Callable[..., Any]
    lazy: bool
    check: Callable[[FloatArray, FloatArray], None] | None = None


def numpy_source(points: FloatArray, *, element: str, min_points: int) -> Source:
    """An in-memory (N, 3) float64 array, its values not checked yet, as a :class:`Source`.

    Per-row results are computed chunk by chunk into one output array (no temporaries of
    the size of the data).
    """

    def rows(function: Callable[..., FloatArray], *args: Any, columns: int | None = None) -> FloatArray:
        return map_chunks(points, function, args, columns)

    def check(lower: FloatArray, upper: FloatArray) -> None:
        check_point_extremes(points, lower, upper, element=element, min_points=min_points, identical=TOL.identical)

    return Source(reduce=in_memory(points), first_row=lambda: points[0].copy(), every=lambda stride: points[::stride],
                  rows=rows, lazy=False, check=check)


def checked_moments(source: Source, element: str) -> tuple[Moments, FloatArray]:
    """Moments about the centroid (one pass, relative to the first point); refuse NaN/inf and identical points."""
    shift = np.asarray(source.first_row(), dtype=np.float64)
    data = moments(source.reduce, shift)
    if source.check is not None:
        source.check(data.lower, data.upper)
        if not data.finite:  # valid coordinates whose sums overflow: the orthogonal routines take them
            raise IllConditionedSteps(element)
    if not data.finite or not np.all(np.isfinite(shift)):
        raise InvalidInputError("points", "finite coordinates", "NaN or inf among the points")
    scale = max(float(np.abs(np.r_[data.lower, data.upper]).max()), 1.0)
    if float(np.max(data.upper - data.lower)) <= TOL.identical * scale:
        raise DegenerateGeometryError(element, f"all {data.count} points are identical")
    return data, shift


def _principal(data: Moments) -> tuple[FloatArray, FloatArray]:
    """Eigenvalues (descending) and eigenvectors (rows) of the scatter matrix."""
    eigen, vectors = np.linalg.eigh(data.scatter)
    return np.maximum(eigen[::-1], 0.0), vectors[:, ::-1].T


def _statistics_kernel(chunk: FloatArray, function: Callable[..., FloatArray], args: tuple, *,
                       out: FloatArray | None = None) -> Sums:
    del out
    values = function(chunk, *args)
    return Sums(np.array([np.einsum("i,i->", values, values)]), np.array([values.min()]), np.array([values.max()]))


def _statistics(source: Source, residuals: Any, function: Callable[..., FloatArray],
                args: tuple) -> tuple[float, float, float]:
    """Sum of squares, minimum and maximum of the residuals (one pass for lazy ones)."""
    if not source.lazy:
        return float(residuals @ residuals), float(residuals.min()), float(residuals.max())
    sums = source.reduce(_statistics_kernel, (function, args), None)
    return float(sums.total[0]), float(sums.low[0]), float(sums.high[0])


# ---------------------------------------------------------------------- plane and line


def plane_residuals(points: FloatArray, point: FloatArray, normal: FloatArray) -> FloatArray:
    return (np.asarray(points, dtype=np.float64) - point) @ normal


def line_components(points: FloatArray, point: FloatArray, e1: FloatArray, e2: FloatArray) -> FloatArray:
    relative = np.asarray(points, dtype=np.float64) - point
    return np.column_stack([relative @ e1, relative @ e2])


def line_distances(points: FloatArray, point: FloatArray, e1: FloatArray, e2: FloatArray) -> FloatArray:
    return np.linalg.norm(line_components(points, point, e1, e2), axis=1)


def fit_plane_scaled(source: Source) -> dict[str, Any]:
    """Fields of :func:`pcmm_geo.fit.fit_plane`'s result from a moment pass (unweighted)."""
    from pcmm_geo.fit._kernels._linear import propagate, sign_convention

    data, _ = checked_moments(source, "plane")
    eigen, vectors = _principal(data)
    if not np.sqrt(eigen[1]) > _GRAM_DEGENERATE * np.sqrt(eigen[0]):
        raise IllConditionedSteps("plane")
    normal = sign_convention(vectors[2])
    e1, e2 = vectors[0], vectors[1]
    residuals = source.rows(plane_residuals, data.centroid, normal)
    cost, low, high = _statistics(source, residuals, plane_residuals, (data.centroid, normal))
    count = data.count
    cov_local, condition = covariance_from_gram(np.diag([count, eigen[0], eigen[1]]), cost, count - 3)
    gradient = np.zeros((6, 3))
    gradient[:3, 0] = normal
    gradient[3:, 1] = e1
    gradient[3:, 2] = e2
    return dict(
        point=data.centroid.copy(), normal=normal.copy(), residuals=residuals,
        rms=float(np.sqrt(cost / count)), form=high - low, n=count, dof=count - 3,
        parameter_names=("point_x", "point_y", "point_z", "normal_x", "normal_y", "normal_z"),
        parameters=np.concatenate([data.centroid, normal]), covariance=propagate(cov_local, gradient),
        condition_number=condition, converged=True, iterations=0,
        message="closed form (eigenvectors of the scatter matrix, accumulated in chunks)",
    )


def fit_line_scaled(source: Source) -> dict[str, Any]:
    """Fields of :func:`pcmm_geo.fit.fit_line`'s result for 3-D points from a moment pass (unweighted)."""
    from pcmm_geo.fit._kernels._linear import propagate, sign_convention

    data, _ = checked_moments(source, "line")
    eigen, vectors = _principal(data)
    if data.count > 2 and eigen[1] >= (1 - 1e-12) ** 2 * eigen[0]:
        raise DegenerateGeometryError("line", "points have no preferred direction (isotropic spread)")
    direction = sign_convention(vectors[0])
    e1, e2 = vectors[1], vectors[2]
    residuals = source.rows(line_distances, data.centroid, e1, e2)
    cost, _, high = _statistics(source, residuals, line_distances, (data.centroid, e1, e2))
    count = data.count
    gram = np.diag([count, count, eigen[0], eigen[0]]).astype(float)
    cov_local, condition = covariance_from_gram(gram, cost, 2 * count - 4)
    gradient = np.zeros((6, 4))
    gradient[:3, 0] = e1
    gradient[:3, 1] = e2
    gradient[3:, 2] = e1
    gradient[3:, 3] = e2
    return dict(
        point=data.centroid.copy(), direction=direction.copy(), residuals=residuals,
        rms=float(np.sqrt(cost / count)), form=2.0 * high, n=count, dof=2 * count - 4,
        parameter_names=("point_x", "point_y", "point_z", "direction_x", "direction_y", "direction_z"),
        parameters=np.concatenate([data.centroid, direction]), covariance=propagate(cov_local, gradient),
        condition_number=condition, converged=True, iterations=0,
        message="closed form (eigenvectors of the scatter matrix, accumulated in chunks)",
        extra={"residual_components": source.rows(line_components, data.centroid, e1, e2, columns=2)},
    )


# ---------------------------------------------------------------------- sphere


def sphere_residuals(points: FloatArray, center: FloatArray, radius: float) -> FloatArray:
    return np.linalg.norm(np.asarray(points, dtype=np.float64) - center, axis=1) - radius


def fit_sphere_scaled(source: Source, radius: float | None) -> tuple[SphereSolution, Any]:
    """The sphere of :func:`pcmm_geo.fit.fit_sphere` from passes, and its residuals (lazy for dask input)."""
    data, shift = checked_moments(source, "sphere")
    found = fit_nsphere_chunked(source.reduce, shift, element="sphere", fixed_radius=radius, data=data)
    return found, source.rows(sphere_residuals, found.center, found.radius)


# ---------------------------------------------------------------------- cylinder


def _cylinder_kernel(chunk: FloatArray, centroid: FloatArray, rotation: FloatArray, params: FloatArray,
                     fixed_radius: float | None, model: Callable[..., Any], *, out: FloatArray | None = None) -> Sums:
    local = (chunk - centroid) @ rotation.T
    residuals, jacobian = model(fixed_radius)(local, params)
    if out is not None:
        out[:] = residuals
    return pack_normal_equations(-jacobian.T, residuals)


def cylinder_residuals(points: FloatArray, point: FloatArray, axis: FloatArray, radius: float) -> FloatArray:
    return np.linalg.norm(np.cross(np.asarray(points, dtype=np.float64) - point, axis), axis=1) - radius


def fit_cylinder_scaled(source: Source, radius: float | None, axis_hint: Any = None, *,
                        fit_cylinder: Callable[..., Any], model: Callable[..., Any],
                        axis_point_jacobian: Callable[..., Any]) -> dict[str, Any]:
    """Fields of :func:`pcmm_geo.fit.fit_cylinder`'s result from a subsample start and Gauss-Newton passes.

    ``fit_cylinder`` (the in-memory fit, for the start), ``model`` (residual model factory of
    the fixed radius) and ``axis_point_jacobian`` come from :mod:`pcmm_geo.fit.cylinder`,
    which passes them in (it imports this module).  Unweighted.
    """
    from pcmm_geo.fit._kernels._axial import canonical_axis, local_direction

    data, _ = checked_moments(source, "cylinder")
    eigen, _ = _principal(data)
    if not np.sqrt(eigen[2]) > _GRAM_DEGENERATE * np.sqrt(eigen[0]):
        raise IllConditionedSteps("cylinder")
    stride = max(1, math.ceil(data.count / min(SUBSAMPLE_ROWS, _tall.TALL_ROWS - 1)))
    start = fit_cylinder(np.ascontiguousarray(source.every(stride), dtype=np.float64), radius=radius,
                         axis_hint=axis_hint)
    rotation = rotation_to_z(start.axis)
    foot = rotation @ (start.point - data.centroid)
    x0 = np.array([foot[0], foot[1], 0.0, 0.0] + ([] if radius is not None else [start.radius]))
    size = len(x0)

    def evaluate(params: FloatArray, frame: FloatArray = rotation) -> NormalEquations:
        sums = source.reduce(_cylinder_kernel, (data.centroid, frame, params, radius, model), None)
        return NormalEquations.from_sums(sums, size)

    outcome = gauss_newton(evaluate, x0, element="cylinder", scale=float(np.sqrt(data.second / data.count)))
    x0_, y0_, a, b = (float(v) for v in outcome.x[:4])
    fitted_radius = float(radius) if radius is not None else float(outcome.x[4])
    direction_local = local_direction(a, b)
    origin_local = np.array([x0_, y0_, 0.0])
    axis = rotation.T @ direction_local
    point = data.centroid + rotation.T @ (origin_local - (origin_local @ direction_local) * direction_local)
    signed_axis = canonical_axis(axis)
    # one more pass in the frame of the fitted axis (a = b = 0 there), where the covariance
    # propagation of axis_point_jacobian is exact
    rotation = rotation_to_z(axis)
    foot_local = rotation @ (point - data.centroid)
    foot_local[2] = 0.0
    equations = evaluate(np.r_[foot_local[:2], 0.0, 0.0, outcome.x[4:]], rotation)
    cov_local, condition = covariance_from_gram(equations.gram, equations.cost, data.count - size)
    d_point, d_axis = axis_point_jacobian(rotation, foot_local)
    if float(signed_axis @ axis) < 0:
        d_axis = -d_axis
    gradient = np.zeros((7, size))
    gradient[0:3, 0:4] = d_point
    gradient[3:6, 0:4] = d_axis
    if radius is None:
        gradient[6, 4] = 1.0
    residuals = source.rows(cylinder_residuals, point, signed_axis, fitted_radius)
    return dict(
        point=point, axis=signed_axis.copy(), radius=fitted_radius, residuals=residuals,
        rms=float(np.sqrt(equations.cost / data.count)), form=equations.high - equations.low, n=data.count,
        dof=data.count - size,
        parameter_names=("point_x", "point_y", "point_z", "axis_x", "axis_y", "axis_z", "radius"),
        parameters=np.array([*point, *signed_axis, fitted_radius]), covariance=gradient @ cov_local @ gradient.T,
        condition_number=condition, converged=outcome.converged, iterations=outcome.iterations,
        message=outcome.message, method="gaussian" if radius is None else "gaussian-fixed-radius",
    )
