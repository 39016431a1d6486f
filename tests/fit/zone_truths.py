"""Exact minimum-zone, MCC and MIC truths that share no code with :mod:`pcmm_geo.fit`, and random sets.

Each truth is an exhaustive search over a finite candidate set that holds the optimum:

- plane: every facet-vertex and edge-edge antipodal pair of the convex hull (Qhull);
- 2-D line: every hull edge with its farthest vertex;
- circle / sphere zone: every centre equidistant from 3 (4) points and every centre equidistant
  within two groups of 2 + 2 (3 + 2) points -- all 4- (5-) point splits;
- circle / sphere MCC: every ball spanned by 2 .. D + 1 points that encloses the rest;
- circle MIC: every Voronoi vertex inside the convex hull and every crossing of a Voronoi edge with
  a hull edge (scipy's Voronoi diagram).

Used by ``tests/fit/test_zone_global.py`` and ``benchmarks/bench_zone.py``.
"""

from __future__ import annotations

from itertools import combinations

import numpy as np
from scipy.spatial import ConvexHull, Voronoi


def slab_truth(points: np.ndarray) -> float:
    """Narrowest slab: hull facets with their farthest vertex, and edge pairs on parallel supporting planes."""
    hull = ConvexHull(points)
    corners = points[hull.vertices]
    best = float(np.ptp(corners @ hull.equations[:, :3].T, axis=0).min())
    edges = np.unique(np.sort(hull.simplices[:, [[0, 1], [1, 2], [0, 2]]].reshape(-1, 2), axis=1), axis=0)
    direction = points[edges[:, 1]] - points[edges[:, 0]]
    i, j = np.triu_indices(len(edges), k=1)
    normals = np.cross(direction[i], direction[j])
    length = np.linalg.norm(normals, axis=1)
    keep = length > 1e-9 * length.max()
    i, j, normals = i[keep], j[keep], normals[keep] / length[keep, None]
    offsets = corners @ normals.T
    high, low = offsets.max(axis=0), offsets.min(axis=0)
    first = np.einsum("kd,kd->k", points[edges[i, 0]], normals)
    second = np.einsum("kd,kd->k", points[edges[j, 0]], normals)
    tol = 1e-10 * float(np.abs(corners).max())
    antipodal = ((np.abs(first - high) < tol) & (np.abs(second - low) < tol)) | (
        (np.abs(first - low) < tol) & (np.abs(second - high) < tol)
    )
    if antipodal.any():
        best = min(best, float((high - low)[antipodal].min()))
    return best


def strip_truth(points: np.ndarray) -> float:
    hull = points[ConvexHull(points).vertices]
    edges = np.roll(hull, -1, axis=0) - hull
    normals = np.column_stack([-edges[:, 1], edges[:, 0]]) / np.linalg.norm(edges, axis=1)[:, None]
    return float(np.ptp(hull @ normals.T, axis=0).min())


