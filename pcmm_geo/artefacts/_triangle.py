"""Triangle kernels of the exact mesh distance: nearest points and nearby triangles.

:func:`closest_on_triangles` gives the nearest point of a triangle to a point, many pairs
at once, in double precision.  The classification of the point into the seven regions of the triangle's plane (three
corners, three edges, the interior) follows the dot-product tests of Ericson, *Real-Time
Collision Detection* (2005), section 5.1.5; here every pair is evaluated at once with
numpy and the answer is returned as barycentric weights, which the sign rule reuses.

The other functions find every triangle that could lie within a given distance of a point,
from bounding spheres about the triangle centroids: :func:`listed_pairs` from per-triangle
lists of centroid neighbours (no search), :func:`pairs_within` from k-d trees (any distance).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: distances below this fraction of the coordinates' size are rounding noise
ROUNDING = 1e-12
#: relative slack on search distances (rounding of box, centroid and triangle distances)
SLACK = 1e-9
#: neighbours asked of a k-d tree first (more for the points that have more within reach)
_FIRST_NEIGHBOURS = 6
#: triangle size classes (half box diagonals within a factor 2 of each other, the last takes the rest)
_SIZE_CLASSES = 8
#: centroid neighbours listed per triangle (see :func:`listed_pairs`)
_LISTED_NEIGHBOURS = 16
#: the neighbour lists reach this many largest triangle radii (fewer when a list is full)
_LISTED_REACH = 3.0
#: points tested against their neighbour lists at once
_LISTED_POINTS_PER_BLOCK = 8192


def closest_on_triangles(points: FloatArray, corners: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Nearest points of triangles to points, pair by pair.

    Parameters
    ----------
    points : ndarray, shape (M, 3)
        Query points (mm).
    corners : ndarray, shape (M, 3, 3)
        Triangle ``m`` has corners ``corners[m, 0..2]`` (mm).

    Returns
    -------
    closest : ndarray, shape (M, 3)
        Nearest point of triangle ``m`` to point ``m``.
    squared : ndarray, shape (M,)
        Squared distance between them (mm^2).
    barycentric : ndarray, shape (M, 3)
        Weights of the corners giving ``closest`` (non-negative, summing to one; exactly
        zero on the edge or corner regions).

    Examples
    --------
    >>> triangle = np.array([[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]])
    >>> closest, squared, weights = closest_on_triangles(np.array([[2.0, 2.0, 1.0]]), triangle)
    >>> closest.tolist(), squared.tolist(), weights.tolist()
    ([[0.5, 0.5, 0.0]], [5.5], [[0.0, 0.5, 0.5]])
    """
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    ab, ac = b - a, c - a
    ap, bp, cp = points - a, points - b, points - c
    d1, d2 = _dot(ab, ap), _dot(ac, ap)
    d3, d4 = _dot(ab, bp), _dot(ac, bp)
    d5, d6 = _dot(ab, cp), _dot(ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    # interior first, then every region overrides it in the reverse order of Ericson's tests
    # (assigned where its test holds only: the edge and corner regions are the minority)
    with np.errstate(divide="ignore", invalid="ignore"):
        total = va + vb + vc
        v = np.where(total != 0.0, vb / total, 1.0 / 3.0)
        w = np.where(total != 0.0, vc / total, 1.0 / 3.0)
        on_bc = (va <= 0.0) & (d4 - d3 >= 0.0) & (d5 - d6 >= 0.0)
        t_bc = (d4 - d3)[on_bc] / ((d4 - d3)[on_bc] + (d5 - d6)[on_bc])
        v[on_bc], w[on_bc] = 1.0 - t_bc, t_bc
        on_ac = (vb <= 0.0) & (d2 >= 0.0) & (d6 <= 0.0)
        v[on_ac], w[on_ac] = 0.0, d2[on_ac] / (d2[on_ac] - d6[on_ac])
        at_c = (d6 >= 0.0) & (d5 <= d6)
        v[at_c], w[at_c] = 0.0, 1.0
        on_ab = (vc <= 0.0) & (d1 >= 0.0) & (d3 <= 0.0)
        v[on_ab], w[on_ab] = d1[on_ab] / (d1[on_ab] - d3[on_ab]), 0.0
        at_b = (d3 >= 0.0) & (d4 <= d3)
        v[at_b], w[at_b] = 1.0, 0.0
        at_a = (d1 <= 0.0) & (d2 <= 0.0)
        v[at_a], w[at_a] = 0.0, 0.0
    barycentric = np.stack([1.0 - v - w, v, w], axis=1)
    closest = a + v[:, None] * ab + w[:, None] * ac
    # a corner region is exactly that corner (no rounding of a + 1 * ab)
    corner_b = at_b & ~at_a
    corner_c = at_c & ~at_a & ~at_b & ~on_ab
    closest[corner_b] = b[corner_b]
    closest[corner_c] = c[corner_c]
    offset = points - closest
    return closest, _dot(offset, offset), barycentric


def _dot(left: FloatArray, right: FloatArray) -> FloatArray:
    return np.einsum("ij,ij->i", left, right)


@dataclass(frozen=True)
class NeighbourLists:
    """Per triangle, the triangles whose centroids lie nearest to its own centroid.

    ``listed[t]`` holds every triangle whose centroid is closer than ``complete_within[t]``
    to the centroid of ``t`` (padded with ``t`` itself); ``centroids`` and ``radius`` (largest
    centroid-to-corner distance, slightly enlarged) describe every triangle.
    """

    listed: IntArray
    complete_within: FloatArray
    centroids: FloatArray
    radius: FloatArray
    centroid_axes: tuple[FloatArray, FloatArray, FloatArray]


@dataclass(frozen=True)
class SizeClass:
    """Triangles of similar size: a k-d tree over their centroids and their largest centroid-to-corner distance."""

    members: IntArray
    tree: Any
    reach: float
    member_reach: FloatArray


def size_classes(triangles: FloatArray) -> tuple[SizeClass, ...]:
    """Triangles grouped by circumscribing radius about the centroid (factor 2 per group), with k-d trees.

    Every point of a triangle lies within its largest centroid-to-corner distance of its
    centroid, so a triangle within ``d`` of a point has its centroid within ``d`` plus
    that radius.
    """
    from scipy.spatial import cKDTree

    centroids = triangles.mean(axis=1)
    radius = np.linalg.norm(triangles - centroids[:, None, :], axis=2).max(axis=1) * (1.0 + SLACK)
    largest = max(float(radius.max()), 1e-300)
    with np.errstate(divide="ignore"):
        level = np.floor(np.log2(largest / np.maximum(radius, 1e-300)))
    level = np.clip(level, 0, _SIZE_CLASSES - 1).astype(np.int64)
    groups = []
    for value in np.unique(level):
        members = np.flatnonzero(level == value)
        groups.append(SizeClass(members=members, tree=cKDTree(centroids[members]),
                                reach=float(radius[members].max()), member_reach=radius[members]))
    return tuple(groups)


def pairs_within(group: SizeClass, query: FloatArray, reach: FloatArray) -> tuple[IntArray, IntArray]:
    """Point-triangle pairs with the centroid within the point's ``reach`` plus the triangle's own radius."""
    count = len(group.members)
    rows = np.arange(len(query))
    radius = reach + group.reach
    asked = _FIRST_NEIGHBOURS
    points, triangles = [], []
    while rows.size:
        asked = min(asked, count)
        distance, neighbour = group.tree.query(query[rows], k=asked, distance_upper_bound=float(radius[rows].max()),
                                               workers=-1)
        distance, neighbour = distance.reshape(len(rows), -1), neighbour.reshape(len(rows), -1)
        complete = ~(distance[:, -1] <= radius[rows]) | (asked == count)
        member = np.minimum(neighbour, count - 1)
        close = (distance <= reach[rows, None] + group.member_reach[member]) & complete[:, None]
        pair_row, pair_column = np.nonzero(close)
        points.append(rows[pair_row])
        triangles.append(group.members[member[pair_row, pair_column]])
        rows = rows[~complete]
        asked *= 4
    return np.concatenate(points), np.concatenate(triangles)


def neighbour_lists(triangles: FloatArray) -> NeighbourLists:
    """The centroid neighbour lists of every triangle (see :func:`listed_pairs`)."""
    from scipy.spatial import cKDTree

    centroids = triangles.mean(axis=1)
    radius = np.linalg.norm(triangles - centroids[:, None, :], axis=2).max(axis=1) * (1.0 + SLACK)
    count = min(_LISTED_NEIGHBOURS, len(triangles))
    bound = _LISTED_REACH * float(radius.max())
    distance, listed = cKDTree(centroids).query(centroids, k=count, distance_upper_bound=bound, workers=-1)
    distance, listed = distance.reshape(len(centroids), count), listed.reshape(len(centroids), count)
    # a full list is complete only below its last distance; rounding of the distances is allowed for
    within = np.where(np.isfinite(distance[:, -1]), distance[:, -1], bound)
    within = within * (1.0 - SLACK) - ROUNDING * (1.0 + np.abs(centroids).max(axis=1))
    own = np.arange(len(triangles))[:, None]
    listed = np.where(listed < len(triangles), listed, own)
    return NeighbourLists(listed=listed, complete_within=within, centroids=centroids, radius=radius,
                          centroid_axes=tuple(np.ascontiguousarray(centroids[:, axis]) for axis in range(3)))


def listed_pairs(lists: NeighbourLists, query: FloatArray, reach: FloatArray, face_index: IntArray,
                 rounding: FloatArray) -> tuple[IntArray, IntArray, IntArray]:
    """Pairs (point, triangle) that could lie within ``reach``, from the candidate's neighbour list.

    A triangle ``t`` within ``reach`` of point ``p`` has its centroid within ``reach + r_t`` of
    ``p`` and so within ``reach + r_max + |p - c|`` of the candidate's centroid ``c`` (triangle
    inequality).  Where that is below the list's completeness radius, the list holds every
    such triangle and no tree search is needed.  Returns the pairs and the rows of the points
    the lists cannot answer (left to the k-d trees).
    """
    to_candidate = np.linalg.norm(query - lists.centroids[face_index], axis=1)
    needed = (reach + float(lists.radius.max()) + to_candidate) * (1.0 + SLACK) + rounding
    local = needed < lists.complete_within[face_index]
    points, triangles = [], []
    # blocks of points and one coordinate at a time: (points, neighbours) temporaries stay small
    for start in range(0, len(query), _LISTED_POINTS_PER_BLOCK):
        rows = start + np.flatnonzero(local[start:start + _LISTED_POINTS_PER_BLOCK])
        listed = lists.listed[face_index[rows]]
        limit = reach[rows, None] + lists.radius[listed]
        squared = np.zeros(listed.shape)
        for axis in range(3):
            offset = lists.centroid_axes[axis][listed] - query[rows, axis, None]
            squared += offset * offset
        pair_row, pair_column = np.nonzero((squared <= limit * limit) & (listed != face_index[rows, None]))
        points.append(rows[pair_row])
        triangles.append(listed[pair_row, pair_column])
    return np.concatenate(points), np.concatenate(triangles), np.flatnonzero(~local)
