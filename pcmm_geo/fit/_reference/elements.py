"""Elements in standard position for the null-space reference-data generator.

Each builder samples foot points on one element placed in *standard position* (centre or
axis point at the origin, axis / normal along +z, a 2-D line along +x) and supplies

* the unit directions along which a residual moves a foot point (one per residual
  component: the surface normal, or two perpendicular directions for a 3-D line and a
  3-D circle), and
* the analytic Jacobian of the orthogonal-distance residuals with respect to a *minimal*
  set of element parameters, evaluated at the standard element for arbitrary points.

These expressions are derived here independently of the fitting code.  With ``rho`` the
distance of a point from the z axis, ``u = (x, y) / rho`` and ``h = z``:

==========  ==========================  ==============================================
element     parameters                  residual derivatives (rows of J)
==========  ==========================  ==============================================
line2d      y0, slope                   y - y0 - slope x  ->  (-1, -x)
line3d      x0, y0, a, b (dir (a,b,1))  x-comp (-1, 0, -z, 0); y-comp (0, -1, 0, -z)
plane       z0, a, b (normal (a,b,1))   (-1, -x, -y)
circle2d    cx, cy, R                   (-ux, -uy, -1)
sphere      cx, cy, cz, R               (-ux, -uy, -uz, -1)
cylinder    x0, y0, a, b, R             (-ux, -uy, -z ux, -z uy, -1)
cone        x0, y0, a, b, r0, alpha     cos(alpha) * (-ux, -uy, -z ux, -z uy, -1) and
                                        extra terms, see :func:`_cone_jacobian`
circle3d    cx, cy, cz, a, b, R         radial (-ux, -uy, 0, -z x/rho, -z y/rho, -1),
                                        axial (0, 0, -1, x, y, 0)
torus       cx, cy, cz, a, b, R, r      see :func:`_torus_jacobian`
==========  ==========================  ==============================================

(``a``, ``b`` tilt the axis: direction ``(a, b, 1) / |(a, b, 1)|`` about the origin.)
Moving foot points along their normals leaves the Jacobian unchanged for lines, planes,
2-D circles, spheres and cylinders; for cones, tori and 3-D circles it depends on the
moved points, which is why the generator iterates for them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError

FloatArray = NDArray[np.float64]

__all__ = ["ELEMENTS", "MIN_POINTS", "ReferenceDataSet", "StandardElement", "build_standard_element"]

#: minimum number of points that determines each element
MIN_POINTS: dict[str, int] = {
    "line2d": 2,
    "line3d": 2,
    "plane": 3,
    "circle2d": 3,
    "circle3d": 3,
    "circle3d_projected": 3,
    "sphere": 4,
    "cylinder": 5,
    "cone": 6,
    "torus": 7,
}
ELEMENTS = tuple(MIN_POINTS)


@record
class ReferenceDataSet:
    """A data set whose Gaussian (least-squares) solution is known.

    Attributes
    ----------
    element : str
        One of :data:`ELEMENTS`.
    points : ndarray, shape (N, 3) or (N, 2)
        The data, mm (2 columns for ``line2d`` and ``circle2d``).
    parameters : dict
        The reference solution under the fit-result contract names, machine frame:
        line ``point`` (data centroid), ``direction``; plane ``point`` (centroid), ``normal``;
        circle2d ``center``, ``radius``; circle3d ``center``, ``normal``, ``radius``; sphere
        ``center``, ``radius``; cylinder ``point`` (axis point nearest the data centroid),
        ``axis``, ``radius``; cone ``apex``, ``axis`` (apex -> opening), ``half_angle``,
        ``point`` (axis point nearest the data centroid), ``radius_at_point``; torus
        ``center``, ``axis``, ``major_radius``, ``minor_radius``.
    residuals : ndarray, shape (N,) or (N, 2)
        Signed orthogonal distances of the points from the reference element, mm
        (two components per point for line3d and the 3-D circles).
    foot_points : ndarray, shape like ``points``
        The points on the reference element before the residuals were applied.
    sampling : dict
        How the set was made (point count, arc, cap, length, form, offset, seed, ...).
    """

    element: str
    points: FloatArray
    parameters: dict[str, Any]
    residuals: FloatArray
    foot_points: FloatArray
    sampling: dict[str, Any] = field(default_factory=dict)

    @property
    def form(self) -> float:
        """Range of the residual values, mm."""
        return float(np.ptp(self.residuals)) if self.residuals.size else 0.0

    @property
    def n(self) -> int:
        """Number of points."""
        return int(self.points.shape[0])


@record
class StandardElement:
    """Foot points, move directions and Jacobian of one element in standard position.

    Attributes
    ----------
    foot_points : ndarray, shape (N, D)
        Points on the element (D = 2 for line2d/circle2d, else 3), mm.
    move_directions : ndarray, shape (K, N, D)
        Unit vector along which residual component k moves point i.
    jacobian : callable
        ``jacobian(points (N, D)) -> (K * N, P)``: rows ordered component-major (all
        points of component 0, then component 1).
    iterative : bool
        True when the Jacobian depends on the moved points.
    size : dict
        Standard-position sizes (``radius``, ``half_angle``, ...).
    """

    foot_points: FloatArray
    move_directions: FloatArray
    jacobian: Callable[[FloatArray], FloatArray]
    iterative: bool
    size: dict[str, float]


def _cylindrical(points: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    x, y, z = points[:, 0], points[:, 1], points[:, 2]
    rho = np.hypot(x, y)
    return x / rho, y / rho, z, rho


def _line2d_jacobian(points: FloatArray) -> FloatArray:
    return np.column_stack([-np.ones(len(points)), -points[:, 0]])


def _line3d_jacobian(points: FloatArray) -> FloatArray:
    n = len(points)
    zeros, ones, z = np.zeros(n), np.ones(n), points[:, 2]
    x_rows = np.column_stack([-ones, zeros, -z, zeros])
    y_rows = np.column_stack([zeros, -ones, zeros, -z])
    return np.vstack([x_rows, y_rows])


def _plane_jacobian(points: FloatArray) -> FloatArray:
    return np.column_stack([-np.ones(len(points)), -points[:, 0], -points[:, 1]])


def _circle2d_jacobian(points: FloatArray) -> FloatArray:
    rho = np.hypot(points[:, 0], points[:, 1])
    return np.column_stack([-points[:, 0] / rho, -points[:, 1] / rho, -np.ones(len(points))])


def _sphere_jacobian(points: FloatArray) -> FloatArray:
    unit = points / np.linalg.norm(points, axis=1, keepdims=True)
    return np.column_stack([-unit, -np.ones(len(points))])


def _cylinder_jacobian(points: FloatArray) -> FloatArray:
    ux, uy, z, _ = _cylindrical(points)
    return np.column_stack([-ux, -uy, -z * ux, -z * uy, -np.ones(len(points))])


def _cone_jacobian_factory(radius_at_origin: float, half_angle: float) -> Callable[[FloatArray], FloatArray]:
    cos_a, sin_a = np.cos(half_angle), np.sin(half_angle)

    def _cone_jacobian(points: FloatArray) -> FloatArray:
        """Residual d = rho cos(a) - r0 cos(a) - h sin(a), h along the axis from the axis point.

        Tilting the axis by ``a`` about the origin changes ``h`` by ``x`` and ``rho`` by
        ``-z x / rho``, so ``dd/da = -z ux cos(alpha) - x sin(alpha)``; ``dd/dalpha =
        -(rho - r0) sin(alpha) - h cos(alpha)``.
        """
        ux, uy, z, rho = _cylindrical(points)
        x, y = points[:, 0], points[:, 1]
        return np.column_stack(
            [
                -ux * cos_a,
                -uy * cos_a,
                -z * ux * cos_a - x * sin_a,
                -z * uy * cos_a - y * sin_a,
                -np.full(len(points), cos_a),
                -(rho - radius_at_origin) * sin_a - z * cos_a,
            ]
        )

    return _cone_jacobian


def _circle3d_jacobian(points: FloatArray) -> FloatArray:
    ux, uy, z, rho = _cylindrical(points)
    x, y = points[:, 0], points[:, 1]
    n = len(points)
    zeros, ones = np.zeros(n), np.ones(n)
    radial = np.column_stack([-ux, -uy, zeros, -z * x / rho, -z * y / rho, -ones])
    axial = np.column_stack([zeros, zeros, -ones, x, y, zeros])
    return np.vstack([radial, axial])


def _torus_jacobian_factory(major_radius: float) -> Callable[[FloatArray], FloatArray]:
    def _torus_jacobian(points: FloatArray) -> FloatArray:
        """Residual d = sqrt((rho - R)^2 + h^2) - r with tube-normal ``(n_rho, n_z)``.

        ``dd/dcx = -n_rho ux``, ``dd/dcz = -n_z``, ``dd/da = -n_rho z x / rho + n_z x``,
        ``dd/dR = -n_rho``, ``dd/dr = -1``.
        """
        ux, uy, z, rho = _cylindrical(points)
        x, y = points[:, 0], points[:, 1]
        tube = np.hypot(rho - major_radius, z)
        n_rho, n_z = (rho - major_radius) / tube, z / tube
        return np.column_stack(
            [
                -n_rho * ux,
                -n_rho * uy,
                -n_z,
                -n_rho * z * x / rho + n_z * x,
                -n_rho * z * y / rho + n_z * y,
                -n_rho,
                -np.ones(len(points)),
            ]
        )

    return _torus_jacobian


def _arc_angles(n_points: int, arc: float) -> FloatArray:
    """``n_points`` angles evenly over ``arc`` (both ends included unless the arc is closed)."""
    if arc >= 2 * np.pi - 1e-12:
        return np.linspace(0.0, 2 * np.pi, n_points, endpoint=False)
    return np.linspace(-arc / 2, arc / 2, n_points)


def _require(condition: bool, what: str, expected: str, got: str) -> None:
    if not condition:
        raise InvalidInputError(what, expected, got)


def build_standard_element(
    element: str,
    n_points: int,
    *,
    radius: float,
    length: float,
    arc: float,
    cap: float,
    half_angle: float,
    minor_radius: float,
    tube_arc: float,
    rng: np.random.Generator,
) -> StandardElement:
    """Sample ``n_points`` foot points on ``element`` in standard position.

    Parameters are documented in :func:`pcmm_geo.fit.reference.make_reference_data`.

    Raises
    ------
    InvalidInputError
        Sizes or angles out of range for the element.
    """
    _require(radius > 0, "radius", "a positive radius (mm)", repr(radius))
    _require(length > 0, "length", "a positive length (mm)", repr(length))
    _require(0 < arc <= 2 * np.pi + 1e-12, "arc", "an angle in (0, 2 pi] rad", repr(arc))
    n = n_points
    ones = np.ones(n)
    zeros = np.zeros(n)
    if element == "line2d":
        t = np.linspace(-length / 2, length / 2, n)
        foot = np.column_stack([t, zeros])
        moves = np.array([np.column_stack([zeros, ones])])
        return StandardElement(foot, moves, _line2d_jacobian, False, {})
    if element == "line3d":
        t = np.linspace(-length / 2, length / 2, n)
        foot = np.column_stack([zeros, zeros, t])
        moves = np.array([np.column_stack([ones, zeros, zeros]), np.column_stack([zeros, ones, zeros])])
        return StandardElement(foot, moves, _line3d_jacobian, False, {})
    if element == "plane":
        xy = rng.uniform(-length / 2, length / 2, size=(n, 2))
        foot = np.column_stack([xy, zeros])
        moves = np.array([np.column_stack([zeros, zeros, ones])])
        return StandardElement(foot, moves, _plane_jacobian, False, {})
    angles = _arc_angles(n, arc)
    u = np.column_stack([np.cos(angles), np.sin(angles)])
    if element == "circle2d":
        return StandardElement(radius * u, np.array([u]), _circle2d_jacobian, False, {"radius": radius})
    if element in ("circle3d", "circle3d_projected"):
        foot = np.column_stack([radius * u, zeros])
        moves = np.array([np.column_stack([u, zeros]), np.column_stack([zeros, zeros, ones])])
        return StandardElement(foot, moves, _circle3d_jacobian, True, {"radius": radius})
    if element == "sphere":
        _require(0 < cap <= np.pi, "cap", "a polar cap angle in (0, pi] rad", repr(cap))
        cos_polar = rng.uniform(np.cos(cap), 1.0, size=n)
        azimuth = rng.uniform(0.0, 2 * np.pi, size=n)
        sin_polar = np.sqrt(1.0 - cos_polar**2)
        unit = np.column_stack([sin_polar * np.cos(azimuth), sin_polar * np.sin(azimuth), cos_polar])
        return StandardElement(radius * unit, np.array([unit]), _sphere_jacobian, False, {"radius": radius})
    heights = rng.uniform(-length / 2, length / 2, size=n)
    if element == "cylinder":
        foot = np.column_stack([radius * u, heights])
        moves = np.array([np.column_stack([u, zeros])])
        return StandardElement(foot, moves, _cylinder_jacobian, False, {"radius": radius})
    if element == "cone":
        _require(0 < half_angle < np.pi / 2, "half_angle", "a half angle in (0, pi/2) rad", repr(half_angle))
        _require(
            radius - length / 2 * np.tan(half_angle) > 0,
            "length",
            f"a cone section that stays below the apex (length < {2 * radius / np.tan(half_angle):.6g} mm)",
            repr(length),
        )
        local_radius = radius + heights * np.tan(half_angle)
        foot = np.column_stack([local_radius[:, None] * u, heights])
        normal = np.column_stack([np.cos(half_angle) * u, -np.sin(half_angle) * ones])
        jac = _cone_jacobian_factory(radius, half_angle)
        return StandardElement(foot, np.array([normal]), jac, True, {"radius": radius, "half_angle": half_angle})
    if element == "torus":
        _require(0 < minor_radius < radius, "minor_radius", f"a tube radius in (0, {radius}) mm", repr(minor_radius))
        _require(0 < tube_arc <= 2 * np.pi + 1e-12, "tube_arc", "an angle in (0, 2 pi] rad", repr(tube_arc))
        tube_angles = rng.uniform(-tube_arc / 2, tube_arc / 2, size=n)
        normal = np.column_stack([np.cos(tube_angles)[:, None] * u, np.sin(tube_angles)])
        centre_line = np.column_stack([radius * u, zeros])
        foot = centre_line + minor_radius * normal
        jac = _torus_jacobian_factory(radius)
        return StandardElement(foot, np.array([normal]), jac, True, {"radius": radius, "minor_radius": minor_radius})
    raise InvalidInputError("element", f"one of {', '.join(ELEMENTS)}", repr(element))
