"""Gaussian fit of a circle (2-D) or sphere (3-D): the shared n-sphere solver.

Residual of point ``p``: ``|p - c| - r``.  The data are centred (and scaled only in
the algebraic start) so that a 1000 mm offset costs no accuracy.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.errors import AmbiguousFitError, DegenerateGeometryError
from pcmm_geo.fit._kernels._core import TOL, SolverOutcome, solve_least_squares
from pcmm_geo.fit._kernels._linear import local_covariance, weighted_centroid
from pcmm_geo.fit._kernels._tall import tall_lstsq, tall_svd

FloatArray = NDArray[np.float64]


def _row_norms_squared(rows: FloatArray) -> FloatArray:
    """``|row|^2`` per row of an (N, D) array (einsum: a reduction over a short axis is slow in numpy)."""
    return np.einsum("ij,ij->i", rows, rows)


def algebraic_nsphere(centred: FloatArray, weights: FloatArray | None, *, element: str) -> tuple[FloatArray, float]:
    """Kasa-type algebraic fit (linear in centre and ``r^2 - |c|^2``) of centred data; a starting value only."""
    squared_norms = _row_norms_squared(centred)
    scale = float(np.sqrt(np.mean(squared_norms)))
    design = np.empty((centred.shape[0], centred.shape[1] + 1))
    np.multiply(centred, 2.0 / scale, out=design[:, :-1])
    design[:, -1] = 1.0
    target = squared_norms / scale**2
    if weights is not None:
        root = np.sqrt(weights)
        design, target = design * root[:, None], target * root
    solution = tall_lstsq(design, target)
    singular, _ = tall_svd(design)
    if singular[-1] <= TOL.degenerate * singular[0]:
        shape = "collinear" if centred.shape[1] == 2 else "coplanar"
        raise DegenerateGeometryError(element, f"points are {shape}; no unique {element} passes through them")
    centre = solution[:-1]
    radius_sq = solution[-1] + centre @ centre
    radius = float(np.sqrt(radius_sq)) if radius_sq > 0 else float(np.sqrt(np.mean(target)))
    return centre * scale, radius * scale


def fit_nsphere(
    points: FloatArray,
    weights: FloatArray | None,
    *,
    element: str,
    fixed_radius: float | None = None,
) -> tuple[FloatArray, float, SolverOutcome, FloatArray, float, FloatArray]:
    """Solve the Gaussian n-sphere problem.

    Returns
    -------
    centre, radius, outcome, residuals (unweighted), condition number,
    local covariance over ``(centre..., radius)`` (radius row/column zero when fixed).
    """
    origin = weighted_centroid(points, weights)
    centred = points - origin
    size = float(np.sqrt(np.mean(_row_norms_squared(centred))))
    if fixed_radius is None:
        centre0, radius0 = algebraic_nsphere(centred, weights, element=element)
    else:
        centre0 = _flat_fixed_radius_start(centred, weights, fixed_radius, element=element)
        if centre0 is None:
            centre0 = _fixed_radius_start(centred, weights, fixed_radius, element=element)
        radius0 = fixed_radius
    dim = points.shape[1]

    def residual_and_jacobian(params: FloatArray) -> tuple[FloatArray, FloatArray]:
        centre = params[:dim]
        radius = params[dim] if fixed_radius is None else fixed_radius
        rel = centred - centre
        dist = np.sqrt(_row_norms_squared(rel))
        safe = np.where(dist > 0, dist, 1.0)
        jac = np.empty((rel.shape[0], dim + (fixed_radius is None)))
        np.divide(rel, -safe[:, None], out=jac[:, :dim])
        if fixed_radius is None:
            jac[:, dim] = -1.0
        return dist - radius, jac

    x0 = np.append(centre0, radius0) if fixed_radius is None else centre0
    sqrt_w = None if weights is None else np.sqrt(weights)
    outcome = solve_least_squares(residual_and_jacobian, x0, element=element, scale=size, sqrt_weights=sqrt_w)
    centre_local = outcome.x[:dim]
    radius = float(outcome.x[dim]) if fixed_radius is None else float(fixed_radius)
    if radius < 0:
        raise DegenerateGeometryError(element, "the least-squares solution has a negative radius")
    if fixed_radius is not None:
        _refuse_mirror_solution(centred, weights, centre_local, origin, element=element, scale=size)
    residuals = outcome.residuals if sqrt_w is None else residual_and_jacobian(outcome.x)[0]
    dof = len(points) - outcome.x.size
    cov, cond = local_covariance(outcome.jacobian, outcome.residuals, dof)
    if fixed_radius is not None:
        full = np.zeros((dim + 1, dim + 1))
        full[:dim, :dim] = cov
        cov = full
    return centre_local + origin, radius, outcome, residuals, cond, cov


def _fixed_radius_start(
    centred: FloatArray, weights: FloatArray | None, radius: float, *, element: str
) -> FloatArray:
    """Start for a fixed-radius fit: the free fit's centre when the data allow it, else the centroid shifted."""
    try:
        centre, _ = algebraic_nsphere(centred, weights, element=element)
        return centre
    except DegenerateGeometryError:
        # a few points on a small arc: start on the side of the normal of the best line/plane
        _, _, vt = np.linalg.svd(centred, full_matrices=False)
        return vt[-1] * radius


