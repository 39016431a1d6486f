"""Gaussian (least-squares) circle in 2-D and 3-D.

2-D: residual ``|p - c| - r``.  3-D, ``method="gaussian"`` (default): the residual of a
point is its distance to the circle *curve*, with two components, in-plane radial
``rho - r`` and axial ``h`` (the least-squares problem uses all 2N components).
3-D, ``method="projected"``: least-squares plane, projection onto it, 2-D Gaussian
circle in that plane -- the convention of NIST's reference pairs.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.elements import Criterion
from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError
from pcmm_geo.fit._kernels._core import FitResult, as_points, as_weights, residual_stats, solve_least_squares
from pcmm_geo.fit._kernels._inputs import positive_length
from pcmm_geo.fit._kernels._linear import frozen, local_covariance, sign_convention, weighted_centroid
from pcmm_geo.fit._kernels._measure import circle_distance, circle_project, query_points
from pcmm_geo.fit._kernels._round import fit_nsphere
from pcmm_geo.fit.plane import fit_plane
from pcmm_geo.fit.zone._common import check_criterion

__all__ = ["CircleFit", "fit_circle"]

FloatArray = NDArray[np.float64]
_ELEMENT = "circle"


@record(kw_only=True)
class CircleFit(FitResult):
    """Result of :func:`fit_circle`.

    Attributes
    ----------
    center : ndarray, shape (2,) or (3,)
        Centre (mm).
    radius : float
        Radius (mm).
    normal : ndarray, shape (3,) or None
        Unit normal of the circle's plane for 3-D data (largest-magnitude component
        positive); ``None`` for 2-D data.
    residual_components : ndarray, shape (N, 2) or (N, 1)
        3-D: in-plane radial and axial components of each point's offset from the circle;
        2-D: the radial residuals as a column.
    r_in : float
        Radius of the inner boundary of the zone: the smallest distance of a point from the
        centre (mm) for the ``"chebyshev"``, ``"mcc"`` and ``"mic"`` criteria; NaN for
        Gaussian fits.
    r_out : float
        Radius of the outer boundary (largest distance of a point from the centre), mm;
        NaN for Gaussian fits.
    """

    center: FloatArray
    radius: float
    normal: FloatArray | None
    residual_components: FloatArray
    r_in: float = float("nan")
    r_out: float = float("nan")

    @property
    def diameter(self) -> float:
        """Fitted diameter (mm)."""
        return 2.0 * self.radius

    def distance(self, points: ArrayLike) -> FloatArray:
        """Signed distances ``(...)`` of ``points`` (``(..., 2)`` or ``(..., 3)``) from the circle, mm.

        As the fit's residuals: positive outside; 3-D: to the circle curve, signed by the
        in-plane radial offset (the projected fit: the in-plane radial offset itself).

        Examples
        --------
        >>> import numpy as np
        >>> t = np.linspace(0, 2 * np.pi, 8, endpoint=False)
        >>> fit = fit_circle(np.c_[5 * np.cos(t), 5 * np.sin(t), np.zeros(8)] + [1, 2, 3])
        >>> np.round(fit.distance([[1, 10, 3], [9, 2, 7]]), 9).tolist()
        [3.0, 5.0]
        >>> (np.round(fit.project([[1, 10, 3], [9, 2, 7]]), 9) + 0.0).tolist()
        [[1.0, 7.0, 3.0], [6.0, 2.0, 3.0]]
        """
        pts = query_points(points, self.center.size)
        return circle_distance(pts, self.center, self.radius, self.normal,
                               in_plane_only=self.method.startswith("projected"))

    def project(self, points: ArrayLike) -> FloatArray:
        """Nearest points on the circle (curve) to ``points`` (``(..., D)``), mm.

        Raises
        ------
        DegenerateGeometryError
            A point on the circle's axis (every point of the circle is nearest).
        """
        return circle_project(query_points(points, self.center.size), self.center, self.radius, self.normal)


def fit_circle(
    points: ArrayLike,
    *,
    radius: float | None = None,
    weights: ArrayLike | None = None,
    method: Literal["gaussian", "projected"] = "gaussian",
    criterion: Criterion = "gaussian",
) -> CircleFit:
    r"""Fit a circle minimising the (weighted) sum of squared orthogonal distances.

    Parameters
    ----------
    points : array_like, shape (N, 2) or (N, 3)
        Measured points (mm); N >= 3, not collinear.  A fixed radius does not lower this:
        two points (or collinear points) lie on two mirror-image circles of a given radius,
        which no data tell apart (:class:`~pcmm_geo.errors.AmbiguousFitError`).
    radius : float, optional
        Fixed radius (mm), one positive number.
    weights : array_like, shape (N,), optional
        Non-negative weights of the squared distances.
    method : {"gaussian", "projected"}
        3-D only: distance to the circle curve (default) or plane-then-projected circle.

    criterion : {"gaussian", "chebyshev", "mcc", "mic"}
        ``"gaussian"`` (least squares, default) or the minimax criteria of
        :mod:`pcmm_geo.fit.zone` (contacts and optimality certificate on the result).
        For 3-D points these are evaluated in the least-squares plane of the points: the
        points are projected onto it and the 2-D minimax circle of the projections is
        returned (``residual_components[:, 1]`` keeps the out-of-plane offsets).

    Returns
    -------
    CircleFit
        ``center``, ``radius``, ``normal`` (3-D), signed ``residuals`` (3-D gaussian: the
        distance to the curve with the sign of the radial component; projected: radial
        residual in the plane), ``rms``, ``form`` (roundness), covariance of the
        machine-frame parameters.

    Raises
    ------
    InvalidInputError
        Wrong shape, complex or non-numeric values, NaN or inf, coordinates beyond 1e150 mm,
        unknown method, a fixed radius that is not one positive number, bad weights.
    TooFewPointsError
        Fewer than 3 points.
    DegenerateGeometryError
        Identical or collinear points (free radius).
    AmbiguousFitError
        Fixed radius and collinear points whose best circles are two mirror images
        (field ``candidates``: both centres).
    ConvergenceError
        The iteration did not converge.

    See Also
    --------
    fit_sphere : the same distance in 3-D
    fit_cylinder : a circle swept along an axis
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

        d_i = \lVert \mathbf{x}_i - \mathbf{c} \rVert - r

    in 2-D.  In 3-D (``method="gaussian"``) :math:`d_i` is the distance to the circle curve of
    centre :math:`\mathbf{c}`, unit normal :math:`\mathbf{n}` and radius :math:`r`, with the two
    components :math:`(\mathbf{x}_i - \mathbf{c}) \cdot \mathbf{n}` and
    :math:`\lVert (\mathbf{x}_i - \mathbf{c}) \times \mathbf{n} \rVert - r`;
    ``method="projected"`` fits the least-squares plane first and the 2-D circle in it, as the
    NIST algorithm testing system does [1]_.  The iteration starts from the algebraic circle of
    Kasa [6]_, which is never returned.

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
    .. [6] I. Kasa, "A circle fitting procedure and its error analysis", *IEEE Trans. Instrum. Meas.*
           IM-25(1), 8-14 (1976).

    Examples
    --------
    >>> angles = np.radians([0, 10, 20, 30])
    >>> pts = np.c_[500 + 5 * np.cos(angles), 500 + 5 * np.sin(angles)]
    >>> result = fit_circle(pts)
    >>> np.round(result.center, 9).tolist(), round(result.radius, 9)
    ([500.0, 500.0], 5.0)
    """
    if method not in ("gaussian", "projected"):
        raise InvalidInputError("method", "'gaussian' or 'projected'", repr(method))
    if radius is not None:
        radius = positive_length(radius, "radius")
    check_criterion(criterion, _ELEMENT, weights=weights, radius=radius)
    pts = as_points(points, element=_ELEMENT, dims=(2, 3), min_points=3)
    if criterion != "gaussian":
        from pcmm_geo.fit.zone._distinct import on_distinct
        from pcmm_geo.fit.zone._round import circle_minimax

        return on_distinct(pts, element=_ELEMENT, min_points=3,
                           solve=lambda q: circle_minimax(q, criterion, result_type=CircleFit, fit_plane=fit_plane))
    w = as_weights(weights, len(pts), element=_ELEMENT)
    if pts.shape[1] == 2:
        return _circle_2d(pts, w, radius)
    if method == "projected":
        return _circle_projected(pts, w, radius)
    return _circle_3d(pts, w, radius)


def _circle_2d(pts: FloatArray, w: FloatArray | None, radius: float | None) -> CircleFit:
    centre, fitted_radius, outcome, residuals, cond, cov = fit_nsphere(pts, w, element=_ELEMENT, fixed_radius=radius)
    rms, form = residual_stats(residuals)
    return CircleFit(
        center=frozen(centre),
        radius=fitted_radius,
        normal=None,
        residual_components=frozen(residuals[:, None]),
        residuals=frozen(residuals),
        rms=rms,
        form=form,
        n=len(pts),
        dof=len(pts) - outcome.x.size,
        parameter_names=("center_x", "center_y", "radius"),
        parameters=frozen(np.append(centre, fitted_radius)),
        covariance=frozen(cov),
        condition_number=cond,
        converged=outcome.converged,
        iterations=outcome.iterations,
        message=outcome.message,
        method="gaussian" if radius is None else "gaussian-fixed-radius",
    )


def _plane_frame(pts: FloatArray, w: FloatArray | None) -> tuple[FloatArray, FloatArray]:
    """Centroid and rows ``(e1, e2, normal)`` of the least-squares plane of the data."""
    try:
        plane = fit_plane(pts, weights=w)
    except DegenerateGeometryError:
        raise DegenerateGeometryError(_ELEMENT, "points are collinear; no unique circle passes through them") from None
    normal = plane.normal
    helper = np.zeros(3)
    helper[int(np.argmin(np.abs(normal)))] = 1.0
    e1 = np.cross(helper, normal)
    e1 /= np.linalg.norm(e1)
    return plane.point, np.vstack([e1, np.cross(normal, e1), normal])


def _circle_projected(pts: FloatArray, w: FloatArray | None, radius: float | None) -> CircleFit:
    origin, frame = _plane_frame(pts, w)
    in_plane = (pts - origin) @ frame[:2].T
    centre2, fitted_radius, outcome, residuals, cond, cov2 = fit_nsphere(
        in_plane, w, element=_ELEMENT, fixed_radius=radius
    )
    centre = origin + centre2 @ frame[:2]
    plane = fit_plane(pts, weights=w)
    # block-diagonal: circle-in-plane uncertainty mapped to 3-D, normal from the plane fit
    gradient = np.zeros((7, 3))
    gradient[:3, 0] = frame[0]
    gradient[:3, 1] = frame[1]
    gradient[6, 2] = 1.0
    cov = gradient @ cov2 @ gradient.T
    cov[3:6, 3:6] = plane.covariance[3:, 3:]
    rms, form = residual_stats(residuals)
    normal = frozen(sign_convention(frame[2]))
    return CircleFit(
        center=frozen(centre),
        radius=fitted_radius,
        normal=normal,
        residual_components=frozen(np.column_stack([residuals, (pts - origin) @ frame[2]])),
        residuals=frozen(residuals),
        rms=rms,
        form=form,
        n=len(pts),
        dof=len(pts) - outcome.x.size,
        parameter_names=_NAMES_3D,
        parameters=frozen(np.concatenate([centre, normal, [fitted_radius]])),
        covariance=frozen(cov),
        condition_number=cond,
        converged=outcome.converged,
        iterations=outcome.iterations,
        message=outcome.message,
        method="projected" if radius is None else "projected-fixed-radius",
    )


_NAMES_3D = ("center_x", "center_y", "center_z", "normal_x", "normal_y", "normal_z", "radius")


def _circle_3d(pts: FloatArray, w: FloatArray | None, radius: float | None) -> CircleFit:
    start = _circle_projected(pts, w, radius)
    origin = weighted_centroid(pts, w)
    # standard position: plane of the starting circle is z = 0, its normal +z
    _, frame = _plane_frame(pts, w)
    local = (pts - origin) @ frame.T
    size = float(np.sqrt(np.mean(np.sum(local**2, axis=1))))
    centre0 = (start.center - origin) @ frame.T
    x0 = np.concatenate([centre0, [0.0, 0.0]] + ([[start.radius]] if radius is None else []))

    def unit_normal(tilt: FloatArray) -> tuple[FloatArray, FloatArray]:
        raw = np.array([tilt[0], tilt[1], 1.0])
        norm = np.linalg.norm(raw)
        normal = raw / norm
        # derivatives of normal with respect to tilt_x, tilt_y (columns)
        d_raw = np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]])
        d_normal = d_raw / norm - np.outer(normal, normal @ d_raw) / norm
        return normal, d_normal

    def residual_and_jacobian(params: FloatArray) -> tuple[FloatArray, FloatArray]:
        centre, tilt = params[:3], params[3:5]
        r = params[5] if radius is None else radius
        normal, d_normal = unit_normal(tilt)
        rel = local - centre
        axial = rel @ normal
        radial_vec = rel - axial[:, None] * normal
        rho = np.linalg.norm(radial_vec, axis=1)
        if np.any(rho == 0):
            raise DegenerateGeometryError(_ELEMENT, "a point lies on the circle's axis; the 3-D residual is undefined")
        d_axial_d_tilt = rel @ d_normal  # (N, 2)
        jac_axial = np.column_stack([np.tile(-normal, (len(rel), 1)), d_axial_d_tilt])
        jac_radial = np.column_stack([-radial_vec / rho[:, None], -(axial / rho)[:, None] * d_axial_d_tilt])
        if radius is None:
            jac_radial = np.column_stack([jac_radial, -np.ones(len(rel))])
            jac_axial = np.column_stack([jac_axial, np.zeros(len(rel))])
        residual = np.empty(2 * len(rel))
        residual[0::2], residual[1::2] = rho - r, axial
        jac = np.empty((2 * len(rel), jac_radial.shape[1]))
        jac[0::2], jac[1::2] = jac_radial, jac_axial
        return residual, jac

    sqrt_w = None if w is None else np.repeat(np.sqrt(w), 2)
    outcome = solve_least_squares(residual_and_jacobian, x0, element=_ELEMENT, scale=size, sqrt_weights=sqrt_w)
    centre_local, tilt = outcome.x[:3], outcome.x[3:5]
    fitted_radius = float(outcome.x[5]) if radius is None else float(radius)
    normal_local, d_normal = unit_normal(tilt)
    stacked, _ = residual_and_jacobian(outcome.x)
    components = stacked.reshape(-1, 2)
    residuals = np.sign(components[:, 0]) * np.hypot(components[:, 0], components[:, 1])
    residuals = np.where(components[:, 0] == 0, np.abs(components[:, 1]), residuals)
    dof = 2 * len(pts) - outcome.x.size
    cov_local, cond = local_covariance(outcome.jacobian, outcome.residuals, dof)
    normal = normal_local @ frame
    flip = -1.0 if normal[int(np.argmax(np.abs(normal)))] < 0 else 1.0
    gradient = np.zeros((7, outcome.x.size))
    gradient[:3, :3] = frame.T
    gradient[3:6, 3:5] = flip * (frame.T @ d_normal)
    if radius is None:
        gradient[6, 5] = 1.0
    centre = origin + centre_local @ frame
    rms, form = residual_stats(residuals)
    return CircleFit(
        center=frozen(centre),
        radius=fitted_radius,
        normal=frozen(flip * normal),
        residual_components=frozen(components * np.array([1.0, flip])),
        residuals=frozen(residuals),
        rms=rms,
        form=form,
        n=len(pts),
        dof=dof,
        parameter_names=_NAMES_3D,
        parameters=frozen(np.concatenate([centre, flip * normal, [fitted_radius]])),
        covariance=frozen(gradient @ cov_local @ gradient.T),
        condition_number=cond,
        converged=outcome.converged,
        iterations=outcome.iterations,
        message=outcome.message,
        method="gaussian" if radius is None else "gaussian-fixed-radius",
    )
