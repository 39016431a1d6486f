"""Exact maximum-inscribed circle / sphere: the largest empty ball centred inside the points' convex hull.

The distance from a centre ``c`` to the nearest point, ``f(c) = min_i |p_i - c|``, is the radius of
the largest ball about ``c`` holding no point.  Over the convex hull of the points (a compact set)
``f`` attains its maximum either

- inside the hull: a local maximum of ``f``, which is a vertex of the Voronoi diagram -- the
  circumcentre of a Delaunay triangle (tetrahedron) -- lying in the convex hull of its nearest
  points (the contacts *surround* it); or
- on the hull boundary: where a Voronoi edge (face) crosses a hull edge (facet).

All Voronoi vertices come from one Delaunay triangulation (Qhull); their radii are measured as
the true nearest-point distance (k-d tree), so a rounding error in a circumcentre cannot inflate
the answer.  Any boundary centre is within the circumradius of its hull edge / facet of a hull
vertex, which bounds the boundary cheaply; where that bound is not below the best interior
vertex, the boundary crossings are enumerated exactly.

The maximum inscribed element of metrology is the global maximum when it lies inside the hull
and is surrounded by its contacts (a profile around a hole, a boss, a spherical cavity).  When the
largest empty ball inside the hull touches the hull boundary the points do not surround it (a
partial arc or cap): no inscribed element is defined and the solver refuses.
"""

from __future__ import annotations

import numpy as np

from pcmm_geo.errors import DegenerateGeometryError
from pcmm_geo.fit.zone._exact._geometry import FloatArray, IndexArray, circumcentre_pairs, equidistant_centres
from pcmm_geo.fit.zone._exact._optimum import ExactOptimum


def _surrounding(points: FloatArray, centre: FloatArray) -> IndexArray | None:
    """Indices of at most ``D + 1`` of ``points`` whose convex hull holds ``centre``, or None (NNLS)."""
    from scipy.optimize import nnls

    rel = points - centre
    scale = max(float(np.abs(rel).max()), 1e-300)
    matrix = np.vstack([rel.T / scale, np.ones(len(points))])
    target = np.zeros(matrix.shape[0])
    target[-1] = 1.0
    weights, residual = nnls(matrix, target, maxiter=50 * matrix.shape[1])
    if residual > 1e-9:
        return None
    return np.flatnonzero(weights > 0)


def _boundary_candidates(
    points: FloatArray, tri: object, faces: FloatArray, tree: object, floor: float
) -> tuple[float, FloatArray]:
    """Largest empty radius centred on the hull boundary, searched only on faces whose bound exceeds ``floor``.

    ``faces`` are the hull edges (2-D, ``(F, 2, 2)``) or triangles (3-D, ``(F, 3, 3)``).
    """
    dim = points.shape[1]
    corners = faces
    if dim == 2:
        bound = 0.5 * np.linalg.norm(corners[:, 1] - corners[:, 0], axis=1)
    else:
        a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
        ab, ac, bc = (np.linalg.norm(u, axis=1) for u in (b - a, c - a, c - b))
        area2 = np.linalg.norm(np.cross(b - a, c - a), axis=1)
        bound = ab * ac * bc / np.maximum(2.0 * area2, 1e-300)
    best_radius, best_centre = -np.inf, np.full(dim, np.nan)
    long_faces = np.flatnonzero(bound > floor)
    if not long_faces.size:
        return best_radius, best_centre
    # Voronoi edges / faces: the Delaunay edges (bisector planes) and, in 3-D, triangles (circumaxes)
    simplices = tri.simplices  # type: ignore[attr-defined]
    corner_pairs = [[i, j] for i in range(dim + 1) for j in range(i + 1, dim + 1)]
    edges = np.unique(np.sort(simplices[:, corner_pairs].reshape(-1, 2), axis=1), axis=0)
    for face in long_faces:
        found = _crossings(points, corners[face], edges, simplices)
        if found.size:
            radii = tree.query(found)[0]  # type: ignore[attr-defined]
            k = int(np.argmax(radii))
            if radii[k] > best_radius:
                best_radius, best_centre = float(radii[k]), found[k]
    return best_radius, best_centre


def _crossings(points: FloatArray, face: FloatArray, edges: IndexArray, simplices: IndexArray) -> FloatArray:
    """Centres on one hull edge / facet where a Voronoi edge or face crosses it."""
    dim = points.shape[1]
    normals = points[edges[:, 1]] - points[edges[:, 0]]
    levels = 0.5 * np.einsum("kd,kd->k", normals, points[edges[:, 1]] + points[edges[:, 0]])
    found = []
    segments = [(face[0], face[1])] if dim == 2 else [(face[0], face[1]), (face[1], face[2]), (face[2], face[0])]
    for start, end in segments:  # bisector planes of Delaunay edges crossing a hull edge
        slope = normals @ (end - start)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (levels - normals @ start) / slope
        t = t[np.isfinite(t) & (t >= 0) & (t <= 1)]
        found.append(start + t[:, None] * (end - start))
    if dim == 3:  # circumaxes of Delaunay triangles crossing a hull facet
        triangles = np.unique(
            np.sort(simplices[:, [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]].reshape(-1, 3), axis=1), axis=0
        )
        plane_normal = np.cross(face[1] - face[0], face[2] - face[0])
        first, second = points[triangles[:, [0, 0]]], points[triangles[:, [1, 2]]]
        rows = second - first
        rhs = 0.5 * np.einsum("kid,kid->ki", rows, second + first)
        system = np.concatenate([rows, np.broadcast_to(plane_normal, (len(rows), 1, 3))], axis=1)
        rhs = np.concatenate([rhs, np.full((len(rows), 1), float(plane_normal @ face[0]))], axis=1)
        det = np.linalg.det(system)
        ok = np.abs(det) > 1e-12 * np.prod(np.linalg.norm(system, axis=2), axis=1)
        if ok.any():
            centres = np.linalg.solve(system[ok], rhs[ok][..., None])[..., 0]
            # keep those inside the triangle (barycentric coordinates >= 0)
            basis = np.column_stack([face[1] - face[0], face[2] - face[0]])
            coords = np.linalg.lstsq(basis, (centres - face[0]).T, rcond=None)[0]
            inside = (coords >= -1e-12).all(axis=0) & (coords.sum(axis=0) <= 1 + 1e-12)
            found.append(centres[inside])
    return np.vstack(found) if found else np.zeros((0, dim))


