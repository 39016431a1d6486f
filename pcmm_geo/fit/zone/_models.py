"""Point distances and their analytic gradients for the minimax fits (local coordinates).

Each model maps ``(points (N, D), x (P,))`` to ``(d (N,), dd/dx (N, P))``.  Data are
given in a local frame (centred; for lines, planes and axial elements rotated so that
the Gaussian direction / normal / axis is the last coordinate axis), so the tilt
parameters stay small and the problems well scaled.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def center_distance(points: FloatArray, center: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``d = |p - c|`` (circle 2-D, sphere); ``x`` is the centre."""
    rel = points - center
    dist = np.sqrt(np.einsum("ij,ij->i", rel, rel))
    return dist, -rel / np.where(dist > 0, dist, 1.0)[:, None]


def line2d_offset(points: FloatArray, tilt: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Signed distance along the normal ``(-a, 1) / sqrt(1 + a^2)`` of a line through the origin along +x."""
    a = float(tilt[0])
    q = np.sqrt(1.0 + a * a)
    d = (points[:, 1] - a * points[:, 0]) / q
    return d, (-points[:, 0] / q - d * a / q**2)[:, None]


def plane_offset(points: FloatArray, tilt: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Signed distance along the normal ``(-a, -b, 1) / q`` (local normal +z)."""
    a, b = float(tilt[0]), float(tilt[1])
    q = np.sqrt(1.0 + a * a + b * b)
    d = (points[:, 2] - a * points[:, 0] - b * points[:, 1]) / q
    jac = np.column_stack([-points[:, 0] / q - d * a / q**2, -points[:, 1] / q - d * b / q**2])
    return d, jac


def _axis_terms(points: FloatArray, x: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, float]:
    """Height, radial distance, radial unit vector and axis for the axis ``(x0, y0, 0) + s (a, b, 1) / q``."""
    x0, y0, a, b = (float(v) for v in x[:4])
    q = np.sqrt(1.0 + a * a + b * b)
    direction = np.array([a, b, 1.0]) / q
    rel = points - np.array([x0, y0, 0.0])
    height = rel @ direction
    radial = rel - height[:, None] * direction
    rho = np.sqrt(np.einsum("ij,ij->i", radial, radial))
    unit = radial / np.where(rho > 0, rho, 1.0)[:, None]
    return height, rho, unit, direction, q


def axis_distance(points: FloatArray, x: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Distance from the axis (cylinder, 3-D line); ``x = (x0, y0, a, b)``."""
    height, rho, unit, _, q = _axis_terms(points, x)
    jac = np.column_stack([-unit[:, 0], -unit[:, 1], -height * unit[:, 0] / q, -height * unit[:, 1] / q])
    return rho, jac


def cone_distance(points: FloatArray, x: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Offset ``rho cos(alpha) - h sin(alpha)`` normal to a cone; ``x = (x0, y0, a, b, alpha)``.

    Two cones of the same axis and half angle whose levels differ by ``t`` are ``t`` apart
    along their common normal.
    """
    height, rho, unit, direction, q = _axis_terms(points, x)
    alpha = float(x[4])
    cos_a, sin_a = np.cos(alpha), np.sin(alpha)
    d = rho * cos_a - height * sin_a
    jac = np.empty((len(points), 5))
    jac[:, 0] = -unit[:, 0] * cos_a + direction[0] * sin_a
    jac[:, 1] = -unit[:, 1] * cos_a + direction[1] * sin_a
    jac[:, 2] = -(height * cos_a + rho * sin_a) * unit[:, 0] / q
    jac[:, 3] = -(height * cos_a + rho * sin_a) * unit[:, 1] / q
    jac[:, 4] = -rho * sin_a - height * cos_a
    return d, jac
