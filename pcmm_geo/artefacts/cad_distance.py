"""Exact signed distances of points from a triangle mesh (double precision, any mesh size).

The nearest surface point of every query point is found by an exact branch-and-bound search
(:class:`SurfaceIndex`, built once per mesh):

1. **first guesses** -- every triangle carries a few surface samples (more along long thin
   ones); the triangles of a point's four nearest samples (scipy k-d tree), then their
   edge neighbours while these are nearer (a short walk over the mesh), give each point an
   exact distance to some triangle: a search radius that holds the true nearest point;
2. **search** -- a bounding-volume hierarchy (triangles ordered along a Morton curve of
   their centroids, neighbours paired level by level up to one root, each node with the
   tight axis-aligned box of its triangles) is searched level by level for all points at
   once, dropping every node whose box lies beyond the point's radius;
3. **exact distances** -- the point-triangle pairs that remain are evaluated with
   ``trimesh.triangles.closest_point`` and the nearest kept.

Nothing is approximated: only triangles that cannot come closer are dropped (with a
relative slack of 1e-9 for rounding), so the result is that of a brute-force search over
all triangles, while the work grows with the number of triangles near each point rather
than with the size of the mesh.  No spatial index beyond scipy's is needed (trimesh's own
``proximity`` queries need ``rtree``).

The sign follows the angle-weighted pseudo-normal of the nearest feature (face, edge or
vertex; Baerentzen and Aanaes, IEEE TVCG 11 (2005) 243): positive on the side the face
normals point to, i.e. outside the material for a closed mesh with outward normals.  The
sign means "outside the material" only for a closed mesh, which is therefore required by
default (``require_closed``).

Examples
--------
>>> import numpy as np
>>> from pcmm_geo.io.meshes import box_mesh
>>> result = surface_distances([[0.0, 0.0, 4.51], [0.0, 0.0, 4.0], [51.0, 18.5, 0.0]], box_mesh(100, 35, 9))
>>> np.round(result.signed_distance, 12).tolist()
[0.01, -0.5, 1.414213562373]
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.fit._kernels._core import as_points

if TYPE_CHECKING:
    import trimesh

__all__ = ["SurfaceDistances", "SurfaceIndex", "check_closed_mesh", "surface_distances"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: barycentric coordinate below which a nearest point counts as lying on an edge or vertex
_ON_BOUNDARY = 1e-9
#: distances below this fraction of the coordinates' size are rounding noise
_ROUNDING = 1e-12
#: relative slack on the pruning distance (rounding of box and triangle distances)
_SLACK = 1e-9
#: point-triangle pairs evaluated at once (bounds the memory to a few tens of MB)
_PAIRS_PER_BLOCK = 400_000
#: point-node pairs of one search front before it is split by points
_FRONT_LIMIT = 1_000_000
#: bits per coordinate of the Morton code
_MORTON_BITS = 21
#: triangles of the nearest surface samples evaluated first (they set the first search radius)
_FIRST_GUESSES = 4
#: steps of the walk from the first guess to edge-neighbouring triangles that are nearer
_WALK_STEPS = 4
#: surface samples per triangle on average at most (long triangles get more than short ones)
_SAMPLES_PER_TRIANGLE = 4


@dataclass(frozen=True)
class SurfaceDistances:
    """Nearest surface points and signed distances of points from a mesh.

    Attributes
    ----------
    closest : ndarray, shape (N, 3)
        Nearest point on the mesh surface (mm).
    signed_distance : ndarray, shape (N,)
        Distance to ``closest`` (mm), positive on the side the face normals point to.
    face_index : ndarray, shape (N,)
        Index of the triangle holding ``closest``.
    direction : ndarray, shape (N, 3)
        Unit gradient of the signed distance: the face normal when ``closest`` lies inside a
        face, else ``(point - closest) / signed_distance`` (the feature's pseudo-normal for a
        point on the surface).  A small move ``dp`` of a point changes its signed distance
        by ``direction . dp``.
    """

    closest: FloatArray
    signed_distance: FloatArray
    face_index: IntArray
    direction: FloatArray


def check_closed_mesh(mesh: trimesh.Trimesh, *, what: str = "mesh") -> None:
    """Raise unless ``mesh`` encloses a volume: triangles, watertight, consistently wound, outward normals.

    Signed deviations ("positive outside the material") need such a mesh; an open surface
    or one with flipped faces gives signs that mean nothing.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        The nominal surface.
    what : str
        Name in the error message (e.g. the file it was read from).

    Raises
    ------
    InvalidInputError
        No triangles, open edges (not watertight), inconsistent face orientation, or
        normals pointing inwards (negative enclosed volume).

    Examples
    --------
    >>> import trimesh
    >>> from pcmm_geo.io.meshes import box_mesh
    >>> check_closed_mesh(box_mesh(1, 1, 1))
    >>> open_box = box_mesh(1, 1, 1)
    >>> open_box.update_faces(np.arange(11))
    >>> try:
    ...     check_closed_mesh(open_box)
    ... except InvalidInputError as exc:
    ...     print(exc.got)
    3 open edges (a boundary: the surface is not watertight)
    """
    faces = np.asarray(mesh.faces)
    if faces.ndim != 2 or len(faces) == 0:
        raise InvalidInputError(what, "a mesh with at least one triangle", "no triangles")
    expected = "a closed mesh (watertight, consistently oriented, outward normals) for signed distances"
    if not mesh.is_watertight:
        edges = np.sort(np.asarray(mesh.edges, dtype=np.int64), axis=1)
        _, counts = np.unique(edges, axis=0, return_counts=True)
        open_edges = int(np.count_nonzero(counts == 1))
        detail = (f"{open_edges} open edges (a boundary: the surface is not watertight)" if open_edges
                  else f"{int(np.count_nonzero(counts > 2))} edges shared by more than two triangles")
        raise InvalidInputError(what, expected, detail)
    if not mesh.is_winding_consistent:
        raise InvalidInputError(what, expected, "faces with inconsistent orientation (some normals flipped)")
    volume = float(mesh.volume)
    if not volume > 0.0:
        raise InvalidInputError(what, expected, f"inward normals (enclosed volume {volume:.6g} mm^3)")


def surface_distances(points: ArrayLike, mesh: trimesh.Trimesh, *, require_closed: bool = True) -> SurfaceDistances:
    """Signed distances (mm) of ``points`` from the surface of ``mesh``, exact in double precision.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Points in the mesh frame (mm).
    mesh : trimesh.Trimesh
        Triangle mesh with outward face normals.
    require_closed : bool
        Refuse a mesh that does not enclose a volume (default).  With False an open but
        consistently oriented surface is accepted; the sign then gives the side its face
        normals point to.

    Returns
    -------
    SurfaceDistances

    Raises
    ------
    InvalidInputError
        Points of the wrong shape or not finite; a mesh without triangles; with
        ``require_closed`` a mesh that is not closed (see :func:`check_closed_mesh`).
    TooFewPointsError
        No points.

    Examples
    --------
    >>> from pcmm_geo.io.meshes import box_mesh
    >>> near = surface_distances([[50.002, 0.0, 0.0]], box_mesh(100, 35, 9))
    >>> round(float(near.signed_distance[0]), 12), near.closest[0].tolist()
    (0.002, [50.0, 0.0, 0.0])
    """
    query = as_points(points, element="mesh distance", min_points=1)
    return SurfaceIndex.build(mesh, require_closed=require_closed).distances(query)


@dataclass(frozen=True, eq=False)
class SurfaceIndex:
    """A mesh prepared for repeated exact distance queries (build once with :meth:`build`).

    Attributes
    ----------
    triangles : ndarray, shape (F, 3, 3)
        Triangle corners (mm).
    face_normals : ndarray, shape (F, 3)
        Unit face normals.
    edge_normals : ndarray, shape (F, 3, 3)
        Pseudo-normal (sum of the two face normals) of edge ``k`` of each face, the edge
        opposite corner ``(k + 2) % 3`` (edges v0v1, v1v2, v2v0).
    corner_normals : ndarray, shape (F, 3, 3)
        Angle-weighted pseudo-normal of the vertex at each corner.
    neighbours : ndarray, shape (F, 3)
        The triangles sharing an edge with each triangle (itself where an edge has none).
    order : ndarray, shape (F,)
        Triangle numbers along the Morton curve: leaf ``k`` of the hierarchy is ``order[k]``.
    lower, upper : tuple of ndarray
        Box corners of the nodes, per level (``[0]`` the leaves, one triangle each; ``[-1]``
        the root); node ``i`` of a level has children ``2i`` and ``2i + 1`` on the level below.
    sample_tree : scipy.spatial.cKDTree
        Points spread over every triangle (more along long ones), for the first guesses.
    sample_triangle : ndarray, shape (S,)
        Triangle of each sample.
    """

    triangles: FloatArray
    face_normals: FloatArray
    edge_normals: FloatArray
    corner_normals: FloatArray
    neighbours: IntArray
    order: IntArray
    lower: tuple[FloatArray, ...]
    upper: tuple[FloatArray, ...]
    sample_tree: Any
    sample_triangle: IntArray

    @classmethod
    def build(cls, mesh: trimesh.Trimesh, *, require_closed: bool = True) -> SurfaceIndex:
        """Index ``mesh`` (see :func:`surface_distances` for ``require_closed``).

        Raises
        ------
        InvalidInputError
            A mesh without triangles, with non-finite vertices or (``require_closed``) not closed.

        Examples
        --------
        >>> from pcmm_geo.io.meshes import box_mesh
        >>> index = SurfaceIndex.build(box_mesh(100, 35, 9))
        >>> [len(level) for level in index.lower]
        [12, 6, 3, 2, 1]
        """
        faces = np.asarray(mesh.faces, dtype=np.int64)
        if faces.ndim != 2 or len(faces) == 0:
            raise InvalidInputError("mesh", "a mesh with at least one triangle", "no triangles")
        vertices = np.asarray(mesh.vertices, dtype=float)
        if not np.all(np.isfinite(vertices)):
            raise InvalidInputError("mesh", "finite vertex coordinates", "NaN or inf")
        if require_closed:
            check_closed_mesh(mesh)
        from scipy.spatial import cKDTree

        triangles = vertices[faces]
        face_normals, edge_normals, corner_normals = _feature_normals(mesh, triangles)
        order, lower, upper = _hierarchy(triangles)
        samples, sample_triangle = _surface_samples(triangles)
        return cls(triangles=triangles, face_normals=face_normals, edge_normals=edge_normals,
                   corner_normals=corner_normals, neighbours=_edge_neighbours(mesh), order=order, lower=lower,
                   upper=upper, sample_tree=cKDTree(samples), sample_triangle=sample_triangle)

    def distances(self, points: ArrayLike) -> SurfaceDistances:
        """Exact signed distances of ``points`` (N, 3) from the indexed surface (see :func:`surface_distances`).

        Raises
        ------
        InvalidInputError
            Points of the wrong shape or not finite.
        TooFewPointsError
            No points.
        """
        query = as_points(points, element="mesh distance", min_points=1)
        closest, face_index = self._nearest(query)
        offset = query - closest
        distance = np.linalg.norm(offset, axis=1)
        pseudo_normal, inside_face = self._pseudo_normals(closest, face_index)
        sign = np.where(np.einsum("ij,ij->i", offset, pseudo_normal) < 0.0, -1.0, 1.0)
        signed = sign * distance
        # nearest point inside a face: the gradient is that face's normal, exactly; at an edge or
        # a vertex it points from the nearest point, unless the distance is down at rounding level
        rounding = _ROUNDING * (1.0 + np.abs(query).max(axis=1))
        from_feature = ~inside_face & (distance > rounding)
        direction = pseudo_normal.copy()
        direction[from_feature] = offset[from_feature] / signed[from_feature, None]
        return SurfaceDistances(closest=closest, signed_distance=signed, face_index=face_index, direction=direction)

    # ------------------------------------------------------------------ search

    def _nearest(self, query: FloatArray) -> tuple[FloatArray, IntArray]:
        """Nearest surface point of every query point and the triangle holding it (exact)."""
        count = len(query)
        best = np.full(count, np.inf)  # squared distance of the nearest triangle evaluated so far
        closest = np.empty_like(query)
        face_index = np.zeros(count, dtype=np.int64)
        everyone = np.arange(count)
        # first guesses: the triangles of the nearest surface samples, then a walk to better neighbours
        _, nearest = self.sample_tree.query(query, k=min(_FIRST_GUESSES, len(self.sample_triangle)))
        nearest = np.asarray(nearest).reshape(count, -1)
        _keep_nearest(query, self.triangles, np.repeat(everyone, nearest.shape[1]),
                      self.sample_triangle[nearest.ravel()], best, closest, face_index)
        moving = everyone
        for _ in range(_WALK_STEPS):
            before = face_index[moving]
            _keep_nearest(query, self.triangles, np.repeat(moving, 3), self.neighbours[before].ravel(),
                          best, closest, face_index)
            moving = moving[face_index[moving] != before]
            if moving.size == 0:
                break
        # exhaustive search, pruned by the best distance so far; a front too large is split by points
        stack = [(len(self.lower) - 1, everyone, np.zeros(count, dtype=np.int64))]
        while stack:
            level, pair_point, pair_node = stack.pop()
            if level == 0:
                for chunk in range(0, len(pair_point), _PAIRS_PER_BLOCK):
                    rows = slice(chunk, chunk + _PAIRS_PER_BLOCK)
                    _keep_nearest(query, self.triangles, pair_point[rows], self.order[pair_node[rows]],
                                  best, closest, face_index)
                continue
            pair_point, pair_node = self._expand(query, level - 1, pair_point, pair_node, best)
            if len(pair_point) > _FRONT_LIMIT and pair_point[0] != pair_point[-1]:
                middle = int(np.searchsorted(pair_point, pair_point[len(pair_point) // 2]))
                middle = middle or int(np.searchsorted(pair_point, pair_point[0], side="right"))
                stack.append((level - 1, pair_point[middle:], pair_node[middle:]))
                stack.append((level - 1, pair_point[:middle], pair_node[:middle]))
            elif len(pair_point):
                stack.append((level - 1, pair_point, pair_node))
        return closest, face_index

    def _expand(
        self, query: FloatArray, level: int, pair_point: IntArray, pair_node: IntArray, best: FloatArray
    ) -> tuple[IntArray, IntArray]:
        """Children on ``level`` of the point-node pairs whose box is not farther than the best triangle so far.

        The pairs stay sorted by point.
        """
        child = (2 * pair_node[:, None] + np.array([0, 1])).ravel()
        point = np.repeat(pair_point, 2)
        exists = child < len(self.lower[level])
        point, child = point[exists], child[exists]
        radius = np.sqrt(best[point]) * (1.0 + _SLACK) + _SLACK
        keep = _box_distance_squared(query[point], self.lower[level][child], self.upper[level][child]) <= radius**2
        return point[keep], child[keep]

    # ------------------------------------------------------------------ sign

    def _pseudo_normals(self, closest: FloatArray, face_index: IntArray) -> tuple[FloatArray, NDArray[np.bool_]]:
        """Pseudo-normals of the features holding the nearest points, and which of these lie inside a face."""
        import trimesh

        barycentric = trimesh.triangles.points_to_barycentric(self.triangles[face_index], closest)
        on_zero = barycentric < _ON_BOUNDARY
        zero_count = on_zero.sum(axis=1)
        normals = self.face_normals[face_index].copy()
        at_edge = np.flatnonzero(zero_count == 1)
        # the edge opposite corner k is the face's edge number (k + 1) % 3: (v0v1, v1v2, v2v0)
        edge = (np.argmax(on_zero[at_edge], axis=1) + 1) % 3
        normals[at_edge] = self.edge_normals[face_index[at_edge], edge]
        at_vertex = np.flatnonzero(zero_count >= 2)
        corner = np.argmax(barycentric[at_vertex], axis=1)
        normals[at_vertex] = self.corner_normals[face_index[at_vertex], corner]
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        return normals / np.where(length > 0.0, length, 1.0), zero_count == 0


def _feature_normals(mesh: trimesh.Trimesh, triangles: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Face normals, edge pseudo-normals (F, 3, 3) and angle-weighted vertex pseudo-normals (F, 3, 3)."""
    import trimesh

    faces = np.asarray(mesh.faces, dtype=np.int64)
    face_normals = np.asarray(mesh.face_normals, dtype=float)
    unique_edges = np.asarray(mesh.faces_unique_edges, dtype=np.int64)  # (F, 3): v0v1, v1v2, v2v0
    edge_sum = np.zeros((int(unique_edges.max()) + 1, 3))
    np.add.at(edge_sum, unique_edges.ravel(), np.repeat(face_normals, 3, axis=0))
    corner_angles = trimesh.triangles.angles(triangles)
    vertex_sum = np.zeros((len(mesh.vertices), 3))
    np.add.at(vertex_sum, faces.ravel(), (face_normals[:, None, :] * corner_angles[:, :, None]).reshape(-1, 3))
    return face_normals, edge_sum[unique_edges], vertex_sum[faces]


