"""Vectorised Gaussian fits of many small point sets at once.

For thousands of probings of 5-25 points each (e.g. every joint sphere of a
calibration), a Python loop over :func:`~pcmm_geo.fit.fit_sphere` is dominated by
overhead.  These functions take ``(K, N, D)`` stacks and iterate all K problems
together (batched QR Gauss-Newton, no loop over K); each answer equals the single
fit's to rounding.  Every set is centred before fitting, so offsets cost no accuracy.
"""

from __future__ import annotations

from dataclasses import fields

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import ConvergenceError, DegenerateGeometryError, InvalidInputError, TooFewPointsError
from pcmm_geo.fit._kernels._batch_cov import (
    line_covariance,
    nsphere_covariance,
    plane_covariance,
    projected_circle_covariance,
)
from pcmm_geo.fit._kernels._core import TOL
from pcmm_geo.fit._kernels._inputs import check_magnitude, real_array
from pcmm_geo.fit._kernels._linear import frozen, weighted_centroid

__all__ = [
    "BatchFit",
    "CircleBatchFit",
    "LineBatchFit",
    "PlaneBatchFit",
    "SphereBatchFit",
    "fit_circles",
    "fit_lines",
    "fit_planes",
    "fit_spheres",
]

FloatArray = NDArray[np.float64]


@record(kw_only=True)
class BatchFit:
    """Fields shared by every batch result (K sets of N points).

    Attributes
    ----------
    residuals : ndarray, shape (K, N)
        Signed orthogonal distances (mm).
    rms, form : ndarray, shape (K,)
        Root mean square and range (max - min) of each set's residuals (mm).
    n : int
        Points per set.
    converged : ndarray of bool, shape (K,)
    iterations : ndarray of int, shape (K,)
    dof : int
        Degrees of freedom of each fit (as the single fit's).
    parameter_names : tuple of str
        Names of the columns of ``parameters`` and rows/columns of each ``covariance[k]``
        (the single fit's names).
    parameters : ndarray, shape (K, P)
        Fitted parameters of every set (machine frame, mm).
    covariance : ndarray, shape (K, P, P)
        Per-set covariance ``s^2 (J^T J)^-1`` mapped to ``parameters``, as the single fit's.
    """

    residuals: FloatArray
    rms: FloatArray
    form: FloatArray
    n: int
    converged: NDArray[np.bool_]
    iterations: NDArray[np.int64]
    dof: int
    parameter_names: tuple[str, ...]
    parameters: FloatArray
    covariance: FloatArray

    def __len__(self) -> int:
        return int(self.residuals.shape[0])

    @property
    def std_errors(self) -> FloatArray:
        """Standard uncertainty of each parameter of every set, shape (K, P), in the order of ``parameters``.

        Until 0.1 a dict ``{name: (K,)}``; ``std_errors["radius"]`` still answers for one
        release, with a ``DeprecationWarning``.
        """
        from pcmm_geo._deprecation import NamedValues

        diagonal = np.sqrt(np.clip(np.diagonal(self.covariance, axis1=1, axis2=2), 0.0, None))
        return NamedValues(diagonal, self.parameter_names, f"{type(self).__name__}.std_errors")

    def __repr__(self) -> str:
        """Short: the count, the shapes of the geometry and the ranges of the statistics (not K x N numbers)."""
        geometry = ", ".join(
            f"{f.name}={_describe(getattr(self, f.name))}" for f in fields(self) if f.name not in _BATCH_FIELDS
        )
        return (
            f"{type(self).__name__}(K={len(self)}, n={self.n}, {geometry}, rms<={_top(self.rms)}, "
            f"form<={_top(self.form)}, converged={int(np.sum(self.converged))}/{len(self)})"
        )


def _top(values: FloatArray) -> str:
    return f"{float(np.max(values)):.3g}" if np.size(values) else "nan"


def _describe(value: object) -> str:
    if isinstance(value, np.ndarray):
        if value.ndim == 1 and value.size:
            return f"[{float(np.min(value)):.6g}..{float(np.max(value)):.6g}]"
        return f"<{value.shape}>"
    return repr(value)


