"""Gaussian (orthogonal-distance least-squares) torus fit.

A torus is the surface swept by a circle of radius ``r`` (minor radius) whose centre runs
round a circle of radius ``R`` (major radius) about an axis.  With ``h`` the height of a
point above the torus' equatorial plane and ``rho`` its distance from the axis, the
residual is ``e = sqrt((rho - R)^2 + h^2) - r`` (positive outside the tube).
"""

from __future__ import annotations

import warnings

import numpy as np
from numpy.typing import ArrayLike

from pcmm_geo._records import record
from pcmm_geo.elements import Criterion
from pcmm_geo.errors import UnassuredMinimumWarning
from pcmm_geo.fit._kernels._axial import (
    AxialSolution,
    FloatArray,
    algebraic_circle,
    as_axis_hint,
    axial_terms,
    candidate_axes,
    canonical_axis,
    check_spread,
    local_direction,
    solve_axial,
    warn_if_ambiguous,
)
from pcmm_geo.fit._kernels._core import FitResult, as_points, as_weights, covariance_from_jacobian, residual_stats
from pcmm_geo.fit._kernels._linear import frozen, weighted_centroid
from pcmm_geo.fit._kernels._measure import axial_parts, query_points, torus_project
from pcmm_geo.fit._kernels._screen import screened_directions, torus_reduced
from pcmm_geo.fit._kernels._torus_search import best_axis_position, refined_axis
from pcmm_geo.fit.zone._common import check_criterion

__all__ = ["TorusFit", "fit_torus"]

_ELEMENT = "torus"
#: Fewest points from which a torus fit without ``axis_hint`` is taken as assured (scans in
#: ``docs/fit-robustness.md``: 8-10 points still end in a spurious minimum about one time in ten).
ASSURED_POINTS = 20
_INVALID_COST = 1e300


@record(kw_only=True)
class TorusFit(FitResult):
    """Least-squares torus.

    Attributes
    ----------
    center : ndarray, shape (3,)
        Centre of the torus (on the axis, in the equatorial plane), mm.
    axis : ndarray, shape (3,)
        Unit axis of revolution, largest-magnitude component positive.
    major_radius : float
        Radius of the circle traced by the tube centre, mm.
    minor_radius : float
        Radius of the tube, mm.

    Notes
    -----
    ``parameter_names`` are ``center_x, center_y, center_z, axis_x, axis_y, axis_z,
    major_radius, minor_radius`` (machine frame; covariance of rank 7).
    """

    center: FloatArray
    axis: FloatArray
    major_radius: float
    minor_radius: float

    def distance(self, points: ArrayLike) -> FloatArray:
        """Signed distances ``(...)`` of ``points`` (``(..., 3)``) from the torus, positive outside the tube (mm).

        Examples
        --------
        >>> import numpy as np
        >>> u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 7)[:-1], np.linspace(0, 2 * np.pi, 5)[:-1])
        >>> tube = np.c_[((10 + 2 * np.cos(v)) * np.cos(u)).ravel(), ((10 + 2 * np.cos(v)) * np.sin(u)).ravel(),
        ...              (2 * np.sin(v)).ravel()]
        >>> fit = fit_torus(tube)
        >>> np.round(fit.distance([[15, 0, 0], [10, 0, 1]]), 6).tolist()
        [3.0, -1.0]
        >>> (np.round(fit.project([[15, 0, 0]]), 6) + 0.0).tolist()
        [[12.0, 0.0, 0.0]]
        """
        height, _, rho = axial_parts(query_points(points, 3), self.center, self.axis)
        return np.hypot(rho - self.major_radius, height) - self.minor_radius

    def project(self, points: ArrayLike) -> FloatArray:
        """Nearest points ``(..., 3)`` on the torus (mm).

        Raises
        ------
        DegenerateGeometryError
            A point on the axis or on the tube's centre circle (no unique nearest point).
        """
        return torus_project(query_points(points, 3), self.center, self.axis, self.major_radius, self.minor_radius)


