"""Segmentation of a scanned artefact into planes and cylinders.

Shapes are extracted one at a time from the points not yet explained:

- a **plane** candidate from open3d's RANSAC ``segment_plane``;
- a **cylinder** candidate from a RANSAC on open3d-estimated normals: two points with their
  normals define an axis direction (``n1 x n2``), the axis passes where the two normal
  lines meet, and the radius is the points' distance from it.

Both are scored by the points within ``distance_threshold`` of the surface whose normal
agrees within ``max_normal_angle``; the better one is fitted by Gaussian least squares
(:func:`~pcmm_geo.fit.fit_plane`, :func:`~pcmm_geo.fit.fit_cylinder`) and the points near the
fitted surface leave the pool.  At the end every point is given to the one surface it lies
within ``distance_threshold`` of; points near two surfaces (along edges) or none stay
unassigned, and each segment's parameters come from a final Gaussian fit of its points.
RANSAC only proposes inliers and starting values; it never provides a result.

Randomness is seeded (``seed`` drives numpy's generator and ``open3d.utility.random``), and
the segments come in a canonical order (largest first), so a seed gives the same result
even though open3d's RANSAC threads may meet equally good planes in either order.

Examples
--------
>>> import numpy as np
>>> rng = np.random.default_rng(1)
>>> floor = np.c_[rng.uniform(-30, 30, 600), rng.uniform(-30, 30, 600), np.zeros(600)]
>>> floor = floor[np.hypot(floor[:, 0], floor[:, 1]) > 6]
>>> angle, height = rng.uniform(0, 2 * np.pi, 400), rng.uniform(0.5, 20, 400)
>>> pin = np.c_[5 * np.cos(angle), 5 * np.sin(angle), height]
>>> result = segment_scan(np.vstack([floor, pin]), distance_threshold=0.01, seed=3)
>>> [s.kind for s in result.segments], round(result.cylinders[0].fit.radius, 9)
(['plane', 'cylinder'], 5.0)
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._optional import require
from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError, PcmmGeoError
from pcmm_geo.fit import as_points

if TYPE_CHECKING:
    from pcmm_geo.fit import CylinderFit, PlaneFit

__all__ = ["SEGMENT_KINDS", "Segment", "Segmentation", "estimate_normals", "segment_scan"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

SEGMENT_KINDS = ("plane", "cylinder")
#: two sampled normals closer to parallel than this (rad) cannot define a cylinder axis
_MIN_NORMAL_SPREAD = np.radians(3.0)
#: hypotheses scored at once (bounds memory to hypotheses x points x 3 doubles)
_HYPOTHESES_PER_BLOCK = 64
#: second RANSAC point drawn among this many nearest remaining neighbours (half the draws)
_LOCAL_NEIGHBOURS = 48
#: assignment / refit passes at the end
_ASSIGNMENT_PASSES = 4


@record
class Segment:
    """One surface found in a scan.

    Attributes
    ----------
    kind : str
        ``"plane"`` or ``"cylinder"``.
    indices : ndarray of int, shape (M,)
        Rows of the segmented points that belong to the surface.
    fit : PlaneFit or CylinderFit
        Gaussian least-squares fit of those points (``fit.residuals`` in the order of ``indices``).
    """

    kind: str
    indices: IntArray
    fit: PlaneFit | CylinderFit


@record
class Segmentation:
    """Result of :func:`segment_scan`.

    Attributes
    ----------
    segments : tuple of Segment
        Largest first (ties: planes before cylinders, then by the first point index).
    unassigned : ndarray of int
        Points near two surfaces (edges) or near none.
    point_count : int
        Number of points segmented.
    distance_threshold : float
        Inlier distance used (mm).
    max_normal_angle : float
        Normal agreement used while searching (rad).
    seed : int
    """

    segments: tuple[Segment, ...]
    unassigned: IntArray
    point_count: int
    distance_threshold: float
    max_normal_angle: float
    seed: int

    @property
    def planes(self) -> tuple[Segment, ...]:
        """The plane segments."""
        return tuple(s for s in self.segments if s.kind == "plane")

    @property
    def cylinders(self) -> tuple[Segment, ...]:
        """The cylinder segments."""
        return tuple(s for s in self.segments if s.kind == "cylinder")

    def labels(self) -> IntArray:
        """Segment number of every point (``-1`` for unassigned), shape (point_count,)."""
        labels = np.full(self.point_count, -1, dtype=np.int64)
        for number, segment in enumerate(self.segments):
            labels[segment.indices] = number
        return labels


def estimate_normals(points: ArrayLike, *, neighbours: int = 16) -> FloatArray:
    """Unit surface normals (N, 3) from the ``neighbours`` nearest points (open3d; sign arbitrary).

    Raises
    ------
    InvalidInputError
        Bad points or fewer than 3 neighbours.

    Examples
    --------
    >>> grid = np.c_[np.repeat(np.arange(5.0), 5), np.tile(np.arange(5.0), 5), np.zeros(25)]
    >>> np.abs(estimate_normals(grid, neighbours=8)[:, 2]).min()
    np.float64(1.0)
    """
    o3d = require("open3d")

    data = as_points(points, element="normals", min_points=3)
    if int(neighbours) < 3:
        raise InvalidInputError("neighbours", "at least 3", repr(neighbours))
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(data))
    cloud.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(int(neighbours)))
    return np.asarray(cloud.normals, dtype=float).copy()


@record
class _Candidate:
    kind: str
    inliers: IntArray  # rows of the full point array
    axis_hint: FloatArray | None


def segment_scan(
    points: ArrayLike,
    *,
    distance_threshold: float = 0.02,
    max_normal_angle: float = np.radians(20.0),
    min_points: int | None = None,
    max_segments: int = 20,
    kinds: tuple[str, ...] = SEGMENT_KINDS,
    iterations: int = 1000,
    neighbours: int = 16,
    seed: int = 0,
) -> Segmentation:
    """Split a scan into planes and cylinders, each fitted by Gaussian least squares.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Scanned points (mm).
    distance_threshold : float
        Largest distance (mm) of a point from a surface it belongs to; a few times the
        measurement noise plus the form error.
    max_normal_angle : float
        Largest angle (rad) between a point's estimated normal and the surface normal while
        searching (normals near edges are blurred, so those points are not used to choose).
    min_points : int, optional
        Smallest segment; default 1 % of the points, at least 20.
    max_segments : int
        Stop after this many segments.
    kinds : tuple of str
        Shapes searched for, from ``("plane", "cylinder")``.
    iterations : int
        RANSAC hypotheses per shape and round.
    neighbours : int
        Neighbours used to estimate each normal.
    seed : int
        Seed of all random draws.

    Returns
    -------
    Segmentation

    Raises
    ------
    InvalidInputError
        Bad points, a non-positive threshold or angle, an unknown kind.
    TooFewPointsError
        Fewer points than ``min_points``.

    Examples
    --------
    See the module docstring.
    """
    o3d = require("open3d")

    data = as_points(points, element="segmentation", min_points=3)
    if not np.isfinite(distance_threshold) or distance_threshold <= 0:
        raise InvalidInputError("distance_threshold", "a positive distance in mm", repr(distance_threshold))
    if not 0 < max_normal_angle < np.pi / 2:
        raise InvalidInputError("max_normal_angle", "an angle between 0 and pi/2 rad", repr(max_normal_angle))
    unknown = sorted(set(kinds) - set(SEGMENT_KINDS))
    if unknown or not kinds:
        raise InvalidInputError("kinds", f"a non-empty selection of {', '.join(SEGMENT_KINDS)}", repr(kinds))
    if min_points is None:
        min_points = max(20, round(0.01 * len(data)))
    min_points = max(int(min_points), 6)
    if len(data) < min_points:
        from pcmm_geo.errors import TooFewPointsError

        raise TooFewPointsError("segmentation", min_points, len(data))
    normals = estimate_normals(data, neighbours=neighbours)
    rng = np.random.default_rng(seed)
    o3d.utility.random.seed(int(seed))
    cos_limit = float(np.cos(max_normal_angle))
    max_radius = 0.5 * float(np.linalg.norm(np.ptp(data, axis=0)))

    fits: list[tuple[str, PlaneFit | CylinderFit]] = []
    remaining = np.arange(len(data))
    while len(fits) < max_segments and len(remaining) >= min_points:
        candidates = []
        if "plane" in kinds:
            candidates.append(_plane_candidate(data, normals, remaining, distance_threshold, cos_limit, iterations))
        if "cylinder" in kinds:
            candidates.append(_cylinder_candidate(data, normals, remaining, distance_threshold, cos_limit,
                                                  iterations, max_radius, rng))
        ranked = sorted((c for c in candidates if c is not None), key=lambda c: -len(c.inliers))
        fitted = None
        for candidate in ranked:
            if len(candidate.inliers) < min_points:
                break
            fitted = _fit(candidate.kind, data[candidate.inliers], candidate.axis_hint)
            if fitted is not None:
                kind = candidate.kind
                break
        if fitted is None:
            break
        near = _distance(kind, fitted, data[remaining]) <= distance_threshold
        if not near.any():
            break
        fits.append((kind, fitted))
        remaining = remaining[~near]
    return _assign(data, fits, distance_threshold, max_normal_angle, min_points, seed)


def _plane_candidate(
    data: FloatArray, normals: FloatArray, remaining: IntArray, threshold: float, cos_limit: float, iterations: int
) -> _Candidate | None:
    o3d = require("open3d")

    if len(remaining) < 3:
        return None
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(data[remaining]))
    model, inliers = cloud.segment_plane(distance_threshold=float(threshold), ransac_n=3,
                                         num_iterations=int(iterations))
    normal = np.asarray(model[:3], dtype=float)
    if len(inliers) == 0 or not np.linalg.norm(normal) > 0:
        return None
    normal /= np.linalg.norm(normal)
    rows = remaining[np.asarray(inliers, dtype=np.int64)]
    agree = np.abs(normals[rows] @ normal) >= cos_limit
    return _Candidate("plane", rows[agree], None)


def _cylinder_candidate(
    data: FloatArray,
    normals: FloatArray,
    remaining: IntArray,
    threshold: float,
    cos_limit: float,
    iterations: int,
    max_radius: float,
    rng: np.random.Generator,
) -> _Candidate | None:
    """Best of ``iterations`` cylinders through two points with their normals."""
    from scipy.spatial import cKDTree

    count = len(remaining)
    if count < 6:
        return None
    points, point_normals = data[remaining], normals[remaining]
    first = rng.integers(0, count, size=iterations)
    second = rng.integers(0, count, size=iterations)
    # half of the pairs are drawn close together: likelier to lie on the same surface
    local = np.arange(iterations) % 2 == 1
    neighbour_count = min(_LOCAL_NEIGHBOURS, count)
    _, nearest = cKDTree(points).query(points[first[local]], k=neighbour_count)
    nearest = np.asarray(nearest).reshape(int(local.sum()), neighbour_count)
    second[local] = nearest[np.arange(len(nearest)), rng.integers(0, neighbour_count, size=len(nearest))]

    p1, p2, n1, n2 = points[first], points[second], point_normals[first], point_normals[second]
    axis = np.cross(n1, n2)
    spread = np.linalg.norm(axis, axis=1)
    valid = spread >= np.sin(_MIN_NORMAL_SPREAD)
    axis[valid] /= spread[valid, None]
    # closest points of the normal lines p1 + s n1 and p2 + t n2 (unit n1, n2)
    cosine = np.einsum("ij,ij->i", n1, n2)
    gap = p1 - p2
    along1, along2 = np.einsum("ij,ij->i", n1, gap), np.einsum("ij,ij->i", n2, gap)
    denominator = np.where(valid, 1.0 - cosine**2, 1.0)
    s = (cosine * along2 - along1) / denominator
    t = (along2 - cosine * along1) / denominator
    axis_point = 0.5 * ((p1 + s[:, None] * n1) + (p2 + t[:, None] * n2))
    radius1 = np.linalg.norm(np.cross(p1 - axis_point, axis), axis=1)
    radius2 = np.linalg.norm(np.cross(p2 - axis_point, axis), axis=1)
    radius = 0.5 * (radius1 + radius2)
    valid &= (np.abs(radius1 - radius2) <= threshold) & (radius > threshold) & (radius < max_radius)
    hypotheses = np.flatnonzero(valid)
    if hypotheses.size == 0:
        return None

    best_count, best_mask, best_axis = -1, None, None
    for start in range(0, hypotheses.size, _HYPOTHESES_PER_BLOCK):
        block = hypotheses[start:start + _HYPOTHESES_PER_BLOCK]
        offset = points[None, :, :] - axis_point[block, None, :]
        along = np.einsum("hnj,hj->hn", offset, axis[block])
        radial = offset - along[..., None] * axis[block, None, :]
        distance = np.linalg.norm(radial, axis=2)
        with np.errstate(invalid="ignore", divide="ignore"):
            agreement = np.abs(np.einsum("hnj,nj->hn", radial, point_normals)) / distance
        mask = (np.abs(distance - radius[block, None]) <= threshold) & (agreement >= cos_limit)
        counts = mask.sum(axis=1)
        winner = int(np.argmax(counts))
        if counts[winner] > best_count:
            best_count, best_mask, best_axis = int(counts[winner]), mask[winner], axis[block[winner]]
    assert best_mask is not None  # at least one hypothesis was scored
    return _Candidate("cylinder", remaining[best_mask], best_axis)


def _fit(kind: str, points: FloatArray, axis_hint: FloatArray | None) -> PlaneFit | CylinderFit | None:
    """Gaussian fit of a candidate's points, or None when they do not determine the shape."""
    from pcmm_geo.fit import fit_cylinder, fit_plane

    try:
        if kind == "plane":
            return fit_plane(points)
        return fit_cylinder(points, axis_hint=axis_hint)
    except (PcmmGeoError, np.linalg.LinAlgError):
        return None