_BATCH_FIELDS = {f.name for f in fields(BatchFit)}


@record(kw_only=True)
class SphereBatchFit(BatchFit):
    """:func:`fit_spheres` result: ``centers`` (K, 3), ``radii`` (K,)."""

    centers: FloatArray
    radii: FloatArray


@record(kw_only=True)
class CircleBatchFit(BatchFit):
    """:func:`fit_circles` result: ``centers`` (K, D), ``radii`` (K,), ``normals`` (K, 3) or None (2-D)."""

    centers: FloatArray
    radii: FloatArray
    normals: FloatArray | None


@record(kw_only=True)
class PlaneBatchFit(BatchFit):
    """:func:`fit_planes` result: ``points`` (K, 3) centroids, unit ``normals`` (K, 3)."""

    points: FloatArray
    normals: FloatArray


@record(kw_only=True)
class LineBatchFit(BatchFit):
    """:func:`fit_lines` result: ``points`` (K, D) centroids, unit ``directions`` (K, D).

    In 3-D the residuals are the (non-negative) distances to each line.
    """

    points: FloatArray
    directions: FloatArray


def _ragged_sizes(points: object) -> list[int] | None:
    """Set sizes of a list of sets whose sizes differ (None when not such a list)."""
    if isinstance(points, np.ndarray) or not isinstance(points, list | tuple):
        return None
    try:
        sizes = [len(member) for member in points]  # type: ignore[arg-type]
    except TypeError:
        return None
    return sizes if len(set(sizes)) > 1 else None


def _as_stack(points: ArrayLike, *, element: str, dims: tuple[int, ...], min_points: int) -> FloatArray:
    sizes = _ragged_sizes(points)
    if sizes is not None:
        counts = ", ".join(str(s) for s in sorted(set(sizes)))
        raise InvalidInputError(
            "points",
            "K sets of equal size (ragged: fits need the same number of points in every set; "
            "fit each group of equal size, or use the single fit per set)",
            f"{len(sizes)} sets of {counts} points",
        )
    arr = real_array(points, "points")
    if arr.ndim != 3 or arr.shape[2] not in dims:
        shapes = " or ".join(f"(K, N, {d})" for d in dims)
        raise InvalidInputError("points", f"shape {shapes}", f"shape {arr.shape}")
    if arr.shape[1] < min_points:
        raise TooFewPointsError(element, min_points, arr.shape[1])
    if not np.all(np.isfinite(arr)):
        bad = int(np.argwhere(~np.isfinite(arr))[0, 0])
        raise InvalidInputError("points", "finite coordinates", f"NaN or inf in set {bad}")
    check_magnitude(arr, "points")
    return arr


def _check_sets(stack: FloatArray, singular: FloatArray, *, element: str, rank: int) -> None:
    """The single fits' degeneracy tests, per set: identical points, and rank below ``rank``.

    ``singular`` are the singular values (K, D) of the centred sets, descending.  The error
    names the first offending set (field ``set_index``).
    """
    count = len(stack)
    scale = np.maximum(np.max(np.abs(stack), axis=(1, 2)), 1.0)
    identical = singular[:, 0] <= TOL.identical * scale
    if np.any(identical):
        k = int(np.argmax(identical))
        raise DegenerateGeometryError(
            element, f"set {k} of {count}: all {stack.shape[1]} points are identical", set_index=k
        )
    if rank >= 2:
        collinear = singular[:, 1] <= TOL.degenerate * singular[:, 0]
        if np.any(collinear):
            k = int(np.argmax(collinear))
            raise DegenerateGeometryError(
                element, f"set {k} of {count}: points are collinear", set_index=k
            )
    if rank >= 3:
        coplanar = singular[:, 2] <= TOL.degenerate * singular[:, 0]
        if np.any(coplanar):
            k = int(np.argmax(coplanar))
            raise DegenerateGeometryError(element, f"set {k} of {count}: points are coplanar", set_index=k)


