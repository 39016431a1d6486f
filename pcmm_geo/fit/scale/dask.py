"""Gaussian fits and surface distances of a ``dask.array.Array`` of points, block by block.

Every pass of a fit maps a per-chunk kernel (:mod:`pcmm_geo.fit.scale.chunked`) over the
blocks of the array and adds the small results up in a binary tree of tasks; only those
sums (a few dozen numbers per block) travel to the caller.  The array is never
materialised, so a cloud larger than memory -- or one generated block by block -- is fitted
with the memory of a few blocks.  The computation runs on whatever dask scheduler is
active: threads by default, a ``dask.distributed`` cluster when a client is active.

Passes per fit: line and plane 2 (moments, residual statistics); sphere 1 + the
Gauss-Newton passes (typically 2-3); cylinder 1 + a fit of a strided subsample of at most
``SUBSAMPLE_ROWS`` points (the start) + the Gauss-Newton passes.  ``residuals`` of the
results stay lazy dask arrays; ``rms`` and ``form`` are computed in the last pass.
Weights are not supported for dask input.
"""

from __future__ import annotations

import math
import uuid
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError, TooFewPointsError
from pcmm_geo.fit._core import TOL, rotation_to_z
from pcmm_geo.fit.scale.chunked import (
    IllConditionedSteps,
    Kernel,
    Moments,
    NormalEquations,
    Reducer,
    Sums,
    covariance_from_gram,
    gauss_newton,
    moments,
    pack_normal_equations,
    reduce_chunks,
)

if TYPE_CHECKING:
    from pcmm_geo.artefacts.cad_distance import SurfaceDistances, SurfaceIndex
    from pcmm_geo.fit.cylinder import CylinderFit
    from pcmm_geo.fit.line import LineFit
    from pcmm_geo.fit.plane import PlaneFit
    from pcmm_geo.fit.sphere import SphereFit

FloatArray = NDArray[np.float64]

#: points of the strided subsample whose in-memory fit starts the cylinder iteration
SUBSAMPLE_ROWS = 20_000
#: a singular-value ratio below this (from a Gram matrix, so not below ~1e-8) means degenerate data
_GRAM_DEGENERATE = 1e-7


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


def _checked_moments(points: Any, element: str) -> tuple[Moments, FloatArray]:
    """Moments about the centroid (one pass, relative to the first point); refuse NaN/inf and identical points."""
    shift = np.asarray(points[:1].compute(), dtype=np.float64)[0]
    data = moments(dask_reducer(points), shift)
    if not data.finite or not np.all(np.isfinite(shift)):
        raise InvalidInputError("points", "finite coordinates", "NaN or inf in the dask array")
    scale = max(float(np.abs(np.r_[data.lower, data.upper]).max()), 1.0)
    if float(np.max(data.upper - data.lower)) <= TOL.identical * scale:
        raise DegenerateGeometryError(element, f"all {data.count} points are identical")
    return data, shift


def _no_weights(weights: Any) -> None:
    if weights is not None:
        raise InvalidInputError("weights", "no weights with a dask array of points (not supported)", "weights")


def _lazy_rows(points: Any, function: Any, *args: Any, columns: int | None = None) -> Any:
    """``function(block, *args)`` per block: (rows,) or (rows, columns) results, lazily."""
    name = f"pcmm-{function.__name__.strip('_')}-{uuid.uuid4().hex}"
    if columns is None:
        return points.map_blocks(function, *args, drop_axis=1, dtype=np.float64, name=name)
    return points.map_blocks(function, *args, chunks=(points.chunks[0], (columns,)), dtype=np.float64, name=name)


# ---------------------------------------------------------------------- plane and line


