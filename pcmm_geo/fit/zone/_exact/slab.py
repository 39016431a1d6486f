"""Narrowest strip (2-D) and slab (3-D) of a point set: the exact, global minimum-zone line and plane.

The width of a point set along a unit normal ``n`` is ``w(n) = max p.n - min p.n``, the support
function of the difference body ``K - K`` (``K`` the convex hull).  Its minimum over all normals
is attained at an antipodal pair of the hull (Houle & Toussaint 1988):

- 2-D: a hull edge and the vertex farthest from its line; the caliper rotated around the hull
  (:func:`narrowest_strip`) visits every edge once, O(H log H) with a sorted search of the
  antipodal vertex;
- 3-D: a hull facet and its farthest vertex, or two hull edges on parallel supporting planes.
  These are exactly the facets of ``K - K``, so the minimum width is the distance from the origin
  to the nearest facet of the convex hull of the differences (Qhull).  For a large hull the
  differences of a growing subset ``S`` of hull vertices are used (:func:`narrowest_slab`):
  ``conv(S - S)`` lies inside ``K - K``, so its nearest facet is a proven *lower* bound of the
  minimum width, and the width of all points along that facet's normal an *upper* bound; the
  extreme points along that normal join ``S`` until both agree (to rounding).  The end result is
  the same antipodal pair as the full enumeration, found without forming all pairs.
"""

from __future__ import annotations

import numpy as np

from pcmm_geo.fit.zone._exact._optimum import ExactOptimum, FloatArray

#: hull vertices up to this count give the full difference body at once
_DIRECT = 48
_MAX_ROUNDS = 200


def _levels(offsets: FloatArray, index: np.ndarray) -> dict[int, float]:
    """Contacts ``{index: +1 upper / -1 lower}`` of the given point indices by their nearer level."""
    high, low = float(offsets.max()), float(offsets.min())
    return {int(i): (1.0 if high - offsets[i] <= offsets[i] - low else -1.0) for i in np.unique(index)}


def _flat_normal(points: FloatArray) -> FloatArray:
    """Unit normal of the best-fit line / plane through the centroid (the data have no hull)."""
    _, _, vt = np.linalg.svd(points - points.mean(axis=0), full_matrices=False)
    normal = np.zeros(points.shape[1])
    normal[: vt.shape[0]] = vt[-1] if vt.shape[0] == points.shape[1] else 0.0
    if vt.shape[0] < points.shape[1] or not np.any(normal):
        # fewer points than dimensions: any normal of their span
        normal = np.linalg.svd(np.vstack([points - points.mean(axis=0), np.zeros(points.shape[1])]))[2][-1]
    return normal / np.linalg.norm(normal)


def _flat_optimum(points: FloatArray, how: str) -> ExactOptimum:
    normal = _flat_normal(points)
    offsets = points @ normal
    extremes = np.array([int(np.argmax(offsets)), int(np.argmin(offsets))])
    return ExactOptimum(
        x=normal,
        lower=float(offsets.min()),
        upper=float(offsets.max()),
        bound=0.0,
        contacts=_levels(offsets, extremes),
        iterations=0,
        method=how,
    )


def narrowest_strip(points: FloatArray) -> ExactOptimum:
    """Minimum-width strip of ``(N, 2)`` centred points by rotating calipers on the convex hull.

    ``x`` of the result is the unit normal of the strip; ``bound`` equals the width (exact).
    Collinear points (or N = 2) give the strip of width zero (to rounding) along their line.
    """
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = ConvexHull(points)
    except (QhullError, ValueError):
        return _flat_optimum(points, "collinear points (width zero)")
    ring = hull.vertices  # counter-clockwise
    corners = points[ring]
    edges = np.roll(corners, -1, axis=0) - corners
    # outward normals of the edges (counter-clockwise hull: (dy, -dx)) and their angles, increasing
    normals = np.column_stack([edges[:, 1], -edges[:, 0]]) / np.linalg.norm(edges, axis=1)[:, None]
    angles = np.unwrap(np.arctan2(normals[:, 1], normals[:, 0]))
    # vertex j+1 supports every direction between the normals of edges j and j+1: the vertex
    # farthest behind edge i supports its inward normal, at angle + pi
    count = len(ring)
    target = angles + np.pi
    start = np.searchsorted(angles, target - 2 * np.pi * np.floor((target - angles[0]) / (2 * np.pi)))
    candidates = (start[:, None] + np.arange(-1, 3)[None, :]) % count
    depth = np.einsum("ikd,id->ik", corners[candidates] - corners[:, None, :], -normals)
    best_k = np.argmax(depth, axis=1)
    widths = depth[np.arange(count), best_k]
    edge = int(np.argmin(widths))
    normal = -normals[edge]
    offsets = points @ normal
    support = np.array([ring[edge], ring[(edge + 1) % count], ring[candidates[edge, best_k[edge]]]])
    return ExactOptimum(
        x=normal,
        lower=float(offsets.min()),
        upper=float(offsets.max()),
        bound=float(widths[edge]),
        contacts=_levels(offsets, support),
        iterations=1,
        method="rotating calipers on the convex hull",
    )


