"""Closest points of straight lines in 3-D.

- :func:`closest_points` -- the common perpendicular of two lines (vectorised over
  leading batch dimensions), parallel lines included.
- :func:`nearest_point_to_lines` -- the point with the least sum of squared distances
  to K >= 2 lines: the general form of thesis eq 7.2, where the thesis minimised the
  squared distance between each pair of slider lines and averaged the pairwise results.
- :func:`pairwise_closest_points` -- :func:`closest_points` of chosen pairs of K lines;
  :func:`mean_pairwise_midpoint` -- the thesis' own form of eq 7.2, the average of the
  pairwise midpoints.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError, TooFewPointsError
from pcmm_geo.fit._kernels._core import TOL
from pcmm_geo.fit._kernels._linear import frozen

__all__ = [
    "LinePair",
    "LinesNearestPoint",
    "closest_points",
    "mean_pairwise_midpoint",
    "nearest_point_to_lines",
    "pairwise_closest_points",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class LinePair:
    """Closest points of two lines (all arrays share the batch shape ``...``).

    Attributes
    ----------
    point_a, point_b : ndarray, shape (..., 3)
        Closest point on line a and on line b (mm).
    distance : ndarray, shape (...)
        Length of the common perpendicular (mm); for parallel lines their separation.
    parameter_a, parameter_b : ndarray, shape (...)
        Positions of the closest points along each line, ``point + t * unit(direction)`` (mm).
    parallel : ndarray of bool, shape (...)
        True where the lines are parallel (closest points then not unique: the foot of
        ``point_a`` on line b is reported).
    """

    point_a: FloatArray
    point_b: FloatArray
    distance: FloatArray
    parameter_a: FloatArray
    parameter_b: FloatArray
    parallel: NDArray[np.bool_]

    @property
    def midpoint(self) -> FloatArray:
        """Midpoint of the common perpendicular, ``(..., 3)``."""
        return 0.5 * (self.point_a + self.point_b)


def _vectors(value: ArrayLike, name: str) -> FloatArray:
    arr = np.asarray(value, dtype=float)
    if arr.ndim < 1 or arr.shape[-1] != 3:
        raise InvalidInputError(name, "shape (..., 3)", f"shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(name, "finite coordinates", "NaN or inf")
    return arr


def _unit_directions(value: ArrayLike, name: str) -> FloatArray:
    arr = _vectors(value, name)
    norm = np.linalg.norm(arr, axis=-1, keepdims=True)
    if np.any(norm == 0):
        raise InvalidInputError(name, "non-zero direction vectors", "a zero vector")
    return arr / norm


def closest_points(
    point_a: ArrayLike, direction_a: ArrayLike, point_b: ArrayLike, direction_b: ArrayLike
) -> LinePair:
    """Closest points of line a (``point_a + t * direction_a``) and line b.

    Parameters
    ----------
    point_a, direction_a, point_b, direction_b : array_like, shape (..., 3)
        A point on each line and its direction (any non-zero length); batch shapes broadcast.

    Returns
    -------
    LinePair

    Raises
    ------
    InvalidInputError
        Wrong shapes, NaN/inf, or a zero direction.

    Examples
    --------
    >>> pair = closest_points([0, 0, 0], [1, 0, 0], [0, 0, 5], [0, 1, 0])
    >>> pair.point_a.tolist(), pair.point_b.tolist(), float(pair.distance)
    ([0.0, 0.0, 0.0], [0.0, 0.0, 5.0], 5.0)
    """
    pa, pb = _vectors(point_a, "point_a"), _vectors(point_b, "point_b")
    da, db = _unit_directions(direction_a, "direction_a"), _unit_directions(direction_b, "direction_b")
    offset = pb - pa
    cos_ab = np.sum(da * db, axis=-1)
    sin_sq = 1.0 - cos_ab**2
    along_a = np.sum(offset * da, axis=-1)
    along_b = np.sum(offset * db, axis=-1)
    parallel = sin_sq <= 1e-24
    safe = np.where(parallel, 1.0, sin_sq)
    t_a = np.where(parallel, 0.0, (along_a - cos_ab * along_b) / safe)
    t_b = np.where(parallel, -along_b, (cos_ab * along_a - along_b) / safe)
    foot_a = pa + t_a[..., None] * da
    foot_b = pb + t_b[..., None] * db
    return LinePair(
        point_a=foot_a,
        point_b=foot_b,
        distance=np.linalg.norm(foot_b - foot_a, axis=-1),
        parameter_a=t_a,
        parameter_b=t_b,
        parallel=np.asarray(parallel),
    )


@dataclass(frozen=True, eq=False)
class LinesNearestPoint:
    """Least-squares point nearest to several lines.

    Attributes
    ----------
    point : ndarray, shape (3,)
        The point minimising the (weighted) sum of squared distances to the lines (mm).
    distances : ndarray, shape (K,)
        Distance from ``point`` to each line (mm).
    feet : ndarray, shape (K, 3)
        Foot of the perpendicular from ``point`` on each line.
    rms : float
        Root mean square of ``distances``.
    condition_number : float
        Of the 3x3 normal matrix; large when the lines are nearly parallel.
    """

    point: FloatArray
    distances: FloatArray
    feet: FloatArray
    rms: float
    condition_number: float


def nearest_point_to_lines(
    points: ArrayLike, directions: ArrayLike, weights: ArrayLike | None = None
) -> LinesNearestPoint:
    """Point with the least (weighted) sum of squared distances to K >= 2 lines.

    Solves ``sum_k w_k (I - d_k d_k^T) x = sum_k w_k (I - d_k d_k^T) p_k`` (thesis eq 7.2
    generalised from line pairs to all lines at once).

    Parameters
    ----------
    points : array_like, shape (K, 3)
        A point on each line (mm).
    directions : array_like, shape (K, 3)
        Direction of each line (any non-zero length).
    weights : array_like, shape (K,), optional
        Non-negative weight of each line's squared distance.

    Returns
    -------
    LinesNearestPoint

    Raises
    ------
    InvalidInputError
        Shapes differ or are not (K, 3), NaN/inf, zero directions, bad weights.
    TooFewPointsError
        Fewer than 2 lines.
    DegenerateGeometryError
        All lines parallel: the point is not unique.

    Examples
    --------
    >>> result = nearest_point_to_lines([[0, 0, 1], [0, 0, -1]], [[1, 0, 0], [0, 1, 0]])
    >>> (result.point + 0.0).tolist(), result.distances.tolist()
    ([0.0, 0.0, 0.0], [1.0, 1.0])
    """
    p = _vectors(points, "points")
    d = _unit_directions(directions, "directions")
    if p.ndim != 2 or d.shape != p.shape:
        raise InvalidInputError("points/directions", "two arrays of shape (K, 3)", f"{p.shape} and {d.shape}")
    if len(p) < 2:
        raise TooFewPointsError("nearest point to lines", 2, len(p))
    w = np.ones(len(p)) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != (len(p),) or not np.all(np.isfinite(w)) or np.any(w < 0):
        raise InvalidInputError("weights", f"{len(p)} finite non-negative values", f"{np.asarray(weights)!r}")
    origin = p.mean(axis=0)
    rel = p - origin
    projectors = np.eye(3)[None] - d[:, :, None] * d[:, None, :]
    normal_matrix = np.einsum("k,kij->ij", w, projectors)
    rhs = np.einsum("k,kij,kj->i", w, projectors, rel)
    singular = np.linalg.svd(normal_matrix, compute_uv=False)
    if singular[-1] <= TOL.degenerate * singular[0]:
        raise DegenerateGeometryError("nearest point to lines", "all lines are parallel; the point is not unique")
    point = np.linalg.solve(normal_matrix, rhs)
    along = np.sum((point - rel) * d, axis=1)
    feet = rel + along[:, None] * d
    distances = np.linalg.norm(point - feet, axis=1)
    return LinesNearestPoint(
        point=frozen(point + origin),
        distances=frozen(distances),
        feet=frozen(feet + origin),
        rms=float(np.sqrt(np.mean(distances**2))),
        condition_number=float(singular[0] / singular[-1]),
    )


def _line_pairs(count: int, pairs: ArrayLike | None) -> NDArray[np.intp]:
    if pairs is None:
        return np.array([(i, j) for i in range(count) for j in range(i + 1, count)], dtype=np.intp).reshape(-1, 2)
    index = np.asarray(pairs)
    if index.ndim != 2 or index.shape[1] != 2 or index.shape[0] < 1 or not np.issubdtype(index.dtype, np.integer):
        raise InvalidInputError("pairs", "integer line indices of shape (P, 2)", f"{index!r}")
    if np.any(index < 0) or np.any(index >= count) or np.any(index[:, 0] == index[:, 1]):
        raise InvalidInputError("pairs", f"two different line indices in 0..{count - 1} per pair", f"{index.tolist()}")
    return index.astype(np.intp)


def pairwise_closest_points(points: ArrayLike, directions: ArrayLike, pairs: ArrayLike | None = None) -> LinePair:
    """Closest points of several pairs of K lines at once (:func:`closest_points` per pair).

    Parameters
    ----------
    points, directions : array_like, shape (K, 3)
        A point on each line (mm) and its direction (any non-zero length), K >= 2.
    pairs : array_like of int, shape (P, 2), optional
        Which lines to pair, as indices into ``points``; by default every pair ``i < j`` in
        lexicographic order (for three lines: 0-1, 0-2, 1-2).  The thesis' slider-line pairs
        a-b, b-c, c-a are ``[(0, 1), (1, 2), (2, 0)]``.

    Returns
    -------
    LinePair
        Batch shape ``(P,)``: ``point_a`` on the first line of each pair, ``point_b`` on
        the second, their ``distance`` (the skew distance) and the ``parallel`` flags.

    Raises
    ------
    InvalidInputError
        Shapes differ or are not (K, 3), NaN/inf, zero directions, bad pair indices.
    TooFewPointsError
        Fewer than 2 lines.

    Examples
    --------
    >>> pair = pairwise_closest_points([[0, 0, 1], [0, 0, -1], [5, 0, 0]], [[1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> pair.distance.round(12).tolist()  # pairs 0-1, 0-2 (they meet at (5, 0, 1)), 1-2
    [2.0, 0.0, 5.0]
    """
    p = _vectors(points, "points")
    d = _unit_directions(directions, "directions")
    if p.ndim != 2 or d.shape != p.shape:
        raise InvalidInputError("points/directions", "two arrays of shape (K, 3)", f"{p.shape} and {d.shape}")
    if len(p) < 2:
        raise TooFewPointsError("pairwise closest points of lines", 2, len(p))
    index = _line_pairs(len(p), pairs)
    return closest_points(p[index[:, 0]], d[index[:, 0]], p[index[:, 1]], d[index[:, 1]])


def mean_pairwise_midpoint(points: ArrayLike, directions: ArrayLike, pairs: ArrayLike | None = None) -> FloatArray:
    """Average of the midpoints of the common perpendiculars of pairs of lines.

    The thesis' theoretical probe point (section 7.2): eq 7.2 is minimised for every pair
    of slider lines and "the average between the three coordinates is taken"; here each
    pair contributes the midpoint of its common perpendicular.  For the least-squares point
    of all lines at once see :func:`nearest_point_to_lines`.

    Parameters
    ----------
    points, directions, pairs
        As for :func:`pairwise_closest_points`.

    Returns
    -------
    ndarray, shape (3,)
        The mean midpoint (mm).

    Raises
    ------
    DegenerateGeometryError
        Two paired lines are parallel (their midpoint is not unique).
    InvalidInputError, TooFewPointsError
        As for :func:`pairwise_closest_points`.

    Examples
    --------
    >>> lines = ([[0, 0, 1], [0, 0, -1], [5, 0, 0]], [[1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> (mean_pairwise_midpoint(*lines, pairs=[(0, 1), (1, 2), (2, 0)]).round(12) + 0.0).tolist()
    [2.5, 0.0, 0.0]
    """
    pair = pairwise_closest_points(points, directions, pairs)
    if np.any(pair.parallel):
        index = _line_pairs(len(np.asarray(points)), pairs)[np.asarray(pair.parallel)]
        raise DegenerateGeometryError(
            "pairwise midpoint of lines", f"lines {index.tolist()} are parallel; their midpoint is not unique"
        )
    return pair.midpoint.mean(axis=0)