def _largest_inside(faces: FloatArray, centres: FloatArray, order: IndexArray, count: int, tie: float) -> IndexArray:
    """The first ``count`` entries of ``order`` whose centre lies in the convex hull bounded by ``faces``.

    ``faces`` are the hull edges ``(F, 2, 2)`` or triangles ``(F, 3, 3)``.  A centre inside the largest
    ball about the vertex centroid that the hull contains, or outside the smallest one about it that
    contains the hull, is decided at once; the others against every facet plane, in order, until
    ``count`` are found.
    """
    dim = centres.shape[1]
    if dim == 2:
        direction = faces[:, 1] - faces[:, 0]
        normals = np.column_stack([direction[:, 1], -direction[:, 0]])
    else:
        normals = np.cross(faces[:, 1] - faces[:, 0], faces[:, 2] - faces[:, 0])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    inner = faces.reshape(-1, dim).mean(axis=0)
    offsets = np.einsum("fd,fd->f", normals, faces[:, 0]) - normals @ inner
    flip = offsets < 0  # orient every normal outward (offsets from the inner point positive)
    normals[flip], offsets[flip] = -normals[flip], -offsets[flip]
    rel = centres[order] - inner
    reach = np.sqrt(np.einsum("kd,kd->k", rel, rel))
    corners = faces.reshape(-1, dim) - inner
    outer = float(np.sqrt(np.einsum("kd,kd->k", corners, corners).max()))
    surely = reach <= float(offsets.min()) - tie
    maybe = reach <= outer + tie
    found: list[int] = []
    block = max(1, 1_000_000 // max(len(faces), 1))
    position = 0
    candidates = np.flatnonzero(maybe)
    while len(found) < count and position < len(candidates):
        chunk = candidates[position : position + block]
        position += block
        unsure = chunk[~surely[chunk]]
        inside = surely[chunk].copy()
        if unsure.size:
            inside[~surely[chunk]] = (rel[unsure] @ normals.T - offsets).max(axis=1) <= tie
        found.extend(chunk[inside].tolist())
    return order[np.array(found[:count], dtype=np.intp)]


def largest_empty_ball(points: FloatArray, *, element: str) -> ExactOptimum:
    """Global maximum-inscribed circle (``(N, 2)``) or sphere (``(N, 3)``) of centred points.

    Raises
    ------
    DegenerateGeometryError
        Collinear / coplanar points, or points that do not surround their largest empty ball.
    """
    from scipy.spatial import Delaunay, QhullError, cKDTree

    dim = points.shape[1]
    shape = "circle" if dim == 2 else "sphere"
    try:
        tri = Delaunay(points)
    except (QhullError, ValueError):
        flat = "collinear" if dim == 2 else "coplanar"
        raise DegenerateGeometryError(element, f"points are {flat}; no unique {shape} passes through them") from None
    tree = cKDTree(points)
    simplices = tri.simplices
    centres, valid = equidistant_centres(points, circumcentre_pairs(simplices))
    size = float(np.sqrt(np.mean(np.einsum("nd,nd->n", points, points))))
    tie = 1e-9 * size
    support = None
    interior, k = -np.inf, -1
    candidates = np.flatnonzero(valid)
    # radius of a Voronoi vertex: its distance to its Delaunay simplex (no point is nearer); the few
    # largest inside the hull are measured against all points, so a rounded circumcentre cannot inflate one
    circumradii = np.linalg.norm(centres[candidates] - points[simplices[candidates, 0]], axis=1)
    top = _largest_inside(points[tri.convex_hull], centres, candidates[np.argsort(-circumradii)], 32, tie)
    if top.size:
        nearest = tree.query(centres[top])[0]
        k = int(top[int(np.argmax(nearest))])
        interior = float(nearest.max())
        near = np.asarray(tree.query_ball_point(centres[k], interior + tie), dtype=np.intp)
        held = _surrounding(points[near], centres[k])
        support = None if held is None else np.union1d(near[held], simplices[k])
    boundary = -np.inf
    if support is not None:
        boundary, _ = _boundary_candidates(points, tri, points[tri.convex_hull], tree, interior)
    if support is None or boundary > interior + tie:
        where = f" (a boundary centre reaches radius {boundary:.6g} mm)" if support is not None else ""
        raise DegenerateGeometryError(
            element,
            f"the maximum inscribed {shape} is not defined: the points do not surround an empty {shape}; the "
            f"largest empty {shape} centred inside their convex hull touches the hull boundary{where} "
            f"(a partial arc or cap has no inscribed {shape})",
        )
    assert support is not None
    distances = np.sqrt(np.einsum("nd,nd->n", points - centres[k], points - centres[k]))
    return ExactOptimum(
        x=centres[k],
        lower=float(distances.min()),
        upper=float(distances.max()),
        bound=interior,
        contacts={int(i): -1.0 for i in support},
        iterations=1,
        method="Voronoi vertices in the convex hull (Qhull)",
    )
