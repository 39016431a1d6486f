"""Exact minimum-zone circle / sphere (narrowest annulus / spherical shell) and minimum enclosing ball.

Both are solved by the same exact scheme on a growing subset ``S`` of the points (the "violator"
scheme of LP-type problems; here with an exhaustive solver for the small subproblem):

1. solve the problem for ``S`` exactly;  since dropping points never widens a zone nor enlarges an
   enclosing ball, that optimum is a proven *lower bound* for all points;
2. evaluate its centre on all points: an *upper* bound;  if both agree (to rounding) the centre is
   the global optimum, else the farthest and nearest points join ``S``.

Zone (``w(c) = max_i |p_i - c| - min_i |p_i - c|``): a local minimum of ``w`` has ``D + 2`` contacts
in general position and its centre is equidistant within each level: the circumcentre of ``D + 1``
points (3 outer + 1 inner, 1 outer + 3 inner in 2-D; 4 + 1, 1 + 4 in 3-D) or the point equidistant
from two groups (2 + 2 in 2-D; 3 + 2, 2 + 3 in 3-D) -- the vertices of the nearest- and
farthest-point Voronoi diagrams and the crossings of their edges.  Configurations with fewer
contacts are not minima: along the set where the contacts keep their levels, the second derivative
of ``w`` is ``(1 - s^2)(1 / r_out - 1 / r_in) <= 0`` (``s`` the common slope).  Far away the annulus
becomes a strip (slab) whose width tends to the width of the points along the centre's direction,
so the infimum over all centres is the smaller of the best candidate and the minimum width of
the points (:func:`~pcmm_geo.fit.zone._exact.slab.minimum_width`).  The enumeration for ``S`` is
therefore exact and global; for all points, the scheme stops when the subset optimum holds them all.

Enclosing ball: the smallest ball enclosing ``S`` is spanned by at most ``D + 1`` of its points
(:func:`~pcmm_geo.fit.zone._exact._geometry.enclosing_ball`); the problem is convex, so this is the
classic exact method and its optimum is global.
"""

from __future__ import annotations

import numpy as np

from pcmm_geo.errors import DegenerateGeometryError
from pcmm_geo.fit.zone._exact._geometry import (
    FloatArray,
    IndexArray,
    circumcentre_pairs,
    enclosing_ball,
    equidistant_centres,
    minimum_width_small,
    split_pairs,
    subsets_with_new,
)
from pcmm_geo.fit.zone._exact._optimum import ExactOptimum
from pcmm_geo.fit.zone._exact.slab import minimum_width

_MAX_ROUNDS = 100
#: subsets up to this size have their minimum width enumerated, larger ones use the convex hull
_SMALL = {2: 60, 3: 16}
#: a subset never grows beyond this (the candidates grow as its 4th / 5th power): the answer is then local
_LARGEST = {2: 120, 3: 40}
#: relative rounding allowance (times the data size) when comparing zone widths and radii
_TIE = 1e-13


def _distances(centres: FloatArray, points: FloatArray) -> FloatArray:
    """``(K, M)`` distances between ``(K, D)`` centres and ``(M, D)`` points."""
    rel = centres[:, None, :] - points[None, :, :]
    return np.sqrt(np.einsum("kmd,kmd->km", rel, rel))


def _distance(points: FloatArray, centre: FloatArray) -> FloatArray:
    rel = points - centre
    return np.sqrt(np.einsum("nd,nd->n", rel, rel))


class _Candidates:
    """Candidate centres of the subset problem with their running farthest / nearest distance over ``S``."""

    def __init__(self, dim: int) -> None:
        self.centres = np.zeros((0, dim))
        self.pairs = np.zeros((0, dim, 2), dtype=np.intp)  # bisector pairs, as positions in S
        self.far = np.zeros(0)
        self.near = np.zeros(0)

    def extend(self, subset: FloatArray, first_new: int) -> None:
        """Update the old candidates with the new points of ``S`` and add the candidates they create."""
        dim = subset.shape[1]
        if first_new < len(subset) and len(self.centres):
            fresh = _distances(self.centres, subset[first_new:])
            np.maximum(self.far, fresh.max(axis=1), out=self.far)
            np.minimum(self.near, fresh.min(axis=1), out=self.near)
        pairs = np.concatenate(
            [
                circumcentre_pairs(subsets_with_new(len(subset), dim + 1, first_new)),
                split_pairs(len(subset), first_new, dim),
            ]
        )
        if not len(pairs):
            return
        centres, valid = equidistant_centres(subset, pairs)
        centres, pairs = centres[valid], pairs[valid]
        reach = _distances(centres, subset)
        self.centres = np.concatenate([self.centres, centres])
        self.pairs = np.concatenate([self.pairs, pairs])
        self.far = np.concatenate([self.far, reach.max(axis=1)])
        self.near = np.concatenate([self.near, reach.min(axis=1)])

    def keep_below(self, width: float) -> None:
        """Drop the candidates whose zone over ``S`` is already at least ``width`` (they cannot win)."""
        keep = self.far - self.near < width
        self.centres, self.pairs = self.centres[keep], self.pairs[keep]
        self.far, self.near = self.far[keep], self.near[keep]


def _seed_subset(distances: FloatArray, per_level: int) -> IndexArray:
    """The ``per_level`` nearest and farthest points (all points of a set of at most ten)."""
    if distances.size <= max(2 * per_level, 10):
        return np.arange(distances.size)
    near = np.argpartition(distances, per_level)[:per_level]
    far = np.argpartition(-distances, per_level)[:per_level]
    return np.unique(np.concatenate([near, far]))