def _projection_kernel(chunk: FloatArray, centroid: FloatArray, axes: FloatArray, *,
                       out: FloatArray | None = None) -> Sums:
    """Sum of squares, minimum and maximum of ``(p - centroid) . axes[0]`` (plane) or of the distance to a line.

    ``axes`` (K, 3): one row -- signed distance along it; two rows -- length of the components.
    """
    del out
    components = np.einsum("kj,ij->ki", axes, chunk - centroid)
    values = components[0] if len(axes) == 1 else np.sqrt(np.einsum("ki,ki->i", components, components))
    return Sums(np.array([np.einsum("i,i->", values, values)]), np.array([values.min()]), np.array([values.max()]))


def _plane_residuals(block: FloatArray, point: FloatArray, normal: FloatArray) -> FloatArray:
    return (np.asarray(block, dtype=np.float64) - point) @ normal


def _line_components(block: FloatArray, point: FloatArray, e1: FloatArray, e2: FloatArray) -> FloatArray:
    relative = np.asarray(block, dtype=np.float64) - point
    return np.column_stack([relative @ e1, relative @ e2])


def _line_distances(block: FloatArray, point: FloatArray, e1: FloatArray, e2: FloatArray) -> FloatArray:
    return np.linalg.norm(_line_components(block, point, e1, e2), axis=1)


def _principal(data: Moments) -> tuple[FloatArray, FloatArray]:
    """Eigenvalues (descending) and eigenvectors (rows) of the scatter matrix."""
    eigen, vectors = np.linalg.eigh(data.scatter)
    return np.maximum(eigen[::-1], 0.0), vectors[:, ::-1].T


def fit_plane_dask(points: Any, *, weights: Any = None) -> PlaneFit:
    """:func:`pcmm_geo.fit.fit_plane` of a dask array (two passes; lazy residuals)."""
    from pcmm_geo.fit._linear import propagate, sign_convention
    from pcmm_geo.fit.plane import PlaneFit

    _no_weights(weights)
    pts = as_dask_points(points, element="plane", min_points=3)
    data, _ = _checked_moments(pts, "plane")
    eigen, vectors = _principal(data)
    if np.sqrt(eigen[1]) <= _GRAM_DEGENERATE * np.sqrt(eigen[0]):
        raise DegenerateGeometryError("plane", "points are collinear; a plane needs points spanning two directions")
    normal = sign_convention(vectors[2])
    e1, e2 = vectors[0], vectors[1]
    stats = reduce_blocks(pts, _projection_kernel, (data.centroid, normal[None, :]))
    cost = float(stats.total[0])
    count = data.count
    cov_local, condition = covariance_from_gram(np.diag([count, eigen[0], eigen[1]]), cost, count - 3)
    gradient = np.zeros((6, 3))
    gradient[:3, 0] = normal
    gradient[3:, 1] = e1
    gradient[3:, 2] = e2
    return PlaneFit(
        point=data.centroid.copy(), normal=normal.copy(),
        residuals=_lazy_rows(pts, _plane_residuals, data.centroid, normal),
        rms=float(np.sqrt(cost / count)), form=float(stats.high[0] - stats.low[0]), n=count, dof=count - 3,
        parameter_names=("point_x", "point_y", "point_z", "normal_x", "normal_y", "normal_z"),
        parameters=np.concatenate([data.centroid, normal]), covariance=propagate(cov_local, gradient),
        condition_number=condition, converged=True, iterations=0,
        message="closed form (eigenvectors of the scatter matrix, accumulated block by block)",
    )


