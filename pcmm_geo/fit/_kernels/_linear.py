"""Shared pieces of the closed-form (SVD) fits of lines and planes."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.errors import DegenerateGeometryError
from pcmm_geo.fit._kernels._core import TOL
from pcmm_geo.fit._kernels._inputs import weighted_centroid
from pcmm_geo.fit._kernels._tall import tall_svd

__all__ = ["frozen", "local_covariance", "principal_frame", "propagate", "sign_convention", "weighted_centroid"]

FloatArray = NDArray[np.float64]


def principal_frame(
    points: FloatArray, weights: FloatArray | None, *, element: str
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Centroid, singular values and right singular vectors (rows, descending) of the centred data.

    Raises :class:`DegenerateGeometryError` when the data have no extent at all.
    """
    centroid = weighted_centroid(points, weights)
    centred = points - centroid
    if weights is not None:
        centred = centred * np.sqrt(weights)[:, None]
    _, singular, vt = np.linalg.svd(centred, full_matrices=False)
    if vt.shape[0] < vt.shape[1]:  # two points in 3-D: complete the orthonormal basis
        vt = np.vstack([vt, np.cross(vt[0], vt[1])])
        singular = np.append(singular, 0.0)
    if singular[0] <= TOL.identical * max(1.0, float(np.abs(points).max())):
        raise DegenerateGeometryError(element, "all points are identical")
    return centroid, singular, vt


def sign_convention(vector: FloatArray) -> FloatArray:
    """Flip ``vector`` so that its largest-magnitude component is positive (documented convention)."""
    return -vector if vector[int(np.argmax(np.abs(vector)))] < 0 else vector


def propagate(local_cov: FloatArray, gradient: FloatArray) -> FloatArray:
    """Covariance of machine-frame parameters ``G @ C @ G.T`` from local ones (``G`` = d machine / d local)."""
    return gradient @ local_cov @ gradient.T


def local_covariance(jacobian: FloatArray, residuals: FloatArray, dof: int) -> tuple[FloatArray, float]:
    """``s^2 (J^T J)^-1`` and the condition number of ``J`` (both already weighted)."""
    singular, vt = tall_svd(jacobian)
    cond = float(singular[0] / singular[-1]) if singular[-1] > 0 else float("inf")
    variance = float(residuals @ residuals) / dof if dof > 0 else float("nan")
    positive = singular > 0
    inverse = np.zeros_like(singular)
    inverse[positive] = 1.0 / singular[positive] ** 2
    cov = (vt.T * inverse) @ vt * variance
    for row in vt[~positive]:  # undetermined directions: infinite variance where they reach (no inf * 0 = NaN)
        cov[np.abs(np.outer(row, row)) > 1e-12] = np.inf
    return cov, cond


def frozen(array: FloatArray) -> FloatArray:
    """Return a float copy of ``array`` owned by the result.

    Results are frozen dataclasses (fields cannot be reassigned); the arrays stay
    writable because scipy (e.g. ``Rotation.apply``) rejects read-only buffers.
    """
    return np.array(array, dtype=float)
