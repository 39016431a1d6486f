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

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError, TooFewPointsError
from pcmm_geo.fit._kernels._core import as_weights
from pcmm_geo.fit._kernels._inputs import check_magnitude, real_array, weighted_centroid
from pcmm_geo.fit._kernels._linear import frozen

__all__ = [
    "LinePair",
    "angle_between",
    "LinesNearestPoint",
    "closest_points",
    "mean_pairwise_midpoint",
    "nearest_point_to_lines",
    "pairwise_closest_points",
]

FloatArray = NDArray[np.float64]


@record
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
    arr = real_array(value, name)
    if arr.ndim < 1 or arr.shape[-1] != 3:
        raise InvalidInputError(name, "shape (..., 3)", f"shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(name, "finite coordinates", "NaN or inf")
    check_magnitude(arr, name)
    return arr


def _unit_directions(value: ArrayLike, name: str) -> FloatArray:
    arr = _vectors(value, name)
    norm = np.linalg.norm(arr, axis=-1, keepdims=True)
    if np.any(norm == 0):
        raise InvalidInputError(name, "non-zero direction vectors", "a zero vector")
    return arr / norm


def _power_of_two_scaled(vectors: FloatArray, lengths: FloatArray) -> FloatArray:
    """``vectors`` times the power of two nearest ``1 / length`` (exact: no rounding of the direction)."""
    exponent = -np.round(np.log2(lengths))
    return np.ldexp(vectors, exponent.astype(int)[..., None])


def _two_product(a: FloatArray, b: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``a * b = product + error`` exactly (Dekker's splitting; no fused multiply-add needed)."""
    product = a * b
    split = 134217729.0  # 2^27 + 1
    a_big = split * a
    a_hi = a_big - (a_big - a)
    a_lo = a - a_hi
    b_big = split * b
    b_hi = b_big - (b_big - b)
    b_lo = b - b_hi
    error = ((a_hi * b_hi - product) + a_hi * b_lo + a_lo * b_hi) + a_lo * b_lo
    return product, error


def accurate_cross(first: FloatArray, second: FloatArray) -> FloatArray:
    """Cross product with each component correct to a few ulp, even under cancellation.

    Every component is a difference of two products; with the products' rounding errors
    kept (:func:`_two_product`) the difference of nearly equal products (nearly parallel
    vectors) is exact and the result relatively accurate.  The plain ``np.cross`` has an
    absolute error of ``eps |a| |b|``, i.e. a relative error ``eps / angle``.
    """
    out = np.empty(np.broadcast_shapes(first.shape, second.shape))
    for index, (i, j) in enumerate(((1, 2), (2, 0), (0, 1))):
        left, left_error = _two_product(first[..., i], second[..., j])
        right, right_error = _two_product(first[..., j], second[..., i])
        out[..., index] = (left - right) + (left_error - right_error)
    return out


def angle_between(first: ArrayLike, second: ArrayLike) -> FloatArray:
    """Angle between vectors in radians, in the closed interval from 0 to pi.

    Computed as ``atan2(|a x b|, a·b)``.  The one implementation of the vector angle in
    pcmm_geo (the arm angles of thesis eq 7.4, corrected by erratum 6, use it).  The ``atan2``
    form is accurate at every angle, where
    ``acos`` of the normalised dot product loses half the digits near 0 and pi; the cross
    product is the error-free one (:func:`accurate_cross`) of the vectors scaled by powers of
    two, so nearly parallel vectors keep a relatively accurate angle.

    Parameters
    ----------
    first, second : array_like, shape (..., 3)
        Non-zero vectors (any length); batch shapes broadcast.

    Returns
    -------
    ndarray, shape (...)
        Angles in radians.

    Raises
    ------
    InvalidInputError
        Not ``(..., 3)``, shapes that do not broadcast, NaN or inf, a zero vector.

    Examples
    --------
    >>> round(float(angle_between([1.0, 0.0, 0.0], [0.0, 2.0, 0.0])), 12)
    1.570796326795
    >>> angle_between([[1.0, 0.0, 0.0], [1.0, 1.0, 0.0]], [1.0, 0.0, 0.0]).round(12).tolist()
    [0.0, 0.785398163397]
    """
    a = _vectors(first, "first")
    b = _vectors(second, "second")
    try:
        np.broadcast_shapes(a.shape, b.shape)
    except ValueError:
        raise InvalidInputError("second", f"a shape that broadcasts with {a.shape}", f"{b.shape}") from None
    lengths_a = np.linalg.norm(a, axis=-1)
    lengths_b = np.linalg.norm(b, axis=-1)
    if np.any(lengths_a == 0) or np.any(lengths_b == 0):
        raise InvalidInputError("first/second", "non-zero vectors", "a zero vector")
    a = _power_of_two_scaled(a, lengths_a)
    b = _power_of_two_scaled(b, lengths_b)
    sine = np.linalg.norm(accurate_cross(a, b), axis=-1)
    return np.arctan2(sine, np.einsum("...i,...i->...", a, b))


#: Lines count as parallel when ``|unit(d_a) x unit(d_b)|`` is at the rounding level of the
#: cross product itself (a few ulp of 1): below it float64 cannot resolve their angle.
_PARALLEL_SINE = 8.0 * float(np.finfo(float).eps)


def closest_points(point_a: ArrayLike, direction_a: ArrayLike, point_b: ArrayLike, direction_b: ArrayLike) -> LinePair:
    r"""Closest points of line a (``point_a + t * direction_a``) and line b.

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
        Wrong or non-broadcasting shapes, complex or non-numeric values, NaN/inf, or a zero
        direction.

    See Also
    --------
    nearest_point_to_lines : the least-squares point of several lines
    pairwise_closest_points : many pairs at once

    Notes
    -----
    With ``n = d_a x d_b`` (unit directions), ``t_a = ((p_b - p_a) x d_b) . n / |n|^2`` and
    ``t_b = ((p_b - p_a) x d_a) . n / |n|^2``.  ``n`` is computed with error-free products
    (:func:`accurate_cross`), so it is relatively accurate however small the angle, and the
    directions are scaled only by powers of two: ``1 - cos^2`` would lose every digit near
    1e-8 rad, and even an eps-level rounding of the directions would move the closest points
    of lines ``s`` apart by ``s eps / angle^2`` (1 mm at 1e-8 rad, 1 mm apart).  What remains
    is the rounding of ``p_b - p_a``, about ``|p| eps / angle`` (1e-5 mm for points 500 mm
    from the origin at 1e-8 rad; see ``tests/fit/test_skew_precision.py``).  Lines are
    parallel only when ``n`` is exactly zero.

    In formulas, with :math:`\mathbf{n} = \mathbf{d}_a \times \mathbf{d}_b`,

    .. math::

        t_a = \frac{((\mathbf{p}_b - \mathbf{p}_a) \times \mathbf{d}_b) \cdot \mathbf{n}}{\lVert \mathbf{n} \rVert^2} ,
        \qquad
        t_b = \frac{((\mathbf{p}_b - \mathbf{p}_a) \times \mathbf{d}_a) \cdot \mathbf{n}}{\lVert \mathbf{n} \rVert^2} ,

    the minimiser of the squared distance between the two lines, eq 7.2 of the thesis [1]_.

    References
    ----------
    .. [1] *A critical investigation into the accuracy of a parallel mechanism coordinate measuring machine*,
           MEng (Mechatronic) thesis, Faculty of Engineering, Stellenbosch University ("the thesis"; the copy
           the project works from names neither author nor year). Section 7.2, eq 7.2.

    Examples
    --------
    >>> pair = closest_points([0, 0, 0], [1, 0, 0], [0, 0, 5], [0, 1, 0])
    >>> pair.point_a.tolist(), pair.point_b.tolist(), float(pair.distance)
    ([0.0, 0.0, 0.0], [0.0, 0.0, 5.0], 5.0)
    """
    pa, pb = _vectors(point_a, "point_a"), _vectors(point_b, "point_b")
    raw_a, raw_b = _vectors(direction_a, "direction_a"), _vectors(direction_b, "direction_b")
    length_a, length_b = np.linalg.norm(raw_a, axis=-1), np.linalg.norm(raw_b, axis=-1)
    if np.any(length_a == 0) or np.any(length_b == 0):
        which = "direction_a" if np.any(length_a == 0) else "direction_b"
        raise InvalidInputError(which, "non-zero direction vectors", "a zero vector")
    try:
        np.broadcast_shapes(pa.shape, raw_a.shape, pb.shape, raw_b.shape)
    except ValueError:
        raise InvalidInputError(
            "point_a, direction_a, point_b, direction_b",
            "shapes that broadcast to one batch shape (..., 3)",
            f"shapes {pa.shape}, {raw_a.shape}, {pb.shape}, {raw_b.shape}",
        ) from None
    # scale the directions by powers of two only (exact), so that the data's angle is kept
    da, db = _power_of_two_scaled(raw_a, length_a), _power_of_two_scaled(raw_b, length_b)
    offset = pb - pa
    # n = d_a x d_b to full relative accuracy even for nearly parallel lines (error-free
    # products): |n| is the sine of the angle, no 1 - cos^2 cancellation and no eps-level
    # direction error that the 1 / angle^2 sensitivity of skew lines would amplify
    normal = accurate_cross(da, db)
    sin_sq = np.sum(normal * normal, axis=-1)
    parallel = ~(sin_sq > 0)
    safe = np.where(parallel, 1.0, sin_sq)
    scale_a, scale_b = np.sum(da * da, axis=-1), np.sum(db * db, axis=-1)
    s_a = np.where(parallel, 0.0, np.sum(np.cross(offset, db) * normal, axis=-1) / safe)
    s_b = np.where(
        parallel, -np.sum(offset * db, axis=-1) / scale_b, np.sum(np.cross(offset, da) * normal, axis=-1) / safe
    )
    foot_a = pa + s_a[..., None] * da
    foot_b = pb + s_b[..., None] * db
    t_a, t_b = s_a * np.sqrt(scale_a), s_b * np.sqrt(scale_b)
    # the separation straight from the data (|offset . n| / |n|), not as a difference of two far feet
    skew_distance = np.abs(np.sum(offset * normal, axis=-1)) / np.sqrt(safe)
    parallel_distance = np.linalg.norm(np.cross(offset, db), axis=-1) / np.sqrt(scale_b)
    return LinePair(
        point_a=foot_a,
        point_b=foot_b,
        distance=np.where(parallel, parallel_distance, skew_distance),
        parameter_a=t_a,
        parameter_b=t_b,
        parallel=np.asarray(parallel),
    )


@record
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
        Of the stacked least-squares system (two rows across each line, weighted): about
        ``1 / angle`` for lines meeting at a small angle (rad); large when nearly parallel.
    """

    point: FloatArray
    distances: FloatArray
    feet: FloatArray
    rms: float
    condition_number: float


def nearest_point_to_lines(
    points: ArrayLike, directions: ArrayLike, weights: ArrayLike | None = None
) -> LinesNearestPoint:
    r"""Point with the least (weighted) sum of squared distances to K >= 2 lines.

    Minimises ``sum_k w_k |(I - d_k d_k^T)(x - p_k)|^2`` (thesis eq 7.2 generalised from line
    pairs to all lines at once).  The normal equations ``sum_k w_k (I - d_k d_k^T) x = ...``
    would square the condition number (lost accuracy for lines meeting at small angles);
    instead two orthonormal rows across each line are stacked and the ``2K x 3`` system is
    solved by SVD, with a rank test at float64 resolution: the lines are called parallel
    only when their angles cannot be resolved in float64.

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
        Shapes differ or are not (K, 3), NaN/inf, zero directions, bad weights (strings,
        negative, all zero).
    TooFewPointsError
        Fewer than 2 lines.
    DegenerateGeometryError
        All lines parallel within float64 resolution, or fewer than two lines with positive
        weight: the point is not unique.

    See Also
    --------
    closest_points : the closest points of two lines
    pcmm_geo.machine.calibration.tetrahedron.calibrate_tetrahedron : the probe point of the slider lines

    Notes
    -----
    The point minimises

    .. math::

        \sum_{k=1}^{K} w_k \, \lVert (I - \mathbf{d}_k \mathbf{d}_k^\mathsf{T})
        (\mathbf{x} - \mathbf{p}_k) \rVert^2 ,

    the sum over all lines of what eq 7.2 of the thesis [1]_ minimises for one pair of slider
    lines (the squared distance between points of the two lines).

    References
    ----------
    .. [1] *A critical investigation into the accuracy of a parallel mechanism coordinate measuring machine*,
           MEng (Mechatronic) thesis, Faculty of Engineering, Stellenbosch University ("the thesis"; the copy
           the project works from names neither author nor year). Section 7.2, eq 7.2.

    Examples
    --------
    >>> result = nearest_point_to_lines([[0, 0, 1], [0, 0, -1]], [[1, 0, 0], [0, 1, 0]])
    >>> (np.round(result.point, 12) + 0.0).tolist(), np.round(result.distances, 12).tolist()
    ([0.0, 0.0, 0.0], [1.0, 1.0])
    """
    p = _vectors(points, "points")
    d = _unit_directions(directions, "directions")
    if p.ndim != 2 or d.shape != p.shape:
        raise InvalidInputError("points/directions", "two arrays of shape (K, 3)", f"{p.shape} and {d.shape}")
    if len(p) < 2:
        raise TooFewPointsError("nearest point to lines", 2, len(p))
    w = np.ones(len(p)) if weights is None else as_weights(weights, len(p), element="nearest point to lines")
    if np.count_nonzero(w) < 2:
        raise DegenerateGeometryError(
            "nearest point to lines", "only one line has a positive weight; the point is not unique"
        )
    origin = weighted_centroid(p, w)
    rel = p - origin
    # two orthonormal rows across each line: |rows @ (x - p_k)| is the distance to line k, so
    # the stacked system's condition number is that of the geometry, not its square
    helper = np.zeros_like(d)
    helper[np.arange(len(d)), np.argmin(np.abs(d), axis=1)] = 1.0
    across_1 = np.cross(helper, d)
    across_1 /= np.linalg.norm(across_1, axis=1, keepdims=True)
    across_2 = np.cross(d, across_1)
    root = np.sqrt(w)[:, None, None]
    rows = np.stack([across_1, across_2], axis=1) * root  # (K, 2, 3)
    design = rows.reshape(-1, 3)
    target = np.einsum("kij,kj->ki", rows, rel).reshape(-1)
    u, singular, vt = np.linalg.svd(design, full_matrices=False)
    # rank test at the rounding level of the stacked rows (entries of size <= 1 per unit weight)
    if singular[-1] <= _PARALLEL_SINE * np.sqrt(len(p)) * singular[0]:
        raise DegenerateGeometryError(
            "nearest point to lines",
            f"all lines are parallel to within float64 resolution (relative singular value "
            f"{singular[-1] / singular[0]:.3g}); the point is not unique",
        )
    point = vt.T @ ((u.T @ target) / singular)
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
