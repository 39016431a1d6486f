"""Reference data whose minimum-zone, MCC or MIC solution is known by construction.

The construction places *support points* exactly on the boundaries of a chosen zone so
that the optimality (Karush-Kuhn-Tucker) conditions hold with strictly positive
multipliers, and fills the rest of the data strictly inside the zone:

1. choose the reference element and its levels (``r_in``, ``r_out``; half widths of a
   strip / slab; the radius of an enclosing cylinder);
2. draw contact points on the boundaries (random positions inside the requested arc, cap
   or length), outer and inner as the criterion needs, ``P + L`` of them where ``P`` is the
   number of element parameters and ``L`` the number of levels;
3. solve the square KKT system ``sum_k s_k lambda_k grad d_k = 0``, ``sum lambda = 1`` per
   level for the multipliers, from the gradients of the point distances written out here
   in closed form; keep the draw only when every multiplier exceeds
   ``0.1 / (P + L)`` (the vertex is then non-degenerate: the optimum is strict and
   isolated), else draw again;
4. add fill points strictly inside the zone (at least 5 % of the form from each
   boundary), then a seeded random rotation and offset.

The gradients are those of the element in its own frame (axis or normal along +z, centre
at the origin), independent of the solvers in this package.  For the non-convex
problems (zones of circles, spheres, cylinders, cones; enclosing cylinders) the KKT
point with positive multipliers is a strict local optimum; with form small against the
size, it is the one a solver started from the least-squares element must find.

Examples
--------
>>> import numpy as np
>>> from pcmm_geo.fit import fit_circle
>>> data = make_minimax_reference("circle", "chebyshev", n_points=50, size=10.0, form=0.01, offset=500.0, rng=3)
>>> result = fit_circle(data.points, criterion="chebyshev")
>>> round(result.form, 12), bool(np.allclose(result.center, data.parameters["center"], atol=1e-9))
(0.01, True)
"""

from __future__ import annotations

from dataclasses import field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.elements import Criterion
from pcmm_geo.errors import InvalidInputError, TooFewPointsError

__all__ = ["ELEMENTS", "MinimaxReference", "make_minimax_reference"]

FloatArray = NDArray[np.float64]

#: element -> criteria with a construction
ELEMENTS: dict[str, tuple[str, ...]] = {
    "line2d": ("chebyshev",),
    "line3d": ("chebyshev",),
    "plane": ("chebyshev",),
    "circle": ("chebyshev", "mcc", "mic"),
    "circle3d": ("chebyshev", "mcc", "mic"),
    "sphere": ("chebyshev", "mcc", "mic"),
    "cylinder": ("chebyshev", "mcc", "mic"),
    "cone": ("chebyshev",),
}
_MAX_DRAWS = 20000
#: fill points keep this fraction of the form away from each boundary
_MARGIN = 0.05


@record
class MinimaxReference:
    """A data set with a known minimax solution.

    Attributes
    ----------
    element, criterion : str
    points : ndarray, shape (N, 2) or (N, 3)
        The data (mm), contacts first in random order with the fill.
    contacts : ndarray of int, shape (M,)
        Indices of the support points.
    multipliers : ndarray, shape (M,)
        Their KKT multipliers (all positive).
    parameters : dict
        The solution in the machine frame: ``center``, ``radius`` (the radius a fit with this
        criterion reports), ``r_in``, ``r_out`` (round elements); ``point``, ``direction`` /
        ``normal`` / ``axis``; ``half_angle``, ``apex`` (cone); ``form`` (zone width, or the
        enclosing diameter of a 3-D line).
    """

    element: str
    criterion: Criterion
    points: FloatArray
    contacts: NDArray[np.intp]
    multipliers: FloatArray
    parameters: dict[str, Any] = field(default_factory=dict)


def _unit_rows(rows: FloatArray) -> FloatArray:
    return rows / np.linalg.norm(rows, axis=1, keepdims=True)


def _multipliers(gradients: FloatArray, signs: FloatArray) -> FloatArray | None:
    """Solve the square KKT system for the multipliers; None when singular."""
    levels = sorted(set(signs.tolist()))
    groups = np.array([[1.0 if s == level else 0.0 for s in signs] for level in levels])
    matrix = np.vstack([(gradients * signs[:, None]).T, groups])
    target = np.concatenate([np.zeros(gradients.shape[1]), np.ones(len(levels))])
    if matrix.shape[0] != matrix.shape[1]:
        return None
    try:
        lam = np.linalg.solve(matrix, target)
    except np.linalg.LinAlgError:
        return None
    if np.linalg.cond(matrix) > 1e8:
        return None
    return lam