def _nearest_difference_facet(subset: FloatArray) -> tuple[FloatArray, float, np.ndarray] | None:
    """Unit normal, distance and vertex pairs ``(k, 2)`` of the facet of ``conv(S - S)`` nearest the origin."""
    from scipy.spatial import ConvexHull, QhullError

    m = len(subset)
    first, second = np.nonzero(~np.eye(m, dtype=bool))
    differences = subset[first] - subset[second]
    try:
        hull = ConvexHull(differences)
    except (QhullError, ValueError):
        return None
    distances = -hull.equations[:, -1]
    k = int(np.argmin(distances))
    vertices = hull.simplices[k]
    return hull.equations[k, :-1], float(distances[k]), np.column_stack([first[vertices], second[vertices]])


def narrowest_slab(points: FloatArray, seed_normal: FloatArray) -> ExactOptimum:
    """Minimum-width slab of ``(N, 3)`` centred points: the global minimum-zone plane.

    ``seed_normal`` (e.g. the least-squares normal) only chooses the first vertices of a large
    hull.  ``x`` of the result is the slab's unit normal, ``bound`` the proven lower bound of the
    minimum width (equal to the width to rounding when the search closes).  Fewer than four or
    coplanar points give the plane through them (width zero to rounding).
    """
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = ConvexHull(points)
    except (QhullError, ValueError):
        return _flat_optimum(points, "coplanar points (width zero)")
    vertices = hull.vertices
    corners = points[vertices]
    if len(vertices) <= _DIRECT:
        chosen = np.arange(len(vertices))
    else:
        along = corners @ seed_normal
        order = np.argsort(along)
        chosen = np.unique(np.concatenate([order[:8], order[-8:]]))
    best: tuple[float, FloatArray] = (np.inf, seed_normal)
    bound = 0.0
    support = np.zeros((0, 2), dtype=np.intp)
    rounds = 0
    for rounds in range(1, _MAX_ROUNDS + 1):  # noqa: B007 (reported after the loop)
        facet = _nearest_difference_facet(corners[chosen])
        if facet is None:  # the chosen vertices are coplanar: their own plane is the lower bound 0
            normal, bound, pairs = _flat_normal(corners[chosen]), 0.0, np.zeros((0, 2), dtype=np.intp)
        else:
            normal, bound, pairs = facet
        along = corners @ normal
        width = float(along.max() - along.min())
        if width < best[0]:
            best, support = (width, normal), chosen[pairs]
        tie = 1e-13 * max(float(np.abs(corners).max()), 1e-300)
        if width <= bound + tie:
            break
        extremes = np.array([int(np.argmax(along)), int(np.argmin(along))])
        fresh = np.setdiff1d(extremes, chosen)
        if fresh.size == 0:
            break
        chosen = np.concatenate([chosen, fresh])
    normal = best[1]
    offsets = points @ normal
    index = vertices[support.ravel()] if support.size else vertices[[int(np.argmax(corners @ normal))]]
    extremes = np.array([int(np.argmax(offsets)), int(np.argmin(offsets))])
    return ExactOptimum(
        x=normal,
        lower=float(offsets.min()),
        upper=float(offsets.max()),
        bound=min(bound, best[0]),
        contacts=_levels(offsets, np.concatenate([index, extremes])),
        iterations=rounds,
        method="antipodal pairs of the convex hull (Qhull)",
    )


def minimum_width(points: FloatArray) -> tuple[float, FloatArray]:
    """Exact minimum width and its unit normal of a small ``(M, 2)`` or ``(M, 3)`` point set."""
    centred = points - points.mean(axis=0)
    if points.shape[1] == 2:
        found = narrowest_strip(centred)
    else:
        found = narrowest_slab(centred, _flat_normal(centred))
    return found.upper - found.lower, found.x
