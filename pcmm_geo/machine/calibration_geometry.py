"""Small geometric kernels of the tetrahedron calibration (thesis ch. 7).

Sphere fits of the probed joints and tip, least-squares lines through joint centres
(eq 7.1 generalised to more than two slider positions), closest points of skew lines
and the point nearest to several lines (eq 7.2), and the angle between two arms
(eq 7.4 as corrected by erratum 6).

Sphere and line fits delegate to :mod:`pcmm_geo.fit` (Gaussian fits); the line-pair
geometry is closed form and lives here because the seed's pairwise-average probe point
needs the individual closest points of each pair.

Examples
--------
>>> import numpy as np
>>> pair = closest_points_of_lines([0, 0, 0], [1, 0, 0], [0, 0, 2], [0, 1, 0])
>>> pair.distance, pair.on_first.tolist(), pair.on_second.tolist()
(2.0, [0.0, 0.0, 0.0], [0.0, 0.0, 2.0])
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError, TooFewPointsError

__all__ = [
    "FittedLine",
    "FittedSphere",
    "LinePairPoints",
    "angle_between_deg",
    "closest_points_of_lines",
    "fit_centre_line",
    "fit_probed_sphere",
    "nearest_point_to_lines",
    "pairwise_average_point",
    "seed_printed_angle_deg",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class FittedSphere:
    """A probed sphere (joint or tip) as the external CMM reports it.

    Attributes
    ----------
    centre : ndarray, shape (3,)
        Sphere centre (mm).
    radius : float
        Radius (mm); NaN when only the centre is known (element-level export without size).
    form : float
        Form error (max - min radial residual, mm; the export's roundness); NaN when unknown.
    n_points : int
        Number of probed points (0 when the centre came from an element-level export).
    """

    centre: FloatArray
    radius: float
    form: float
    n_points: int


@dataclass(frozen=True)
class FittedLine:
    """Least-squares 3-D line through sphere centres.

    Attributes
    ----------
    point : ndarray, shape (3,)
        Centroid of the centres (mm), on the line.
    direction : ndarray, shape (3,)
        Unit direction (sign chosen by the caller).
    straightness : float
        Max - min orthogonal distance of the centres from the line (mm); 0 for two centres.
    residuals : ndarray, shape (K,)
        Orthogonal distance of each centre from the line (mm).
    """

    point: FloatArray
    direction: FloatArray
    straightness: float
    residuals: FloatArray


@dataclass(frozen=True)
class LinePairPoints:
    """Closest points of two lines and their distance (mm)."""

    on_first: FloatArray
    on_second: FloatArray
    distance: float

    @property
    def midpoint(self) -> FloatArray:
        """Midpoint of the common perpendicular, shape (3,)."""
        return 0.5 * (self.on_first + self.on_second)


def fit_probed_sphere(points: ArrayLike, *, what: str) -> FittedSphere:
    """Gaussian sphere fit of probed points (at least 4, the seed probed >= 5).

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Probed points on the sphere (mm), N >= 4.
    what : str
        Feature name for error messages (``"joint_a position 1"``).

    Returns
    -------
    FittedSphere

    Raises
    ------
    TooFewPointsError, InvalidInputError, DegenerateGeometryError
        From :func:`pcmm_geo.fit.fit_sphere`.

    Examples
    --------
    >>> import numpy as np
    >>> pts = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1.0]]) * 5 + 7
    >>> sphere = fit_probed_sphere(pts, what="tip")
    >>> round(sphere.radius, 9), np.round(sphere.centre, 9).tolist()
    (5.0, [7.0, 7.0, 7.0])
    """
    from pcmm_geo.fit import fit_sphere

    result = fit_sphere(points)
    return FittedSphere(
        centre=np.asarray(result.center, dtype=float),
        radius=float(result.radius),
        form=float(result.form),
        n_points=int(result.n),
    )


def fit_centre_line(centres: ArrayLike, *, what: str) -> FittedLine:
    """Least-squares line through two or more sphere centres (eq 7.1 for K = 2).

    Parameters
    ----------
    centres : array_like, shape (K, 3)
        Joint centres at the slider positions (mm), K >= 2, not all equal.
    what : str
        Name for error messages.

    Returns
    -------
    FittedLine
        Direction oriented from the first centre towards the last one.

    Raises
    ------
    TooFewPointsError
        Fewer than two centres.
    DegenerateGeometryError
        All centres coincide.

    Examples
    --------
    >>> import numpy as np
    >>> line = fit_centre_line([[0, 0, 0], [0, 0, 1], [0, 0, 2.0]], what="a")
    >>> bool(np.allclose(line.direction, [0, 0, 1])), round(line.straightness, 12) + 0.0
    (True, 0.0)
    """
    arr = np.asarray(centres, dtype=float)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise InvalidInputError(what, "centres of shape (K, 3)", f"shape {arr.shape}")
    if arr.shape[0] < 2:
        raise TooFewPointsError(f"slider line {what}", 2, arr.shape[0])
    centroid = arr.mean(axis=0)
    _, sing, vt = np.linalg.svd(arr - centroid, full_matrices=False)
    if sing[0] <= 1e-12 * max(1.0, float(np.abs(arr).max())):
        raise DegenerateGeometryError(f"slider line {what}", "all joint centres coincide")
    direction = vt[0]
    if direction @ (arr[-1] - arr[0]) < 0:
        direction = -direction
    offsets = arr - centroid
    along = offsets @ direction
    perpendicular = offsets - along[:, None] * direction
    distances = np.linalg.norm(perpendicular, axis=1)
    # straightness: diameter of the cylinder about the fitted line that holds every centre
    straightness = 0.0 if arr.shape[0] == 2 else float(2.0 * distances.max())
    return FittedLine(point=centroid, direction=direction, straightness=straightness, residuals=distances)


def closest_points_of_lines(
    point_1: ArrayLike, direction_1: ArrayLike, point_2: ArrayLike, direction_2: ArrayLike
) -> LinePairPoints:
    """Closest points of two 3-D lines ``p1 + s d1`` and ``p2 + t d2`` (minimiser of eq 7.2).

    Raises
    ------
    DegenerateGeometryError
        Parallel lines (the common perpendicular is not unique).

    Examples
    --------
    >>> closest_points_of_lines([0, 0, 0], [1, 0, 0], [5, 3, 1], [0, 1, 0]).on_second.tolist()
    [5.0, 0.0, 1.0]
    """
    p1, d1 = np.asarray(point_1, float), np.asarray(direction_1, float)
    p2, d2 = np.asarray(point_2, float), np.asarray(direction_2, float)
    d1 = d1 / np.linalg.norm(d1)
    d2 = d2 / np.linalg.norm(d2)
    offset = p1 - p2
    cos_angle = float(d1 @ d2)
    denom = 1.0 - cos_angle**2
    if denom < 1e-14:
        raise DegenerateGeometryError("line pair", "the lines are parallel")
    along_1 = (cos_angle * (d2 @ offset) - (d1 @ offset)) / denom
    along_2 = ((d2 @ offset) - cos_angle * (d1 @ offset)) / denom
    on_1 = p1 + along_1 * d1
    on_2 = p2 + along_2 * d2
    return LinePairPoints(on_first=on_1, on_second=on_2, distance=float(np.linalg.norm(on_1 - on_2)))


def nearest_point_to_lines(points: ArrayLike, directions: ArrayLike) -> FloatArray:
    """Point minimising the sum of squared distances to K >= 2 lines (eq 7.2 generalised).

    Solves ``sum_k (I - d_k d_k^T) x = sum_k (I - d_k d_k^T) p_k``.

    Parameters
    ----------
    points, directions : array_like, shape (K, 3)
        A point on each line and its direction (any length).

    Returns
    -------
    ndarray, shape (3,)

    Raises
    ------
    DegenerateGeometryError
        All lines parallel.

    Examples
    --------
    >>> nearest_point_to_lines([[0, 0, 1], [0, 0, -1]], [[1, 0, 0], [0, 1, 0]]).tolist()
    [0.0, 0.0, 0.0]
    """
    pts = np.asarray(points, dtype=float)
    dirs = np.asarray(directions, dtype=float)
    dirs = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    projectors = np.eye(3)[None] - dirs[:, :, None] * dirs[:, None, :]
    normal_matrix = projectors.sum(axis=0)
    rhs = np.einsum("kij,kj->i", projectors, pts)
    sing = np.linalg.svd(normal_matrix, compute_uv=False)
    if sing[-1] < 1e-12 * sing[0]:
        raise DegenerateGeometryError("nearest point to lines", "the lines are all parallel")
    return np.linalg.solve(normal_matrix, rhs)


def pairwise_average_point(points: Sequence[ArrayLike], directions: Sequence[ArrayLike]) -> FloatArray:
    """The seed's theoretical probe point: average of the pairwise closest-point midpoints.

    Section 7.2: eq 7.2 is minimised for every pair of slider lines (a-b, b-c, c-a) and
    "the average between the three coordinates is taken".  We take, for each pair, the
    midpoint of the common perpendicular and average the three midpoints.

    Examples
    --------
    >>> point = pairwise_average_point([[0, 0, 1], [0, 0, -1], [5, 0, 0]], [[1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> (point.round(6) + 0.0).tolist()
    [2.5, 0.0, 0.0]
    """
    count = len(points)
    midpoints = [
        closest_points_of_lines(points[i], directions[i], points[(i + 1) % count], directions[(i + 1) % count]).midpoint
        for i in range(count)
    ]
    return np.mean(midpoints, axis=0)


def angle_between_deg(vector_1: ArrayLike, vector_2: ArrayLike) -> FloatArray:
    """Angle between vectors in degrees, eq 7.4 corrected (erratum 6): ``acos(P_i.P_in / (|P_i| |P_in|))``.

    Vectorised over leading dimensions ``(..., 3)``; uses ``atan2(|a x b|, a.b)`` which is
    accurate at all angles and equals the arccos form.

    Examples
    --------
    >>> float(angle_between_deg([1, 0, 0], [1, 1, 0]))
    45.0
    """
    a = np.asarray(vector_1, dtype=float)
    b = np.asarray(vector_2, dtype=float)
    cross = np.linalg.norm(np.cross(a, b), axis=-1)
    dot = np.einsum("...i,...i->...", a, b)
    return np.degrees(np.arctan2(cross, dot))


def seed_printed_angle_deg(vector_1: ArrayLike, vector_2: ArrayLike) -> FloatArray:
    """Eq 7.4 exactly as printed: ``acos(P_i.P_in / |P_i - P_in|)`` in degrees (erratum 6).

    Kept only to document the erratum: the printed quotient is not a cosine (it has units
    of length and exceeds 1 for the seed's arms), so the result is NaN wherever
    ``|P_i.P_in| > |P_i - P_in|``.  Appendix C's ``angles`` function uses the correct form.

    Examples
    --------
    >>> bool(np.isnan(seed_printed_angle_deg([400.0, 0, 0], [150.0, 370.0, 0])))
    True
    """
    a = np.asarray(vector_1, dtype=float)
    b = np.asarray(vector_2, dtype=float)
    quotient = np.einsum("...i,...i->...", a, b) / np.linalg.norm(a - b, axis=-1)
    with np.errstate(invalid="ignore"):
        return np.degrees(np.arccos(np.where(np.abs(quotient) <= 1.0, quotient, np.nan)))
