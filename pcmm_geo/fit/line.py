"""Gaussian (least-squares) straight line in 2-D or 3-D.

The orthogonal-distance least-squares line passes through the (weighted) centroid
along the right singular vector of the largest singular value of the centred data.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.elements import Criterion
from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError
from pcmm_geo.fit._kernels import _tall
from pcmm_geo.fit._kernels._core import FitResult, as_weights, check_points, residual_stats
from pcmm_geo.fit._kernels._inputs import point_array
from pcmm_geo.fit._kernels._linear import frozen, local_covariance, principal_frame, propagate, sign_convention
from pcmm_geo.fit.scale import is_dask_array
from pcmm_geo.fit.zone._common import check_criterion
from pcmm_geo.fit.zone.axial.region import SearchBudget, check_minimax_only

__all__ = ["LineFit", "fit_line"]

FloatArray = NDArray[np.float64]
_ELEMENT = "line"


@record(kw_only=True)
class LineFit(FitResult):
    """Result of :func:`fit_line`.

    Attributes
    ----------
    point : ndarray, shape (D,)
        The (weighted) centroid of the data, which lies on the line (mm).
    direction : ndarray, shape (D,)
        Unit direction; sign chosen so that its largest-magnitude component is positive.

    Notes
    -----
    In 2-D ``residuals`` are signed (positive on the left of ``direction``); in 3-D they
    are the (non-negative) distances to the line, and ``extra["residual_components"]``
    holds the two perpendicular components ``(N, 2)`` that the least-squares problem uses.
    """

    point: FloatArray
    direction: FloatArray

    def distance(self, points: ArrayLike) -> FloatArray:
        """Distances of ``points`` (``(..., D)``) from the line (signed in 2-D)."""
        rel = np.asarray(points, dtype=float) - self.point
        if self.point.size == 2:
            return rel @ np.array([-self.direction[1], self.direction[0]])
        return np.linalg.norm(rel - (rel @ self.direction)[..., None] * self.direction, axis=-1)

    def project(self, points: ArrayLike) -> FloatArray:
        """Orthogonal projections of ``points`` (``(..., D)``) onto the line."""
        rel = np.asarray(points, dtype=float) - self.point
        return self.point + (rel @ self.direction)[..., None] * self.direction


def fit_line(
    points: ArrayLike,
    *,
    weights: ArrayLike | None = None,
    criterion: Criterion = "gaussian",
    search_budget: SearchBudget | None = None,
) -> LineFit:
    r"""Fit a straight line minimising the (weighted) sum of squared orthogonal distances.

    Parameters
    ----------
    points : array_like, shape (N, 2) or (N, 3), or dask.array.Array, shape (N, 3)
        Measured points (mm), N >= 2, not all identical.  From ``pcmm_geo.fit._kernels._tall.TALL_ROWS``
        unweighted 3-D points on, the moments are accumulated in chunks
        (:mod:`pcmm_geo.fit.scale.fits`); a dask array is fitted so, block by block (no
        weights), with lazy ``residuals``.
    weights : array_like, shape (N,), optional
        Non-negative weights of the squared distances.

    criterion : {"gaussian", "chebyshev"}
        ``"gaussian"`` (least squares, default) or the minimax criteria of
        :mod:`pcmm_geo.fit.zone` (contacts and optimality certificate on the result).
        In 3-D the minimum zone is the smallest enclosing cylinder over all directions,
        searched globally by branch and bound (``certificate.scope``).
    search_budget : SearchBudget, optional
        3-D minimum zone only: cell and time limits of that search.

    Returns
    -------
    LineFit
        ``point`` (centroid), unit ``direction``, residuals, ``rms``, ``form``
        (straightness: max - min of the signed distances in 2-D; in 3-D twice the
        largest distance, the diameter of the enclosing cylinder about the fitted axis),
        covariance of ``point_*`` and ``direction_*`` in the machine frame.

    Raises
    ------
    InvalidInputError
        Wrong shape, NaN or inf.
    TooFewPointsError
        Fewer than 2 points.
    DegenerateGeometryError
        All points identical.

    See Also
    --------
    fit_plane : the plane through the same centroid, normal along the smallest singular vector
    pcmm_geo.fit.skew.closest_points : closest points of two 3-D lines
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

        d_i = \lVert (\mathbf{x}_i - \mathbf{x}_0) \times \mathbf{u} \rVert

    (signed in 2-D) for a line through :math:`\mathbf{x}_0` with unit direction
    :math:`\mathbf{u}`.  The solution is closed-form: :math:`\mathbf{x}_0` is the weighted
    centroid and :math:`\mathbf{u}` the right singular vector of the centred data with the
    largest singular value [1]_ [2]_.

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
    >>> result = fit_line([[0, 0, 0], [1, 1, 1], [2, 2, 2]])
    >>> np.round(result.direction * np.sqrt(3), 12).tolist(), result.point.tolist()
    ([1.0, 1.0, 1.0], [1.0, 1.0, 1.0])
    """
    check_criterion(criterion, _ELEMENT, weights=weights)
    check_minimax_only(criterion, search_budget=search_budget)
    if is_dask_array(points):
        if criterion != "gaussian":
            raise InvalidInputError("criterion", "'gaussian' for a dask array of points", repr(criterion))
        from pcmm_geo.fit.scale.dask import fit_line_dask

        return LineFit(**fit_line_dask(points, weights=weights))
    min_points = 2
    pts = point_array(points, element=_ELEMENT, dims=(2, 3), min_points=min_points)
    chunked = (weights is None and criterion == "gaussian" and pts.shape[1] == 3
               and len(pts) >= _tall.TALL_ROWS)
    if not chunked:  # the chunked fit checks the values in its first pass
        check_points(pts, element=_ELEMENT, min_points=min_points)
    if criterion != "gaussian":
        from pcmm_geo.fit.zone._distinct import on_distinct

        if pts.shape[1] == 3:
            from pcmm_geo.fit.zone._axial import line3d_minimax

            def solve_3d(q: FloatArray) -> LineFit:
                try:
                    start: LineFit | None = fit_line(q)
                except DegenerateGeometryError:  # no preferred direction: the zone still exists
                    start = None
                return line3d_minimax(q, criterion, gauss=start, result_type=LineFit, search_budget=search_budget)

            return on_distinct(pts, element=_ELEMENT, min_points=min_points, solve=solve_3d)
        if search_budget is not None:
            raise InvalidInputError("search_budget", "None for a 2-D line (its zone is exact)", repr(search_budget))
        from pcmm_geo.fit.zone._linear import line_minimax

        return on_distinct(pts, element=_ELEMENT, min_points=min_points,
                           solve=lambda q: line_minimax(q, criterion, gauss=fit_line(q), result_type=LineFit))
    w = as_weights(weights, len(pts), element=_ELEMENT)
    if chunked:
        from pcmm_geo.fit.scale.chunked import IllConditionedSteps
        from pcmm_geo.fit.scale.fits import fit_line_scaled, numpy_source

        try:
            return LineFit(**fit_line_scaled(numpy_source(pts, element=_ELEMENT, min_points=min_points)))
        except IllConditionedSteps:
            pass  # sums beyond float64 (coordinates near the limit): the decomposition below takes them
    centroid, singular, vt = principal_frame(pts, w, element=_ELEMENT)
    if len(singular) > 1 and singular[1] >= (1 - 1e-12) * singular[0] and len(pts) > 2:
        raise DegenerateGeometryError(_ELEMENT, "points have no preferred direction (isotropic spread)")
    direction = sign_convention(vt[0])
    rel = pts - centroid
    along = rel @ direction
    sqrt_w = np.ones(len(pts)) if w is None else np.sqrt(w)
    dim = pts.shape[1]
    if dim == 2:
        normal = np.array([-direction[1], direction[0]])
        residuals = rel @ normal
        # local parameters: offset along the normal, rotation angle of the direction
        jacobian = np.column_stack([-np.ones(len(pts)), -along])
        dof = len(pts) - 2
        cov_local, cond = local_covariance(jacobian * sqrt_w[:, None], residuals * sqrt_w, dof)
        gradient = np.zeros((4, 2))
        gradient[:2, 0] = normal
        gradient[2:, 1] = normal
        components = residuals[:, None]
        rms, form = residual_stats(residuals)
    else:
        e1, e2 = vt[1], vt[2]
        components = np.column_stack([rel @ e1, rel @ e2])
        residuals = np.linalg.norm(components, axis=1)
        # local parameters: point shifts along e1, e2; direction tilts towards e1, e2
        jacobian = np.zeros((2 * len(pts), 4))
        jacobian[0::2, 0] = -1.0
        jacobian[1::2, 1] = -1.0
        jacobian[0::2, 2] = -along
        jacobian[1::2, 3] = -along
        dof = 2 * len(pts) - 4
        stacked_w = np.repeat(sqrt_w, 2)
        cov_local, cond = local_covariance(jacobian * stacked_w[:, None], components.ravel() * stacked_w, dof)
        gradient = np.zeros((6, 4))
        gradient[:3, 0] = e1
        gradient[:3, 1] = e2
        gradient[3:, 2] = e1
        gradient[3:, 3] = e2
        rms = float(np.sqrt(np.mean(residuals**2)))
        form = 2.0 * float(residuals.max())
    names = tuple(f"point_{c}" for c in "xyz"[:dim]) + tuple(f"direction_{c}" for c in "xyz"[:dim])
    return LineFit(
        point=frozen(centroid),
        direction=frozen(direction),
        residuals=frozen(residuals),
        rms=rms,
        form=form,
        n=len(pts),
        dof=dof,
        parameter_names=names,
        parameters=frozen(np.concatenate([centroid, direction])),
        covariance=frozen(propagate(cov_local, gradient)),
        condition_number=cond,
        converged=True,
        iterations=0,
        message="closed form (singular value decomposition)",
        extra={"residual_components": frozen(components)},
    )
