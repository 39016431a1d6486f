"""Gaussian (least-squares) sphere."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.elements import Criterion
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.fit._kernels import _tall
from pcmm_geo.fit._kernels._core import TOL, FitResult, as_weights, check_points, residual_stats
from pcmm_geo.fit._kernels._inputs import check_point_extremes, point_array, positive_length
from pcmm_geo.fit._kernels._linear import frozen
from pcmm_geo.fit._kernels._measure import query_points, radial_unit
from pcmm_geo.fit._kernels._round import fit_nsphere
from pcmm_geo.fit.scale import is_dask_array
from pcmm_geo.fit.zone._common import check_criterion

__all__ = ["SphereFit", "fit_sphere"]

FloatArray = NDArray[np.float64]
_ELEMENT = "sphere"


@record(kw_only=True)
class SphereFit(FitResult):
    """Result of :func:`fit_sphere`.

    Attributes
    ----------
    center : ndarray, shape (3,)
        Centre (mm).
    radius : float
        Radius (mm); ``diameter`` is twice it.
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
    r_in: float = float("nan")
    r_out: float = float("nan")

    @property
    def diameter(self) -> float:
        """Fitted diameter (mm)."""
        return 2.0 * self.radius

    def distance(self, points: ArrayLike) -> FloatArray:
        """Signed distances of ``points`` (``(..., 3)``) from the sphere, positive outside."""
        return np.linalg.norm(np.asarray(points, dtype=float) - self.center, axis=-1) - self.radius

    def project(self, points: ArrayLike) -> FloatArray:
        """Nearest points ``(..., 3)`` on the sphere to ``points`` (``(..., 3)``), mm.

        Raises
        ------
        DegenerateGeometryError
            A point at the centre (every surface point is nearest).
        """
        pts = query_points(points, 3)
        rel = pts - self.center
        return self.center + self.radius * radial_unit(rel, np.linalg.norm(rel, axis=-1), _ELEMENT, self.radius)


def fit_sphere(
    points: ArrayLike,
    *,
    radius: float | None = None,
    weights: ArrayLike | None = None,
    criterion: Criterion = "gaussian",
) -> SphereFit:
    r"""Fit a sphere minimising the (weighted) sum of squared orthogonal distances.

    Gauss-Newton / Levenberg-Marquardt on centred data from an algebraic (Kasa)
    starting value; the algebraic fit is never returned.  From ``pcmm_geo.fit._kernels._tall.TALL_ROWS``
    points on (unweighted) the data are read in cache-sized chunks: the start from moments of
    one pass, then each Gauss-Newton step from normal equations accumulated chunk by chunk
    (:mod:`pcmm_geo.fit.scale.sphere`); ill-conditioned data go to the orthogonal routines.

    Parameters
    ----------
    points : array_like or dask.array.Array, shape (N, 3)
        Measured points (mm); N >= 4 (N >= 3 with a fixed radius), not coplanar.  A dask
        array is fitted block by block without being materialised (no weights); the
        result's ``residuals`` are then a lazy dask array.
    radius : float, optional
        Fixed radius (mm, one positive number): only the centre is fitted (e.g. a calibrated
        reference sphere).  Coplanar points then fit a centre and its mirror image in their
        plane equally well unless the best centre lies in the plane (points on a circle
        larger than the radius): the ambiguous case raises :class:`~pcmm_geo.errors.AmbiguousFitError`.
    weights : array_like, shape (N,), optional
        Non-negative weights of the squared distances.

    criterion : {"gaussian", "chebyshev", "mcc", "mic"}
        ``"gaussian"`` (least squares, default) or the minimax criteria of
        :mod:`pcmm_geo.fit.zone` (contacts and optimality certificate on the result).

    Returns
    -------
    SphereFit
        ``center``, ``radius``, signed ``residuals`` (positive outside), ``rms``, ``form``
        (sphericity, max - min residual), covariance of ``center_x, center_y, center_z, radius``.

    Raises
    ------
    InvalidInputError
        Wrong shape, complex or non-numeric values, NaN or inf, coordinates beyond 1e150 mm,
        a fixed radius that is not one positive number, bad weights.
    TooFewPointsError
        Fewer than 4 points (3 with fixed radius).
    DegenerateGeometryError
        Identical or coplanar points (free radius).
    AmbiguousFitError
        Fixed radius, coplanar points, two mirror-image centres (field ``candidates``).
    ConvergenceError
        The iteration did not converge.

    See Also
    --------
    fit_circle : the same distance in a plane
    pcmm_geo.artefacts.iso10360_5.evaluate_probing : ISO 10360-5 probing error from a sphere fit
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

    for the sphere of centre :math:`\mathbf{c}` and radius :math:`r` (positive outside).
    The Gauss-Newton iteration starts from the algebraic (Kasa) fit [6]_, which is never
    returned.

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
    >>> pts = [[11, 0, 0], [-9, 0, 0], [1, 10, 0], [1, -10, 0], [1, 0, 10], [1, 0, -10]]
    >>> result = fit_sphere(pts)
    >>> (np.round(result.center, 12) + 0.0).tolist(), round(result.radius, 12)
    ([1.0, 0.0, 0.0], 10.0)
    """
    if radius is not None:
        radius = positive_length(radius, "radius")
    check_criterion(criterion, _ELEMENT, weights=weights, radius=radius)
    if is_dask_array(points):
        if criterion != "gaussian":
            raise InvalidInputError("criterion", "'gaussian' for a dask array of points", repr(criterion))
        from pcmm_geo.fit.scale.dask import fit_sphere_dask

        found, residuals = fit_sphere_dask(points, radius=radius, weights=weights)
        return _from_solution(found, residuals, radius)
    min_points = 4 if radius is None else 3
    pts = point_array(points, element=_ELEMENT, min_points=min_points)
    if weights is None and criterion == "gaussian" and len(pts) >= _tall.TALL_ROWS:
        chunked = _fit_chunked(pts, radius, min_points)  # checks the values in its first pass
        if chunked is not None:
            return chunked
    else:
        check_points(pts, element=_ELEMENT, min_points=min_points)
    if criterion != "gaussian":
        from pcmm_geo.fit.zone._distinct import on_distinct
        from pcmm_geo.fit.zone._round import sphere_minimax

        return on_distinct(pts, element=_ELEMENT, min_points=min_points,
                           solve=lambda q: sphere_minimax(q, criterion, result_type=SphereFit))
    w = as_weights(weights, len(pts), element=_ELEMENT)
    centre, fitted_radius, outcome, residuals, cond, cov = fit_nsphere(pts, w, element=_ELEMENT, fixed_radius=radius)
    rms, form = residual_stats(residuals)
    return sphere_result(centre, fitted_radius, residuals, rms=rms, form=form, n=len(pts),
                         parameter_count=outcome.x.size, covariance=cov, condition=cond, converged=outcome.converged,
                         iterations=outcome.iterations, message=outcome.message, fixed=radius is not None)


