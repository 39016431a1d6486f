"""Coincident points merged before every minimax fit, and the answer mapped back to the caller's points.

A minimum zone, enclosing or inscribed element depends on the *set* of points, not on how often a
point was given: every point that coincides with another one (exactly, or within the merge tolerance
below) is one point of the problem.  The exact solvers need this -- a circumcentre of two equal points
is undefined, and a Voronoi diagram or a contact set with repeated sites is degenerate (issue 31: the
enclosing circle of points stacked three times came out twice too large) -- and it makes every answer
invariant under duplication.

Merge tolerance
---------------
``tolerance = 1e-13 * extent + 8 * eps * max|coordinate|`` (mm), ``extent`` the largest distance of a
point from the centroid and ``eps`` the machine epsilon.  The second term covers coordinates that differ
only by the rounding of a few arithmetic operations (a unit conversion, a frame change) at the data's
magnitude; the first keeps the tolerance negligible against the data: each distance a zone is built from
(to a centre, a plane, a line, an axis, a cone) moves by at most the distance a point moves, so merging
changes a zone width by at most twice the tolerance and a radius by at most once -- 2e-10 mm for data
1 m across, below the 1e-9 mm gap of a global certificate.  Groups are connected components of the
points within the tolerance of each other; a component wider than the tolerance (a chain) is split so
that every point lies within the tolerance of its group's first point.

The reported contacts are indices into the caller's array: the *first* (smallest) index of each merged
group; a merged point's residual is its group's (the members differ by at most the tolerance).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import DegenerateGeometryError
from pcmm_geo.fit._kernels._core import FitResult

FloatArray = NDArray[np.float64]
IndexArray = NDArray[np.intp]
ResultT = TypeVar("ResultT", bound=FitResult)

#: merge tolerance relative to the data's extent (largest distance from the centroid)
MERGE_RELATIVE = 1e-13
#: machine epsilons of the largest coordinate magnitude added to the merge tolerance (rounding)
MERGE_ULPS = 8.0
#: per-point arrays of a result (first axis: the points) that are mapped back to the caller's points
_PER_POINT = ("residuals", "residual_components")


def extent_of(points: FloatArray) -> float:
    """Largest distance of a point from the centroid (mm)."""
    centred = points - points.mean(axis=0)
    return float(np.sqrt(np.einsum("ij,ij->i", centred, centred).max()))


def merge_tolerance(points: FloatArray) -> float:
    """Distance (mm) within which two points are one point of a minimax problem (see the module notes)."""
    magnitude = float(np.abs(points).max()) if points.size else 0.0
    return MERGE_RELATIVE * extent_of(points) + MERGE_ULPS * float(np.finfo(float).eps) * magnitude


@record
class Distinct:
    """The distinct points of a point set.

    Attributes
    ----------
    points : ndarray, shape (M, D)
        One point per merged group, the group's first point, in the order of first occurrence (mm).
    first : ndarray of int, shape (M,)
        Caller's index of each distinct point (the smallest index of its group).
    group : ndarray of int, shape (N,)
        Row of ``points`` that each of the caller's points was merged into.
    tolerance : float
        The merge tolerance used (mm).
    """

    points: FloatArray
    first: IndexArray
    group: IndexArray
    tolerance: float

    @property
    def merged(self) -> bool:
        """Some points were merged (fewer distinct points than given)."""
        return len(self.first) < len(self.group)


def _components(points: FloatArray, tolerance: float) -> IndexArray:
    """Label of each point: the smallest index of its component of points within ``tolerance``."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    n = len(points)
    pairs = cKDTree(points).query_pairs(tolerance, output_type="ndarray")
    if not len(pairs):
        return np.arange(n, dtype=np.intp)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    first = np.full(labels.max() + 1, n, dtype=np.intp)
    np.minimum.at(first, labels, np.arange(n, dtype=np.intp))
    return first[labels]


def merge_duplicates(points: FloatArray) -> Distinct:
    """Merge the coincident points of ``(N, D)`` finite points (exact duplicates and those within the tolerance)."""
    n = len(points)
    tolerance = merge_tolerance(points)
    # exact copies first, by a stable sort of the rows (a point repeated k times would give k^2 / 2 pairs
    # to the tree), then the tolerance on the distinct rows
    order = np.lexsort(points.T[::-1])
    ordered = points[order]
    fresh = np.r_[True, np.any(ordered[1:] != ordered[:-1], axis=1)]  # first row of each run of equal rows
    label = np.empty(n, dtype=np.intp)
    label[order] = order[fresh][np.cumsum(fresh) - 1]  # the stable sort puts the smallest index first in a run
    todo = np.sort(order[fresh])
    while todo.size:
        local = _components(points[todo], tolerance)
        label[todo] = todo[local]
        # a chain of close points may span more than the tolerance: split off the members too far from the first
        far = np.linalg.norm(points[todo] - points[label[todo]], axis=1) > tolerance
        todo = todo[far]
    label = label[label]  # exact copies follow their row into its tolerance group
    first = np.flatnonzero(label == np.arange(n))
    position = np.zeros(n, dtype=np.intp)
    position[first] = np.arange(len(first))
    return Distinct(points=points[first], first=first, group=position[label], tolerance=tolerance)


def _expand(result: ResultT, distinct: Distinct) -> ResultT:
    """``result`` of the distinct points restated for the caller's points (per-point arrays, n, dof, contacts)."""
    if not distinct.merged:
        return result
    m, n = len(distinct.first), len(distinct.group)
    changes: dict[str, object] = {}
    for name in _PER_POINT:
        value = getattr(result, name, None)
        if isinstance(value, np.ndarray) and value.shape[:1] == (m,):
            changes[name] = value[distinct.group]
    extra = dict(result.extra)
    per_point = 1
    for name in _PER_POINT:
        value = extra.get(name)
        if isinstance(value, np.ndarray) and value.shape[:1] == (m,):
            extra[name] = value[distinct.group]
            if name == "residual_components" and value.ndim == 2:
                per_point = value.shape[1]
    residuals = changes["residuals"]
    assert isinstance(residuals, np.ndarray)
    changes.update(
        extra=extra,
        rms=float(np.sqrt(np.mean(residuals**2))),
        n=n,
        dof=result.dof + per_point * (n - m),
        contacts=distinct.first[result.contacts],
    )
    return dataclasses.replace(result, **changes)  # type: ignore[arg-type]


def on_distinct(
    points: FloatArray, *, element: str, min_points: int, solve: Callable[[FloatArray], ResultT]
) -> ResultT:
    """Solve a minimax fit on the distinct points, then restate it for ``points`` and check its certificate.

    ``solve`` maps distinct ``(M, D)`` points to the fit result; the answer's per-point arrays are
    indexed back to the caller's ``N`` points, its contacts are the first index of each merged group,
    and its certificate is checked independently on every one of the caller's points
    (:func:`pcmm_geo.fit.zone._check.apply_check`).

    Raises
    ------
    DegenerateGeometryError
        Fewer than ``min_points`` distinct points.
    """
    from pcmm_geo.fit.zone._check import apply_check

    distinct = merge_duplicates(points)
    if len(distinct.first) < min_points:
        raise DegenerateGeometryError(
            element,
            f"only {len(distinct.first)} distinct points among the {len(points)} given (points within "
            f"{distinct.tolerance:.3g} mm of each other are one point); the fit needs at least {min_points}",
        )
    result = _expand(solve(distinct.points), distinct)
    return apply_check(result, points, tolerance=distinct.tolerance)
