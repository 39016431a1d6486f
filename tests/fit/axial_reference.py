"""Independent reference for the axial minimax fits: dense axis-direction grids solved exactly in 2-D.

Nothing here uses pcmm_geo.  For each direction ``d`` of a dense grid the points are
projected on the plane normal to ``d`` and the 2-D problem is solved exactly by enumeration:

* minimum enclosing circle (MCC cylinder, 3-D line): incremental (Welzl-type) algorithm;
* minimum-zone annulus (cylinder zone): every candidate centre of the classic
  characterisation -- circumcentres of point triples (three points on one circle) and the
  points equidistant from two pairs (two on each circle) -- the optimum with a finite
  centre is one of them;
* largest empty circle (MIC cylinder): circumcentres of triples strictly inside the
  projected hull (Voronoi vertices), each with the distance to its nearest point.

Candidates whose axis leaves the stated region are dropped, so every value is that of an
axis of the region: the reference is a *feasible* value (an upper bound of the minimum for
MCC and zone, a lower bound of the maximum for MIC).  The best grid directions are then
polished by Nelder-Mead on the direction with the exact 2-D solve inside.
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize


@dataclass(frozen=True)
class Region:
    """Axes within ``cone_deg`` of ``axis`` crossing the plane normal to it through ``origin`` within ``offset``."""

    axis: np.ndarray
    origin: np.ndarray
    cone_deg: float = 45.0
    offset: float = np.inf

    @classmethod
    def around(
        cls, points: np.ndarray, axis: np.ndarray, through: np.ndarray, cone_deg: float, offset: float
    ) -> Region:
        axis = axis / np.linalg.norm(axis)
        centroid = points.mean(axis=0)
        origin = through + ((centroid - through) @ axis) * axis
        return cls(axis, origin, cone_deg, offset)


def basis(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.eye(3)[int(np.argmin(np.abs(d)))]
    e1 = np.cross(d, helper)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(d, e1)


def cap_directions(axis: np.ndarray, cone_deg: float, count: int) -> np.ndarray:
    """About ``count`` directions evenly spread over the cap within ``cone_deg`` of ``axis`` (a spiral)."""
    golden = np.pi * (3.0 - np.sqrt(5.0))
    k = np.arange(count)
    cos_max = np.cos(np.radians(cone_deg))
    z = 1.0 - (1.0 - cos_max) * (k + 0.5) / count
    r = np.sqrt(1.0 - z * z)
    local = np.c_[r * np.cos(golden * k), r * np.sin(golden * k), z]
    e1, e2 = basis(axis / np.linalg.norm(axis))
    return local @ np.vstack([e1, e2, axis / np.linalg.norm(axis)])


Point2 = tuple[float, float]


def _circle2(a: Point2, b: Point2) -> tuple[Point2, float]:
    centre = (0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]))
    return centre, math.hypot(a[0] - centre[0], a[1] - centre[1])


def _circle3(a: Point2, b: Point2, c: Point2) -> tuple[Point2, float]:
    bx, by = b[0] - a[0], b[1] - a[1]
    cx, cy = c[0] - a[0], c[1] - a[1]
    det = 2.0 * (bx * cy - by * cx)
    if abs(det) < 1e-300:
        pairs = [_circle2(a, b), _circle2(a, c), _circle2(b, c)]
        return max(pairs, key=lambda pair: pair[1])
    ux = (cy * (bx * bx + by * by) - by * (cx * cx + cy * cy)) / det
    uy = (bx * (cx * cx + cy * cy) - cx * (bx * bx + by * by)) / det
    return (a[0] + ux, a[1] + uy), math.hypot(ux, uy)


@functools.lru_cache(maxsize=64)
def _order(n: int, seed: int) -> tuple[int, ...]:
    return tuple(int(k) for k in np.random.default_rng(seed).permutation(n))


def enclosing_circle(q: np.ndarray, seed: int = 0) -> tuple[np.ndarray, float]:
    """Exact minimum enclosing circle of 2-D points (incremental algorithm, random order)."""
    rows = q.tolist()
    pts = [(rows[k][0], rows[k][1]) for k in _order(len(rows), seed)]
    slack = 1e-12 * (1.0 + float(np.abs(q).max()))

    def outside(p: Point2, centre: Point2, radius: float) -> bool:
        return math.hypot(p[0] - centre[0], p[1] - centre[1]) > radius + slack

    centre, radius = pts[0], 0.0
    for i in range(1, len(pts)):
        if not outside(pts[i], centre, radius):
            continue
        centre, radius = pts[i], 0.0
        for j in range(i):
            if not outside(pts[j], centre, radius):
                continue
            centre, radius = _circle2(pts[i], pts[j])
            for k in range(j):
                if outside(pts[k], centre, radius):
                    centre, radius = _circle3(pts[i], pts[j], pts[k])
    return np.array(centre), radius


def _circumcentres(q: np.ndarray, triples: np.ndarray) -> np.ndarray:
    """Centres (..., T, 2) of the circles through point triples of ``q`` (..., N, 2) (NaN for collinear ones)."""
    a, b, c = q[..., triples[:, 0], :], q[..., triples[:, 1], :], q[..., triples[:, 2], :]
    b, c = b - a, c - a
    det = 2.0 * (b[..., 0] * c[..., 1] - b[..., 1] * c[..., 0])
    bb, cc = (b * b).sum(axis=-1), (c * c).sum(axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ux = (c[..., 1] * bb - b[..., 1] * cc) / det
        uy = (b[..., 0] * cc - c[..., 0] * bb) / det
    return a + np.stack([ux, uy], axis=-1)


@functools.lru_cache(maxsize=64)
def _subsets(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Index triples (T, 3) and disjoint pairs of pairs (P, 4) of ``n`` points.

    Two pairs that share a point are equidistant from their three points only at those points'
    circumcentre, a triple's candidate already: only disjoint pairs add candidates.
    """
    triples = np.array(list(itertools.combinations(range(n), 3)), dtype=int).reshape(-1, 3)
    pairs = np.array(list(itertools.combinations(range(n), 2)), dtype=int).reshape(-1, 2)
    first, second = np.triu_indices(len(pairs), k=1)
    quads = np.hstack([pairs[first], pairs[second]])
    disjoint = (quads[:, 0] != quads[:, 2]) & (quads[:, 0] != quads[:, 3]) & (quads[:, 1] != quads[:, 2]) & (
        quads[:, 1] != quads[:, 3])
    return triples, quads[disjoint]


