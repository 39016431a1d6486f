"""Distances to and projections onto fitted elements: the geometry behind ``distance`` / ``project``.

Every function is vectorised over leading dimensions: points ``(..., D)`` give distances
``(...)`` and projections ``(..., D)``.  The signs follow the fits' residuals (positive
outside), so ``fit.distance(data)`` reproduces ``fit.residuals``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError

FloatArray = NDArray[np.float64]


def query_points(points: ArrayLike, dim: int) -> FloatArray:
    """``points`` as a float array ``(..., dim)`` of finite numbers, or a typed error."""
    try:
        pts = np.asarray(points, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInputError("points", f"an array of numbers of shape (..., {dim})", type(points).__name__) from None
    if pts.ndim == 0 or pts.shape[-1] != dim:
        raise InvalidInputError("points", f"shape (..., {dim})", f"shape {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise InvalidInputError("points", "finite coordinates", "NaN or inf")
    return pts


def axial_parts(points: FloatArray, origin: FloatArray, axis: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Height along ``axis``, radial vector ``(..., 3)`` and its length ``rho`` of each point."""
    rel = points - origin
    height = rel @ axis
    radial = rel - height[..., None] * axis
    return height, radial, np.linalg.norm(radial, axis=-1)


#: a point nearer than this fraction of the element's size to an axis (or centre) has no direction
_ON_AXIS = 1e-12


def radial_unit(radial: FloatArray, rho: FloatArray, element: str, size: float = 1.0) -> FloatArray:
    """Unit radial directions; a point on the axis (within ``1e-12 * max(1, size)``) has none."""
    if np.any(rho <= _ON_AXIS * max(1.0, abs(size))):
        raise DegenerateGeometryError(element, "a point lies on the axis: its nearest surface point is not unique")
    return radial / rho[..., None]


def circle_distance(
    points: FloatArray, center: FloatArray, radius: float, normal: FloatArray | None, *, in_plane_only: bool
) -> FloatArray:
    """Signed distance from a circle (2-D, or 3-D curve with unit ``normal``), as the circle fit's residuals.

    3-D: ``sign(rho - r) * hypot(rho - r, h)`` (``|h|`` when ``rho = r``); with ``in_plane_only``
    (the projected fit) just ``rho - r``.
    """
    if normal is None:
        return np.linalg.norm(points - center, axis=-1) - radius
    height, _, rho = axial_parts(points, center, normal)
    radial = rho - radius
    if in_plane_only:
        return radial
    return np.where(radial == 0.0, np.abs(height), np.sign(radial) * np.hypot(radial, height))


def circle_project(points: FloatArray, center: FloatArray, radius: float, normal: FloatArray | None) -> FloatArray:
    """Nearest points on the circle (2-D, or the 3-D curve)."""
    if normal is None:
        rel = points - center
        rho = np.linalg.norm(rel, axis=-1)
        return center + radius * radial_unit(rel, rho, "circle", radius)
    _, radial, rho = axial_parts(points, center, normal)
    return center + radius * radial_unit(radial, rho, "circle", radius)


def cone_frame(
    points: FloatArray, point: FloatArray, axis: FloatArray, radius: float, half_angle: float
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Height, radial vector, rho and the cone residual ``(rho - r) cos(a) - h sin(a)``."""
    height, radial, rho = axial_parts(points, point, axis)
    distance = (rho - radius) * np.cos(half_angle) - height * np.sin(half_angle)
    return height, radial, rho, distance


def torus_project(
    points: FloatArray, center: FloatArray, axis: FloatArray, major: float, minor: float
) -> FloatArray:
    """Nearest points on the torus: from the nearest point of the tube's centre circle, ``minor`` toward the point."""
    _, radial, rho = axial_parts(points, center, axis)
    tube_center = center + major * radial_unit(radial, rho, "torus", major)
    offset = points - tube_center
    length = np.linalg.norm(offset, axis=-1)
    if np.any(length <= _ON_AXIS * max(1.0, major)):
        raise DegenerateGeometryError("torus", "a point lies on the tube's centre circle: no unique nearest point")
    return tube_center + minor * offset / length[..., None]
