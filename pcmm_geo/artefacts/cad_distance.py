"""Exact signed distances of points from a triangle mesh (double precision, any mesh size).

The nearest surface point of every query point is found in three steps
(:class:`SurfaceIndex`, built once per mesh and reused):

1. **candidate** -- the triangle whose centroid is nearest to the point (a k-d tree over the
   centroids, ``_triangle.CentroidTree``: pykdtree where installed, else
   scipy's; :meth:`SurfaceIndex.nearby`); for a point farther than three triangle radii
   from every centroid, the triangle open3d's float32 ray-casting scene (Embree,
   ``compute_closest_points``) finds nearest, which keeps the search of step 3 tight;
2. **upper bound** -- the distance ``d0`` from the point to that triangle, in double precision.
   It is the distance to an actual triangle, so the true nearest triangle is never farther;
3. **proof or correction** -- every triangle that could come within ``d0`` (with a relative
   slack of 1e-9 for rounding) is evaluated in double precision and the nearest is kept.
   Such a triangle has its centroid within ``d0`` plus its own centroid-to-corner radius of
   the point.  Most points are answered from a list, made once per triangle, of the
   triangles with the nearest centroids: when ``d0`` plus the largest radius plus the
   point's distance from the candidate's centroid stays below the radius up to which that
   list is complete, the list holds every such triangle (triangle inequality), so no search
   is needed.  The other points search k-d trees over the centroids (one per size
   class).  A lower bound from the triangle's plane and its three edge planes (exact except
   in corner regions) discards nearly all pairs before the exact evaluation.

The points are taken in the order of a coarse grid over their box (the answers are put back in
the caller's order): neighbouring points share candidates and list entries, which keeps the
trees' and the gathers' memory reads in cache.

Correctness relies on no float32 bound: step 3 only uses ``d0``, the double precision distance
to a real triangle.  The result is that of a brute-force double-precision search.

The sign follows the angle-weighted pseudo-normal of the nearest feature (face, edge or
vertex; Baerentzen and Aanaes, IEEE TVCG 11 (2005) 243): positive on the side the face
normals point to, i.e. outside the material for a closed mesh with outward normals.  The
sign means "outside the material" only for a closed mesh, which is therefore required by
default (``require_closed``).

A ``dask.array.Array`` of points is evaluated block by block (lazily); the index is sent
to the workers without its open3d scene, which each worker rebuilds once.

Examples
--------
>>> import numpy as np
>>> from pcmm_geo.io.meshes import box_mesh
>>> result = surface_distances([[0.0, 0.0, 4.51], [0.0, 0.0, 4.0], [51.0, 18.5, 0.0]], box_mesh(100, 35, 9))
>>> np.round(result.signed_distance, 12).tolist()
[0.01, -0.5, 1.414213562373]
"""

from __future__ import annotations

import itertools
import numbers
import os
import threading
from dataclasses import field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._optional import require
from pcmm_geo._records import record
from pcmm_geo.artefacts._triangle import (
    ROUNDING,
    SLACK,
    NeighbourLists,
    SizeClass,
    bounding_planes,
    closest_on_triangles,
    corner_normals,
    edge_normals,
    enclosed_volume,
    listed_pairs,
    neighbour_lists,
    pairs_within,
    size_classes,
    twin_edges,
    within_reach,
)
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.fit import as_points
from pcmm_geo.fit.scale import is_dask_array

if TYPE_CHECKING:
    import trimesh

