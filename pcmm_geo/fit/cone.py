"""Gaussian (orthogonal-distance least-squares) cone fit.

The cone is parameterised by a point ``a`` of its axis, the unit axis ``d``, the radius
``r`` of the cone at ``a`` and the half angle ``alpha``.  The residual of a point ``p``
is (NIST's convention, positive outside)::

    h = (p - a) . d,   rho = |(p - a) - h d|,   e = (rho - r - h tan(alpha)) cos(alpha).

This form stays regular for nearly cylindrical cones, where the apex runs off to
infinity; the apex is derived only at the end (``apex = a - r / tan(alpha) d``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from pcmm_geo._records import record
from pcmm_geo.elements import Criterion
from pcmm_geo.errors import ConvergenceError
from pcmm_geo.fit._kernels._axial import (
    AxialSolution,
    FloatArray,
    as_axis_hint,
    axial_terms,
    candidate_axes,
    check_spread,
    local_direction,
    solve_axial,
    warn_if_ambiguous,
)
from pcmm_geo.fit._kernels._core import FitResult, as_points, as_weights, covariance_from_jacobian, residual_stats
from pcmm_geo.fit._kernels._linear import frozen, weighted_centroid
from pcmm_geo.fit._kernels._measure import cone_frame, query_points, radial_unit
from pcmm_geo.fit._kernels._screen import cone_reduced, screened_directions
from pcmm_geo.fit.cylinder import _cylinder_model, _cylinder_start, axis_point_jacobian
from pcmm_geo.fit.zone._common import check_criterion

__all__ = ["ConeFit", "fit_cone"]

_ELEMENT = "cone"
#: Iteration budget of the cylinder fit that only provides a starting axis.
_CYLINDER_START_BUDGET = 40


@record(kw_only=True)
class ConeFit(FitResult):
    """Least-squares cone.

    Attributes
    ----------
    apex : ndarray, shape (3,)
        Vertex ``point - radius_at_point / tan(half_angle) * axis`` (mm); components are
        ``inf`` for an exactly cylindrical solution (``half_angle == 0``).
    axis : ndarray, shape (3,)
        Unit axis, from the apex toward the opening (direction of increasing radius).
    half_angle : float
        Half of the apex angle (rad), ``0 <= half_angle < pi / 2``.
    point : ndarray, shape (3,)
        Orthogonal projection of the data centroid onto the axis (mm).
    radius_at_point : float
        Radius of the cone in the plane through ``point`` perpendicular to the axis (mm).

    Notes
    -----
    ``parameter_names`` are ``point_x, point_y, point_z, axis_x, axis_y, axis_z,
    radius_at_point, half_angle`` (machine frame; covariance of rank 6).
    """

    apex: FloatArray
    axis: FloatArray
    half_angle: float
    point: FloatArray
    radius_at_point: float

    @property
    def apex_angle_deg(self) -> float:
        """Full apex angle in degrees (NIST's 8th number)."""
        return float(np.degrees(2.0 * self.half_angle))

    @property
    def surface_distance(self) -> float:
        """Perpendicular distance from ``point`` to the cone surface, ``r cos(alpha)`` (NIST's 7th number), mm."""
        return float(self.radius_at_point * np.cos(self.half_angle))

    def distance(self, points: ArrayLike) -> FloatArray:
        """Signed distances ``(...)`` of ``points`` (``(..., 3)``) from the cone, positive outside (mm).

        The fit's residual ``(rho - r) cos(alpha) - h sin(alpha)``: the distance to the
        generator line in the point's axial half-plane (exact for points on the apex's
        opening side of the normal through the apex).

        Examples
        --------
        >>> import numpy as np
        >>> t = np.linspace(0, 2 * np.pi, 6, endpoint=False)
        >>> ring = np.c_[np.cos(t), np.sin(t), np.zeros(6)]
        >>> fit = fit_cone(np.vstack([ring, 2 * ring + [0, 0, 1], 3 * ring + [0, 0, 2]]))  # 45 degrees
        >>> np.round(fit.distance([[4, 0, 0]]) * np.sqrt(2), 9).tolist()
        [3.0]
        >>> (np.round(fit.project([[4, 0, 0]]), 9) + 0.0).tolist()
        [[2.5, 0.0, 1.5]]
        """
        return cone_frame(query_points(points, 3), self.point, self.axis, self.radius_at_point, self.half_angle)[3]

    def project(self, points: ArrayLike) -> FloatArray:
        """Feet ``(..., 3)`` of the perpendiculars from ``points`` to the cone's generator lines (mm).

        Raises
        ------
        DegenerateGeometryError
            A point on the axis (no unique generator line).
        """
        pts = query_points(points, 3)
        height, radial, rho, distance = cone_frame(pts, self.point, self.axis, self.radius_at_point, self.half_angle)
        unit = radial_unit(radial, rho, _ELEMENT, self.radius_at_point)
        foot_height = height + distance * np.sin(self.half_angle)
        foot_rho = rho - distance * np.cos(self.half_angle)
        return self.point + foot_height[..., None] * self.axis + foot_rho[..., None] * unit


def _cone_model(local: FloatArray, params: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Residuals and Jacobian in standard position; params ``(x0, y0, a, b, r, alpha)``."""
    x0, y0, a, b, radius, half_angle = (float(v) for v in params)
    terms = axial_terms(local, np.array([x0, y0, 0.0]), a, b)
    cos_a, sin_a = np.cos(half_angle), np.sin(half_angle)
    residuals = (terms.rho - radius) * cos_a - terms.height * sin_a
    jac = np.empty((local.shape[0], 6))
    geometry = terms.d_rho * cos_a - terms.d_height * sin_a
    jac[:, 0:2] = geometry[:, 0:2]
    jac[:, 2:4] = geometry[:, 3:5]
    jac[:, 4] = -cos_a
    jac[:, 5] = -(terms.rho - radius) * sin_a - terms.height * cos_a
    return residuals, jac


def _slide_cone(old: FloatArray, new: FloatArray, shift: float) -> FloatArray:
    """Radius at the axis point after that point moved by ``-shift`` along the axis."""
    new[4] = old[4] - shift * np.tan(old[5])
    return new


def _cone_start(local: FloatArray) -> FloatArray | None:
    """Algebraic cone around the local z axis: ``x^2 + y^2 = 2 x0 x + 2 y0 y + c + e z + f z^2``.

    With ``rho = r + t z`` one has ``f = t^2``, ``e = 2 r t`` and ``c = r^2 - x0^2 - y0^2``.
    """
    x, y, z = local.T
    design = np.c_[2 * x, 2 * y, np.ones_like(x), z, z * z]
    (x0, y0, c, e, f), *_ = np.linalg.lstsq(design, x * x + y * y, rcond=None)
    if f > 0:
        slope = float(np.copysign(np.sqrt(f), e))
        radius = abs(e) / (2 * np.sqrt(f))
    else:
        slope = 0.0
        radius = float(np.sqrt(max(c + x0 * x0 + y0 * y0, 0.0)))
    if not radius > 0:
        return None
    return np.array([x0, y0, 0.0, 0.0, radius, np.arctan(slope)])


def fit_cone(
    points: ArrayLike,
    *,
    weights: ArrayLike | None = None,
    axis_hint: ArrayLike | None = None,
    criterion: Criterion = "gaussian",
) -> ConeFit:
    r"""Fit a cone to 3-D points by orthogonal-distance least squares.

    Levenberg-Marquardt with an analytic Jacobian in standard position (data centred at
    the centroid, current axis along +z).  Local parameters: the axis crossing ``x0, y0``
    of the local ``z = 0`` plane, two tilts, the radius at that plane and the half angle.
    Starting axes: ``axis_hint``, a short cylinder fit, the polished minima of a direction
    screening (:mod:`pcmm_geo.fit._kernels._screen`), and the principal axes;
    for each, an algebraic cone (``x^2 + y^2`` linear in ``x, y, 1, z, z^2``) gives the
    remaining starting values.  The converged solution of least cost is returned.  The
    half angle is reported in ``[0, pi/2)`` with the axis pointing to the opening.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Measured points (mm), N >= 6.
    weights : array_like, shape (N,), optional
        Non-negative weights of the squared residuals.
    axis_hint : array_like, shape (3,), optional
        Approximate axis direction tried first (either sign).

    criterion : {"gaussian", "chebyshev"}
        ``"gaussian"`` (least squares, default) or the minimax criteria of
        :mod:`pcmm_geo.fit.zone` (contacts and optimality certificate on the result).

    Returns
    -------
    ConeFit
        Residuals ``(rho - r - h tan(alpha)) cos(alpha)`` (mm, positive outside).

    Raises
    ------
    InvalidInputError
        NaN/inf, wrong shape, bad weights or hint.
    TooFewPointsError
        Fewer than 6 points.
    DegenerateGeometryError
        All points on a line or in a plane.
    ConvergenceError
        No starting value led to a converged solution.

    See Also
    --------
    fit_cylinder : the cone of half angle zero
    pcmm_geo.fit.zone.form.evaluate_form : minimum-zone form deviation and its verdict
    pcmm_geo.fit.probe.compensate_probe : probe-ball centres onto the touched surface

    Notes
    -----
    The Gaussian (least-squares) element minimises the weighted sum of squared orthogonal
    distances [1]_ [2]_

    .. math::

        \min_{\mathbf{a}} \; \sum_{i=1}^{N} w_i \, d_i(\mathbf{a})^2 ,

    where :math:`\mathbf{a}` are the element's parameters and :math:`d_i` the signed distance
    of point :math:`\mathbf{x}_i`, here

    .. math::

        d_i = \rho_i \cos\psi - h_i \sin\psi , \qquad
        h_i = (\mathbf{x}_i - \mathbf{p}) \cdot \mathbf{u} , \quad
        \rho_i = \lVert (\mathbf{x}_i - \mathbf{p}) \times \mathbf{u} \rVert

    for the cone of apex :math:`\mathbf{p}`, unit axis :math:`\mathbf{u}` (apex to opening)
    and half angle :math:`\psi` (positive outside) [1]_.

    ``criterion="chebyshev"`` minimises the largest distance instead (minimum zone, as in the
    reference software of [4]_): the form zone of ISO 1101 [3]_; such a result carries an
    optimality certificate.
    :mod:`pcmm_geo.artefacts.iso10360_6` tests fitting software, these fits included, in the
    manner of ISO 10360-6 [5]_.

    References
    ----------
    .. [1] C. M. Shakarji, "Least-squares fitting algorithms of the NIST algorithm testing system", *J. Res.
           Natl. Inst. Stand. Technol.* 103(6), 633-641 (1998).
    .. [2] A. B. Forbes, "Least-squares best-fit geometric elements", NPL Report DITC 140/89, National
           Physical Laboratory, Teddington (1989).
    .. [3] ISO 1101:2017, *Geometrical product specifications (GPS) -- Geometrical tolerancing -- Tolerances
           of form, orientation, location and run-out* (the form zone is the smallest one containing the
           feature).
    .. [4] G. T. Anthony et al., "Reference software for finding Chebyshev best-fit geometric elements",
           *Precision Engineering* 19(1), 28-36 (1996).
    .. [5] ISO 10360-6:2001, *Geometrical Product Specifications (GPS) -- Acceptance and reverification tests
           for coordinate measuring machines (CMM) -- Part 6: Estimation of errors in computing Gaussian
           associated features*.

    Examples
    --------
    >>> import numpy as np
    >>> angle = np.linspace(0, 2 * np.pi, 6, endpoint=False)
    >>> heights = np.array([0.0, 10.0])
    >>> pts = np.array([[(2 + h) * np.cos(t), (2 + h) * np.sin(t), h] for h in heights for t in angle])
    >>> fit = fit_cone(pts + 500.0)
    >>> round(fit.apex_angle_deg / 2, 9), np.round(fit.apex, 9).tolist()
    (45.0, [500.0, 500.0, 498.0])
    """
    check_criterion(criterion, _ELEMENT, weights=weights, axis_hint=axis_hint)
    data = as_points(points, element=_ELEMENT, min_points=6)
    if criterion != "gaussian":
        from pcmm_geo.fit.zone._axial import cone_minimax
        from pcmm_geo.fit.zone._distinct import on_distinct

        return on_distinct(data, element=_ELEMENT, min_points=6,
                           solve=lambda q: cone_minimax(q, criterion, gauss=fit_cone(q), result_type=ConeFit))
    weight = as_weights(weights, data.shape[0], element=_ELEMENT)
    sqrt_weights = None if weight is None else np.sqrt(weight)
    centroid = weighted_centroid(data)
    centred = data - centroid
    check_spread(centred, element=_ELEMENT, forbid_coplanar=True)
    hint = as_axis_hint(axis_hint)
    extra: list[FloatArray | None] = [hint]
    try:  # a quick cylinder fit gives a good axis for long, slender cones
        cylinder = solve_axial(
            data,
            centroid,
            candidate_axes(centred, [hint]),
            start=_cylinder_start(None),
            model=_cylinder_model(None),
            position_slots=(0, 1),
            tilt_slots=(2, 3),
            element=_ELEMENT,
            sqrt_weights=sqrt_weights,
            max_iterations=_CYLINDER_START_BUDGET,
        )
        extra.append(cylinder.rotation[2])
    except ConvergenceError:
        pass
    solution = solve_axial(
        data,
        centroid,
        candidate_axes(centred, [*extra, *screened_directions(centred, cone_reduced)]),
        start=_cone_start,
        model=_cone_model,
        position_slots=(0, 1),
        tilt_slots=(2, 3),
        element=_ELEMENT,
        sqrt_weights=sqrt_weights,
        slide=_slide_cone,
    )
    warn_if_ambiguous(
        solution,
        element=_ELEMENT,
        position_slots=(0, 1),
        tilt_slots=(2, 3),
        sizes=lambda params: {"radius": float(params[4]), "half_angle": abs(float(params[5]))},
    )
    return _result(data, solution)


def _result(data: FloatArray, solution: AxialSolution) -> ConeFit:
    params = solution.params
    rotation = solution.rotation
    x0, y0, a, b, radius, half_angle = (float(v) for v in params)
    direction_local = local_direction(a, b)
    origin_local = np.array([x0, y0, 0.0])
    shift = float(origin_local @ direction_local)
    foot_local = origin_local - shift * direction_local
    # radius at the foot point: it lies `-shift` along the axis from the crossing point
    radius_at_point = radius - shift * np.tan(half_angle)
    axis = rotation.T @ direction_local
    # alpha and alpha + k pi describe the same surface (only the residual sign flips): reduce
    # to (-pi/2, pi/2], then describe the cone from the side it opens to (0 <= alpha < pi/2)
    half_angle -= np.pi * round(half_angle / np.pi)
    if half_angle < 0:
        axis, half_angle, flip = -axis, -half_angle, -1.0
    else:
        flip = 1.0
    point = solution.centroid + rotation.T @ foot_local
    with np.errstate(divide="ignore"):
        apex = point - radius_at_point / np.tan(half_angle) * axis if half_angle > 0 else np.full(3, np.inf)

    offset = data - point
    height = offset @ axis
    rho = np.linalg.norm(offset - height[:, None] * axis, axis=1)
    residuals = (rho - radius_at_point - height * np.tan(half_angle)) * np.cos(half_angle)

    outcome = solution.outcome
    dof = data.shape[0] - 6
    cov_local, condition = covariance_from_jacobian(outcome.jacobian, outcome.residuals, dof, element=_ELEMENT)
    d_point, d_axis = axis_point_jacobian(rotation, foot_local)
    propagate = np.zeros((8, 6))
    propagate[0:3, 0:4] = d_point
    propagate[3:6, 0:4] = flip * d_axis
    # radius at the foot point = r - (p0 . d) tan(alpha); at a = b = 0: d/dr = 1, d/da = -x0 tan(alpha), ...
    slope = np.tan(float(params[5]))
    propagate[6, 2] = -foot_local[0] * slope
    propagate[6, 3] = -foot_local[1] * slope
    propagate[6, 4] = 1.0
    propagate[7, 5] = flip
    covariance = propagate @ cov_local @ propagate.T
    rms, form = residual_stats(residuals)
    return ConeFit(
        apex=frozen(apex),
        axis=frozen(axis),
        half_angle=float(half_angle),
        point=frozen(point),
        radius_at_point=float(radius_at_point),
        residuals=frozen(residuals),
        rms=rms,
        form=form,
        n=data.shape[0],
        dof=dof,
        parameter_names=(
            "point_x",
            "point_y",
            "point_z",
            "axis_x",
            "axis_y",
            "axis_z",
            "radius_at_point",
            "half_angle",
        ),
        parameters=frozen([*point, *axis, radius_at_point, half_angle]),
        covariance=frozen(covariance),
        condition_number=condition,
        converged=outcome.converged,
        iterations=solution.iterations,
        message=outcome.message,
    )