def fit_line_dask(points: Any, *, weights: Any = None) -> LineFit:
    """:func:`pcmm_geo.fit.fit_line` of a dask array of 3-D points (two passes; lazy residuals)."""
    from pcmm_geo.fit._linear import propagate, sign_convention
    from pcmm_geo.fit.line import LineFit

    _no_weights(weights)
    pts = as_dask_points(points, element="line", min_points=2)
    data, _ = _checked_moments(pts, "line")
    eigen, vectors = _principal(data)
    if data.count > 2 and eigen[1] >= (1 - 1e-12) ** 2 * eigen[0]:
        raise DegenerateGeometryError("line", "points have no preferred direction (isotropic spread)")
    direction = sign_convention(vectors[0])
    e1, e2 = vectors[1], vectors[2]
    stats = reduce_blocks(pts, _projection_kernel, (data.centroid, np.vstack([e1, e2])))
    cost = float(stats.total[0])
    count = data.count
    gram = np.diag([count, count, eigen[0], eigen[0]]).astype(float)
    cov_local, condition = covariance_from_gram(gram, cost, 2 * count - 4)
    gradient = np.zeros((6, 4))
    gradient[:3, 0] = e1
    gradient[:3, 1] = e2
    gradient[3:, 2] = e1
    gradient[3:, 3] = e2
    return LineFit(
        point=data.centroid.copy(), direction=direction.copy(),
        residuals=_lazy_rows(pts, _line_distances, data.centroid, e1, e2),
        rms=float(np.sqrt(cost / count)), form=2.0 * float(stats.high[0]), n=count, dof=2 * count - 4,
        parameter_names=("point_x", "point_y", "point_z", "direction_x", "direction_y", "direction_z"),
        parameters=np.concatenate([data.centroid, direction]), covariance=propagate(cov_local, gradient),
        condition_number=condition, converged=True, iterations=0,
        message="closed form (eigenvectors of the scatter matrix, accumulated block by block)",
        extra={"residual_components": _lazy_rows(pts, _line_components, data.centroid, e1, e2, columns=2)},
    )


# ---------------------------------------------------------------------- sphere


def _sphere_residuals(block: FloatArray, center: FloatArray, radius: float) -> FloatArray:
    return np.linalg.norm(np.asarray(block, dtype=np.float64) - center, axis=1) - radius


def fit_sphere_dask(points: Any, *, radius: float | None = None, weights: Any = None) -> SphereFit:
    """:func:`pcmm_geo.fit.fit_sphere` of a dask array (moments, then Gauss-Newton passes; lazy residuals)."""
    from pcmm_geo.fit.scale.sphere import fit_nsphere_chunked
    from pcmm_geo.fit.sphere import sphere_result

    _no_weights(weights)
    pts = as_dask_points(points, element="sphere", min_points=4 if radius is None else 3)
    data, shift = _checked_moments(pts, "sphere")
    try:
        found = fit_nsphere_chunked(dask_reducer(pts), shift, element="sphere", fixed_radius=radius, data=data)
    except IllConditionedSteps:
        raise DegenerateGeometryError("sphere", "points are (nearly) coplanar; no unique sphere passes through "
                                      "them") from None
    return sphere_result(found.center, found.radius, _lazy_rows(pts, _sphere_residuals, found.center, found.radius),
                         rms=found.rms, form=found.form, n=found.count, parameter_count=found.parameter_count,
                         covariance=found.covariance, condition=found.condition, converged=found.converged,
                         iterations=found.iterations, message=found.message, fixed=radius is not None)


# ---------------------------------------------------------------------- cylinder


def _cylinder_kernel(chunk: FloatArray, centroid: FloatArray, rotation: FloatArray, params: FloatArray,
                     fixed_radius: float | None, *, out: FloatArray | None = None) -> Sums:
    from pcmm_geo.fit.cylinder import _cylinder_model

    del out
    local = (chunk - centroid) @ rotation.T
    residuals, jacobian = _cylinder_model(fixed_radius)(local, params)
    return pack_normal_equations(-jacobian.T, residuals)


def _cylinder_residuals(block: FloatArray, point: FloatArray, axis: FloatArray, radius: float) -> FloatArray:
    return np.linalg.norm(np.cross(np.asarray(block, dtype=np.float64) - point, axis), axis=1) - radius