def _sign_rows(vectors: FloatArray) -> FloatArray:
    index = np.argmax(np.abs(vectors), axis=-1)
    sign = np.sign(np.take_along_axis(vectors, index[..., None], axis=-1))
    return vectors * np.where(sign == 0, 1.0, sign)


def _stats(residuals: FloatArray) -> tuple[FloatArray, FloatArray]:
    return np.sqrt(np.mean(residuals**2, axis=1)), residuals.max(axis=1) - residuals.min(axis=1)


def _nsphere_batch(points: FloatArray, *, element: str) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Batched Gauss-Newton n-sphere fit; returns centres, radii, converged, iterations."""
    k, n, dim = points.shape
    origin = weighted_centroid(points)[:, None, :]
    centred = points - origin
    scale = np.sqrt(np.mean(np.sum(centred**2, axis=2), axis=1))  # (K,)
    if np.any(scale == 0):
        raise DegenerateGeometryError(element, f"set {int(np.argmin(scale))}: all points are identical")
    scaled = centred / scale[:, None, None]
    # algebraic start, batched least squares via QR
    design = np.concatenate([2.0 * scaled, np.ones((k, n, 1))], axis=2)
    target = np.sum(scaled**2, axis=2)
    q, r = np.linalg.qr(design)
    diag = np.abs(np.diagonal(r, axis1=1, axis2=2))
    bad = diag.min(axis=1) <= TOL.degenerate * diag.max(axis=1)
    if np.any(bad):
        shape = "collinear" if dim == 2 else "coplanar"
        raise DegenerateGeometryError(element, f"set {int(np.argmax(bad))}: points are {shape}")
    solution = np.linalg.solve(r, np.einsum("kni,kn->ki", q, target)[..., None])[..., 0]
    centre = solution[:, :dim]
    radius = np.sqrt(np.maximum(solution[:, dim] + np.sum(centre**2, axis=1), 1e-12))
    params = np.concatenate([centre, radius[:, None]], axis=1)
    converged = np.zeros(k, dtype=bool)
    iterations = np.zeros(k, dtype=np.int64)
    previous = np.full(k, np.inf)
    active = np.arange(k)
    for iteration in range(1, TOL.max_iterations + 1):
        sub = scaled[active]
        rel = sub - params[active, None, :dim]
        dist = np.sqrt(np.sum(rel**2, axis=2))
        resid = dist - params[active, None, dim]
        jac = np.concatenate([-rel / np.where(dist > 0, dist, 1.0)[..., None], -np.ones((*dist.shape, 1))], axis=2)
        q, r = np.linalg.qr(jac)
        step = np.linalg.solve(r, -np.einsum("kni,kn->ki", q, resid)[..., None])[..., 0]
        params[active] += step
        iterations[active] = iteration
        norm = np.linalg.norm(step, axis=1)
        size = 1.0 + np.linalg.norm(params[active], axis=1)
        done = (norm <= TOL.step * size) | ((norm <= TOL.rounding_floor * size) & (norm >= 0.5 * previous[active]))
        previous[active] = norm
        converged[active[done]] = True
        active = active[~done]
        if active.size == 0:
            break
    if active.size:
        raise ConvergenceError(element, TOL.max_iterations, f"{active.size} of {k} sets did not converge")
    centres = params[:, :dim] * scale[:, None] + origin[:, 0, :]
    radii = params[:, dim] * scale
    return centres, radii, converged, iterations


def fit_spheres(points: ArrayLike) -> SphereBatchFit:
    """Gaussian sphere fits of K point sets at once.

    Parameters
    ----------
    points : array_like, shape (K, N, 3)
        K sets of N >= 4 points each (mm).

    Returns
    -------
    SphereBatchFit

    Raises
    ------
    InvalidInputError, TooFewPointsError, DegenerateGeometryError, ConvergenceError
        As for :func:`~pcmm_geo.fit.fit_sphere`; messages name the offending set.

    Examples
    --------
    >>> unit = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]], dtype=float)
    >>> batch = fit_spheres(np.stack([5 * unit, 2 * unit + 100]))
    >>> np.round(batch.radii, 12).tolist(), np.round(batch.centers[1], 12).tolist()
    ([5.0, 2.0], [100.0, 100.0, 100.0])
    """
    stack = _as_stack(points, element="sphere", dims=(3,), min_points=4)
    _check_sets(stack, _planes(stack)[1], element="sphere", rank=3)
    centres, radii, converged, iterations = _nsphere_batch(stack, element="sphere")
    residuals = np.linalg.norm(stack - centres[:, None, :], axis=2) - radii[:, None]
    rms, form = _stats(residuals)
    return SphereBatchFit(
        centers=frozen(centres),
        radii=frozen(radii),
        residuals=frozen(residuals),
        rms=frozen(rms),
        form=frozen(form),
        n=stack.shape[1],
        converged=converged,
        iterations=iterations,
        dof=stack.shape[1] - 4,
        parameter_names=("center_x", "center_y", "center_z", "radius"),
        parameters=frozen(np.column_stack([centres, radii])),
        covariance=frozen(nsphere_covariance(stack, centres, radii)),
    )


def _planes(stack: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Batched SVD: centroids (K, D), singular values (K, D) and right singular vectors (K, D, D), descending."""
    centroid = weighted_centroid(stack)
    _, singular, vt = np.linalg.svd(stack - centroid[:, None, :], full_matrices=False)
    if singular.shape[1] < stack.shape[2]:  # fewer points than dimensions
        singular = np.concatenate([singular, np.zeros((len(stack), stack.shape[2] - singular.shape[1]))], axis=1)
    return centroid, singular, vt


