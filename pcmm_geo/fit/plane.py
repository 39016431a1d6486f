"""Gaussian (least-squares) plane.

The orthogonal-distance least-squares plane passes through the (weighted) centroid,
with the normal along the right singular vector of the smallest singular value of
the centred data: a closed form, no iteration.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.elements import Criterion
from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError
from pcmm_geo.fit._kernels import _tall
from pcmm_geo.fit._kernels._core import TOL, FitResult, as_weights, check_points, residual_stats
from pcmm_geo.fit._kernels._inputs import point_array
from pcmm_geo.fit._kernels._linear import frozen, local_covariance, principal_frame, propagate, sign_convention
from pcmm_geo.fit.scale import is_dask_array
from pcmm_geo.fit.zone._common import check_criterion

__all__ = ["PlaneFit", "fit_plane"]

FloatArray = NDArray[np.float64]
_ELEMENT = "plane"


@record(kw_only=True)
class PlaneFit(FitResult):
    """Result of :func:`fit_plane`.

    Attributes
    ----------
    point : ndarray, shape (3,)
        The (weighted) centroid of the data, which lies on the plane (mm).
    normal : ndarray, shape (3,)
        Unit normal; sign chosen so that its largest-magnitude component is positive.
    """

    point: FloatArray
    normal: FloatArray

    def distance(self, points: ArrayLike) -> FloatArray:
        """Signed distances of ``points`` (``(..., 3)``) from the plane, positive along ``normal``."""
        return (np.asarray(points, dtype=float) - self.point) @ self.normal

    def project(self, points: ArrayLike) -> FloatArray:
        """Orthogonal projections of ``points`` (``(..., 3)``) onto the plane."""
        pts = np.asarray(points, dtype=float)
        return pts - self.distance(pts)[..., None] * self.normal


def fit_plane(points: ArrayLike, *, weights: ArrayLike | None = None, criterion: Criterion = "gaussian") -> PlaneFit:
    r"""Fit a plane minimising the (weighted) sum of squared orthogonal distances.

    Parameters
    ----------
    points : array_like or dask.array.Array, shape (N, 3)
        Measured points (mm), N >= 3, not all on one line.  From ``pcmm_geo.fit._kernels._tall.TALL_ROWS``
        unweighted points on, the centroid and scatter matrix are accumulated in chunks and the
        normal is their eigenvector (:mod:`pcmm_geo.fit.scale.fits`); a dask array is fitted so,
        block by block (no weights), with lazy ``residuals``.
    weights : array_like, shape (N,), optional
        Non-negative weights of the squared distances.

    criterion : {"gaussian", "chebyshev"}
        ``"gaussian"`` (least squares, default) or the minimax criteria of
        :mod:`pcmm_geo.fit.zone` (contacts and optimality certificate on the result).

    Returns
    -------
    PlaneFit
        ``point``, ``normal``, signed ``residuals`` (positive along the normal), ``rms``,
        ``form`` (flatness), and the covariance of the machine-frame parameters
        ``point_x, point_y, point_z, normal_x, normal_y, normal_z`` (rank 3: the point
        moves only along the normal, the normal only perpendicular to itself).

    Raises
    ------
    InvalidInputError
        Wrong shape, NaN or inf.
    TooFewPointsError
        Fewer than 3 points.
    DegenerateGeometryError
        Identical or collinear points.

    See Also
    --------
    fit_line : the least-squares line (largest singular vector)
    pcmm_geo.fit.zone.form.evaluate_form : minimum-zone form deviation and its verdict

    Notes
    -----
    The Gaussian (least-squares) element minimises the weighted sum of squared orthogonal
    distances [1]_ [2]_

    .. math::

        \min_{\mathbf{a}} \; \sum_{i=1}^{N} w_i \, d_i(\mathbf{a})^2 ,

    where :math:`\mathbf{a}` are the element's parameters and :math:`d_i` the signed distance
    of point :math:`\mathbf{x}_i`, here

    .. math::

        d_i = (\mathbf{x}_i - \mathbf{x}_0) \cdot \mathbf{n}

    for the plane through :math:`\mathbf{x}_0` with unit normal :math:`\mathbf{n}`.  The
    solution is closed-form: :math:`\mathbf{x}_0` is the weighted centroid and
    :math:`\mathbf{n}` the right singular vector of the centred data with the smallest
    singular value [1]_ [2]_.

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
    >>> result = fit_plane([[0, 0, 1], [1, 0, 1], [0, 1, 1], [1, 1, 1]])
    >>> result.normal.tolist(), result.point.tolist(), result.form
    ([0.0, 0.0, 1.0], [0.5, 0.5, 1.0], 0.0)
    """
    check_criterion(criterion, _ELEMENT, weights=weights)
    if is_dask_array(points):
        if criterion != "gaussian":
            raise InvalidInputError("criterion", "'gaussian' for a dask array of points", repr(criterion))
        from pcmm_geo.fit.scale.dask import fit_plane_dask

        return PlaneFit(**fit_plane_dask(points, weights=weights))
    min_points = 3
    pts = point_array(points, element=_ELEMENT, min_points=min_points)
    chunked = weights is None and criterion == "gaussian" and len(pts) >= _tall.TALL_ROWS
    if not chunked:  # the chunked fit checks the values in its first pass
        check_points(pts, element=_ELEMENT, min_points=min_points)
    if criterion != "gaussian":
        from pcmm_geo.fit.zone._distinct import on_distinct
        from pcmm_geo.fit.zone._linear import plane_minimax

        return on_distinct(pts, element=_ELEMENT, min_points=min_points,
                           solve=lambda q: plane_minimax(q, criterion, gauss=fit_plane(q), result_type=PlaneFit))
    w = as_weights(weights, len(pts), element=_ELEMENT)
    if chunked:
        from pcmm_geo.fit.scale.chunked import IllConditionedSteps
        from pcmm_geo.fit.scale.fits import fit_plane_scaled, numpy_source

        try:
            return PlaneFit(**fit_plane_scaled(numpy_source(pts, element=_ELEMENT, min_points=min_points)))
        except IllConditionedSteps:
            pass  # nearly collinear: the singular value decomposition below decides
    centroid, singular, vt = principal_frame(pts, w, element=_ELEMENT)
    if singular[1] <= TOL.degenerate * singular[0]:
        raise DegenerateGeometryError(_ELEMENT, "points are collinear; a plane needs points spanning two directions")
    normal = sign_convention(vt[2])
    e1, e2 = vt[0], vt[1]
    residuals = (pts - centroid) @ normal
    # local parameters: offset along the normal, tilts of the normal towards e1 and e2
    jacobian = np.column_stack([-np.ones(len(pts)), -(pts - centroid) @ e1, -(pts - centroid) @ e2])
    sqrt_w = np.ones(len(pts)) if w is None else np.sqrt(w)
    dof = len(pts) - 3
    cov_local, cond = local_covariance(jacobian * sqrt_w[:, None], residuals * sqrt_w, dof)
    gradient = np.zeros((6, 3))
    gradient[:3, 0] = normal
    gradient[3:, 1] = e1
    gradient[3:, 2] = e2
    rms, form = residual_stats(residuals)
    return PlaneFit(
        point=frozen(centroid),
        normal=frozen(normal),
        residuals=frozen(residuals),
        rms=rms,
        form=form,
        n=len(pts),
        dof=dof,
        parameter_names=("point_x", "point_y", "point_z", "normal_x", "normal_y", "normal_z"),
        parameters=frozen(np.concatenate([centroid, normal])),
        covariance=frozen(propagate(cov_local, gradient)),
        condition_number=cond,
        converged=True,
        iterations=0,
        message="closed form (singular value decomposition)",
    )
