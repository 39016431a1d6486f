"""Triangle kernels of the exact mesh distance: nearest points and nearby triangles.

:func:`closest_on_triangles` gives the nearest point of a triangle to a point, many pairs
at once, in double precision.  The classification of the point into the seven regions of the triangle's plane (three
corners, three edges, the interior) follows the dot-product tests of Ericson, *Real-Time
Collision Detection* (2005), section 5.1.5; here every pair is evaluated at once with
numpy and the answer is returned as barycentric weights, which the sign rule reuses.

The other functions find every triangle that could lie within a given distance of a point,
from bounding spheres about the triangle centroids: :func:`listed_pairs` from per-triangle
lists of centroid neighbours (no search), :func:`pairs_within` from k-d trees (any distance).
:func:`within_reach` then discards most of these pairs with a lower bound of the distance
from four planes per triangle (:func:`bounding_planes`), cheaper than the exact distance and
equal to it wherever the nearest point lies inside the triangle or on an edge.

The mesh-wide helpers of the index build come last: :func:`twin_edges` (is the mesh a closed
oriented manifold, and which face lies across each edge), :func:`enclosed_volume`,
:func:`edge_normals` and :func:`corner_normals` (the pseudo-normals of the sign rule).  They
work on coordinates stored by axis (one contiguous row per coordinate), which keeps numpy's
passes over the mesh few and cheap.
"""

from __future__ import annotations

import itertools
import os
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record

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
_LISTED_NEIGHBOURS = 14
#: the neighbour lists reach this many largest triangle radii (fewer when a list is full)
_LISTED_REACH = 3.0
#: points tested against their neighbour lists at once
_LISTED_POINTS_PER_BLOCK = 8192


class CentroidTree:
    """A k-d tree over triangle centroids, asked as scipy's ``cKDTree.query`` is asked.

    pykdtree, where installed (the ``cad`` extra), answers the same nearest-neighbour questions
    in about two thirds of scipy's time; its OpenMP threads are limited per call (threadpoolctl)
    to the ``workers`` asked.  Without it scipy's tree is used.  Either gives the exact nearest
    neighbours in double precision (ties may come in another order); missing neighbours are
    reported as scipy does: index ``n`` (the number of centroids) at infinite distance.  The
    tree itself is not pickled (pykdtree's cannot be): a copy rebuilds it on first use.
    """

    def __init__(self, centroids: FloatArray) -> None:
        self.centroids = np.ascontiguousarray(centroids, dtype=np.float64)
        self._tree: Any = None

    def __getstate__(self) -> dict[str, Any]:
        return {"centroids": self.centroids, "_tree": None}

    def __len__(self) -> int:
        return len(self.centroids)

    def query(self, points: FloatArray, *, k: int, distance_upper_bound: float = np.inf,
              workers: int = -1) -> tuple[FloatArray, IntArray]:
        """Distances (P, k) and indices (P, k) of the ``k`` nearest centroids of each point, within the bound."""
        tree = self._tree
        if tree is None:
            tree = self._tree = _new_tree(self.centroids)
        if isinstance(tree, _ScipyTree):
            distance, index = tree.tree.query(points, k=k, distance_upper_bound=distance_upper_bound, workers=workers)
        else:
            with _openmp_threads(workers):
                distance, index = tree.query(np.ascontiguousarray(points, dtype=np.float64), k=k,
                                             distance_upper_bound=None if np.isinf(distance_upper_bound)
                                             else float(distance_upper_bound))
        return (np.asarray(distance, dtype=np.float64).reshape(len(points), k),
                np.asarray(index, dtype=np.int64).reshape(len(points), k))


class _ScipyTree:
    """scipy's tree, where pykdtree is not installed."""

    def __init__(self, tree: Any) -> None:
        self.tree = tree


def _new_tree(centroids: FloatArray) -> Any:
    try:
        from pykdtree.kdtree import KDTree
    except ImportError:
        from scipy.spatial import cKDTree

        return _ScipyTree(cKDTree(centroids, balanced_tree=False))  # sliding midpoint: quicker to build
    return KDTree(centroids, leafsize=16)


def _openmp_threads(workers: int) -> Any:
    """A context that limits OpenMP to ``workers`` threads in this thread (-1: no limit)."""
    import contextlib

    if workers < 0:
        return contextlib.nullcontext()
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # pykdtree then uses every core; the answers are the same
        return contextlib.nullcontext()
    global _CONTROLLER
    if _CONTROLLER is None:
        _CONTROLLER = ThreadpoolController()
    return _CONTROLLER.limit(limits=workers, user_api="openmp")