def _distance(kind: str, fit: PlaneFit | CylinderFit, points: FloatArray) -> FloatArray:
    """Unsigned distance of points from a fitted surface (mm)."""
    offset = points - fit.point
    if kind == "plane":
        return np.abs(offset @ fit.normal)  # type: ignore[union-attr]
    return np.abs(np.linalg.norm(np.cross(offset, fit.axis), axis=1) - fit.radius)  # type: ignore[union-attr]


def _assign(
    data: FloatArray,
    fits: list[tuple[str, PlaneFit | CylinderFit]],
    threshold: float,
    max_normal_angle: float,
    min_points: int,
    seed: int,
) -> Segmentation:
    """Give each point to the single surface it is near, refit, repeat until the labels settle."""
    labels = np.full(len(data), -1, dtype=np.int64)
    for _ in range(_ASSIGNMENT_PASSES):
        if not fits:
            break
        near = np.column_stack([_distance(kind, fit, data) <= threshold for kind, fit in fits])
        unique = near.sum(axis=1) == 1
        new_labels = np.where(unique, np.argmax(near, axis=1), -1)
        refitted: list[tuple[str, PlaneFit | CylinderFit]] = []
        kept_labels = np.full(len(data), -1, dtype=np.int64)
        for number, (kind, fit) in enumerate(fits):
            members = np.flatnonzero(new_labels == number)
            hint = getattr(fit, "axis", None)
            new_fit = _fit(kind, data[members], hint) if len(members) >= min_points else None
            if new_fit is not None:
                kept_labels[members] = len(refitted)
                refitted.append((kind, new_fit))
        settled = np.array_equal(kept_labels, labels) and len(refitted) == len(fits)
        fits, labels = refitted, kept_labels
        if settled:
            break
    found = [Segment(kind=kind, indices=np.flatnonzero(labels == number), fit=fit)
             for number, (kind, fit) in enumerate(fits)]
    # a canonical order: open3d's multi-threaded RANSAC may find equally good surfaces in either order
    segments = tuple(sorted(found, key=lambda s: (-len(s.indices), s.kind, int(s.indices[0]))))  # none is empty
    return Segmentation(
        segments=segments,
        unassigned=np.flatnonzero(labels == -1),
        point_count=len(data),
        distance_threshold=float(threshold),
        max_normal_angle=float(max_normal_angle),
        seed=int(seed),
    )