def _edge_neighbours(mesh: trimesh.Trimesh) -> IntArray:
    """(F, 3) triangles sharing an edge with each triangle, padded with the triangle itself."""
    count = len(mesh.faces)
    pairs = np.asarray(mesh.face_adjacency, dtype=np.int64).reshape(-1, 2)
    both = np.vstack([pairs, pairs[:, ::-1]])
    both = both[np.argsort(both[:, 0], kind="stable")]
    rank = np.arange(len(both)) - np.searchsorted(both[:, 0], both[:, 0])
    neighbours = np.repeat(np.arange(count, dtype=np.int64)[:, None], 3, axis=1)
    first_three = rank < 3
    neighbours[both[first_three, 0], rank[first_three]] = both[first_three, 1]
    return neighbours


def _hierarchy(triangles: FloatArray) -> tuple[IntArray, tuple[FloatArray, ...], tuple[FloatArray, ...]]:
    """Leaf order along the Morton curve of the centroids, and the node boxes level by level."""
    centroids = triangles.mean(axis=1)
    origin = centroids.min(axis=0)
    extent = max(float(np.ptp(centroids, axis=0).max()), 1e-300)
    cells = np.minimum((centroids - origin) / extent * 2**_MORTON_BITS, 2**_MORTON_BITS - 1).astype(np.uint64)
    code = _spread_bits(cells[:, 0]) | (_spread_bits(cells[:, 1]) << np.uint64(1)) | (
        _spread_bits(cells[:, 2]) << np.uint64(2))
    order = np.argsort(code, kind="stable").astype(np.int64)
    lower = [triangles.min(axis=1)[order]]
    upper = [triangles.max(axis=1)[order]]
    while len(lower[-1]) > 1:
        pairs = np.arange(0, len(lower[-1]), 2)
        lower.append(np.minimum.reduceat(lower[-1], pairs))
        upper.append(np.maximum.reduceat(upper[-1], pairs))
    return order, tuple(lower), tuple(upper)