_CONTROLLER: Any = None


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
    a, b, c = _by_axis(corners)  # each (3, M): one contiguous row per coordinate
    query = np.ascontiguousarray(np.asarray(points, dtype=np.float64).T)
    ab, ac = b - a, c - a
    ap, bp, cp = query - a, query - b, query - c
    d1, d2 = _dot_rows(ab, ap), _dot_rows(ac, ap)
    d3, d4 = _dot_rows(ab, bp), _dot_rows(ac, bp)
    d5, d6 = _dot_rows(ab, cp), _dot_rows(ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    # the projection falls inside the triangle for most pairs: only the others need Ericson's region tests
    inside = (va > 0.0) & (vb > 0.0) & (vc > 0.0)
    total = va + vb + vc
    with np.errstate(divide="ignore", invalid="ignore"):
        v, w = vb / total, vc / total
    outside = np.flatnonzero(~inside)
    corner = np.zeros(0, dtype=np.int64)
    if len(outside):
        pick = (d1[outside], d2[outside], d3[outside], d4[outside], d5[outside], d6[outside], va[outside],
                vb[outside], vc[outside])
        v[outside], w[outside], corner = _boundary_weights(*pick)
    closest = ab * v
    closest += ac * w
    closest += a
    if len(outside):
        # a corner region is exactly that corner (no rounding of a + 1 * ab)
        at_b, at_c = outside[corner == 1], outside[corner == 2]
        closest[:, at_b] = b[:, at_b]
        closest[:, at_c] = c[:, at_c]
    barycentric = np.stack([1.0 - v - w, v, w], axis=1)
    offset = query - closest  # (query may share memory with points)
    return np.ascontiguousarray(closest.T), _dot_rows(offset, offset), barycentric


def _boundary_weights(d1: FloatArray, d2: FloatArray, d3: FloatArray, d4: FloatArray, d5: FloatArray,
                      d6: FloatArray, va: FloatArray, vb: FloatArray,
                      vc: FloatArray) -> tuple[FloatArray, FloatArray, IntArray]:
    """Weights ``v``, ``w`` of corners b and c for pairs whose projection may lie outside, and the corner (0: none).

    Every region overrides the interior in the reverse order of Ericson's tests (assigned
    where its test holds only); a degenerate triangle (zero area) starts at its centroid.
    """
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
    corner = np.zeros(len(v), dtype=np.int64)
    corner[at_c & ~at_a & ~at_b & ~on_ab] = 2
    corner[at_b & ~at_a] = 1
    return v, w, corner


def bounding_planes(triangles: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The plane of each triangle and the three planes through its edges perpendicular to it.

    Returns a (16, F) array (one contiguous row per coefficient, for fast gathers): the unit
    normal ``n`` and the outward unit edge normals ``m_k`` (in the triangle's plane, edge
    ``k`` from corner ``k`` to ``k + 1``) as rows 0-11, then the four offsets ``-n.a``,
    ``-m_k.v_k``.  A degenerate triangle (no area) gets zeros, which make
    :func:`within_reach` keep every pair it is in.  Also returns the (3, F) area vectors
    ``(b - a) x (c - a)`` (twice the vector area; ``n`` is this one normalised), which the
    enclosed volume and the corner angles reuse.

    For a point ``p`` with ``h = n.p - n.a`` and ``e = max(0, max_k m_k.p - m_k.v_k)``,
    ``sqrt(h^2 + e^2)`` is at most the distance from ``p`` to the triangle: the triangle lies
    in its plane, inside each edge's half-plane.  The bound is the distance itself when the
    nearest point lies inside the triangle or on an edge, and smaller only in a corner region.
    """
    corners = _by_axis(triangles)  # (corner, axis, F): every coordinate a contiguous row
    area_vectors = _cross_rows(corners[1] - corners[0], corners[2] - corners[0])
    length = np.sqrt(_dot_rows(area_vectors, area_vectors))
    scale = np.abs(corners).max(axis=(0, 1)) + 1.0
    usable = length > 1e-14 * scale * scale
    planes = np.empty((16, corners.shape[2]))
    normal = planes[0:3]
    np.divide(area_vectors, np.where(usable, length, np.inf), out=normal)  # zero where degenerate
    planes[12] = -_dot_rows(normal, corners[0])
    for k in range(3):
        start = corners[k]
        outward = planes[3 + 3 * k:6 + 3 * k]
        outward[:] = _cross_rows(corners[(k + 1) % 3] - start, normal)
        size = np.sqrt(_dot_rows(outward, outward))
        outward /= np.where(usable & (size > 0.0), size, np.inf)
        planes[13 + k] = -_dot_rows(outward, start)
    return planes, area_vectors


def _by_axis(triangles: FloatArray) -> FloatArray:
    """Triangles (F, 3, 3) rearranged as (corner, axis, F), contiguous."""
    return np.ascontiguousarray(np.asarray(triangles, dtype=np.float64).transpose(1, 2, 0))


def _cross_rows(left: FloatArray, right: FloatArray) -> FloatArray:
    """Cross products of vectors stored as rows of coordinates, (3, M) x (3, M) -> (3, M)."""
    out = np.empty_like(left)
    np.multiply(left[1], right[2], out=out[0])
    out[0] -= left[2] * right[1]
    np.multiply(left[2], right[0], out=out[1])
    out[1] -= left[0] * right[2]
    np.multiply(left[0], right[1], out=out[2])
    out[2] -= left[1] * right[0]
    return out


def _dot_rows(left: FloatArray, right: FloatArray) -> FloatArray:
    """Dot products of vectors stored as rows of coordinates, (3, M) . (3, M) -> (M,)."""
    out = left[0] * right[0]
    out += left[1] * right[1]
    out += left[2] * right[2]
    return out


def within_reach(planes: FloatArray, triangle_of_pair: IntArray, coordinates: FloatArray,
                 reach: FloatArray) -> NDArray[np.bool_]:
    """Which pairs can lie within ``reach``: the plane lower bound of :func:`bounding_planes` is not beyond it.

    ``planes`` (16, F) from :func:`bounding_planes`; per pair the triangle (M,), the point's
    coordinates transposed (3, M) and ``reach`` (M,).  The bound is formed from coordinates
    as given; its rounding error (a few units in the last place of the coordinates) must be
    covered by ``reach``.
    """
    rows = np.take(planes, triangle_of_pair, axis=1)  # (16, M): contiguous rows
    x, y, z = coordinates

    def plane(k: int) -> FloatArray:
        value = rows[3 * k] * x
        value += rows[3 * k + 1] * y
        value += rows[3 * k + 2] * z
        value += rows[12 + k]
        return value

    height = plane(0)
    edge = np.maximum(np.maximum(plane(1), plane(2)), plane(3))
    np.maximum(edge, 0.0, out=edge)
    height *= height
    edge *= edge
    height += edge
    return height <= reach * reach


def twin_edges(faces: IntArray, vertex_count: int) -> IntArray | None:
    """The opposite directed edge of every directed edge, or None unless the mesh is a closed oriented 2-manifold.

    Directed edge ``3 f + k`` runs from corner ``k`` to corner ``k + 1`` of face ``f``.  In a
    closed, consistently oriented mesh every directed edge occurs once and its reverse once
    (in the neighbouring face); the answer is then the index of that reverse edge.  None when
    an edge occurs twice in one direction (inconsistent orientation or more than two faces),
    has no reverse (an open boundary) or joins a vertex to itself.

    Examples
    --------
    >>> tetrahedron = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]])
    >>> twin_edges(tetrahedron, 4).reshape(4, 3).tolist()
    [[9, 6, 3], [2, 8, 10], [1, 11, 4], [0, 5, 7]]
    >>> twin_edges(tetrahedron[:3], 4) is None  # a face missing: open
    True
    """
    start = np.asarray(faces, dtype=np.int64)
    end = np.empty_like(start)
    end[:, :2], end[:, 2] = start[:, 1:], start[:, 0]
    start, end = start.ravel(), end.ravel()
    if len(start) % 2 or np.any(start == end):
        return None
    # one sort by (undirected edge, direction): a closed oriented 2-manifold gives every undirected
    # edge exactly twice, once each way, i.e. sorted keys in pairs (2 e, 2 e + 1)
    key = np.minimum(start, end) * vertex_count
    key += np.maximum(start, end)
    key *= 2
    key += start > end
    order = _sorting_order(key)
    forward, backward = order[0::2], order[1::2]
    first, second = key[forward], key[backward]
    if np.any(first % 2) or not np.array_equal(second, first + 1):
        return None
    twins = np.empty_like(order)
    twins[forward] = backward
    twins[backward] = forward
    return twins


def _sorting_order(key: IntArray) -> IntArray:
    """``np.argsort(key)`` (ties in index order) for int64 keys: a plain sort of key and index packed in one
    integer when both fit in 63 bits (numpy's vectorised sort is several times faster than its argsort)."""
    index_bits = max(1, (len(key) - 1).bit_length())
    if len(key) == 0 or int(key.min()) < 0 or int(key.max()) >= 1 << (63 - index_bits):
        return np.argsort(key)
    packed = key << index_bits
    packed |= np.arange(len(key))
    packed.sort()
    packed &= (1 << index_bits) - 1
    return packed


def corner_angles(triangles: FloatArray) -> FloatArray:
    """Interior angle (rad) at each corner of each triangle, (F, 3); 0 or pi at a corner of a degenerate triangle."""
    corners = _by_axis(triangles)
    # |cross| of the two edges at a corner is twice the area, the same at every corner
    doubled_area = np.sqrt(_dot_rows(*(2 * [_cross_rows(corners[1] - corners[0], corners[2] - corners[0])])))
    angles = np.empty((corners.shape[2], 3))
    for k in range(3):
        at = corners[k]
        angles[:, k] = np.arctan2(doubled_area, _dot_rows(corners[(k + 1) % 3] - at, corners[(k + 2) % 3] - at))
    return angles


@record
class NeighbourLists:
    """Per triangle, the other triangles whose centroids lie nearest to its own centroid.

    ``listed[t]`` holds every other triangle whose centroid is closer than
    ``complete_within[t]`` to the centroid of ``t``, padded with ``F`` (the number of
    triangles: no triangle).  ``centroids`` and ``radius`` (largest centroid-to-corner
    distance, slightly enlarged) describe every triangle, ``listed_radius[t]`` is the largest
    radius in the list of ``t``.  ``centroid_axes`` are the centroid coordinates, one array
    per axis, with an infinite entry ``F`` for the padding; ``tree`` a k-d tree over the centroids.
    ``listed_near[t]`` (3, width) holds the centroids of the list of ``t`` in float32 relative to
    ``origin`` (the centre of their box; at most ``extent`` from it in each coordinate; infinite
    for the padding): the list test reads one contiguous row per point, half the bytes of float64.
    """

    listed: IntArray
    complete_within: FloatArray
    centroids: FloatArray
    radius: FloatArray
    listed_radius: FloatArray
    centroid_axes: tuple[FloatArray, FloatArray, FloatArray]
    tree: Any
    origin: FloatArray
    extent: float
    listed_near: NDArray[np.float32]


@record
class SizeClass:
    """Triangles of similar size: a k-d tree over their centroids and their largest centroid-to-corner distance."""

    members: IntArray
    tree: Any
    reach: float
    member_reach: FloatArray


def size_classes(lists: NeighbourLists) -> tuple[SizeClass, ...]:
    """Triangles grouped by circumscribing radius about the centroid (factor 2 per group), with k-d trees.

    Every point of a triangle lies within its largest centroid-to-corner distance of its
    centroid, so a triangle within ``d`` of a point has its centroid within ``d`` plus
    that radius.  Centroids and radii come from the neighbour lists; a single class (a mesh of
    similar triangles) reuses their tree.
    """
    centroids, radius = lists.centroids, lists.radius
    largest = max(float(radius.max()), 1e-300)
    with np.errstate(divide="ignore"):
        level = np.floor(np.log2(largest / np.maximum(radius, 1e-300)))
    level = np.clip(level, 0, _SIZE_CLASSES - 1).astype(np.int64)
    groups = []
    for value in np.unique(level):
        members = np.flatnonzero(level == value)
        tree = lists.tree if len(members) == len(centroids) else CentroidTree(centroids[members])
        groups.append(SizeClass(members=members, tree=tree, reach=float(radius[members].max()),
                                member_reach=radius[members]))
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
        complete = ~(distance[:, -1] <= radius[rows]) | (asked == count)
        member = np.minimum(neighbour, count - 1)
        close = (distance <= reach[rows, None] + group.member_reach[member]) & complete[:, None]
        pair_row, pair_column = np.nonzero(close)
        points.append(rows[pair_row])
        triangles.append(group.members[member[pair_row, pair_column]])
        rows = rows[~complete]
        asked *= 4
    return np.concatenate(points), np.concatenate(triangles)


def neighbour_lists(triangles: FloatArray, workers: int = -1) -> NeighbourLists:
    """The centroid neighbour lists of every triangle (see :func:`listed_pairs`); ``workers``: threads (-1: all)."""
    corners = _by_axis(triangles)
    count = corners.shape[2]
    centroid_rows = corners[0] + corners[1]
    centroid_rows += corners[2]
    centroid_rows /= 3.0
    squared = np.max([_dot_rows(corner - centroid_rows, corner - centroid_rows) for corner in corners], axis=0)
    radius = np.sqrt(squared) * (1.0 + SLACK)
    centroids = np.ascontiguousarray(centroid_rows.T)
    asked = min(_LISTED_NEIGHBOURS, count)
    bound = _LISTED_REACH * float(radius.max())
    tree = CentroidTree(centroids)
    size = np.maximum(np.maximum(np.abs(centroid_rows[0]), np.abs(centroid_rows[1])), np.abs(centroid_rows[2]))
    padded_radius = np.append(radius, 0.0)
    origin = (centroid_rows.min(axis=1) + centroid_rows.max(axis=1)) / 2.0
    near_axes = [np.append(values - centre, np.inf).astype(np.float32)
                 for values, centre in zip(centroid_rows, origin, strict=True)]
    listed = np.empty((count, asked), dtype=np.int64)
    within = np.empty(count)
    listed_radius = np.empty(count)
    near = np.empty((count, 3, asked), dtype=np.float32)  # (F, 3, width)

    def fill(rows: slice) -> None:  # the lists of the triangles ``rows``, written in place
        distance, found = tree.query(centroids[rows], k=asked, distance_upper_bound=bound, workers=1)
        # a full list is complete only below its last distance; rounding of the distances is allowed for
        last = np.where(np.isfinite(distance[:, -1]), distance[:, -1], bound)
        within[rows] = last * (1.0 - SLACK) - ROUNDING * (1.0 + size[rows])
        found[found == np.arange(rows.start, rows.stop)[:, None]] = count  # not itself (padding: count)
        listed[rows] = found
        radii = np.take(padded_radius, found)
        listed_radius[rows] = np.maximum.reduce([radii[:, k] for k in range(asked)])  # faster than axis=1
        for axis in range(3):
            near[rows, axis] = np.take(near_axes[axis], found)

    threads = max(1, min(workers if workers > 0 else (os.cpu_count() or 1), count // 4096))
    bounds = np.linspace(0, count, threads + 1).astype(np.int64)
    chunks = [slice(int(a), int(b)) for a, b in itertools.pairwise(bounds)]
    if len(chunks) == 1:
        fill(chunks[0])
    else:  # one chunk per thread: the tree's query and numpy's gathers release the GIL
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(len(chunks)) as pool:
            list(pool.map(fill, chunks))
    axes = tuple(np.append(values, np.inf) for values in centroid_rows)
    return NeighbourLists(listed=listed, complete_within=within, centroids=centroids, radius=radius,
                          listed_radius=listed_radius, centroid_axes=axes, tree=tree, origin=origin,
                          extent=float(np.abs(centroids - origin).max()), listed_near=near)


def listed_pairs(lists: NeighbourLists, coordinates: FloatArray, reach: FloatArray, face_index: IntArray,
                 rounding: FloatArray) -> tuple[IntArray, IntArray, IntArray]:
    """Pairs (point, triangle) that could lie within ``reach``, from the candidate's neighbour list.

    ``coordinates`` are the points transposed, (3, N).  A triangle ``t`` within ``reach`` of
    point ``p`` has its centroid within ``reach + r_t`` of ``p`` and so within
    ``reach + r_max + |p - c|`` of the candidate's centroid ``c`` (triangle inequality).
    Where that is below the list's completeness radius, the list holds every such triangle
    and no tree search is needed.  Returns the pairs (the candidate itself excluded) and the
    rows of the points the lists cannot answer (left to the k-d trees).
    """
    candidate_axes = [np.take(axis, face_index) - values for axis, values in zip(lists.centroid_axes, coordinates,
                                                                                   strict=True)]
    to_candidate = np.sqrt(sum(offset * offset for offset in candidate_axes))
    needed = (reach + float(lists.radius.max()) + to_candidate) * (1.0 + SLACK) + rounding
    local = needed < np.take(lists.complete_within, face_index)
    # the test runs in float32 relative to the centroids' box centre; ``allowance`` covers its rounding:
    # each difference is off by at most 2 u (extent + |p - origin|) (u = 2^-24), the sum of squares
    # by 4 u relative; 8 u (extent + |p - origin|) and a relative 1e-6 cover both with room to spare
    relative = [values - centre for values, centre in zip(coordinates, lists.origin, strict=True)]
    allowance = 5e-7 * (lists.extent + np.max(np.abs(relative), axis=0))
    near_points = [np.asarray(values, dtype=np.float32) for values in relative]
    width = lists.listed.shape[1]
    points, triangles = [], []
    # blocks of points and one coordinate at a time: (points, neighbours) temporaries stay small.
    # np.take, not fancy indexing: it copies whole rows and is many times faster here
    for start in range(0, coordinates.shape[1], _LISTED_POINTS_PER_BLOCK):
        rows = start + np.flatnonzero(local[start:start + _LISTED_POINTS_PER_BLOCK])
        candidate = np.take(face_index, rows)
        near = np.take(lists.listed_near, candidate, axis=0)  # (points, 3, width)
        limit = (np.take(reach, rows) + np.take(lists.listed_radius, candidate) + np.take(allowance, rows))
        limit = (limit * (1.0 + 1e-6)).astype(np.float32)
        squared = near[:, 0] - np.take(near_points[0], rows)[:, None]
        squared *= squared
        for axis in (1, 2):
            offset = near[:, axis] - np.take(near_points[axis], rows)[:, None]
            offset *= offset
            squared += offset
        limit *= limit
        hit = np.flatnonzero(squared <= limit[:, None])  # the padding is infinitely far
        row_of_hit = hit // width
        points.append(np.take(rows, row_of_hit))
        triangles.append(np.take(lists.listed, np.take(candidate, row_of_hit) * width + hit % width))
    return np.concatenate(points), np.concatenate(triangles), np.flatnonzero(~local)


def enclosed_volume(triangles: FloatArray, area_vectors: FloatArray | None = None) -> float:
    """Signed volume (mm^3) enclosed by closed triangles (divergence theorem), about the centre of their box.

    ``area_vectors``: the (3, F) ``(b - a) x (c - a)`` of :func:`bounding_planes`, if at hand;
    ``(a - o) . ((b - a) x (c - a))`` equals ``(a - o) . ((b - o) x (c - o))``, six times the
    volume of the tetrahedron of the face and the centre ``o``.
    """
    corners = _by_axis(triangles)
    if area_vectors is None:
        area_vectors = _cross_rows(corners[1] - corners[0], corners[2] - corners[0])
    centre = (corners.min(axis=(0, 2)) + corners.max(axis=(0, 2))) / 2.0
    return float(np.sum(_dot_rows(corners[0] - centre[:, None], area_vectors))) / 6.0


def edge_normals(mesh: Any, faces: IntArray, face_normals: FloatArray, twins: IntArray | None) -> FloatArray:
    """Edge pseudo-normals (F, 3, 3): edge ``k`` of each face (v0v1, v1v2, v2v0), unnormalised.

    An edge's pseudo-normal is the sum of the normals of the faces sharing it: the face and
    its twin across the edge for a closed oriented mesh (``twins``), else every face trimesh
    finds on the edge (an open surface's boundary edges have one).
    """
    count = len(faces)
    if twins is not None:
        return face_normals[:, None, :] + np.take(face_normals, twins // 3, axis=0).reshape(count, 3, 3)
    unique_edges = np.asarray(mesh.faces_unique_edges, dtype=np.int64)  # (F, 3): v0v1, v1v2, v2v0
    edge_sum = np.zeros((int(unique_edges.max()) + 1, 3))
    np.add.at(edge_sum, unique_edges.ravel(), np.repeat(face_normals, 3, axis=0))
    return edge_sum[unique_edges]


def corner_normals(faces: IntArray, triangles: FloatArray, face_normals: FloatArray) -> FloatArray:
    """Angle-weighted vertex pseudo-normals (F, 3, 3) at each corner of each face, unnormalised."""
    weighted = face_normals[:, None, :] * corner_angles(triangles)[:, :, None]
    vertex_count = int(faces.max()) + 1
    vertex_sum = np.column_stack([np.bincount(faces.ravel(), weights=weighted[:, :, axis].ravel(),
                                              minlength=vertex_count) for axis in range(3)])
    return np.take(vertex_sum, faces, axis=0)