def _contacts(distances: FloatArray, index: IndexArray) -> dict[int, float]:
    high, low = float(distances.max()), float(distances.min())
    return {int(i): (1.0 if high - distances[i] <= distances[i] - low else -1.0) for i in np.unique(index)}


def zone_annulus(points: FloatArray, seed: FloatArray, *, element: str) -> ExactOptimum:
    """Global minimum-zone circle (``(N, 2)``) or sphere (``(N, 3)``) of centred points.

    ``seed`` is a centre near the optimum (e.g. the least-squares centre); it only chooses the
    first subset.  Returns the centre, the zone's radii, the proven lower bound of the width and
    the support points.

    Raises
    ------
    DegenerateGeometryError
        The narrowest zone is a strip / slab: no finite centre is better (points on a line or plane,
        or an arc so flat that a straight zone is narrower than every annulus).
    """
    dim = points.shape[1]
    size = float(np.sqrt(np.mean(np.einsum("nd,nd->n", points, points))))
    tie = _TIE * max(size, float(np.linalg.norm(seed)))
    distances = _distance(points, seed)
    best_width, best_centre = float(np.ptp(distances)), seed
    chosen = _seed_subset(distances, dim)
    first_new = 0
    candidates = _Candidates(dim)
    bound = 0.0
    support: IndexArray = chosen[np.array([int(np.argmax(distances[chosen])), int(np.argmin(distances[chosen]))])]
    rounds = 0
    for rounds in range(1, _MAX_ROUNDS + 1):  # noqa: B007 (reported after the loop)
        subset = points[chosen]
        candidates.extend(subset, first_new)
        candidates.keep_below(best_width)
        width_far, normal_far = minimum_width_small(subset) if len(subset) <= _SMALL[dim] else minimum_width(subset)
        values = candidates.far - candidates.near
        finite_low = float(values.min()) if values.size else np.inf
        bound = min(finite_low, width_far)
        if bound >= best_width - tie:
            break
        if width_far < finite_low:  # the subset's narrowest zone is a straight one (centre at infinity)
            along = points @ normal_far
            if float(np.ptp(along)) <= width_far + tie:
                shape = "circle" if dim == 2 else "sphere"
                raise DegenerateGeometryError(
                    element,
                    f"the minimum-zone {shape} runs off to an infinite radius: a straight zone of width "
                    f"{float(np.ptp(along)):.6g} mm is narrower than every {shape} zone (points nearly on a "
                    f"{'line' if dim == 2 else 'plane'})",
                )
            extremes = np.array([int(np.argmax(along)), int(np.argmin(along))])
        else:
            k = int(np.argmin(values))
            centre = candidates.centres[k]
            distances = _distance(points, centre)
            width = float(np.ptp(distances))
            if width < best_width:
                best_width, best_centre = width, centre
                support = chosen[np.unique(candidates.pairs[k])]
            if width <= values[k] + tie:
                break
            extremes = np.array([int(np.argmax(distances)), int(np.argmin(distances))])
        fresh = np.setdiff1d(extremes, chosen)
        if fresh.size == 0 or len(chosen) + fresh.size > _LARGEST[dim]:  # rounding stall, or too large a subset
            break
        first_new = len(chosen)
        chosen = np.concatenate([chosen, fresh])
    distances = _distance(points, best_centre)
    extremes = np.array([int(np.argmax(distances)), int(np.argmin(distances))])
    return ExactOptimum(
        x=best_centre,
        lower=float(distances.min()),
        upper=float(distances.max()),
        bound=min(bound, best_width),
        contacts=_contacts(distances, np.concatenate([support, extremes])),
        iterations=rounds,
        method="Voronoi-vertex candidates of a violator-grown subset",
    )


def enclosing_sphere(points: FloatArray, seed: FloatArray) -> ExactOptimum:
    """Global minimum circumscribed circle / sphere of centred ``(N, D)`` points (smallest enclosing ball)."""
    dim = points.shape[1]
    size = float(np.sqrt(np.mean(np.einsum("nd,nd->n", points, points))))
    tie = _TIE * max(size, float(np.linalg.norm(seed)))
    distances = _distance(points, seed)
    chosen = np.argsort(distances)[-(dim + 1) :]
    best_radius, best_centre, bound = np.inf, seed, 0.0
    support: IndexArray = chosen
    rounds = 0
    for rounds in range(1, _MAX_ROUNDS + 1):  # noqa: B007 (reported after the loop)
        centre, radius, on_sphere = enclosing_ball(points[chosen])
        if np.isfinite(radius):  # repeated sites leave no finite ball: no bound (issue 31 proved inf "exact")
            bound = max(bound, radius)
        distances = _distance(points, centre)
        reach = float(distances.max())
        if reach < best_radius:
            best_radius, best_centre, support = reach, centre, chosen[on_sphere]
        if reach <= radius + tie:
            break
        fresh = np.setdiff1d(np.argsort(distances)[-2:], chosen)
        if fresh.size == 0:
            break
        chosen = np.concatenate([chosen, fresh])
    distances = _distance(points, best_centre)
    return ExactOptimum(
        x=best_centre,
        lower=float(distances.min()),
        upper=float(distances.max()),
        bound=min(bound, best_radius),
        contacts={int(i): 1.0 for i in np.unique(np.append(support, int(np.argmax(distances))))},
        iterations=rounds,
        method="smallest enclosing ball of a violator-grown subset",
    )