def _torus_model(local: FloatArray, params: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Residuals and Jacobian in standard position; params ``(x0, y0, z0, a, b, R, r)``."""
    x0, y0, z0, a, b, major, minor = (float(v) for v in params)
    terms = axial_terms(local, np.array([x0, y0, z0]), a, b)
    radial_gap = terms.rho - major
    tube_distance = np.hypot(radial_gap, terms.height)
    safe = np.where(tube_distance > 0, tube_distance, 1.0)
    jac = np.empty((local.shape[0], 7))
    jac[:, 0:5] = (radial_gap[:, None] * terms.d_rho + terms.height[:, None] * terms.d_height) / safe[:, None]
    jac[:, 5] = -radial_gap / safe
    jac[:, 6] = -1.0
    return tube_distance - minor, jac


def _torus_cost(local: FloatArray, params: FloatArray) -> float:
    """Sum of squared residuals (no Jacobian), for ranking starting values."""
    x0, y0, z0, a, b, major, minor = (float(v) for v in params)
    direction = local_direction(a, b)
    offset = local - np.array([x0, y0, z0])
    height = offset @ direction
    rho = np.linalg.norm(offset - height[:, None] * direction, axis=1)
    residuals = np.hypot(rho - major, height) - minor
    return float(residuals @ residuals)


def _params_from_centre(local: FloatArray, x0: float, y0: float) -> FloatArray | None:
    """With the axis at ``(x0, y0)`` the points lie on a circle in the (rho, z) half-plane: fit it algebraically."""
    rho = np.hypot(local[:, 0] - x0, local[:, 1] - y0)
    major, z0, minor = algebraic_circle(np.c_[rho, local[:, 2]])
    if not (minor > 0 and major > 0):
        return None
    return np.array([x0, y0, z0, 0.0, 0.0, major, minor])


def _torus_start_cheap(local: FloatArray) -> FloatArray | None:
    """Starting values around the local z axis: axis position from circles, then a circle in (rho, z).

    Every slice ``z = const`` of a torus is one or two circles about its axis, so the axis
    position ``x0, y0`` is taken from an algebraic circle through the highest (and,
    separately, the lowest) eighth of the points, or through all projected points (good
    for a thin ring, biased for a fat partial elbow).  Of the three candidates the one whose
    residuals are smallest is returned.
    """
    order = np.argsort(local[:, 2])
    slice_size = max(5, local.shape[0] // 8)
    best: tuple[float, FloatArray] | None = None
    for subset in (local, local[order[-slice_size:]], local[order[:slice_size]]):
        x0, y0, _ = algebraic_circle(subset[:, :2])
        params = _params_from_centre(local, x0, y0)
        if params is None:
            continue
        cost = _torus_cost(local, params)
        if np.isfinite(cost) and (best is None or cost < best[0]):
            best = (cost, params)
    return None if best is None else best[1]


def _torus_start(local: FloatArray) -> FloatArray | None:
    """Best of :func:`_torus_start_cheap` and a coarse-to-fine search of the axis position, polished by Nelder-Mead.

    Search and polish vary ``x0, y0`` only; ``R, z0, r`` follow from the (rho, z) circle
    (variable projection), and the geometric sum of squares is the objective.
    """
    from scipy.optimize import minimize  # heavy import kept out of the module import

    params = _torus_start_cheap(local)
    searched_cost, searched = best_axis_position(local)
    if np.isfinite(searched_cost) and (params is None or searched_cost < _torus_cost(local, params)):
        params = searched
    if params is None:
        return None

    def cost(centre: FloatArray) -> float:
        candidate = _params_from_centre(local, float(centre[0]), float(centre[1]))
        # a finite penalty: Nelder-Mead compares simplex values by subtraction
        return _INVALID_COST if candidate is None else _torus_cost(local, candidate)

    step = 1e-3 * float(params[5])
    search = minimize(
        cost,
        params[:2],
        method="Nelder-Mead",
        options={
            "initial_simplex": params[:2] + np.array([[0.0, 0.0], [step, 0.0], [0.0, step]]),
            "xatol": 1e-3 * step,
            "fatol": 0,
            "maxfev": 150,
        },
    )
    polished = _params_from_centre(local, float(search.x[0]), float(search.x[1]))
    return polished if polished is not None and search.fun < _torus_cost(local, params) else params


def _hinted_axes(centred: FloatArray, hint: FloatArray | None) -> list[FloatArray]:
    """The hint and the hint refined by the projected-cost pattern search (sparse data have narrow basins)."""
    if hint is None:
        return []
    return [refined_axis(centred, hint), hint]


def fit_torus(
    points: ArrayLike,
    *,
    weights: ArrayLike | None = None,
    axis_hint: ArrayLike | None = None,
    criterion: Criterion = "gaussian",
) -> TorusFit:
    r"""Fit a torus to 3-D points by orthogonal-distance least squares.

    Levenberg-Marquardt with an analytic Jacobian in standard position (data centred at
    the centroid, current axis along +z).  Local parameters: the centre ``x0, y0, z0``,
    two axis tilts, the major and the minor radius.  Starting axes are ``axis_hint`` (as
    given and refined by a tilt pattern search), the polished minima of a direction screening
    (a fat pipe elbow has no principal axis near its torus axis) and the principal axes.
    For each axis the axis position comes from a coarse-to-fine grid search with ``z0, R, r``
    projected out (a circle in the ``(rho, z)`` half-plane), polished by Nelder-Mead.  The converged solution of least
    cost is returned.

    See Also
    --------
    fit_circle : the torus' tube centre line is a circle
    fit_sphere

    Notes
    -----
    Sparse data (seven to about a dozen points, whole or partial torus) can be fitted to some
    10 um rms by spurious tori whose axes lie tens of degrees from the true one, while the
    true minimum's basin is a fraction of a degree wide.  The direction screening
    (:mod:`pcmm_geo.fit._kernels._screen`: a 240-direction lattice, each direction's reduced fit started
    also from the best cells of an axis-position grid) finds that basin without a hint; when
    two distinct minima are within ``TOL.ambiguous`` (1 %) of each other,
    :class:`~pcmm_geo.errors.AmbiguousFitWarning` lists them.  It does not find it every time:
    with 8-10 points about one set in ten still ends in a spurious minimum (measured rates:
    ``docs/fit-robustness.md``), so a fit of fewer than ``ASSURED_POINTS`` (20) points without
    ``axis_hint`` always warns with :class:`~pcmm_geo.errors.UnassuredMinimumWarning`; pass the
    nominal axis, or measure more points.

    The Gaussian (least-squares) element minimises the weighted sum of squared orthogonal
    distances [1]_ [2]_

    .. math::

        \min_{\mathbf{a}} \; \sum_{i=1}^{N} w_i \, d_i(\mathbf{a})^2 ,

    where :math:`\mathbf{a}` are the element's parameters and :math:`d_i` the signed distance
    of point :math:`\mathbf{x}_i`, here

    .. math::

        d_i = \sqrt{(\rho_i - R)^2 + h_i^2} - r , \qquad
        h_i = (\mathbf{x}_i - \mathbf{c}) \cdot \mathbf{u} , \quad
        \rho_i = \lVert (\mathbf{x}_i - \mathbf{c}) \times \mathbf{u} \rVert

    for the torus of centre :math:`\mathbf{c}`, unit axis :math:`\mathbf{u}`, major radius
    :math:`R` and minor radius :math:`r` [1]_ [2]_.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Measured points (mm), N >= 7.
    weights : array_like, shape (N,), optional
        Non-negative weights of the squared residuals.
    axis_hint : array_like, shape (3,), optional
        Approximate (nominal) axis direction tried first (either sign).

    criterion : {"gaussian"}
        Only the least-squares criterion is defined for a torus (an explicit error otherwise).

    Returns
    -------
    TorusFit
        Residuals ``sqrt((rho - R)^2 + h^2) - r`` (mm, positive outside the tube).

    Raises
    ------
    InvalidInputError
        NaN/inf, wrong shape, bad weights or hint.
    TooFewPointsError
        Fewer than 7 points.
    DegenerateGeometryError
        All points on a line or in a plane.
    ConvergenceError
        No starting value led to a converged solution.

    References
    ----------
    .. [1] C. M. Shakarji, "Least-squares fitting algorithms of the NIST algorithm testing system", *J. Res.
           Natl. Inst. Stand. Technol.* 103(6), 633-641 (1998).
    .. [2] A. B. Forbes, "Least-squares best-fit geometric elements", NPL Report DITC 140/89, National
           Physical Laboratory, Teddington (1989).

    Examples
    --------
    >>> import numpy as np
    >>> u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 8, endpoint=False), np.linspace(0, 2 * np.pi, 5, endpoint=False))
    >>> u, v = u.ravel(), v.ravel()
    >>> pts = np.c_[(20 + 4 * np.cos(v)) * np.cos(u), (20 + 4 * np.cos(v)) * np.sin(u), 4 * np.sin(v)]
    >>> fit = fit_torus(pts + [0.0, 0.0, 1000.0])
    >>> round(fit.major_radius, 9), round(fit.minor_radius, 9), (np.round(fit.center, 9) + 0.0).tolist()
    (20.0, 4.0, [0.0, 0.0, 1000.0])
    """
    check_criterion(criterion, _ELEMENT)
    data = as_points(points, element=_ELEMENT, min_points=7)
    weight = as_weights(weights, data.shape[0], element=_ELEMENT)
    sqrt_weights = None if weight is None else np.sqrt(weight)
    centroid = weighted_centroid(data)
    centred = data - centroid
    check_spread(centred, element=_ELEMENT, forbid_coplanar=True)
    solution = solve_axial(
        data,
        centroid,
        candidate_axes(
            centred,
            [*_hinted_axes(centred, as_axis_hint(axis_hint)), *screened_directions(centred, torus_reduced)],
        ),
        start=_torus_start,
        model=_torus_model,
        position_slots=(0, 1, 2),
        tilt_slots=(3, 4),
        element=_ELEMENT,
        sqrt_weights=sqrt_weights,
    )
    warn_if_ambiguous(
        solution,
        element=_ELEMENT,
        position_slots=(0, 1, 2),
        tilt_slots=(3, 4),
        sizes=lambda params: {"major_radius": float(params[5]), "minor_radius": float(params[6])},
    )
    if axis_hint is None and data.shape[0] < ASSURED_POINTS:
        warnings.warn(UnassuredMinimumWarning(_ELEMENT, data.shape[0], ASSURED_POINTS), stacklevel=2)
    return _result(data, solution)


def _result(data: FloatArray, solution: AxialSolution) -> TorusFit:
    params = solution.params
    rotation = solution.rotation
    x0, y0, z0, a, b, major, minor = (float(v) for v in params)
    axis = rotation.T @ local_direction(a, b)
    center = solution.centroid + rotation.T @ np.array([x0, y0, z0])
    signed_axis = canonical_axis(axis)

    offset = data - center
    height = offset @ axis
    rho = np.linalg.norm(offset - height[:, None] * axis, axis=1)
    residuals = np.hypot(rho - major, height) - minor

    outcome = solution.outcome
    dof = data.shape[0] - 7
    cov_local, condition = covariance_from_jacobian(outcome.jacobian, outcome.residuals, dof, element=_ELEMENT)
    # machine parameters: centre = centroid + R^T (x0, y0, z0); axis = R^T (a, b, 1)/n, at a = b = 0
    propagate = np.zeros((8, 7))
    propagate[0:3, 0:3] = rotation.T
    sign = 1.0 if float(signed_axis @ axis) > 0 else -1.0
    propagate[3:6, 3] = sign * rotation.T[:, 0]
    propagate[3:6, 4] = sign * rotation.T[:, 1]
    propagate[6, 5] = 1.0
    propagate[7, 6] = 1.0
    covariance = propagate @ cov_local @ propagate.T
    rms, form = residual_stats(residuals)
    return TorusFit(
        center=frozen(center),
        axis=frozen(signed_axis),
        major_radius=major,
        minor_radius=minor,
        residuals=frozen(residuals),
        rms=rms,
        form=form,
        n=data.shape[0],
        dof=dof,
        parameter_names=(
            "center_x",
            "center_y",
            "center_z",
            "axis_x",
            "axis_y",
            "axis_z",
            "major_radius",
            "minor_radius",
        ),
        parameters=frozen([*center, *signed_axis, major, minor]),
        covariance=frozen(covariance),
        condition_number=condition,
        converged=outcome.converged,
        iterations=solution.iterations,
        message=outcome.message,
    )