def _signs(criterion: Criterion, n_upper_zone: int, total: int) -> FloatArray:
    if criterion == "mcc":
        return np.ones(total)
    if criterion == "mic":
        return -np.ones(total)
    return np.array([1.0] * n_upper_zone + [-1.0] * (total - n_upper_zone))


def _round_contacts(rng: np.random.Generator, dim: int, arc: float, signs: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Unit directions inside the arc (2-D) / cap (3-D) with positive multipliers for ``d = |p - c|``."""
    for _ in range(_MAX_DRAWS):
        if dim == 2:
            angles = rng.uniform(0.0, arc, len(signs))
            units = np.column_stack([np.cos(angles), np.sin(angles)])
        else:
            polar = np.arccos(rng.uniform(np.cos(min(arc, np.pi)), 1.0, len(signs)))
            azimuth = rng.uniform(0.0, 2 * np.pi, len(signs))
            units = np.column_stack([np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar)])
        # d = |p - c|: gradient with respect to the centre is -u
        lam = _multipliers(-units, signs)
        if lam is not None and lam.min() > 0.1 / len(signs):
            return units, lam
    raise InvalidInputError("arc", "an arc / cap wide enough to support the criterion's contacts", f"{arc} rad")


def _axial_gradients(units: FloatArray, heights: FloatArray, radii: FloatArray, half_angle: float) -> FloatArray:
    """Gradients of ``rho cos(alpha) - h sin(alpha)`` w.r.t. axis shift (2), tilt (2) [and alpha] at the axis +z."""
    cos_a, sin_a = np.cos(half_angle), np.sin(half_angle)
    lever = heights * cos_a + radii * sin_a
    columns = [-units[:, 0] * cos_a, -units[:, 1] * cos_a, -lever * units[:, 0], -lever * units[:, 1]]
    if half_angle != 0.0:
        columns.append(-radii * sin_a - heights * cos_a)
    return np.column_stack(columns)


def make_minimax_reference(
    element: str,
    criterion: Criterion = "chebyshev",
    *,
    n_points: int = 50,
    size: float = 10.0,
    form: float = 0.01,
    arc: float = 2 * np.pi,
    length: float | None = None,
    half_angle: float = np.radians(20.0),
    offset: float = 0.0,
    rng: int | np.random.Generator | None = None,
) -> MinimaxReference:
    """Build a data set whose Chebyshev / MCC / MIC solution is known.

    Parameters
    ----------
    element : str
        One of :data:`ELEMENTS` (``line2d``, ``line3d``, ``plane``, ``circle``, ``circle3d``,
        ``sphere``, ``cylinder``, ``cone``).
    criterion : {"chebyshev", "mcc", "mic"}
    n_points : int
        Number of points (contacts included): at least the number of contacts.
    size : float
        Radius of circles, spheres, cylinders; radius of the cone at mid height; half length
        of a 2-D line or plane side (mm).
    form : float
        Zone width (chebyshev); radial spread of the fill below / above the circumscribed /
        inscribed radius (mcc / mic); diameter of the cylinder enclosing a 3-D line (mm).
    arc : float
        Angular extent (rad): arc of a circle or cylinder, half angle of a spherical cap
        (``pi`` or more = whole sphere).  MCC and MIC need an arc above ``pi`` (half sphere for a cap).
    length : float, optional
        Length of a cylinder, cone or 3-D line (default ``2 * size``).
    half_angle : float
        Cone half angle (rad).
    offset : float
        Distance of the data from the origin (mm), along a random direction.
    rng : int or Generator, optional
        Seed.

    Returns
    -------
    MinimaxReference

    Raises
    ------
    InvalidInputError
        Unknown element / criterion, non-positive sizes, an arc too narrow for the criterion.
    TooFewPointsError
        ``n_points`` below the number of contacts.
    """
    if element not in ELEMENTS:
        raise InvalidInputError("element", "one of " + ", ".join(ELEMENTS), repr(element))
    if criterion not in ELEMENTS[element]:
        raise InvalidInputError("criterion", f"one of {ELEMENTS[element]} for {element}", repr(criterion))
    for name, value in (("size", size), ("form", form), ("arc", arc)):
        if not (np.isfinite(value) and value > 0):
            raise InvalidInputError(name, "a positive finite number", repr(value))
    if criterion in ("mcc", "mic") and arc <= (np.pi if element in ("circle", "circle3d", "cylinder") else np.pi / 2):
        raise InvalidInputError("arc", f"more than a half {element} for {criterion}", f"{arc} rad")
    generator = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    length = 2.0 * size if length is None else float(length)
    builder = _BUILDERS[element]
    local, contacts_n, multipliers, params = builder(
        generator, criterion, n_points, size, form, arc, length, half_angle
    )
    return _place(element, criterion, local, contacts_n, multipliers, params, offset, generator)


def _check_count(element: str, n_points: int, contacts: int) -> None:
    if n_points < contacts:
        raise TooFewPointsError(element, contacts, n_points)


def _fill_band(rng: np.random.Generator, count: int, low: float, high: float) -> FloatArray:
    span = high - low
    return rng.uniform(low + _MARGIN * span, high - _MARGIN * span, count)


def _levels(criterion: Criterion, size: float, form: float) -> tuple[float, float, float]:
    """(r_in, r_out, reported radius) of a round element; the fill lies in [r_in, r_out]."""
    if criterion == "chebyshev":
        return size - form / 2, size + form / 2, size
    if criterion == "mcc":
        return size - form, size, size
    return size, size + form, size


def _build_round(dim: int):
    def build(rng, criterion, n_points, size, form, arc, length, half_angle):
        n_contacts = dim + (2 if criterion == "chebyshev" else 1)
        _check_count("circle" if dim == 2 else "sphere", n_points, n_contacts)
        signs = _signs(criterion, n_contacts // 2, n_contacts)
        units, lam = _round_contacts(rng, dim, arc, signs)
        r_in, r_out, radius = _levels(criterion, size, form)
        contact_points = units * np.where(signs > 0, r_out, r_in)[:, None]
        fill_n = n_points - n_contacts
        if dim == 2:
            angles = rng.uniform(0.0, arc, fill_n)
            fill_units = np.column_stack([np.cos(angles), np.sin(angles)])
        else:
            polar = np.arccos(rng.uniform(np.cos(min(arc, np.pi)), 1.0, fill_n))
            azimuth = rng.uniform(0.0, 2 * np.pi, fill_n)
            fill_units = np.column_stack(
                [np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar)]
            )
        fill = fill_units * _fill_band(rng, fill_n, r_in, r_out)[:, None]
        params = {"center": np.zeros(dim), "radius": radius, "r_in": r_in, "r_out": r_out, "form": r_out - r_in}
        if criterion == "chebyshev":
            params["radius"] = 0.5 * (r_in + r_out)
        return np.vstack([contact_points, fill]), n_contacts, lam, params

    return build


def _build_line2d(rng, criterion, n_points, size, form, arc, length, half_angle):
    _check_count("line", n_points, 3)
    half = form / 2
    for _ in range(_MAX_DRAWS):
        x = rng.uniform(-size, size, 3)
        signs = np.array([1.0, -1.0, 1.0]) if rng.uniform() < 0.5 else np.array([-1.0, 1.0, -1.0])
        # d = y - a x: gradient w.r.t. the tilt a at a = 0 is -x
        lam = _multipliers(-x[:, None], signs)
        if lam is not None and lam.min() > 0.1 / 3:
            break
    contact_points = np.column_stack([x, half * signs])
    fill = np.column_stack([rng.uniform(-size, size, n_points - 3), _fill_band(rng, n_points - 3, -half, half)])
    params = {"point": np.zeros(2), "direction": np.array([1.0, 0.0]), "normal": np.array([0.0, 1.0]), "form": form}
    return np.vstack([contact_points, fill]), 3, lam, params


def _build_plane(rng, criterion, n_points, size, form, arc, length, half_angle):
    _check_count("plane", n_points, 4)
    half = form / 2
    for _ in range(_MAX_DRAWS):
        xy = rng.uniform(-size, size, (4, 2))
        signs = np.array([1.0, 1.0, -1.0, -1.0]) if rng.uniform() < 0.5 else np.array([1.0, 1.0, 1.0, -1.0])
        lam = _multipliers(-xy, signs)
        if lam is not None and lam.min() > 0.1 / 4:
            break
    contact_points = np.column_stack([xy, half * signs])
    fill = np.column_stack([rng.uniform(-size, size, (n_points - 4, 2)), _fill_band(rng, n_points - 4, -half, half)])
    params = {"point": np.zeros(3), "normal": np.array([0.0, 0.0, 1.0]), "form": form}
    return np.vstack([contact_points, fill]), 4, lam, params


def _axial_contacts(rng, signs, radii_of_sign, arc, length, half_angle):
    """Contacts on coaxial cylinders / cones around +z with positive multipliers."""
    for _ in range(_MAX_DRAWS):
        phi = rng.uniform(0.0, arc, len(signs))
        heights = rng.uniform(-length / 2, length / 2, len(signs))
        units = np.column_stack([np.cos(phi), np.sin(phi)])
        levels = np.where(signs > 0, radii_of_sign[1], radii_of_sign[0])
        # level = rho cos(alpha) - h sin(alpha)  ->  rho = (level + h sin(alpha)) / cos(alpha)
        rho = (levels + heights * np.sin(half_angle)) / np.cos(half_angle)
        lam = _multipliers(_axial_gradients(units, heights, rho, half_angle), signs)
        if lam is not None and lam.min() > 0.1 / len(signs):
            points = np.column_stack([rho[:, None] * units, heights])
            return points, lam
    raise InvalidInputError("arc", "an arc wide enough to support the criterion's contacts", f"{arc} rad")


def _axial_fill(rng, count, low, high, arc, length, half_angle):
    phi = rng.uniform(0.0, arc, count)
    heights = rng.uniform(-length / 2, length / 2, count)
    levels = _fill_band(rng, count, low, high)
    rho = (levels + heights * np.sin(half_angle)) / np.cos(half_angle)
    return np.column_stack([rho * np.cos(phi), rho * np.sin(phi), heights])


def _build_cylinder(rng, criterion, n_points, size, form, arc, length, half_angle):
    n_contacts = 6 if criterion == "chebyshev" else 5
    _check_count("cylinder", n_points, n_contacts)
    signs = _signs(criterion, 3, n_contacts)
    r_in, r_out, radius = _levels(criterion, size, form)
    contact_points, lam = _axial_contacts(rng, signs, (r_in, r_out), arc, length, 0.0)
    fill = _axial_fill(rng, n_points - n_contacts, r_in, r_out, arc, length, 0.0)
    params = {"point": np.zeros(3), "axis": np.array([0.0, 0.0, 1.0]), "radius": radius, "r_in": r_in, "r_out": r_out}
    params["form"] = r_out - r_in
    return np.vstack([contact_points, fill]), n_contacts, lam, params


def _build_line3d(rng, criterion, n_points, size, form, arc, length, half_angle):
    _check_count("line", n_points, 5)
    radius = form / 2
    signs = np.ones(5)
    contact_points, lam = _axial_contacts(rng, signs, (0.0, radius), 2 * np.pi, length, 0.0)
    fill = _axial_fill(rng, n_points - 5, 0.0, radius, 2 * np.pi, length, 0.0)
    params = {"point": np.zeros(3), "direction": np.array([0.0, 0.0, 1.0]), "form": form}
    return np.vstack([contact_points, fill]), 5, lam, params


def _build_cone(rng, criterion, n_points, size, form, arc, length, half_angle):
    _check_count("cone", n_points, 7)
    signs = _signs(criterion, 4, 7)
    mid = size * np.cos(half_angle)  # level of the cone of radius `size` at height 0
    low, high = mid - form / 2, mid + form / 2
    contact_points, lam = _axial_contacts(rng, signs, (low, high), arc, length, half_angle)
    fill = _axial_fill(rng, n_points - 7, low, high, arc, length, half_angle)
    params = {
        "point": np.zeros(3),
        "axis": np.array([0.0, 0.0, 1.0]),
        "half_angle": half_angle,
        "radius_at_point": size,
        "apex": np.array([0.0, 0.0, -size / np.tan(half_angle)]),
        "form": form,
    }
    return np.vstack([contact_points, fill]), 7, lam, params


def _build_circle3d(rng, criterion, n_points, size, form, arc, length, half_angle):
    planar, n_contacts, lam, params = _build_round(2)(rng, criterion, n_points, size, form, arc, length, half_angle)
    points = np.column_stack([planar, np.zeros(len(planar))])
    params = dict(params, center=np.zeros(3), normal=np.array([0.0, 0.0, 1.0]))
    return points, n_contacts, lam, params


_BUILDERS = {
    "line2d": _build_line2d,
    "line3d": _build_line3d,
    "plane": _build_plane,
    "circle": _build_round(2),
    "circle3d": _build_circle3d,
    "sphere": _build_round(3),
    "cylinder": _build_cylinder,
    "cone": _build_cone,
}


def _place(element, criterion, local, n_contacts, multipliers, params, offset, rng):
    """Shuffle, rotate and shift; map the parameters to the machine frame."""
    from pcmm_geo.fit.reference import random_rotation

    dim = local.shape[1]
    order = rng.permutation(len(local))
    points = local[order]
    moved_to = np.argsort(order)[:n_contacts]  # new index of each original contact
    by_index = np.argsort(moved_to)
    contacts = moved_to[by_index]
    lam = multipliers[by_index]
    rotation = random_rotation(rng, dim)
    shift = rng.normal(size=dim)
    shift *= offset / np.linalg.norm(shift)
    world = points @ rotation.T + shift
    out: dict[str, Any] = {}
    for name, value in params.items():
        if name in ("center", "point", "apex"):
            out[name] = rotation @ value + shift
        elif name in ("direction", "normal", "axis"):
            out[name] = rotation @ value
        else:
            out[name] = float(value)
    return MinimaxReference(element, criterion, world, contacts, lam, out)
