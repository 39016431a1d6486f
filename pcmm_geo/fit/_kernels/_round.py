"""Gaussian fit of a circle (2-D) or sphere (3-D): the shared n-sphere solver.

Residual of point ``p``: ``|p - c| - r``.  The data are centred (and scaled only in
the algebraic start) so that a 1000 mm offset costs no accuracy.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.errors import DegenerateGeometryError
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
