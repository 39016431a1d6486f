"""Gaussian (orthogonal-distance least-squares) cylinder fit.

The residual of a point ``p`` is its distance from the axis minus the radius,
``e = |(p - a) x d| - r`` (positive outside), and the fit minimises ``sum w e^2``
over the axis and the radius (or over the axis alone when the radius is fixed).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from pcmm_geo._records import record
from pcmm_geo.elements import Criterion
from pcmm_geo.errors import InvalidInputError, PcmmGeoError
from pcmm_geo.fit._kernels import _tall
from pcmm_geo.fit._kernels._axial import (
    AxialSolution,
    FloatArray,
    LocalModel,
    StartRule,
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
from pcmm_geo.fit._kernels._core import FitResult, as_weights, check_points, covariance_from_jacobian, residual_stats
from pcmm_geo.fit._kernels._inputs import point_array, positive_length
from pcmm_geo.fit._kernels._linear import frozen, weighted_centroid
from pcmm_geo.fit._kernels._measure import axial_parts, query_points, radial_unit
from pcmm_geo.fit._kernels._screen import DENSE_POINTS, cylinder_reduced, screened_directions, surrounds_axis
from pcmm_geo.fit.scale import is_dask_array
from pcmm_geo.fit.zone._common import check_criterion
from pcmm_geo.fit.zone.axial.region import AxisRegion, SearchBudget, check_minimax_only

__all__ = ["CylinderFit", "fit_cylinder"]

_ELEMENT = "cylinder"


@record(kw_only=True)
class CylinderFit(FitResult):
    """Least-squares cylinder.

    Attributes
    ----------
    point : ndarray, shape (3,)
        Point of the axis nearest the data centroid (orthogonal projection of the
        centroid onto the axis), mm.
    axis : ndarray, shape (3,)
        Unit axis direction, sign chosen so that its largest-magnitude component is positive.
    radius : float
        Radius, mm.
    r_in, r_out : float
        Minimum-zone, MCC and MIC fits: smallest / largest distance of a point from the axis
        (mm); NaN for Gaussian fits.

    Notes
    -----
    ``parameter_names`` are ``point_x, point_y, point_z, axis_x, axis_y, axis_z, radius``
    (machine frame).  The covariance of these 7 numbers has rank 5 (4 with a fixed radius):
    the point can only move across the axis and the axis only tilt.

    With a non-Gaussian ``criterion`` the reported ``radius`` is the mid-zone radius
    (``"chebyshev"``), the circumscribed (``"mcc"``) or the inscribed (``"mic"``) radius;
    ``r_in`` / ``r_out`` are the smallest / largest point distances from the axis (NaN for
    Gaussian fits).
    """

    point: FloatArray
    axis: FloatArray
    radius: float
    r_in: float = float("nan")
    r_out: float = float("nan")

    @property
    def diameter(self) -> float:
        """Diameter ``2 r`` (mm), the number NIST's reference fits report."""
        return 2.0 * self.radius

    def distance(self, points: ArrayLike) -> FloatArray:
        """Signed distances ``(...)`` of ``points`` (``(..., 3)``) from the surface, positive outside (mm).

        Examples
        --------
        >>> import numpy as np
        >>> t = np.linspace(0, 2 * np.pi, 6, endpoint=False)
        >>> ring = np.c_[2 * np.cos(t), 2 * np.sin(t), np.zeros(6)]
        >>> fit = fit_cylinder(np.vstack([ring, ring + [0, 0, 5]]))
        >>> np.round(fit.distance([[5, 0, 1], [0, 1, 9]]), 9).tolist()
        [3.0, -1.0]
        >>> (np.round(fit.project([[5, 0, 1]]), 9) + 0.0).tolist()
        [[2.0, 0.0, 1.0]]
        """
        _, _, rho = axial_parts(query_points(points, 3), self.point, self.axis)
        return rho - self.radius

    def project(self, points: ArrayLike) -> FloatArray:
        """Nearest points ``(..., 3)`` on the cylinder surface (mm).

        Raises
        ------
        DegenerateGeometryError
            A point on the axis (a whole circle of surface points is nearest).
        """
        pts = query_points(points, 3)
        height, radial, rho = axial_parts(pts, self.point, self.axis)
        unit = radial_unit(radial, rho, _ELEMENT, self.radius)
        return self.point + height[..., None] * self.axis + self.radius * unit