def _surface_samples(triangles: FloatArray) -> tuple[FloatArray, IntArray]:
    """Centres of the ``m x m`` congruent sub-triangles of every triangle, ``m`` growing with its longest edge.

    ``m`` is the longest edge over a common spacing, the finest that gives at most
    ``_SAMPLES_PER_TRIANGLE`` samples per triangle on average (``m`` from 1 to 64): long
    triangles are sampled along their length, so the nearest samples find a triangle near a
    point's foot.
    """
    longest = np.linalg.norm(triangles - np.roll(triangles, 1, axis=1), axis=2).max(axis=1)
    budget = _SAMPLES_PER_TRIANGLE * len(triangles)

    def divisions_for(spacing: float) -> IntArray:
        return np.clip(np.ceil(longest / spacing), 1, 64).astype(np.int64)

    # the finest spacing within the budget (bisection in log scale; the longest edge gives one each)
    coarse, fine = max(float(longest.max()), 1e-300), max(float(longest.max()), 1e-300) / 64.0
    for _ in range(40):
        middle = float(np.sqrt(coarse * fine))
        if int(np.sum(divisions_for(middle) ** 2)) <= budget:
            coarse = middle
        else:
            fine = middle
    divisions = divisions_for(coarse)
    points, owners = [], []
    for m in np.unique(divisions):
        members = np.flatnonzero(divisions == m)
        i, j = np.meshgrid(np.arange(m), np.arange(m), indexing="ij")
        up = np.c_[i.ravel() + 1 / 3, j.ravel() + 1 / 3][(i + j).ravel() <= m - 1]
        down = np.c_[i.ravel() + 2 / 3, j.ravel() + 2 / 3][(i + j).ravel() <= m - 2]
        u, v = np.vstack([up, down]).T / m
        weights = np.c_[1.0 - u - v, u, v]  # (m*m, 3) barycentric
        points.append(np.einsum("sk,tkj->tsj", weights, triangles[members]).reshape(-1, 3))
        owners.append(np.repeat(members, len(weights)))
    return np.vstack(points), np.concatenate(owners)


