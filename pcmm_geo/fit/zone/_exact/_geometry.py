"""Closed-form pieces of the exact solvers: equidistant centres, index subsets, small enclosing balls.

Every candidate centre of a circle or sphere zone, enclosing or empty ball is a point at equal
distance from the points of one or two groups: it solves ``D`` bisector equations

    (p_b - p_a) . x = (|p_b|^2 - |p_a|^2) / 2

for ``D`` pairs ``(a, b)`` (``D`` = 2 or 3).  :func:`equidistant_centres` solves a batch of them
by Cramer's rule (2-D) or cross products (3-D), so a near-singular system is flagged instead of
raising.  The data are expected centred (coordinates of the order of the data size).
"""

from __future__ import annotations

from itertools import combinations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IndexArray = NDArray[np.intp]

#: a bisector system whose determinant is below this fraction of the product of its row norms is singular
SINGULAR = 1e-12


def equidistant_centres(points: FloatArray, pairs: IndexArray) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Points equidistant from each pair of ``pairs``.

    Parameters
    ----------
    points : ndarray, shape (M, D)
        Centred coordinates (mm), D = 2 or 3.
    pairs : ndarray of int, shape (K, D, 2)
        For each candidate, ``D`` index pairs ``(a, b)``: the centre is as far from ``p_a`` as from ``p_b``.

    Returns
    -------
    centres : ndarray, shape (K, D)
        The solutions (NaN where singular).
    valid : ndarray of bool, shape (K,)
        False where the bisectors are (nearly) parallel: no finite centre.
    """
    first = points[pairs[..., 0]]
    second = points[pairs[..., 1]]
    rows = second - first  # (K, D, D)
    rhs = 0.5 * np.einsum("kij,kij->ki", rows, second + first)
    dim = points.shape[1]
    scale = np.prod(np.linalg.norm(rows, axis=2), axis=1)
    if dim == 2:
        det = rows[:, 0, 0] * rows[:, 1, 1] - rows[:, 0, 1] * rows[:, 1, 0]
        numer = np.stack(
            [
                rhs[:, 0] * rows[:, 1, 1] - rhs[:, 1] * rows[:, 0, 1],
                rows[:, 0, 0] * rhs[:, 1] - rows[:, 1, 0] * rhs[:, 0],
            ],
            axis=1,
        )
    else:
        c12 = np.cross(rows[:, 1], rows[:, 2])
        c20 = np.cross(rows[:, 2], rows[:, 0])
        c01 = np.cross(rows[:, 0], rows[:, 1])
        det = np.einsum("ki,ki->k", rows[:, 0], c12)
        numer = rhs[:, 0:1] * c12 + rhs[:, 1:2] * c20 + rhs[:, 2:3] * c01
    valid = np.abs(det) > SINGULAR * scale
    with np.errstate(divide="ignore", invalid="ignore"):
        centres = numer / np.where(valid, det, np.nan)[:, None]
    return centres, valid


def subsets_with_new(count: int, size: int, first_new: int) -> IndexArray:
    """All ``size``-subsets of ``range(count)`` holding at least one index ``>= first_new`` (shape (K, size))."""
    if count < size:
        return np.zeros((0, size), dtype=np.intp)
    table = np.array(list(combinations(range(count), size)), dtype=np.intp).reshape(-1, size)
    return table[table.max(axis=1) >= first_new]


def circumcentre_pairs(subsets: IndexArray) -> IndexArray:
    """Bisector pairs of the circumcentre of each ``(D + 1)``-subset: ``(s0, s1), (s0, s2), ...``."""
    first = np.repeat(subsets[:, :1], subsets.shape[1] - 1, axis=1)
    return np.stack([first, subsets[:, 1:]], axis=2)


def split_pairs(count: int, first_new: int, dim: int) -> IndexArray:
    """Bisector pairs of the two-group centres of ``range(count)`` that involve an index ``>= first_new``.

    2-D: two disjoint pairs ``{a, b}``, ``{c, d}`` (two points on each level); 3-D: a triple and a
    disjoint pair (three points on one level, two on the other).  Returns shape (K, D, 2).
    """
    pairs = np.array(list(combinations(range(count), 2)), dtype=np.intp).reshape(-1, 2)
    if dim == 2:
        i, j = np.triu_indices(len(pairs), k=1)
        left, right = pairs[i], pairs[j]
        keep = (
            (left[:, 0] != right[:, 0])
            & (left[:, 0] != right[:, 1])
            & (left[:, 1] != right[:, 0])
            & (left[:, 1] != right[:, 1])
            & (np.maximum(left.max(axis=1), right.max(axis=1)) >= first_new)
        )
        return np.stack([left[keep], right[keep]], axis=1)
    triples = np.array(list(combinations(range(count), 3)), dtype=np.intp).reshape(-1, 3)
    fresh_triples = triples.max(axis=1) >= first_new
    fresh_pairs = pairs.max(axis=1) >= first_new
    parts = []
    # a triple with a new index and any pair; an old triple and a pair with a new index
    for triple_set, pair_set in ((triples[fresh_triples], pairs), (triples[~fresh_triples], pairs[fresh_pairs])):
        i, j = np.meshgrid(np.arange(len(triple_set)), np.arange(len(pair_set)), indexing="ij")
        triple, pair = triple_set[i.ravel()], pair_set[j.ravel()]
        disjoint = ~((triple[:, :, None] == pair[:, None, :]).any(axis=(1, 2)))
        triple, pair = triple[disjoint], pair[disjoint]
        parts.append(np.stack([triple[:, [0, 1]], triple[:, [0, 2]], pair], axis=1))
    return np.concatenate(parts)


def enclosing_ball(points: FloatArray) -> tuple[FloatArray, float, IndexArray]:
    """Smallest ball enclosing a small point set, by enumeration (exact; for up to a few dozen points).

    The smallest enclosing ball is the smallest of the balls spanned by 2 .. D + 1 of the points
    (centre in the affine hull of its support, equidistant from it) that enclose every point.

    Returns
    -------
    centre : ndarray, shape (D,)
    radius : float
    support : ndarray of int
        Indices of the points on the sphere.
    """
    count, dim = points.shape
    best_centre, best_radius, best_support = points[0].copy(), np.inf, np.array([0], dtype=np.intp)
    if count == 1:
        return best_centre, 0.0, best_support
    slack = 1e-13 * max(float(np.abs(points).max()), 1e-300)
    for size in range(2, min(dim + 1, count) + 1):
        subsets = np.array(list(combinations(range(count), size)), dtype=np.intp)
        centres = _affine_circumcentres(points, subsets)
        finite = np.isfinite(centres).all(axis=1)
        subsets, centres = subsets[finite], centres[finite]
        radii = np.linalg.norm(centres - points[subsets[:, 0]], axis=1)
        reach = np.linalg.norm(points[None, :, :] - centres[:, None, :], axis=2).max(axis=1)
        encloses = reach <= radii + slack
        if encloses.any():
            k = int(np.flatnonzero(encloses)[np.argmin(reach[encloses])])
            if reach[k] < best_radius:
                best_centre, best_radius, best_support = centres[k], float(reach[k]), subsets[k]
    return best_centre, best_radius, best_support


def _affine_circumcentres(points: FloatArray, subsets: IndexArray) -> FloatArray:
    """Centre of the smallest sphere through each subset (in the subset's affine hull); NaN if degenerate."""
    base = points[subsets[:, 0]]
    edges = points[subsets[:, 1:]] - base[:, None, :]  # (K, s-1, D)
    gram = np.einsum("kid,kjd->kij", edges, edges)
    rhs = 0.5 * np.einsum("kid,kid->ki", edges, edges)
    det = np.linalg.det(gram)
    scale = np.prod(np.einsum("kii->ki", gram), axis=1)
    ok = np.abs(det) > 1e-12 * scale
    centres = np.full(base.shape, np.nan)
    if ok.any():
        coefficients = np.linalg.solve(gram[ok], rhs[ok][..., None])[..., 0]
        centres[ok] = base[ok] + np.einsum("ki,kid->kd", coefficients, edges[ok])
    return centres


def minimum_width_small(points: FloatArray) -> tuple[float, FloatArray]:
    """Exact minimum width and its unit normal of a small ``(M, 2)`` or ``(M, 3)`` point set, by enumeration.

    The narrowest strip has a side through two of the points (normal perpendicular to their
    difference); the narrowest slab a side through three (a facet normal) or one edge on each side
    (normal perpendicular to two differences).  Every such normal is tried.  Returns ``(0, normal)``
    for points on one line / plane.
    """
    count, dim = points.shape
    pairs = np.array(list(combinations(range(count), 2)), dtype=np.intp).reshape(-1, 2)
    differences = points[pairs[:, 1]] - points[pairs[:, 0]]
    if dim == 2:
        normals = np.column_stack([-differences[:, 1], differences[:, 0]])
    else:
        i, j = np.triu_indices(len(differences), k=1)
        normals = np.cross(differences[i], differences[j])
    lengths = np.linalg.norm(normals, axis=1)
    scale = float(np.abs(points - points.mean(axis=0)).max()) ** (dim - 1)
    usable = lengths > 1e-13 * max(scale, 1e-300)
    if not usable.any():
        return 0.0, np.eye(dim)[-1]
    normals = normals[usable] / lengths[usable, None]
    widths = np.ptp(points @ normals.T, axis=0)
    k = int(np.argmin(widths))
    return float(widths[k]), normals[k]
