"""Small geometric kernels of the tetrahedron calibration (thesis ch. 7).

Sphere fits of the probed joints and tip, least-squares lines through joint centers
(eq 7.1 generalised to more than two slider positions) and the angle between two arms
(eq 7.4 as corrected by erratum 6).

The geometry itself is :mod:`pcmm_geo.fit`'s: sphere fits are :func:`pcmm_geo.fit.fit_sphere`,
slider lines :func:`pcmm_geo.fit.fit_line`; closest points of slider lines, their skew
distances and the probe point of eq 7.2 are :mod:`pcmm_geo.fit.skew`
(:func:`~pcmm_geo.fit.skew.closest_points`, :func:`~pcmm_geo.fit.skew.nearest_point_to_lines`,
:func:`~pcmm_geo.fit.skew.mean_pairwise_midpoint`).  This module only adds what the
calibration calls these results: the CMM's view of a probed sphere and a slider line with
its straightness.

Examples
--------
>>> import numpy as np
>>> line = fit_center_line([[0, 0, 0], [1, 0, 0.001], [2, 0, 0]], what="a")
>>> (line.direction.round(6) + 0.0).tolist(), round(line.straightness, 6)
([1.0, 0.0, 0.0], 0.001333)
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._deprecation import module_aliases, renamed_fields, renamed_parameters
from pcmm_geo._records import record
from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError, TooFewPointsError
from pcmm_geo.fit.skew import angle_between as skew_angle_between

__all__ = [
    "FittedLine",
    "FittedSphere",
    "angle_between",
    "angle_between_deg",
    "fit_center_line",
    "fit_probed_sphere",
    "seed_printed_angle_deg",
]

FloatArray = NDArray[np.float64]


@renamed_fields(centre="center")
@record
class FittedSphere:
    """A probed sphere (joint or tip) as the external CMM reports it.

    Attributes
    ----------
    center : ndarray, shape (3,)
        Sphere center (mm).
    radius : float
        Radius (mm); NaN when only the center is known (element-level export without size).
    form : float
        Form error (max - min radial residual, mm; the export's roundness); NaN when unknown.
    n_points : int
        Number of probed points (0 when the center came from an element-level export).
    """

    center: FloatArray
    radius: float
    form: float
    n_points: int


@record
class FittedLine:
    """Least-squares 3-D line through sphere centers.

    Attributes
    ----------
    point : ndarray, shape (3,)
        Centroid of the centers (mm), on the line.
    direction : ndarray, shape (3,)
        Unit direction (sign chosen by the caller).
    straightness : float
        Max - min orthogonal distance of the centers from the line (mm); 0 for two centers.
    residuals : ndarray, shape (K,)
        Orthogonal distance of each center from the line (mm).
    """

    point: FloatArray
    direction: FloatArray
    straightness: float
    residuals: FloatArray


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
    >>> round(sphere.radius, 9), np.round(sphere.center, 9).tolist()
    (5.0, [7.0, 7.0, 7.0])
    """
    from pcmm_geo.fit import fit_sphere

    result = fit_sphere(points)
    return FittedSphere(
        center=np.asarray(result.center, dtype=float),
        radius=float(result.radius),
        form=float(result.form),
        n_points=int(result.n),
    )


@renamed_parameters(centres="centers")
def fit_center_line(centers: ArrayLike, *, what: str) -> FittedLine:
    """Least-squares line through two or more sphere centers (eq 7.1 for K = 2).

    Parameters
    ----------
    centers : array_like, shape (K, 3)
        Joint centers at the slider positions (mm), K >= 2, not all equal.
    what : str
        Name for error messages.

    Returns
    -------
    FittedLine
        Direction oriented from the first center towards the last one.

    Raises
    ------
    TooFewPointsError
        Fewer than two centers.
    DegenerateGeometryError
        All centers coincide, or three or more spread with no preferred direction
        (from :func:`pcmm_geo.fit.fit_line`).

    Examples
    --------
    >>> import numpy as np
    >>> line = fit_center_line([[0, 0, 0], [0, 0, 1], [0, 0, 2.0]], what="a")
    >>> bool(np.allclose(line.direction, [0, 0, 1])), round(line.straightness, 12) + 0.0
    (True, 0.0)
    """
    from pcmm_geo.fit import fit_line

    arr = np.asarray(centers, dtype=float)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise InvalidInputError(what, "centers of shape (K, 3)", f"shape {arr.shape}")
    if arr.shape[0] < 2:
        raise TooFewPointsError(f"slider line {what}", 2, arr.shape[0])
    if np.ptp(arr, axis=0).max() <= 1e-12 * max(1.0, float(np.abs(arr).max())):
        raise DegenerateGeometryError(f"slider line {what}", "all joint centres coincide")
    fitted = fit_line(arr)
    centroid = np.asarray(fitted.point, dtype=float)
    direction = np.asarray(fitted.direction, dtype=float)
    if direction @ (arr[-1] - arr[0]) < 0:
        direction = -direction
    offsets = arr - centroid
    perpendicular = offsets - (offsets @ direction)[:, None] * direction
    distances = np.linalg.norm(perpendicular, axis=1)
    # straightness: diameter of the cylinder about the fitted line that holds every center (fit_line's
    # 3-D form); two centers define the line, so it is 0 by definition rather than rounding noise
    straightness = 0.0 if arr.shape[0] == 2 else float(fitted.form)
    return FittedLine(point=centroid, direction=direction, straightness=straightness, residuals=distances)


def angle_between(vector_1: ArrayLike, vector_2: ArrayLike) -> FloatArray:
    """Angle between vectors in radians, eq 7.4 corrected (erratum 6): ``acos(P_i.P_in / (|P_i| |P_in|))``.

    Vectorised over leading dimensions ``(..., 3)``; computed by :func:`pcmm_geo.fit.skew.angle_between`
    as ``atan2(|a x b|, a.b)``.

    Examples
    --------
    >>> round(float(angle_between([1, 0, 0], [0, 1, 0])), 12)
    1.570796326795
    """
    return skew_angle_between(vector_1, vector_2)


def angle_between_deg(vector_1: ArrayLike, vector_2: ArrayLike) -> FloatArray:
    """Angle between vectors in degrees, eq 7.4 corrected (erratum 6): ``acos(P_i.P_in / (|P_i| |P_in|))``.

    Vectorised over leading dimensions ``(..., 3)``; the degrees of
    :func:`pcmm_geo.fit.skew.angle_between` (``atan2(|a x b|, a.b)``, accurate at all angles).

    Examples
    --------
    >>> float(angle_between_deg([1, 0, 0], [1, 1, 0]))
    45.0
    """
    return np.degrees(skew_angle_between(vector_1, vector_2))


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


__getattr__ = module_aliases(__name__, globals(), fit_centre_line="fit_center_line")