def _spread_bits(value: NDArray[np.uint64]) -> NDArray[np.uint64]:
    """Insert two zero bits after each of the lowest 21 bits (Morton interleaving)."""
    spread = value & np.uint64(0x1FFFFF)
    for shift, mask in ((32, 0x1F00000000FFFF), (16, 0x1F0000FF0000FF), (8, 0x100F00F00F00F00F),
                        (4, 0x10C30C30C30C30C3), (2, 0x1249249249249249)):
        spread = (spread | (spread << np.uint64(shift))) & np.uint64(mask)
    return spread


def _box_distance_squared(points: FloatArray, lower: FloatArray, upper: FloatArray) -> FloatArray:
    """Squared distance from each point to its axis-aligned box (0 inside): no triangle in it is nearer."""
    gap = np.maximum(np.maximum(lower - points, points - upper), 0.0)
    return np.einsum("ij,ij->i", gap, gap)


def _keep_nearest(
    query: FloatArray,
    triangles: FloatArray,
    point_of_pair: IntArray,
    triangle_of_pair: IntArray,
    best_squared: FloatArray,
    closest: FloatArray,
    face_index: IntArray,
) -> FloatArray:
    """Update the running nearest points (in place) with a chunk of point-triangle pairs; their squared distances."""
    import trimesh

    if len(point_of_pair) == 0:
        return np.empty(0)
    on_triangle = trimesh.triangles.closest_point(triangles[triangle_of_pair], query[point_of_pair])
    difference = on_triangle - query[point_of_pair]
    squared = np.einsum("ij,ij->i", difference, difference)
    order = np.lexsort((squared, point_of_pair))
    first = order[np.r_[True, point_of_pair[order][1:] != point_of_pair[order][:-1]]]
    better = squared[first] < best_squared[point_of_pair[first]]
    winners = first[better]
    rows = point_of_pair[winners]
    best_squared[rows] = squared[winners]
    closest[rows] = on_triangle[winners]
    face_index[rows] = triangle_of_pair[winners]
    return squared
