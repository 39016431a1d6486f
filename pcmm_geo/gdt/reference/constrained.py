"""A datum plane at a nominal angle (other than 0 or 90 deg) to a higher-precedence datum direction.

ISO 5459-2 / ASME Y14.5-2018 7.10: a secondary datum plane is oriented by the primary: here its inward
normal ``n`` keeps the nominal angle ``alpha`` to the primary's direction ``a``, ``n . a = cos(alpha)`` -- a
cone of normals with one degree of freedom, the azimuth ``phi`` about ``a``:

    n(phi) = cos(alpha) a + sin(alpha) (cos(phi) e1 + sin(phi) e2).

``"minimax"`` (ISO default): the tangent outside-material plane of least largest distance over that cone,
``min_phi ptp(P n(phi))``; a branch and bound over ``phi`` within ``window`` of the nominal azimuth (the
part is pre-aligned) with the Lipschitz constant ``sin(alpha) * 2 max |p - centroid|`` gives the proven
lower bound, then the optimum is made exact from the candidate contacts (two points tied at the top or the
bottom, or one top and one bottom point stationary).  ``"constrained-lsq"`` (ASME default): least squares
of the distances from the tangent plane over the cone, a bounded scalar minimisation (local).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.errors import InvalidInputError

__all__ = ["cone_normal", "cone_plane", "fixed_normal"]

FloatArray = NDArray[np.float64]

#: the azimuths searched each side of the nominal one (the part is pre-aligned within a few degrees)
WINDOW_RAD = np.radians(15.0)


def _basis(axis: FloatArray) -> tuple[FloatArray, FloatArray]:
    e1 = np.cross(axis, np.eye(3)[int(np.argmin(np.abs(axis)))])
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(axis, e1)


def cone_normal(axis: FloatArray, cos_angle: float, phi: float) -> tuple[FloatArray, FloatArray]:
    """``n(phi)`` and its derivative ``dn/dphi`` (both (3,))."""
    e1, e2 = _basis(axis)
    s = float(np.sqrt(max(0.0, 1.0 - cos_angle ** 2)))
    n = cos_angle * axis + s * (np.cos(phi) * e1 + np.sin(phi) * e2)
    return n, s * (-np.sin(phi) * e1 + np.cos(phi) * e2)


def _width(points: FloatArray, axis: FloatArray, cos_angle: float, phi: float) -> float:
    return float(np.ptp(points @ cone_normal(axis, cos_angle, phi)[0]))


def _ties(d: FloatArray, axis: FloatArray, cos_angle: float) -> list[float]:
    """Azimuths where ``d . n(phi) = 0``."""
    e1, e2 = _basis(axis)
    s = float(np.sqrt(max(0.0, 1.0 - cos_angle ** 2)))
    a, b, c = s * float(d @ e1), s * float(d @ e2), -cos_angle * float(d @ axis)
    r = float(np.hypot(a, b))
    if r == 0 or abs(c) > r:
        return []
    base, spread = float(np.arctan2(b, a)), float(np.arccos(c / r))
    return [base + spread, base - spread]


def cone_plane(points: FloatArray, inward: FloatArray, axis: FloatArray, cos_angle: float, *,
               criterion: str = "minimax", label: str = "B") -> tuple[FloatArray, FloatArray, str, float]:
    """The inward normal of the datum plane on the cone, the turning direction, the scope and the bound.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    inward : ndarray, shape (3,)
        The nominal inward normal (its azimuth starts the search).
    axis : ndarray, shape (3,)
        The higher datum's direction (unit).
    cos_angle : float
        ``cos`` of the nominal angle between the inward normal and ``axis``.
    criterion : {"minimax", "constrained-lsq"}

    Returns
    -------
    normal, turn : ndarray, shape (3,)
        The unit inward normal and ``dn/dphi`` there (the one direction it may turn in).
    scope : str
    bound : float
        Proven lower bound of the largest distance (minimax), NaN otherwise.
    """
    from scipy.optimize import minimize_scalar

    from pcmm_geo.gdt.reference._floating import minimise_angle

    if not -1 + 1e-9 < cos_angle < 1 - 1e-9:
        raise InvalidInputError(f"datum {label} angle", "an angle strictly between 0 and 180 deg", repr(cos_angle))
    e1, e2 = _basis(axis)
    phi0 = float(np.arctan2(inward @ e2, inward @ e1))
    rel = points - points.mean(axis=0)
    if criterion == "constrained-lsq":
        def cost(phi: float) -> float:
            h = rel @ cone_normal(axis, cos_angle, phi)[0]
            d = h - h.min()
            return float(d @ d)

        res = minimize_scalar(cost, bounds=(phi0 - WINDOW_RAD, phi0 + WINDOW_RAD), method="bounded",
                              options={"xatol": 1e-13})
        phi, scope, bound = float(res.x), "local", float("nan")
    else:
        s = float(np.sqrt(1.0 - cos_angle ** 2))
        lipschitz = s * 2.0 * float(np.linalg.norm(rel, axis=1).max())
        scale = WINDOW_RAD / np.pi  # minimise_angle searches [-pi, pi]: map it onto the window

        def width(u: float) -> float:
            return _width(rel, axis, cos_angle, phi0 + scale * u)

        _, bound, u_best = minimise_angle(width, lipschitz * scale, tol=1e-12, budget=6000)
        phi = phi0 + scale * u_best
        phi = _exact(rel, axis, cos_angle, phi, lipschitz)
        scope = "global"
        bound = min(bound, _width(rel, axis, cos_angle, phi))
    normal, turn = cone_normal(axis, cos_angle, phi)
    if normal @ inward < 0:
        raise InvalidInputError(f"datum {label}", "a plane whose normal keeps the nominal angle within "
                                f"{np.degrees(WINDOW_RAD):g} deg of its nominal azimuth", "none found")
    return normal, turn, scope, float(bound)


def _exact(rel: FloatArray, axis: FloatArray, cos_angle: float, phi: float, lipschitz: float) -> float:
    """The exact optimum near ``phi`` from its candidate contacts (ties at a level, or a stationary pair)."""
    heights = rel @ cone_normal(axis, cos_angle, phi)[0]
    slack = max(1e-9, 1e-6 * lipschitz)
    top = np.flatnonzero(heights >= heights.max() - slack)[:40]
    low = np.flatnonzero(heights <= heights.min() + slack)[:40]
    e1, e2 = _basis(axis)
    candidates = [phi]
    for group in (top, low):
        for i in range(len(group)):
            for j in range(i + 1, len(group)):
                candidates += _ties(rel[group[i]] - rel[group[j]], axis, cos_angle)
    for i in top:
        for j in low:
            d = rel[i] - rel[j]
            base = float(np.arctan2(d @ e2, d @ e1))
            candidates += [base, base + np.pi]
    near = [(c + np.pi - phi) % (2 * np.pi) - np.pi + phi for c in candidates]
    near = [c for c in near if abs(c - phi) <= 1e-3]
    return float(min(near, key=lambda c: _width(rel, axis, cos_angle, c)))


def fixed_normal(before: list[object], nominals: list[FloatArray], inward: FloatArray) -> list[FloatArray]:
    """Two directions perpendicular to the nominal ``inward`` as carried by the measured frame of the first two
    direction datums of ``before`` (associations, with their nominal directions ``nominals``): a plane whose
    normal two higher datums fix (a tertiary after a secondary at an angle)."""
    def _frame_of(first: FloatArray, second: FloatArray) -> FloatArray:
        e1 = first / np.linalg.norm(first)
        e2 = second - (second @ e1) * e1
        e2 /= np.linalg.norm(e2)
        return np.column_stack([e1, e2, np.cross(e1, e2)])

    pairs = [(b, n) for b, n in zip(before, nominals, strict=True) if b.element in ("plane", "cylinder")][:2]  # type: ignore[attr-defined]
    rotation = _frame_of(pairs[0][0].direction, pairs[1][0].direction) @ _frame_of(pairs[0][1], pairs[1][1]).T  # type: ignore[attr-defined]
    normal = rotation @ inward
    u, _, _ = np.linalg.svd(np.eye(3) - np.outer(normal, normal))
    return [u[:, 0], u[:, 1]]