__all__ = ["SurfaceDistances", "SurfaceIndex", "check_closed_mesh", "surface_distances"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: barycentric coordinate below which a nearest point counts as lying on an edge or vertex
_ON_BOUNDARY = 1e-9
#: points handled at once (bounds the memory of the candidate pairs)
_POINTS_PER_BLOCK = 65_536
#: a point farther than this many largest triangle radii from every centroid takes open3d's candidate
_NEARBY_REACH = 3.0
#: grid cells per axis of the spatial order of the points (32^3 keys fit in 16 bits)
_GRID_CELLS = 32
#: from this many points on, the query is taken in spatial order
_ORDERED_FROM = 4096
#: point-triangle pairs evaluated at once
_PAIRS_PER_BLOCK = 1_000_000
#: held while a part of an index is built on first use
_BUILDING = threading.Lock()
@record
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

    For a dask array of points every field is a lazy dask array (computed block by block).
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
    vertices = np.asarray(mesh.vertices, dtype=float)
    twins = twin_edges(faces, len(vertices))
    _check_closed(mesh, twins, enclosed_volume(vertices[faces]) if twins is not None else 0.0, what)


def _check_closed(mesh: trimesh.Trimesh, twins: IntArray | None, volume: float, what: str) -> None:
    """:func:`check_closed_mesh` given the twin edges (None: not a closed oriented manifold) and the enclosed volume.

    A closed, consistently oriented mesh with a positive enclosed volume passes at once; any
    other goes through trimesh's checks, which name what is wrong.
    """
    if twins is not None and volume > 0.0:
        return
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


def surface_distances(points: ArrayLike, mesh: trimesh.Trimesh, *, require_closed: bool = True,
                      workers: int | None = None) -> SurfaceDistances:
    """Signed distances (mm) of ``points`` from the surface of ``mesh``, exact in double precision.

    Parameters
    ----------
    points : array_like or dask.array.Array, shape (N, 3)
        Points in the mesh frame (mm).  A dask array is evaluated block by block: the
        fields of the result are then lazy dask arrays.
    mesh : trimesh.Trimesh
        Triangle mesh with outward face normals.
    require_closed : bool
        Refuse a mesh that does not enclose a volume (default).  With False an open but
        consistently oriented surface is accepted; the sign then gives the side its face
        normals point to.
    workers : int, optional
        Threads for the search (open3d's and the exact one); default every core this
        process may use.

    Returns
    -------
    SurfaceDistances

    Raises
    ------
    InvalidInputError
        Points of the wrong shape or not finite; a mesh without triangles; with
        ``require_closed`` a mesh that is not closed (see :func:`check_closed_mesh`);
        ``workers`` not a positive integer.
    TooFewPointsError
        No points.

    Examples
    --------
    >>> from pcmm_geo.io.meshes import box_mesh
    >>> near = surface_distances([[50.002, 0.0, 0.0]], box_mesh(100, 35, 9))
    >>> round(float(near.signed_distance[0]), 12), (np.round(near.closest[0], 12) + 0.0).tolist()
    (0.002, [50.0, 0.0, 0.0])
    """
    threads = _thread_count(workers)
    if threads == 1 or is_dask_array(points):
        index = SurfaceIndex.build(mesh, require_closed=require_closed, workers=workers)
        return index.distances(points, workers=workers)
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(1) as pool:  # the points are checked and ordered while the index is built
        ordered = pool.submit(_ordered_points, points)
        index = SurfaceIndex.build(mesh, require_closed=require_closed, workers=workers)
        query, order = ordered.result()
    return index._ordered_distances(query, order, threads)


@record
class SurfaceIndex:
    """A mesh prepared for repeated exact distance queries (build once with :meth:`SurfaceIndex.build`).

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
        Angle-weighted pseudo-normal of the vertex at each corner (made on first use: only
        points nearest to a vertex need it).
    planes : ndarray, shape (16, F)
        Each triangle's plane and edge planes, for a lower bound of the distance
        (:func:`~pcmm_geo.artefacts._triangle.bounding_planes`).
    neighbours : NeighbourLists
        For each triangle, the triangles with centroids nearest to its own (the local proof).
    scene_origin : ndarray, shape (3,)
        Centre of the mesh's box: the open3d scene holds ``vertices - scene_origin`` in float32.
    vertices, faces : ndarray
        The mesh, from which the open3d scene is built (on first use, once per process).
    """

    triangles: FloatArray
    face_normals: FloatArray
    edge_normals: FloatArray
    planes: FloatArray
    neighbours: NeighbourLists
    scene_origin: FloatArray
    vertices: FloatArray
    faces: IntArray
    _cache: dict[str, Any] = field(default_factory=dict, repr=False)

    @classmethod
    def build(cls, mesh: trimesh.Trimesh, *, require_closed: bool = True, workers: int | None = None) -> SurfaceIndex:
        """Index ``mesh`` (see :func:`surface_distances` for ``require_closed`` and ``workers``).

        Raises
        ------
        InvalidInputError
            A mesh without triangles, with non-finite vertices or (``require_closed``) not closed;
            ``workers`` not a positive integer.

        Examples
        --------
        >>> from pcmm_geo.io.meshes import box_mesh
        >>> index = SurfaceIndex.build(box_mesh(100, 35, 9))
        >>> len(index.triangles), [len(group.members) for group in index.size_classes]  # long faces, end faces
        (12, [8, 4])
        """
        threads = _thread_count(workers)
        faces = np.asarray(mesh.faces, dtype=np.int64)
        if faces.ndim != 2 or len(faces) == 0:
            raise InvalidInputError("mesh", "a mesh with at least one triangle", "no triangles")
        vertices = np.asarray(mesh.vertices, dtype=float)
        if not np.all(np.isfinite(vertices)):
            raise InvalidInputError("mesh", "finite vertex coordinates", "NaN or inf")
        triangles = np.take(vertices, faces, axis=0)
        if threads == 1:
            neighbours = neighbour_lists(triangles, 1)
            return cls._assemble(mesh, vertices, faces, triangles, neighbours, require_closed)
        from concurrent.futures import ThreadPoolExecutor

        # the neighbour lists (mostly the k-d tree's threaded query) are made while this thread checks the
        # mesh and makes its planes and normals: numpy and the tree release the GIL in their loops
        with ThreadPoolExecutor(1) as pool:
            lists = pool.submit(neighbour_lists, triangles, threads)
            try:
                return cls._assemble(mesh, vertices, faces, triangles, lists, require_closed)
            finally:
                lists.cancel()

    @classmethod
    def _assemble(cls, mesh: trimesh.Trimesh, vertices: FloatArray, faces: IntArray, triangles: FloatArray,
                  neighbours: Any, require_closed: bool) -> SurfaceIndex:
        """The index of checked arrays; ``neighbours``: the lists, or a future of them (made meanwhile)."""
        twins = twin_edges(faces, len(vertices))
        planes, area_vectors = bounding_planes(triangles)
        if require_closed:
            _check_closed(mesh, twins, enclosed_volume(triangles, area_vectors) if twins is not None else 0.0, "mesh")
        face_normals = np.ascontiguousarray(planes[0:3].T)
        normals = edge_normals(mesh, faces, face_normals, twins)
        cache: dict[str, Any] = {}
        if not isinstance(neighbours, NeighbourLists):  # the lists are still being made: the vertex normals too
            cache["corner_normals"] = corner_normals(faces, triangles, face_normals)
            neighbours = neighbours.result()
        return cls(triangles=triangles, face_normals=face_normals, edge_normals=normals, planes=planes,
                   neighbours=neighbours, scene_origin=_box_centre(vertices),
                   vertices=vertices, faces=faces, _cache=cache)

    @property
    def size_classes(self) -> tuple[SizeClass, ...]:
        """Triangles grouped by size, each group with a k-d tree over its centroids (built on first use)."""
        with _BUILDING:  # threads of one query may ask at once
            groups = self._cache.get("size_classes")
            if groups is None:
                groups = self._cache["size_classes"] = size_classes(self.neighbours)
        return groups

    @property
    def corner_normals(self) -> FloatArray:
        """Angle-weighted vertex pseudo-normals at each corner, (F, 3, 3) (made on first use)."""
        with _BUILDING:
            normals = self._cache.get("corner_normals")
            if normals is None:
                normals = self._cache["corner_normals"] = corner_normals(self.faces, self.triangles, self.face_normals)
        return normals

    def __getstate__(self) -> dict[str, Any]:
        # the open3d scene does not pickle (dask workers): each process builds its own
        state = dict(self.__dict__)
        state["_cache"] = {}
        return state

    @property
    def scene(self) -> Any:
        """The open3d ``RaycastingScene`` of the mesh (float32, centred on ``scene_origin``), built once."""
        with _BUILDING:  # threads of one query may ask at once
            scene = self._cache.get("scene")
            if scene is None:
                o3d = require("open3d")

                scene = o3d.t.geometry.RaycastingScene()
                scene.add_triangles(o3d.core.Tensor((self.vertices - self.scene_origin).astype(np.float32)),
                                    o3d.core.Tensor(self.faces.astype(np.uint32)))
                self._cache["scene"] = scene
        return scene

    def distances(self, points: ArrayLike, *, workers: int | None = None) -> SurfaceDistances:
        """Exact signed distances of ``points`` (N, 3) from the indexed surface (see :func:`surface_distances`).

        ``workers``: threads for the search, open3d's and the exact one (default: every core
        this process may use; a dask array's blocks use one each, dask runs them in parallel).

        Raises
        ------
        InvalidInputError
            Points of the wrong shape or not finite; ``workers`` not a positive integer.
        TooFewPointsError
            No points.
        """
        threads = _thread_count(workers)
        if is_dask_array(points):
            return self._lazy_distances(points)
        return self._ordered_distances(*_ordered_points(points), threads)

    def _ordered_distances(self, query: FloatArray, order: IntArray | None, threads: int) -> SurfaceDistances:
        """Distances of ``query`` (points in spatial order), written back to the caller's order ``order``."""
        pieces = max(threads, -(-len(query) // _POINTS_PER_BLOCK))
        pieces = min(-(-pieces // threads) * threads, len(query))  # equal shares for the threads
        bounds = np.linspace(0, len(query), pieces + 1).astype(np.int64)
        blocks = [slice(int(start), int(stop)) for start, stop in itertools.pairwise(bounds)]
        count = len(query)
        found = SurfaceDistances(closest=np.empty((count, 3)), signed_distance=np.empty(count),
                                 face_index=np.empty(count, dtype=np.int64), direction=np.empty((count, 3)))

        def block_distances(rows: slice) -> None:  # one thread a block, unless there is one block; each writes its rows
            part = self._distances(query[rows], threads if len(blocks) == 1 else 1)
            target = rows if order is None else order[rows]
            for name in ("closest", "signed_distance", "face_index", "direction"):
                getattr(found, name)[target] = getattr(part, name)

        if threads == 1 or len(blocks) == 1:
            for rows in blocks:
                block_distances(rows)
        else:
            from concurrent.futures import ThreadPoolExecutor

            with ThreadPoolExecutor(min(threads, len(blocks))) as pool:  # numpy releases the GIL in its loops
                list(pool.map(block_distances, blocks))
        return found

    def _lazy_distances(self, points: Any) -> SurfaceDistances:
        """Block-wise distances of a dask array of points; every field a lazy dask array."""
        from pcmm_geo.fit.scale.dask import as_dask_points, lazy_rows

        checked = as_dask_points(points, element="mesh distance", min_points=1)
        packed = lazy_rows(checked, _packed_distances, self, columns=8)
        return SurfaceDistances(closest=packed[:, 0:3], signed_distance=packed[:, 3],
                                face_index=packed[:, 4].astype(np.int64), direction=packed[:, 5:8])

    def _distances(self, query: FloatArray, threads: int = 1) -> SurfaceDistances:
        """Exact distances of one block of points, searched on ``threads`` threads (see the module: step 1)."""
        candidates = self.nearby(query, threads=threads)
        far = np.flatnonzero(candidates < 0)
        if len(far):
            candidates[far] = self.candidates(query[far], threads=threads)
        rounding = ROUNDING * (1.0 + _largest_coordinate(query))
        closest, squared, face_index, barycentric = self._nearest(query, candidates, rounding)
        offset = query - closest
        distance = np.sqrt(squared)
        pseudo_normal, inside_face = self._pseudo_normals(barycentric, face_index)
        sign = np.where(np.einsum("ij,ij->i", offset, pseudo_normal) < 0.0, -1.0, 1.0)
        signed = sign * distance
        # nearest point inside a face: the gradient is that face's normal, exactly; at an edge or
        # a vertex it points from the nearest point, unless the distance is down at rounding level
        from_feature = ~inside_face & (distance > rounding)
        direction = pseudo_normal.copy()
        direction[from_feature] = offset[from_feature] / signed[from_feature, None]
        return SurfaceDistances(closest=closest, signed_distance=signed, face_index=face_index, direction=direction)

    # ------------------------------------------------------------------ search

    def candidates(self, query: FloatArray, *, threads: int = 0) -> IntArray:
        """The triangle open3d finds nearest to each point, in float32 (a candidate, not the answer).

        ``threads``: open3d's threads (0: its own choice, all cores).
        """
        o3d = require("open3d")

        answer = self.scene.compute_closest_points(o3d.core.Tensor((query - self.scene_origin).astype(np.float32)),
                                                   nthreads=threads)
        return answer["primitive_ids"].numpy().astype(np.int64)

    def nearby(self, query: FloatArray, *, threads: int = 1) -> IntArray:
        """The triangle with the centroid nearest to each point (k-d tree; a candidate), -1 when none is near
        (within three times the largest centroid-to-corner radius: see :meth:`candidates`)."""
        lists = self.neighbours
        _, nearest = lists.tree.query(query, k=1, distance_upper_bound=_NEARBY_REACH * float(lists.radius.max()),
                                      workers=threads)
        nearest = nearest[:, 0]
        nearest[nearest >= len(self.triangles)] = -1  # nothing within reach
        return nearest

    def _nearest(self, query: FloatArray, candidates: IntArray, rounding: FloatArray | None = None,
                 ) -> tuple[FloatArray, FloatArray, IntArray, FloatArray]:
        """Nearest surface point, squared distance, triangle and barycentric weights of every point (exact).

        ``rounding`` (N,): the distances below which a difference is rounding (made here when not given).
        """
        face_index = np.array(candidates, dtype=np.int64)
        coordinates = np.ascontiguousarray(query.T)
        closest, squared, barycentric = closest_on_triangles(query, np.take(self.triangles, face_index, axis=0))
        # every triangle within the candidate's exact distance could be nearer
        if rounding is None:
            rounding = ROUNDING * (1.0 + _largest_coordinate(query))
        reach = np.sqrt(squared) * (1.0 + SLACK) + rounding
        found = [listed_pairs(self.neighbours, coordinates, reach, face_index, rounding)]
        rest = found[0][2]
        for group in self.size_classes if len(rest) else ():
            point_of_pair, triangle_of_pair = pairs_within(group, query[rest], reach[rest])
            found.append((rest[point_of_pair], triangle_of_pair, rest))
        for point_of_pair, triangle_of_pair, _ in found:
            for chunk in range(0, len(point_of_pair), _PAIRS_PER_BLOCK):
                rows = slice(chunk, chunk + _PAIRS_PER_BLOCK)
                self._keep_nearer(query, coordinates, point_of_pair[rows], triangle_of_pair[rows], reach,
                                  closest, squared, face_index, barycentric)
        return closest, squared, face_index, barycentric

    def _keep_nearer(self, query: FloatArray, coordinates: FloatArray, point_of_pair: IntArray,
                     triangle_of_pair: IntArray, reach: FloatArray, closest: FloatArray, squared: FloatArray,
                     face_index: IntArray, barycentric: FloatArray) -> None:
        """Evaluate the pairs whose plane bound lies within reach; keep (in place) any strictly nearer triangle.

        ``coordinates`` is ``query`` transposed (3, N), for contiguous gathers.
        """
        other = triangle_of_pair != face_index[point_of_pair]
        point_of_pair, triangle_of_pair = point_of_pair[other], triangle_of_pair[other]
        keep = np.flatnonzero(within_reach(self.planes, triangle_of_pair, np.take(coordinates, point_of_pair, axis=1),
                                           reach[point_of_pair]))
        if len(keep) == 0:
            return
        point_of_pair, triangle_of_pair = point_of_pair[keep], triangle_of_pair[keep]
        corners = np.take(self.triangles, triangle_of_pair, axis=0)
        on_triangle, pair_squared, pair_weights = closest_on_triangles(np.take(query, point_of_pair, axis=0), corners)
        order = np.lexsort((triangle_of_pair, pair_squared, point_of_pair))
        first = order[np.r_[True, point_of_pair[order][1:] != point_of_pair[order][:-1]]]
        winners = first[pair_squared[first] < squared[point_of_pair[first]]]
        rows = point_of_pair[winners]
        squared[rows] = pair_squared[winners]
        closest[rows] = on_triangle[winners]
        face_index[rows] = triangle_of_pair[winners]
        barycentric[rows] = pair_weights[winners]

    # ------------------------------------------------------------------ sign

    def _pseudo_normals(self, barycentric: FloatArray, face_index: IntArray) -> tuple[FloatArray, NDArray[np.bool_]]:
        """Pseudo-normals of the features holding the nearest points, and which of these lie inside a face."""
        on_zero = barycentric < _ON_BOUNDARY
        zero_count = on_zero[:, 0].astype(np.int8) + on_zero[:, 1] + on_zero[:, 2]  # column by column: see _box
        normals = np.take(self.face_normals, face_index, axis=0)
        at_edge = np.flatnonzero(zero_count == 1)
        # the edge opposite corner k is the face's edge number (k + 1) % 3: (v0v1, v1v2, v2v0)
        edge = (np.argmax(on_zero[at_edge], axis=1) + 1) % 3
        normals[at_edge] = self.edge_normals[face_index[at_edge], edge]
        at_vertex = np.flatnonzero(zero_count >= 2)
        if len(at_vertex):
            corner = np.argmax(barycentric[at_vertex], axis=1)
            normals[at_vertex] = self.corner_normals[face_index[at_vertex], corner]
        length = np.sqrt(np.einsum("ij,ij->i", normals, normals))[:, None]
        return normals / np.where(length > 0.0, length, 1.0), zero_count == 0


def _thread_count(workers: int | None) -> int:
    """Threads for the exact search: ``workers``, or every core this process may use."""
    if workers is None:
        try:
            return max(1, len(os.sched_getaffinity(0)))
        except AttributeError:  # not on Linux
            return max(1, os.cpu_count() or 1)
    if isinstance(workers, bool) or not isinstance(workers, numbers.Integral) or workers < 1:
        raise InvalidInputError("workers", "a positive integer (threads) or None (every core)", repr(workers))
    return int(workers)


def _box(points: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Lowest and highest coordinates of ``points`` (N, 3), column by column (a reduction along axis 0 of an
    (N, 3) array strides through memory and takes some twenty times longer)."""
    return (np.array([points[:, k].min() for k in range(3)]), np.array([points[:, k].max() for k in range(3)]))


def _box_centre(points: FloatArray) -> FloatArray:
    low, high = _box(points)
    return (low + high) / 2


def _largest_coordinate(points: FloatArray) -> FloatArray:
    """``max_k |points[:, k]|`` (N,), column by column (see :func:`_box`)."""
    return np.maximum(np.maximum(np.abs(points[:, 0]), np.abs(points[:, 1])), np.abs(points[:, 2]))


def _ordered_points(points: ArrayLike) -> tuple[FloatArray, IntArray | None]:
    """The checked points (N, 3) in spatial order (:func:`_spatial_order`) and that order (None: as given)."""
    query = as_points(points, element="mesh distance", min_points=1)
    order = _spatial_order(query)
    return (query, None) if order is None else (np.take(query, order, axis=0), order)


def _spatial_order(points: FloatArray) -> IntArray | None:
    """An order of ``points`` (N, 3) cell by cell of a 32 x 32 x 32 grid over their box; None for few points.

    The order changes no result (every point is answered on its own); it only makes points
    that share candidates and list entries follow each other in memory.  The cell key fits
    in 16 bits, for which numpy's stable sort is a radix sort.
    """
    if len(points) < _ORDERED_FROM:
        return None
    low, high = _box(points)
    scale = (_GRID_CELLS - 1e-9) / np.maximum(high - low, 1e-300)
    cell = ((points - low) * scale).astype(np.int16)
    key = (cell[:, 0] * _GRID_CELLS + cell[:, 1]) * _GRID_CELLS + cell[:, 2]
    return np.argsort(key.astype(np.int16), kind="stable").astype(np.int64)


def _packed_distances(block: FloatArray, index: SurfaceIndex) -> FloatArray:
    """Distances of one block packed as columns: closest (3), signed distance, face index, direction (3)."""
    found = index.distances(np.asarray(block, dtype=np.float64), workers=1)
    return np.column_stack([found.closest, found.signed_distance, found.face_index.astype(np.float64),
                            found.direction])