def axis_point_jacobian(rotation: FloatArray, origin_local: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Machine-frame derivatives of the centroid's foot point and of the axis w.r.t. ``(x0, y0, a, b)``.

    At ``a = b = 0`` the foot of the perpendicular from the local origin is
    ``p = p0 - (p0 . d) d``; differentiating gives ``dp/dx0 = e_x``, ``dp/dy0 = e_y``,
    ``dp/da = -x0 e_z``, ``dp/db = -y0 e_z`` and ``dd/da = e_x``, ``dd/db = e_y`` (local),
    rotated back with ``rotation.T``.

    Returns
    -------
    d_point : ndarray, shape (3, 4)
    d_axis : ndarray, shape (3, 4)
    """
    x0, y0 = float(origin_local[0]), float(origin_local[1])
    d_point_local = np.zeros((3, 4))
    d_point_local[0, 0] = 1.0
    d_point_local[1, 1] = 1.0
    d_point_local[2, 2] = -x0
    d_point_local[2, 3] = -y0
    d_axis_local = np.zeros((3, 4))
    d_axis_local[0, 2] = 1.0
    d_axis_local[1, 3] = 1.0
    return rotation.T @ d_point_local, rotation.T @ d_axis_local


def _cylinder_model(fixed_radius: float | None) -> LocalModel:
    """Residual model ``rho - r`` in standard position; params ``(x0, y0, a, b[, r])``."""

    def model(local: FloatArray, params: FloatArray) -> tuple[FloatArray, FloatArray]:
        x0, y0, a, b = params[:4]
        radius = fixed_radius if fixed_radius is not None else params[4]
        terms = axial_terms(local, np.array([x0, y0, 0.0]), float(a), float(b))
        jac = np.empty((local.shape[0], params.size))
        jac[:, 0:2] = terms.d_rho[:, 0:2]
        jac[:, 2:4] = terms.d_rho[:, 3:5]
        if fixed_radius is None:
            jac[:, 4] = -1.0
        return terms.rho - radius, jac

    return model


def _cylinder_start(fixed_radius: float | None) -> StartRule:
    """Starting values around the local z axis: an algebraic circle of the projected points."""

    def start(local: FloatArray) -> FloatArray | None:
        x0, y0, radius = algebraic_circle(local[:, :2])
        if fixed_radius is not None:
            return np.array([x0, y0, 0.0, 0.0])
        if not radius > 0:
            return None
        return np.array([x0, y0, 0.0, 0.0, radius])

    return start


def fit_cylinder(
    points: ArrayLike,
    *,
    radius: float | None = None,
    weights: ArrayLike | None = None,
    axis_hint: ArrayLike | None = None,
    criterion: Criterion = "gaussian",
    axis_region: AxisRegion | None = None,
    search_budget: SearchBudget | None = None,
) -> CylinderFit:
    r"""Fit a cylinder to 3-D points by orthogonal-distance least squares.

    Gauss-Newton / Levenberg-Marquardt with an analytic Jacobian in standard position
    (data centred at the centroid, current axis rotated to +z; local parameters are the
    axis crossing ``x0, y0`` of the local ``z = 0`` plane, two tilts ``a, b`` and the radius).
    From ``pcmm_geo.fit._kernels._tall.TALL_ROWS`` unweighted points on, and for a dask array, the fit
    of a strided subsample starts Gauss-Newton passes whose normal equations are accumulated
    in chunks (:mod:`pcmm_geo.fit.scale.fits`).
    Starting axes are ``axis_hint``, the polished local minima of a direction screening
    (:mod:`pcmm_geo.fit._kernels._screen`: the circle fit of the data projected along each of 240
    directions) and the principal axes; an algebraic circle of the projected data starts each.
    The converged solution of least cost is returned; when another distinct minimum is within
    ``TOL.ambiguous`` (1 %) of it, :class:`~pcmm_geo.errors.AmbiguousFitWarning` lists both.

    Parameters
    ----------
    points : array_like or dask.array.Array, shape (N, 3)
        Measured points (mm); N >= 5 (N >= 4 with a fixed radius).  A dask array is fitted
        block by block (no weights); ``residuals`` are then lazy.
    radius : float, optional
        Fix the radius (mm) and fit the axis only.
    weights : array_like, shape (N,), optional
        Non-negative weights of the squared residuals.
    axis_hint : array_like, shape (3,), optional
        Approximate axis direction tried first (either sign).

    criterion : {"gaussian", "chebyshev", "mcc", "mic"}
        ``"gaussian"`` (least squares, default) or the minimax criteria of
        :mod:`pcmm_geo.fit.zone` (contacts and optimality certificate on the result).
        These are searched globally over the axes of ``axis_region`` by branch and bound;
        ``certificate.scope`` says ``"global"`` when the optimum over the region is proven
        to 1e-9 mm, ``"local"`` (with the proven ``bound_mm``) when ``search_budget`` ran out.
    axis_region : AxisRegion, optional
        Minimax criteria only: the axes searched (default: within 45 deg of the
        least-squares axis, crossing the plane normal to it through the data centroid
        within twice the least-squares radius of it).
    search_budget : SearchBudget, optional
        Minimax criteria only: cell and time limits of the search.

    Returns
    -------
    CylinderFit
        Residuals are ``distance to axis - radius`` (mm, positive outside).

    Raises
    ------
    InvalidInputError
        NaN/inf, wrong shape, a non-positive fixed radius, a bad hint or bad weights.
    TooFewPointsError
        Fewer than 5 points (4 with a fixed radius).
    DegenerateGeometryError
        All points on a line or in a plane.
    ConvergenceError
        No starting value led to a converged solution.

    See Also
    --------
    fit_line : the axis of thin data
    fit_cone : a cylinder whose radius changes along the axis
    pcmm_geo.fit.zone.form.evaluate_form : minimum-zone form deviation and its verdict
    pcmm_geo.fit.probe.compensate_probe : probe-ball centres onto the touched surface
    pcmm_geo.fit.zone.axial.region.AxisRegion : the axes searched by the minimax criteria

    Notes
    -----
    The Gaussian (least-squares) element minimises the weighted sum of squared orthogonal
    distances [1]_ [2]_

    .. math::

        \min_{\mathbf{a}} \; \sum_{i=1}^{N} w_i \, d_i(\mathbf{a})^2 ,

    where :math:`\mathbf{a}` are the element's parameters and :math:`d_i` the signed distance
    of point :math:`\mathbf{x}_i`, here

    .. math::

        d_i = \lVert (\mathbf{x}_i - \mathbf{x}_0) \times \mathbf{u} \rVert - r

    for the cylinder of axis point :math:`\mathbf{x}_0`, unit axis :math:`\mathbf{u}` and
    radius :math:`r` [1]_ [2]_.

    The other criteria minimise the largest distance instead (Chebyshev, minimum zone, as in
    the reference software of [4]_) or the circumscribed / inscribed radius (MCC, MIC): the
    form zone of ISO 1101 [3]_; such a result carries an optimality certificate.
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
    >>> angle = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    >>> ring = np.c_[5 * np.cos(angle), 5 * np.sin(angle), np.zeros(8)]
    >>> pts = np.vstack([ring, ring + [0, 0, 20]]) + [1000.0, 0.0, 0.0]
    >>> fit = fit_cylinder(pts)
    >>> round(fit.radius, 12), (np.round(fit.axis, 12) + 0.0).tolist(), (np.round(fit.point, 9) + 0.0).tolist()
    (5.0, [0.0, 0.0, 1.0], [1000.0, 0.0, 10.0])
    """
    if radius is not None:
        radius = positive_length(radius, "radius")
    check_criterion(criterion, _ELEMENT, weights=weights, radius=radius, axis_hint=axis_hint)
    check_minimax_only(criterion, axis_region=axis_region, search_budget=search_budget)
    if is_dask_array(points):
        if criterion != "gaussian":
            raise InvalidInputError("criterion", "'gaussian' for a dask array of points", repr(criterion))
        from pcmm_geo.fit.scale.dask import fit_cylinder_dask

        return CylinderFit(**fit_cylinder_dask(points, radius=radius, weights=weights, axis_hint=axis_hint,
                                               **_scale_parts()))
    min_points = 5 if radius is None else 4
    data = point_array(points, element=_ELEMENT, min_points=min_points)
    chunked = weights is None and criterion == "gaussian" and len(data) >= _tall.TALL_ROWS
    if not chunked:  # the chunked fit checks the values in its first pass
        check_points(data, element=_ELEMENT, min_points=min_points)
    if criterion != "gaussian":
        from pcmm_geo.fit.zone._axial import cylinder_minimax
        from pcmm_geo.fit.zone._distinct import on_distinct

        def solve(q: np.ndarray) -> CylinderFit:
            return cylinder_minimax(q, criterion, gauss=fit_cylinder(q), result_type=CylinderFit,
                                    axis_region=axis_region, search_budget=search_budget)

        return on_distinct(data, element=_ELEMENT, min_points=min_points, solve=solve)
    weight = as_weights(weights, data.shape[0], element=_ELEMENT)
    if chunked:
        from pcmm_geo.fit.scale.chunked import IllConditionedSteps
        from pcmm_geo.fit.scale.fits import fit_cylinder_scaled, numpy_source

        try:
            source = numpy_source(data, element=_ELEMENT, min_points=min_points)
            return CylinderFit(**fit_cylinder_scaled(source, radius, axis_hint, **_scale_parts()))
        except IllConditionedSteps:
            pass  # nearly coplanar: the solver below decides
    sqrt_weights = None if weight is None else np.sqrt(weight)
    centroid = weighted_centroid(data)
    centred = data - centroid
    check_spread(centred, element=_ELEMENT, forbid_coplanar=True)
    solution = _solve(data, centroid, centred, as_axis_hint(axis_hint), radius, sqrt_weights)
    warn_if_ambiguous(
        solution,
        element=_ELEMENT,
        position_slots=(0, 1),
        tilt_slots=(2, 3),
        sizes=lambda params: {"radius": radius if radius is not None else float(params[4])},
    )
    return _result(data, solution, radius)


#: dense unweighted data of more than twice this many points start from the fit of a strided subsample of
#: about this many (a start from each principal axis costs iterations over every point, the subsample's a fifth)
_START_SUBSAMPLE = 1000


def _solve(data: FloatArray, centroid: FloatArray, centred: FloatArray, hint: FloatArray | None,
           radius: float | None, sqrt_weights: FloatArray | None) -> AxialSolution:
    """The least-squares cylinder from the principal axes and ``hint``, and screened directions where needed.

    Sparse data are screened first.  Dense data are fitted from the principal axes; when that
    fit does not surround its axis (a partial surface,
    :func:`~pcmm_geo.fit._kernels._screen.surrounds_axis`), they are screened and fitted again.
    Many dense unweighted points are first fitted so on a strided subsample, whose axis then
    starts the one fit of all points (unless the subsample has rival minima: then all points
    go through the search).
    """
    def solve(axes: list[FloatArray]) -> AxialSolution:
        return solve_axial(data, centroid, axes, start=_cylinder_start(radius), model=_cylinder_model(radius),
                           position_slots=(0, 1), tilt_slots=(2, 3), element=_ELEMENT, sqrt_weights=sqrt_weights)

    def screened() -> list[FloatArray]:
        return screened_directions(centred, cylinder_reduced(radius))

    # points of zero weight do not count: they neither make data dense nor fill a gap
    counted = centred if sqrt_weights is None else centred[sqrt_weights > 0]
    dense = len(counted) > DENSE_POINTS
    if dense and sqrt_weights is None and len(data) > 2 * _START_SUBSAMPLE:
        sample = data[::len(data) // _START_SUBSAMPLE]
        sample_centroid = weighted_centroid(sample)
        try:
            rough = _solve(sample, sample_centroid, sample - sample_centroid, hint, radius, None)
        except PcmmGeoError:
            rough = None  # all points decide below
        if rough is not None and not rough.others:
            return solve([rough.rotation[2]])  # the subsample's axis (its final frame has a = b = 0)
    solution = solve(candidate_axes(centred, [hint] if dense else [hint, *screened()]))
    if dense and not surrounds_axis(len(counted), _across_axis(counted, solution)):
        solution = solve(candidate_axes(centred, [hint, *screened()]))  # a partial surface
    return solution


def _across_axis(centred: FloatArray, solution: AxialSolution) -> FloatArray:
    """Coordinates (N, 2) of the centred data across the fitted axis, relative to it (final frame: a = b = 0)."""
    return centred @ solution.rotation[:2].T - solution.params[:2]


def _scale_parts() -> dict[str, object]:
    """What :mod:`pcmm_geo.fit.scale.fits` needs of this module (passed in: it must not import us)."""
    return {"fit_cylinder": fit_cylinder, "model": _cylinder_model, "axis_point_jacobian": axis_point_jacobian}


def _result(data: FloatArray, solution: AxialSolution, fixed_radius: float | None) -> CylinderFit:
    params = solution.params
    rotation = solution.rotation
    x0, y0, a, b = (float(v) for v in params[:4])
    radius = fixed_radius if fixed_radius is not None else float(params[4])
    direction_local = local_direction(a, b)
    origin_local = np.array([x0, y0, 0.0])
    foot_local = origin_local - (origin_local @ direction_local) * direction_local
    axis = rotation.T @ direction_local
    point = solution.centroid + rotation.T @ foot_local
    signed_axis = canonical_axis(axis)

    residuals = np.linalg.norm(np.cross(data - point, axis), axis=1) - radius
    outcome = solution.outcome
    n_param = params.size
    dof = data.shape[0] - n_param
    cov_local, condition = covariance_from_jacobian(outcome.jacobian, outcome.residuals, dof, element=_ELEMENT)
    d_point, d_axis = axis_point_jacobian(rotation, foot_local)
    if float(signed_axis @ axis) < 0:
        d_axis = -d_axis
    propagate = np.zeros((7, n_param))
    propagate[0:3, 0:4] = d_point
    propagate[3:6, 0:4] = d_axis
    if fixed_radius is None:
        propagate[6, 4] = 1.0
    covariance = propagate @ cov_local @ propagate.T
    rms, form = residual_stats(residuals)
    return CylinderFit(
        point=frozen(point),
        axis=frozen(signed_axis),
        radius=radius,
        residuals=frozen(residuals),
        rms=rms,
        form=form,
        n=data.shape[0],
        dof=dof,
        parameter_names=("point_x", "point_y", "point_z", "axis_x", "axis_y", "axis_z", "radius"),
        parameters=frozen([*point, *signed_axis, radius]),
        covariance=frozen(covariance),
        condition_number=condition,
        converged=outcome.converged,
        iterations=solution.iterations,
        message=outcome.message,
        method="gaussian" if fixed_radius is None else "gaussian-fixed-radius",
    )