def _solve(rows: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Batched linear solves, NaN where singular."""
    det = np.linalg.det(rows)
    ok = np.abs(det) > 1e-12 * np.prod(np.linalg.norm(rows, axis=2), axis=1)
    out = np.full(rhs.shape, np.nan)
    out[ok] = np.linalg.solve(rows[ok], rhs[ok][..., None])[..., 0]
    return out[ok]


def _bisector_rows(q: np.ndarray, pairs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a, b = q[pairs[..., 0]], q[pairs[..., 1]]
    return b - a, 0.5 * np.einsum("kij,kij->ki", b - a, b + a)


def round_zone_truth(points: np.ndarray) -> float:
    """Minimum-zone circle / sphere over all (D+1)-point circumcentres and 2+2 / 3+2 group centres."""
    q = points - points.mean(axis=0)
    dim = q.shape[1]
    n = len(q)
    systems = []
    for sub in combinations(range(n), dim + 1):
        systems.append([(sub[0], s) for s in sub[1:]])
    for sub in combinations(range(n), dim + 2):
        for group in combinations(sub, dim if dim == 3 else 2):
            other = [s for s in sub if s not in group]
            if dim == 2:
                if group[0] != sub[0]:
                    continue  # each split once
                systems.append([(group[0], group[1]), (other[0], other[1])])
            else:
                systems.append([(group[0], group[1]), (group[0], group[2]), (other[0], other[1])])
    rows, rhs = _bisector_rows(q, np.array(systems))
    centres = _solve(rows, rhs)
    distances = np.linalg.norm(q[None, :, :] - centres[:, None, :], axis=2)
    return float(np.ptp(distances, axis=1).min())


def enclosing_truth(points: np.ndarray) -> float:
    """Smallest enclosing circle / sphere: the centres of all balls spanned by 2 .. D+1 points."""
    q = points - points.mean(axis=0)
    dim = q.shape[1]
    centres = [0.5 * (q[i] + q[j]) for i, j in combinations(range(len(q)), 2)]
    for size in range(3, dim + 2):
        for sub in combinations(range(len(q)), size):
            edges = q[list(sub[1:])] - q[sub[0]]
            gram = edges @ edges.T
            if abs(np.linalg.det(gram)) < 1e-12 * np.prod(np.diag(gram)):
                continue
            centres.append(q[sub[0]] + np.linalg.solve(gram, 0.5 * np.diag(gram)) @ edges)
    reach = np.linalg.norm(q[None, :, :] - np.array(centres)[:, None, :], axis=2).max(axis=1)
    return float(reach.min())


def empty_circle_truth(points: np.ndarray) -> tuple[float, bool]:
    """Largest empty circle centred in the convex hull: (radius, centre on the hull boundary?)."""
    q = points - points.mean(axis=0)
    diagram, hull = Voronoi(q), ConvexHull(q)
    inside = (diagram.vertices @ hull.equations[:, :2].T + hull.equations[:, 2]).max(axis=1) <= 1e-9
    interior = [np.linalg.norm(q - v, axis=1).min() for v in diagram.vertices[inside]]
    best_inside = max(interior, default=-np.inf)
    ring = q[hull.vertices]
    best_boundary = -np.inf
    for start, end in zip(ring, np.roll(ring, -1, axis=0), strict=True):
        for s, t in diagram.ridge_points:
            normal = q[t] - q[s]
            slope = normal @ (end - start)
            if abs(slope) < 1e-15:
                continue
            u = (0.5 * normal @ (q[t] + q[s]) - normal @ start) / slope
            if 0.0 <= u <= 1.0:
                best_boundary = max(best_boundary, np.linalg.norm(q - (start + u * (end - start)), axis=1).min())
    return max(best_inside, best_boundary), bool(best_boundary > best_inside + 1e-12)


def rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


def warped_patch(rng: np.random.Generator) -> np.ndarray:
    n = int(rng.integers(4, 31))
    xy = rng.uniform(-20, 20, (n, 2))
    if rng.random() < 0.5:
        xy[:, 1] *= rng.uniform(0.01, 0.1)  # a strip
    z = (
        rng.normal(0, 10 ** rng.uniform(-3, -1), n)
        + rng.normal(0, 2e-3) * xy[:, 0] * xy[:, 1]
        + rng.normal(0, 1e-3) * (xy**2).sum(axis=1)
    )
    return np.c_[xy, z] @ rotation(rng).T + rng.uniform(-500, 500, 3)


def round_profile(rng: np.random.Generator, dim: int, n_range: tuple[int, int], arcs: bool) -> np.ndarray:
    n = int(rng.integers(*n_range))
    radius = 10 ** rng.uniform(-1, 2)  # 0.1 to 100 mm
    noise = 10 ** rng.uniform(-4, -0.5)  # relative
    if dim == 2:
        angles = rng.uniform(0, 2 * np.pi, n) * (rng.uniform(0.3, 1.0) if arcs and rng.random() < 0.3 else 1.0)
        unit = np.c_[np.cos(angles), np.sin(angles)]
    else:
        unit = rng.normal(size=(n, 3))
        if arcs and rng.random() < 0.3:
            unit[:, 2] = np.abs(unit[:, 2]) + rng.uniform(0, 1)  # a cap
        unit /= np.linalg.norm(unit, axis=1)[:, None]
    return unit * radius * (1 + noise * rng.uniform(-1, 1, (n, 1))) + rng.uniform(-500, 500, dim)
