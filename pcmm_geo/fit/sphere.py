"""Gaussian (least-squares) sphere."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.fit._core import FitResult, as_points, as_weights, residual_stats
from pcmm_geo.fit._inputs import positive_length
from pcmm_geo.fit._linear import frozen
from pcmm_geo.fit._round import fit_nsphere

__all__ = ["SphereFit", "fit_sphere"]

FloatArray = NDArray[np.float64]
_ELEMENT = "sphere"


@dataclass(frozen=True, kw_only=True, eq=False, repr=False)
class SphereFit(FitResult):
    """Result of :func:`fit_sphere`.

    Attributes
    ----------
    center : ndarray, shape (3,)
        Centre (mm).
    radius : float
        Radius (mm); ``diameter`` is twice it.
    """

    center: FloatArray
    radius: float

    @property
    def diameter(self) -> float:
        """Fitted diameter (mm)."""
        return 2.0 * self.radius

    def distance(self, points: ArrayLike) -> FloatArray:
        """Signed distances of ``points`` (``(..., 3)``) from the sphere, positive outside."""
        return np.linalg.norm(np.asarray(points, dtype=float) - self.center, axis=-1) - self.radius


def fit_sphere(
    points: ArrayLike,
    *,
    radius: float | None = None,
    weights: ArrayLike | None = None,
) -> SphereFit:
    """Fit a sphere minimising the (weighted) sum of squared orthogonal distances.

    Gauss-Newton / Levenberg-Marquardt on centred data from an algebraic (Kasa)
    starting value; the algebraic fit is never returned.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Measured points (mm); N >= 4, not coplanar (N >= 3 with a fixed radius).
    radius : float, optional
        Fixed radius (mm, one positive number): only the centre is fitted (e.g. a calibrated
        reference sphere).  Coplanar points then fit a centre and its mirror image in their
        plane equally well unless the best centre lies in the plane (points on a circle
        larger than the radius): the ambiguous case raises :class:`~pcmm_geo.errors.AmbiguousFitError`.
    weights : array_like, shape (N,), optional
        Non-negative weights of the squared distances.

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

    Examples
    --------
    >>> pts = [[11, 0, 0], [-9, 0, 0], [1, 10, 0], [1, -10, 0], [1, 0, 10], [1, 0, -10]]
    >>> result = fit_sphere(pts)
    >>> (np.round(result.center, 12) + 0.0).tolist(), round(result.radius, 12)
    ([1.0, 0.0, 0.0], 10.0)
    """
    if radius is not None:
        radius = positive_length(radius, "radius")
    pts = as_points(points, element=_ELEMENT, min_points=4 if radius is None else 3)
    w = as_weights(weights, len(pts), element=_ELEMENT)
    centre, fitted_radius, outcome, residuals, cond, cov = fit_nsphere(pts, w, element=_ELEMENT, fixed_radius=radius)
    rms, form = residual_stats(residuals)
    return SphereFit(
        center=frozen(centre),
        radius=fitted_radius,
        residuals=frozen(residuals),
        rms=rms,
        form=form,
        n=len(pts),
        dof=len(pts) - outcome.x.size,
        parameter_names=("center_x", "center_y", "center_z", "radius"),
        parameters=frozen(np.append(centre, fitted_radius)),
        covariance=frozen(cov),
        condition_number=cond,
        converged=outcome.converged,
        iterations=outcome.iterations,
        message=outcome.message,
        method="gaussian" if radius is None else "gaussian-fixed-radius",
    )