def _zone_candidates(q: np.ndarray) -> np.ndarray:
    """Candidate centres (..., C, 2) of the minimum-zone annulus of ``q`` (..., N, 2): 3 points on one circle, or
    2 + 2 on the two (non-finite where the points give none)."""
    triples, quads = _subsets(q.shape[-2])
    i, j, k, m = quads.T
    # |c - qi| = |c - qj| and |c - qk| = |c - qm|: two linear equations A c = b
    a1, a2 = 2 * (q[..., j, :] - q[..., i, :]), 2 * (q[..., m, :] - q[..., k, :])
    squared = (q * q).sum(axis=-1)  # |q|^2 of each point, once
    b1 = squared[..., j] - squared[..., i]
    b2 = squared[..., m] - squared[..., k]
    det = a1[..., 0] * a2[..., 1] - a1[..., 1] * a2[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        split = np.stack([(b1 * a2[..., 1] - b2 * a1[..., 1]) / det, (a1[..., 0] * b2 - a2[..., 0] * b1) / det],
                         axis=-1)
    return np.concatenate([_circumcentres(q, triples), split], axis=-2)


def _hull_contains(q: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Whether each centre of ``c`` (..., C, 2) lies strictly inside the convex hull of ``q`` (..., N, 2)
    (angular gaps < pi)."""
    rel = q[..., None, :, :] - c[..., :, None, :]
    angles = np.sort(np.arctan2(rel[..., 1], rel[..., 0]), axis=-1)
    gaps = np.diff(np.concatenate([angles, angles[..., :1] + 2 * np.pi], axis=-1), axis=-1)
    return gaps.max(axis=-1) < np.pi - 1e-12


def _crossing(d: np.ndarray, foot: np.ndarray, region: Region) -> np.ndarray:
    """Offsets from the region origin of the crossings of axes ``foot + s d`` (feet (B, C, 3), directions
    (B, 3)) with the reference plane."""
    a = region.axis
    height = (foot - region.origin) @ a
    return foot - (height / (d @ a)[:, None])[..., None] * d[:, None, :] - region.origin


def _bases(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`basis` of each unit direction of ``d`` (B, 3)."""
    helper = np.eye(3)[np.argmin(np.abs(d), axis=1)]
    e1 = np.cross(d, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, np.cross(d, e1)


def solve_directions(points: np.ndarray, directions: np.ndarray, criterion: str, region: Region) -> np.ndarray:
    """Exact 2-D optimum for each axis direction of ``directions`` (B, 3) (``inf`` / ``-inf`` where no axis of
    the region qualifies), all directions at once."""
    worst = np.inf if criterion != "mic" else -np.inf
    d = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    in_cone = np.degrees(np.arccos(np.minimum(1.0, np.abs(d @ region.axis)))) <= region.cone_deg + 1e-9
    e1, e2 = _bases(d)
    q = np.stack([np.einsum("nk,bk->bn", points, e1), np.einsum("nk,bk->bn", points, e2)], axis=-1)  # (B, N, 2)
    if criterion == "mcc":
        circles = [enclosing_circle(plane) for plane in q]
        centres = np.array([centre for centre, _ in circles])[:, None, :]
        values = np.array([radius for _, radius in circles])[:, None]
        valid = np.ones(values.shape, dtype=bool)
    else:
        triples = _subsets(q.shape[1])[0]
        centres = _circumcentres(q, triples) if criterion == "mic" else _zone_candidates(q)  # (B, C, 2)
        valid = np.all(np.isfinite(centres), axis=-1)
        if criterion == "mic":
            valid &= _hull_contains(q, centres)
        with np.errstate(invalid="ignore"):
            dist = np.hypot(q[:, None, :, 0] - centres[..., 0:1], q[:, None, :, 1] - centres[..., 1:2])
        values = np.ptp(dist, axis=-1) if criterion == "chebyshev" else dist.min(axis=-1)
    foot = centres[..., 0:1] * e1[:, None, :] + centres[..., 1:2] * e2[:, None, :]  # (B, C, 3)
    with np.errstate(invalid="ignore"):
        valid &= np.linalg.norm(_crossing(d, foot, region), axis=-1) <= region.offset * (1 + 1e-12)
    valid &= in_cone[:, None]
    chosen = np.where(valid, values, worst)
    return chosen.min(axis=1) if criterion != "mic" else chosen.max(axis=1)


def solve_direction(points: np.ndarray, d: np.ndarray, criterion: str, region: Region) -> float:
    """Exact 2-D optimum (``inf`` / ``-inf`` when no axis of the region qualifies) for axis direction ``d``."""
    return float(solve_directions(points, np.asarray(d, dtype=float)[None, :], criterion, region)[0])


#: directions solved at once on the grid (memory: about 350 kB each for a 13-point zone)
_BATCH = 64


@dataclass(frozen=True)
class Reference:
    value: float  # zone width / circumscribed radius / inscribed radius of the best axis found
    direction: np.ndarray


def best_axis(points: np.ndarray, criterion: str, region: Region, *, count: int = 1500, polish: int = 3) -> Reference:
    """Dense direction grid in the region's cone, exact 2-D solves, then Nelder-Mead from the best directions."""
    sign = 1.0 if criterion != "mic" else -1.0
    directions = cap_directions(region.axis, min(region.cone_deg, 89.999), count)
    values = sign * np.concatenate([solve_directions(points, directions[k:k + _BATCH], criterion, region)
                                    for k in range(0, len(directions), _BATCH)])
    order = np.argsort(values)[:polish]

    def objective(tilt: np.ndarray, start: np.ndarray, s1: np.ndarray, s2: np.ndarray) -> float:
        d = start + tilt[0] * s1 + tilt[1] * s2
        value = sign * solve_direction(points, d, criterion, region)
        return value if np.isfinite(value) else 1e12  # outside the region: a finite wall for the simplex

    best_value, best_direction = float(values[order[0]]), directions[order[0]]
    for k in order:
        start = directions[k]
        s1, s2 = basis(start)
        result = minimize(
            objective, np.zeros(2), args=(start, s1, s2), method="Nelder-Mead",
            options={"xatol": 1e-12, "fatol": 1e-14, "initial_simplex": np.array([[0, 0], [0.02, 0], [0, 0.02]]),
                     "maxiter": 300},
        )
        if result.fun < best_value:
            best_value = float(result.fun)
            best_direction = start + result.x[0] * s1 + result.x[1] * s2
    return Reference(sign * best_value, best_direction / np.linalg.norm(best_direction))


def hemisphere_directions(count: int) -> np.ndarray:
    """About ``count`` directions spread over a hemisphere (each axis once)."""
    return cap_directions(np.array([0.0, 0.0, 1.0]), 90.0, count)


def best_line(points: np.ndarray, *, count: int = 4000, polish: int = 3) -> Reference:
    """Smallest enclosing cylinder over all directions: the diameter (``value``) and its direction."""
    centred = points - points.mean(axis=0)
    directions = hemisphere_directions(count)
    values = np.array([enclosing_circle(np.c_[centred @ basis(d)[0], centred @ basis(d)[1]])[1] for d in directions])
    best_value, best_direction = float(values.min()), directions[int(np.argmin(values))]
    for k in np.argsort(values)[:polish]:
        start = directions[k]
        s1, s2 = basis(start)

        def objective(tilt: np.ndarray, start: np.ndarray = start, s1: np.ndarray = s1, s2: np.ndarray = s2) -> float:
            d = start + tilt[0] * s1 + tilt[1] * s2
            d = d / np.linalg.norm(d)
            e1, e2 = basis(d)
            return enclosing_circle(np.c_[centred @ e1, centred @ e2])[1]

        result = minimize(objective, np.zeros(2), method="Nelder-Mead",
                          options={"xatol": 1e-12, "fatol": 1e-14, "maxiter": 300,
                                   "initial_simplex": np.array([[0, 0], [0.03, 0], [0, 0.03]])})
        if result.fun < best_value:
            best_value = float(result.fun)
            best_direction = start + result.x[0] * s1 + result.x[1] * s2
    return Reference(2.0 * best_value, best_direction / np.linalg.norm(best_direction))