def fit_cylinder_dask(points: Any, *, radius: float | None = None, weights: Any = None,
                      axis_hint: Any = None) -> CylinderFit:
    """:func:`pcmm_geo.fit.fit_cylinder` of a dask array.

    The start is the in-memory fit of every k-th point (at most ``SUBSAMPLE_ROWS``); the
    least-squares cylinder of all points is then reached by Gauss-Newton passes whose normal
    equations are accumulated block by block.
    """
    from pcmm_geo.fit._axial import canonical_axis, local_direction
    from pcmm_geo.fit.cylinder import CylinderFit, axis_point_jacobian, fit_cylinder

    _no_weights(weights)
    pts = as_dask_points(points, element="cylinder", min_points=5 if radius is None else 4)
    data, _ = _checked_moments(pts, "cylinder")
    eigen, _ = _principal(data)
    if np.sqrt(eigen[2]) <= _GRAM_DEGENERATE * np.sqrt(eigen[0]):
        raise DegenerateGeometryError("cylinder", "points lie in a plane (or on a line); no unique cylinder")
    stride = max(1, math.ceil(data.count / SUBSAMPLE_ROWS))
    start = fit_cylinder(np.asarray(pts[::stride].compute()), radius=radius, axis_hint=axis_hint)
    rotation = rotation_to_z(start.axis)
    foot = rotation @ (start.point - data.centroid)
    x0 = np.array([foot[0], foot[1], 0.0, 0.0] + ([] if radius is not None else [start.radius]))
    size = len(x0)
    reduce = dask_reducer(pts)

    def evaluate(params: FloatArray) -> NormalEquations:
        return NormalEquations.from_sums(reduce(_cylinder_kernel, (data.centroid, rotation, params, radius), None),
                                         size)

    outcome = gauss_newton(evaluate, x0, element="cylinder", scale=float(np.sqrt(data.second / data.count)))
    x0_, y0_, a, b = (float(v) for v in outcome.x[:4])
    fitted_radius = float(radius) if radius is not None else float(outcome.x[4])
    direction_local = local_direction(a, b)
    origin_local = np.array([x0_, y0_, 0.0])
    foot_local = origin_local - (origin_local @ direction_local) * direction_local
    axis = rotation.T @ direction_local
    point = data.centroid + rotation.T @ foot_local
    signed_axis = canonical_axis(axis)
    equations = outcome.equations
    cov_local, condition = covariance_from_gram(equations.gram, equations.cost, data.count - size)
    d_point, d_axis = axis_point_jacobian(rotation, foot_local)
    if float(signed_axis @ axis) < 0:
        d_axis = -d_axis
    gradient = np.zeros((7, size))
    gradient[0:3, 0:4] = d_point
    gradient[3:6, 0:4] = d_axis
    if radius is None:
        gradient[6, 4] = 1.0
    return CylinderFit(
        point=point, axis=signed_axis.copy(), radius=fitted_radius,
        residuals=_lazy_rows(pts, _cylinder_residuals, point, signed_axis, fitted_radius),
        rms=float(np.sqrt(equations.cost / data.count)), form=equations.high - equations.low, n=data.count,
        dof=data.count - size,
        parameter_names=("point_x", "point_y", "point_z", "axis_x", "axis_y", "axis_z", "radius"),
        parameters=np.array([*point, *signed_axis, fitted_radius]), covariance=gradient @ cov_local @ gradient.T,
        condition_number=condition, converged=outcome.converged, iterations=outcome.iterations,
        message=outcome.message, method="gaussian" if radius is None else "gaussian-fixed-radius",
    )


# ---------------------------------------------------------------------- surface distances


def _packed_distances(block: FloatArray, index: SurfaceIndex) -> FloatArray:
    found = index.distances(np.asarray(block, dtype=np.float64))
    return np.column_stack([found.closest, found.signed_distance, found.face_index.astype(np.float64),
                            found.direction])


def lazy_surface_distances(index: SurfaceIndex, points: Any) -> SurfaceDistances:
    """Signed distances of a dask array of points, block by block; every field a lazy dask array."""
    from pcmm_geo.artefacts.cad_distance import SurfaceDistances

    pts = as_dask_points(points, element="mesh distance", min_points=1)
    packed = _lazy_rows(pts, _packed_distances, index, columns=8)
    return SurfaceDistances(closest=packed[:, 0:3], signed_distance=packed[:, 3],
                            face_index=packed[:, 4].astype(np.int64), direction=packed[:, 5:8])