def _refuse_mirror_solution(
    centred: FloatArray,
    weights: FloatArray | None,
    centre: FloatArray,
    origin: FloatArray,
    *,
    element: str,
    scale: float,
) -> None:
    """Raise :class:`AmbiguousFitError` when a fixed-radius fit has a mirror-image twin.

    Points that span only a hyperplane (coplanar in 3-D, collinear in 2-D) are symmetric
    under the reflection in it, and so is the sum of squares: a centre off that hyperplane
    and its mirror image fit exactly equally well.  Only a centre in the hyperplane (the
    points' circle is larger than the fixed radius) is unique.
    """
    weighted = centred if weights is None else centred * np.sqrt(weights)[:, None]
    _, singular, vt = np.linalg.svd(weighted, full_matrices=False)
    if singular.size == centred.shape[1] and singular[-1] > TOL.degenerate * singular[0]:
        return
    normal = vt[-1] if singular.size == centred.shape[1] else _completing_normal(vt)
    height = float(centre @ normal)
    if abs(height) <= 1e-9 * max(scale, 1.0):
        return
    shape = "coplanar" if centred.shape[1] == 3 else "collinear"
    mirror = centre - 2.0 * height * normal
    raise AmbiguousFitError(
        element,
        f"the points are {shape}: the fixed-radius {element} and its mirror image in their "
        f"{'plane' if shape == 'coplanar' else 'line'} (centres {height:+.6g} mm either side) fit equally well",
        candidates=(centre + origin, mirror + origin),
    )


def _completing_normal(vt: FloatArray) -> FloatArray:
    """A unit vector orthogonal to the rows of ``vt`` (fewer points than dimensions)."""
    if vt.shape[1] == 3:
        cross = np.cross(vt[0], vt[1])
        return cross / np.linalg.norm(cross)
    return np.array([-vt[0, 1], vt[0, 0]])


def _flat_fixed_radius_start(
    centred: FloatArray, weights: FloatArray | None, radius: float, *, element: str
) -> FloatArray | None:
    """Start for a fixed-radius fit of points spanning only a hyperplane (``None`` if they do not).

    The fit within the hyperplane is solved first.  With ``d_i`` the distances of the points
    from that centre, the sum of squares grows when the centre leaves the hyperplane iff
    ``sum w_i (1 - r / d_i) > 0`` (its second derivative there); the in-plane centre is then
    the answer.  Otherwise it falls off on both sides to two mirror-image minima, and a start
    off the plane leads to one of them (which :func:`_refuse_mirror_solution` then reports).
    """
    dim = centred.shape[1]
    weighted = centred if weights is None else centred * np.sqrt(weights)[:, None]
    _, singular, vt = np.linalg.svd(weighted, full_matrices=False)
    if dim == 1 or (singular.size == dim and singular[-1] > TOL.degenerate * singular[0]):
        return None
    basis = vt[: dim - 1]
    normal = vt[-1] if singular.size == dim else _completing_normal(vt)
    in_plane = centred @ basis.T
    sub_centre = fit_nsphere(in_plane, weights, element=element, fixed_radius=radius)[0]
    distances = np.linalg.norm(in_plane - sub_centre, axis=1)
    w = np.ones(len(distances)) if weights is None else weights
    curvature = float(np.sum(w * (1.0 - radius / np.maximum(distances, 1e-300))))
    centre = sub_centre @ basis
    if curvature > 0:
        return centre
    return centre + normal * np.sqrt(max(radius**2 - float(np.mean(distances**2)), 0.25 * radius**2))