def fit_planes(points: ArrayLike) -> PlaneBatchFit:
    """Gaussian plane fits of K point sets at once (closed form, batched SVD).

    Parameters
    ----------
    points : array_like, shape (K, N, 3)
        K sets of N >= 3 points.

    Returns
    -------
    PlaneBatchFit
        Normals follow the single fit's sign convention (largest component positive).

    Raises
    ------
    InvalidInputError, TooFewPointsError
        As for :func:`~pcmm_geo.fit.fit_plane`.
    DegenerateGeometryError
        A set of identical or collinear points; the message and the field ``set_index``
        name the first such set.
    """
    stack = _as_stack(points, element="plane", dims=(3,), min_points=3)
    centroid, singular, vt = _planes(stack)
    _check_sets(stack, singular, element="plane", rank=2)
    normals = _sign_rows(vt[:, 2, :])
    rel = stack - centroid[:, None, :]
    residuals = np.einsum("kni,ki->kn", rel, normals)
    rms, form = _stats(residuals)
    return PlaneBatchFit(
        points=frozen(centroid),
        normals=frozen(normals),
        residuals=frozen(residuals),
        rms=frozen(rms),
        form=frozen(form),
        n=stack.shape[1],
        converged=np.ones(len(stack), dtype=bool),
        iterations=np.zeros(len(stack), dtype=np.int64),
        dof=stack.shape[1] - 3,
        parameter_names=("point_x", "point_y", "point_z", "normal_x", "normal_y", "normal_z"),
        parameters=frozen(np.column_stack([centroid, normals])),
        covariance=frozen(plane_covariance(rel, vt, normals, residuals)),
    )


