"""Per-fit parameter covariance of the batch fits, in the parameters of the single fits.

Each set's covariance is ``s^2 (J^T J)^-1`` from its Jacobian at the solution (``s^2`` =
sum of squared residuals / dof), mapped to machine-frame parameters exactly as the single
fit (:mod:`pcmm_geo.fit.sphere`, :mod:`~pcmm_geo.fit.plane`, ...) maps it, so a batch's
``covariance[k]`` equals the single fit's ``covariance`` of set ``k`` to rounding.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def batch_local_covariance(jacobian: FloatArray, residuals: FloatArray, dof: int) -> FloatArray:
    """``s^2 (J^T J)^-1`` for every set: jacobian ``(K, M, P)``, residuals ``(K, M)`` -> ``(K, P, P)``."""
    _, singular, vt = np.linalg.svd(jacobian, full_matrices=False)
    variance = np.sum(residuals**2, axis=1) / dof if dof > 0 else np.full(len(residuals), np.nan)
    with np.errstate(divide="ignore"):
        inverse = np.where(singular > 0, 1.0 / singular**2, np.inf)
    return np.einsum("kpi,ki,kiq->kpq", np.swapaxes(vt, 1, 2), inverse, vt) * variance[:, None, None]


def propagate_batch(local: FloatArray, gradient: FloatArray) -> FloatArray:
    """``G C G^T`` per set: local ``(K, P, P)``, gradient ``(K, Q, P)`` -> ``(K, Q, Q)``."""
    return np.einsum("kqp,kpr,ksr->kqs", gradient, local, gradient)


def nsphere_covariance(points: FloatArray, centers: FloatArray, radii: FloatArray) -> FloatArray:
    """Covariance of ``(center..., radius)`` of circles / spheres: points ``(K, N, D)`` -> ``(K, D+1, D+1)``."""
    rel = points - centers[:, None, :]
    dist = np.linalg.norm(rel, axis=2)
    jacobian = np.concatenate([-rel / np.where(dist > 0, dist, 1.0)[..., None], -np.ones((*dist.shape, 1))], axis=2)
    residuals = dist - radii[:, None]
    return batch_local_covariance(jacobian, residuals, points.shape[1] - points.shape[2] - 1)


def plane_covariance(rel: FloatArray, frames: FloatArray, normals: FloatArray, residuals: FloatArray) -> FloatArray:
    """Covariance of ``(point, normal)`` (K, 6, 6) of plane fits, as :func:`pcmm_geo.fit.fit_plane`.

    ``rel`` (K, N, 3) points minus centroids, ``frames`` (K, 3, 3) principal axes (rows).
    """
    k, n, _ = rel.shape
    jacobian = np.stack([-np.ones((k, n)), -np.einsum("kni,ki->kn", rel, frames[:, 0]),
                         -np.einsum("kni,ki->kn", rel, frames[:, 1])], axis=2)
    local = batch_local_covariance(jacobian, residuals, n - 3)
    gradient = np.zeros((k, 6, 3))
    gradient[:, :3, 0] = normals
    gradient[:, 3:, 1] = frames[:, 0]
    gradient[:, 3:, 2] = frames[:, 1]
    return propagate_batch(local, gradient)


def line_covariance(rel: FloatArray, frames: FloatArray, directions: FloatArray) -> FloatArray:
    """Covariance of ``(point, direction)`` of line fits (K, 2D, 2D), as :func:`pcmm_geo.fit.fit_line`."""
    k, n, dim = rel.shape
    along = np.einsum("kni,ki->kn", rel, directions)
    if dim == 2:
        normal = np.stack([-directions[:, 1], directions[:, 0]], axis=1)
        residuals = np.einsum("kni,ki->kn", rel, normal)
        jacobian = np.stack([-np.ones((k, n)), -along], axis=2)
        local = batch_local_covariance(jacobian, residuals, n - 2)
        gradient = np.zeros((k, 4, 2))
        gradient[:, :2, 0] = normal
        gradient[:, 2:, 1] = normal
        return propagate_batch(local, gradient)
    e1, e2 = frames[:, 1], frames[:, 2]
    components = np.stack([np.einsum("kni,ki->kn", rel, e1), np.einsum("kni,ki->kn", rel, e2)], axis=2)
    jacobian = np.zeros((k, 2 * n, 4))
    jacobian[:, 0::2, 0] = -1.0
    jacobian[:, 1::2, 1] = -1.0
    jacobian[:, 0::2, 2] = -along
    jacobian[:, 1::2, 3] = -along
    local = batch_local_covariance(jacobian, components.reshape(k, 2 * n), 2 * n - 4)
    gradient = np.zeros((k, 6, 4))
    gradient[:, :3, 0], gradient[:, :3, 1] = e1, e2
    gradient[:, 3:, 2], gradient[:, 3:, 3] = e1, e2
    return propagate_batch(local, gradient)


def projected_circle_covariance(
    in_plane: FloatArray, centers2: FloatArray, radii: FloatArray, frames: FloatArray, plane_cov: FloatArray
) -> FloatArray:
    """Covariance of ``(center, normal, radius)`` (K, 7, 7) of 3-D projected circles.

    The in-plane circle's covariance mapped to 3-D and the normal block of the plane fit, as
    ``fit_circle(..., method="projected")``.
    """
    local = nsphere_covariance(in_plane, centers2, radii)  # (K, 3, 3): center2 x, y, radius
    k = len(local)
    gradient = np.zeros((k, 7, 3))
    gradient[:, :3, 0] = frames[:, 0]
    gradient[:, :3, 1] = frames[:, 1]
    gradient[:, 6, 2] = 1.0
    cov = propagate_batch(local, gradient)
    cov[:, 3:6, 3:6] = plane_cov[:, 3:, 3:]
    return cov