def _fit_chunked(pts: FloatArray, radius: float | None, min_points: int) -> SphereFit | None:
    """The chunked solver on in-memory points, unchecked so far; None when they need the orthogonal routines.

    The values are checked from the extremes of the moment pass (the row of a bad value is
    then found and named); nothing else reads the points before.
    """
    from pcmm_geo.fit.scale.chunked import IllConditionedSteps, in_memory, moments
    from pcmm_geo.fit.scale.sphere import fit_nsphere_chunked

    reduce = in_memory(pts)
    shift = pts[0].copy()
    data = moments(reduce, shift)
    check_point_extremes(pts, data.lower, data.upper, element=_ELEMENT, min_points=min_points,
                         identical=TOL.identical)
    residuals = np.empty(len(pts))
    try:
        found = fit_nsphere_chunked(reduce, shift, element=_ELEMENT, fixed_radius=radius, out=residuals, data=data)
    except IllConditionedSteps:
        return None
    return _from_solution(found, residuals, radius)


def _from_solution(found: Any, residuals: Any, radius: float | None) -> SphereFit:
    """A :class:`SphereFit` from a :class:`~pcmm_geo.fit.scale.sphere.SphereSolution`."""
    return sphere_result(found.center, found.radius, residuals, rms=found.rms, form=found.form, n=found.count,
                         parameter_count=found.parameter_count, covariance=found.covariance,
                         condition=found.condition, converged=found.converged, iterations=found.iterations,
                         message=found.message, fixed=radius is not None)


def sphere_result(
    center: FloatArray, radius: float, residuals: Any, *, rms: float, form: float, n: int, parameter_count: int,
    covariance: FloatArray, condition: float, converged: bool, iterations: int, message: str, fixed: bool,
) -> SphereFit:
    """Assemble a :class:`SphereFit` (``residuals`` a numpy array, or a lazy dask array)."""
    return SphereFit(
        center=frozen(center),
        radius=float(radius),
        residuals=residuals if is_dask_array(residuals) else frozen(residuals),
        rms=rms,
        form=form,
        n=n,
        dof=n - parameter_count,
        parameter_names=("center_x", "center_y", "center_z", "radius"),
        parameters=frozen(np.append(center, radius)),
        covariance=frozen(covariance),
        condition_number=condition,
        converged=converged,
        iterations=iterations,
        message=message,
        method="gaussian-fixed-radius" if fixed else "gaussian",
    )