def fit_lines(points: ArrayLike) -> LineBatchFit:
    """Gaussian line fits of K point sets at once (closed form, batched SVD).

    Parameters
    ----------
    points : array_like, shape (K, N, 2) or (K, N, 3)
        K sets of N >= 2 points.

    Raises
    ------
    InvalidInputError, TooFewPointsError
        As for :func:`~pcmm_geo.fit.fit_line`.
    DegenerateGeometryError
        A set whose points are all identical (field ``set_index``).
    """
    stack = _as_stack(points, element="line", dims=(2, 3), min_points=2)
    centroid, singular, vt = _planes(stack)
    _check_sets(stack, singular, element="line", rank=1)
    directions = _sign_rows(vt[:, 0, :])
    rel = stack - centroid[:, None, :]
    along = np.einsum("kni,ki->kn", rel, directions)
    if stack.shape[2] == 2:
        normals = np.stack([-directions[:, 1], directions[:, 0]], axis=1)
        residuals = np.einsum("kni,ki->kn", rel, normals)
    else:
        residuals = np.linalg.norm(rel - along[..., None] * directions[:, None, :], axis=2)
    rms, form = _stats(residuals)
    if stack.shape[2] == 3:
        form = 2.0 * residuals.max(axis=1)
    dim = stack.shape[2]
    return LineBatchFit(
        points=frozen(centroid),
        directions=frozen(directions),
        residuals=frozen(residuals),
        rms=frozen(rms),
        form=frozen(form),
        n=stack.shape[1],
        converged=np.ones(len(stack), dtype=bool),
        iterations=np.zeros(len(stack), dtype=np.int64),
        dof=stack.shape[1] - 2 if dim == 2 else 2 * stack.shape[1] - 4,
        parameter_names=tuple(f"point_{c}" for c in "xyz"[:dim]) + tuple(f"direction_{c}" for c in "xyz"[:dim]),
        parameters=frozen(np.column_stack([centroid, directions])),
        covariance=frozen(line_covariance(rel, vt, directions)),
    )


def fit_circles(points: ArrayLike) -> CircleBatchFit:
    """Gaussian circle fits of K point sets at once.

    Parameters
    ----------
    points : array_like, shape (K, N, 2) or (K, N, 3)
        2-D: Gaussian circles.  3-D: the projected method (least-squares plane, then the
        2-D Gaussian circle in it), like ``fit_circle(..., method="projected")``.

    Raises
    ------
    InvalidInputError, TooFewPointsError, ConvergenceError
        As for :func:`~pcmm_geo.fit.fit_circle`.
    DegenerateGeometryError
        A set of identical or collinear points (field ``set_index``).
    """
    stack = _as_stack(points, element="circle", dims=(2, 3), min_points=3)
    centroid, singular, vt = _planes(stack)
    _check_sets(stack, singular, element="circle", rank=2)
    if stack.shape[2] == 2:
        centres, radii, converged, iterations = _nsphere_batch(stack, element="circle")
        residuals = np.linalg.norm(stack - centres[:, None, :], axis=2) - radii[:, None]
        normals = None
        names: tuple[str, ...] = ("center_x", "center_y", "radius")
        parameters = np.column_stack([centres, radii])
        covariance = nsphere_covariance(stack, centres, radii)
    else:
        frame = vt[:, :2, :]  # (K, 2, 3) in-plane axes
        in_plane = np.einsum("kni,kji->knj", stack - centroid[:, None, :], frame)
        centres2, radii, converged, iterations = _nsphere_batch(in_plane, element="circle")
        centres = centroid + np.einsum("kj,kji->ki", centres2, frame)
        residuals = np.linalg.norm(in_plane - centres2[:, None, :], axis=2) - radii[:, None]
        normals = frozen(_sign_rows(vt[:, 2, :]))
        rel = stack - centroid[:, None, :]
        plane_cov = plane_covariance(rel, vt, normals, np.einsum("kni,ki->kn", rel, normals))
        names = ("center_x", "center_y", "center_z", "normal_x", "normal_y", "normal_z", "radius")
        parameters = np.column_stack([centres, normals, radii])
        covariance = projected_circle_covariance(in_plane, centres2, radii, frame, plane_cov)
    rms, form = _stats(residuals)
    return CircleBatchFit(
        centers=frozen(centres),
        radii=frozen(radii),
        normals=normals,
        residuals=frozen(residuals),
        rms=frozen(rms),
        form=frozen(form),
        n=stack.shape[1],
        converged=converged,
        iterations=iterations,
        dof=stack.shape[1] - 3,  # centre (2 in the plane) and radius, as the single fits
        parameter_names=names,
        parameters=frozen(parameters),
        covariance=frozen(covariance),
    )
