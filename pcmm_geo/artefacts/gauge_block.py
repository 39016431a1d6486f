"""Gauge block length from probed points: the ISO 3650 method, the seed's method and an exact projection.

Points are labelled by the face they were probed on:

* ``face_1``, ``face_2`` -- the two measuring faces (at least 3 points each),
* ``top`` and ``side`` -- two reference faces parallel to the block axis (optional for
  the ISO method; 3 points each are needed by the seed's method and the projection).

ISO 3650 method (:func:`measure_gauge_block`).  A least-squares (Gaussian) plane is fitted
to each measuring face.  The central length is the distance from the centre point of one
measuring face to the plane of the other; it is reported both ways (face 1 → plane 2 and
face 2 → plane 1) and as their mean.  The centre point of a face is taken as the centroid of
its probed points projected onto its fitted plane -- probe the faces symmetrically about
their centres.  The variation in length (ISO 3650: largest minus smallest length over the
measuring face) is evaluated over the probed points, as the range of the distances of the
points of one face from the plane of the other, when the face has at least 4 points.

Seed method (thesis eqs 5.1-5.3, :func:`seed_gauge_block_length`).  Top and side planes
through three points each (``n = (P1 − P2) × (P1 − P3)``, eq 5.1), the angle between them
``φ = atan(|n_T × n_S| / (n_T · n_S))`` (eq 5.2), the angles of the measuring vector ``v``
(one point on each measuring face) with the planes ``θ = asin(|n · v| / (|n| |v|))``
(eq 5.3) and the length ``L = |v| cos θ1 cos θ2``.

How the seed's method errs.  Write ``v`` in block axes as ``(L, Δy, Δz)`` (axis, side
normal, top normal).  With exact perpendicular planes ``sin θ1 = |Δz|/|v|``,
``sin θ2 = |Δy|/|v|``, so ``|v| cos θ1 cos θ2 = sqrt((|v|² − Δz²)(|v|² − Δy²)) / |v|``, i.e.
about ``L (1 + t_y² t_z² / (2 (1 + t_y² + t_z²)))`` with ``t = Δ/L``: the two cosines remove
the two lateral components one at a time and double-count their product.  The result is exact only when the
two probed points lie opposite each other in at least one lateral direction; it is 4.9 µm
too long for 10 mm offsets in both directions on a 100 mm block.  The block's rotation in
the machine (misalignment) itself does not enter with exact planes, but the 3-point planes
carry the full probing noise into the normals and the two single points carry it into
``v`` with no averaging, so the seed's length scatters with about ``σ √2`` where the ISO
method averages over all points of both faces.

Exact projection (:func:`projected_length`).  The block axis is ``e = n_T × n_S / |n_T × n_S|``,
the direction common to the top and side planes; ``L = |v · e|`` for any two points on the
measuring faces, whatever their lateral offset and whatever the angle between top and side.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._deprecation import renamed_fields
from pcmm_geo._records import record
from pcmm_geo.errors import DegenerateGeometryError, FileFormatError, InvalidInputError
from pcmm_geo.fit import as_points

__all__ = [
    "FACE_LABELS",
    "GaugeBlockMeasurement",
    "SeedGaugeBlockLength",
    "measure_gauge_block",
    "plane_from_three_points",
    "projected_length",
    "read_gauge_block_csv",
    "seed_gauge_block_length",
]

FloatArray = NDArray[np.float64]

#: Face labels understood by :func:`measure_gauge_block`.
FACE_LABELS = ("face_1", "face_2", "top", "side")


@dataclass(frozen=True)
class SeedGaugeBlockLength:
    """The seed's gauge block evaluation (eqs 5.1-5.3).

    Attributes
    ----------
    length : float
        ``|v| cos θ1 cos θ2`` (mm).
    phi : float
        Angle between top and side planes (rad), eq 5.2; π/2 for a perfect block.
    theta_top, theta_side : float
        Angles between ``v`` and the top / side planes (rad), eq 5.3.
    vector_length : float
        ``|v|``, the naive two-point distance (mm).
    """

    length: float
    phi: float
    theta_top: float
    theta_side: float
    vector_length: float


@renamed_fields(face_centres="face_centers")
@record
class GaugeBlockMeasurement:
    """Gauge block evaluation by the ISO 3650 method, with the seed's and the projection method.

    Attributes
    ----------
    central_length : float
        Mean of the two one-way central lengths (mm).
    length_face1_to_plane2, length_face2_to_plane1 : float
        Distance from the centre point of one measuring face to the plane of the other (mm).
    variation_in_length : float
        Largest range of point-to-opposite-plane distances over the probed points (mm);
        NaN when neither measuring face has 4 points.
    parallelism : float
        Angle between the two measuring-face normals (rad).
    face_form : tuple of float
        Flatness (max − min residual) of the fitted planes of face 1 and face 2 (mm).
    axis : ndarray, shape (3,)
        Unit direction face 1 → face 2 (mean of the measuring-face normals).
    face_centers : ndarray, shape (2, 3)
        Centre points used for faces 1 and 2 (mm).
    seed : SeedGaugeBlockLength or None
        The seed's method, when top and side faces have 3 points or more.
    projected_length : float
        Exact projection of the first-point vector onto the top × side direction (mm);
        NaN without top and side points.
    n_points : dict
        Points per face label.
    """

    central_length: float
    length_face1_to_plane2: float
    length_face2_to_plane1: float
    variation_in_length: float
    parallelism: float
    face_form: tuple[float, float]
    axis: FloatArray
    face_centers: FloatArray
    seed: SeedGaugeBlockLength | None
    projected_length: float
    n_points: dict[str, int]


def plane_from_three_points(points: ArrayLike) -> FloatArray:
    """Normal of the plane through the first three points, ``(P1 − P2) × (P1 − P3)`` (eq 5.1), not normalised.

    Parameters
    ----------
    points : array_like, shape (N, 3), N >= 3
        Only the first three rows are used, as in the seed.

    Returns
    -------
    ndarray, shape (3,)

    Raises
    ------
    TooFewPointsError
        Fewer than 3 points.
    DegenerateGeometryError
        Collinear first three points.

    Examples
    --------
    >>> plane_from_three_points([[0, 0, 0], [1, 0, 0], [0, 1, 0]]).tolist()
    [0.0, 0.0, 1.0]
    """
    pts = as_points(points, element="three-point plane", min_points=3)
    normal = np.cross(pts[0] - pts[1], pts[0] - pts[2])
    scale = np.linalg.norm(pts[0] - pts[1]) * np.linalg.norm(pts[0] - pts[2])
    if np.linalg.norm(normal) <= 1e-12 * max(scale, 1e-300):
        raise DegenerateGeometryError("three-point plane", "the first three points are collinear")
    return normal


def seed_gauge_block_length(
    top_points: ArrayLike,
    side_points: ArrayLike,
    point_face_1: ArrayLike,
    point_face_2: ArrayLike,
) -> SeedGaugeBlockLength:
    """Gauge block length by the seed's eqs 5.1-5.3 (two angles, two cosines).

    Parameters
    ----------
    top_points, side_points : array_like, shape (N, 3), N >= 3
        Points on the top and side faces; the first three define each plane.
    point_face_1, point_face_2 : array_like, shape (3,)
        One probed point on each measuring face (mm).

    Returns
    -------
    SeedGaugeBlockLength

    Raises
    ------
    TooFewPointsError, DegenerateGeometryError, InvalidInputError
        Too few or collinear plane points, coincident measuring points.

    Examples
    --------
    >>> top = [[0, 0, 4.5], [50, 0, 4.5], [0, 10, 4.5]]
    >>> side = [[0, 17.5, 0], [50, 17.5, 0], [0, 17.5, 3]]
    >>> res = seed_gauge_block_length(top, side, [0, 0, 0], [100, 0, 0])
    >>> round(res.length, 12), round(math.degrees(res.phi), 12)
    (100.0, 90.0)
    """
    n_top = plane_from_three_points(top_points)
    n_side = plane_from_three_points(side_points)
    p1 = as_points(np.reshape(point_face_1, (1, -1)), element="gauge block", name="point_face_1")[0]
    p2 = as_points(np.reshape(point_face_2, (1, -1)), element="gauge block", name="point_face_2")[0]
    v = p2 - p1
    v_len = float(np.linalg.norm(v))
    if v_len == 0:
        raise InvalidInputError("point_face_2", "a point distinct from point_face_1", f"{p2.tolist()}")
    phi = math.atan2(float(np.linalg.norm(np.cross(n_top, n_side))), float(n_top @ n_side))  # eq 5.2
    if phi > math.pi / 2:
        phi = math.pi - phi  # normals' signs are arbitrary with 3-point planes

    def angle(normal: FloatArray) -> float:  # eq 5.3
        return math.asin(min(1.0, abs(float(normal @ v)) / (float(np.linalg.norm(normal)) * v_len)))

    theta_top, theta_side = angle(n_top), angle(n_side)
    return SeedGaugeBlockLength(
        length=v_len * math.cos(theta_top) * math.cos(theta_side),
        phi=phi,
        theta_top=theta_top,
        theta_side=theta_side,
        vector_length=v_len,
    )


def _plane(points: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    from pcmm_geo.fit import fit_plane

    fit = fit_plane(points)
    return np.asarray(fit.point, dtype=float), np.asarray(fit.normal, dtype=float), np.asarray(fit.residuals)


def projected_length(
    top_points: ArrayLike,
    side_points: ArrayLike,
    point_face_1: ArrayLike,
    point_face_2: ArrayLike,
) -> float:
    """Length as ``|v · e|`` with ``e`` the unit direction common to the top and side planes.

    The planes are least-squares planes of all given points.  Exact for any two points on the
    measuring faces of a block whose measuring faces are perpendicular to the top-side edge.

    Parameters
    ----------
    top_points, side_points : array_like, shape (N, 3), N >= 3
    point_face_1, point_face_2 : array_like, shape (3,)

    Returns
    -------
    float
        Length (mm).

    Raises
    ------
    TooFewPointsError, DegenerateGeometryError
        Too few points, or parallel top and side planes.

    Examples
    --------
    >>> top = [[0, 0, 4.5], [50, 0, 4.5], [0, 10, 4.5]]
    >>> side = [[0, 17.5, 0], [50, 17.5, 0], [0, 17.5, 3]]
    >>> round(projected_length(top, side, [0, 3, 1], [100, -5, 2]), 12)
    100.0
    """
    top = as_points(top_points, element="plane", min_points=3, name="top_points")
    side = as_points(side_points, element="plane", min_points=3, name="side_points")
    _, n_top, _ = _plane(top)
    _, n_side, _ = _plane(side)
    axis = np.cross(n_top, n_side)
    norm = float(np.linalg.norm(axis))
    if norm < 1e-9:
        raise DegenerateGeometryError("gauge block", "top and side planes are parallel; no common direction")
    v = np.asarray(point_face_2, dtype=float) - np.asarray(point_face_1, dtype=float)
    return abs(float(v @ axis)) / norm


def measure_gauge_block(points_by_face: Mapping[str, ArrayLike]) -> GaugeBlockMeasurement:
    """Evaluate a gauge block from points labelled by face (ISO 3650 method, plus the seed's and the projection).

    Parameters
    ----------
    points_by_face : mapping str -> array_like (N, 3)
        ``face_1`` and ``face_2`` (>= 3 points each, mm) are required; ``top`` and ``side``
        (>= 3 points each) enable the seed's method and the projection.  The first point of
        each measuring face serves as the seed's single probing point.

    Returns
    -------
    GaugeBlockMeasurement

    Raises
    ------
    InvalidInputError
        Unknown face labels or a missing measuring face.
    TooFewPointsError
        Fewer than 3 points on a face that is given.
    DegenerateGeometryError
        Collinear face points, or measuring faces facing the same way.

    Examples
    --------
    >>> ys, zs = np.meshgrid([-10.0, 0.0, 10.0], [-3.0, 0.0, 3.0])
    >>> lateral = np.c_[ys.ravel(), zs.ravel()]
    >>> faces = {"face_1": np.c_[np.zeros(9), lateral], "face_2": np.c_[np.full(9, 100.0), lateral]}
    >>> round(measure_gauge_block(faces).central_length, 12)
    100.0
    """
    unknown = set(points_by_face) - set(FACE_LABELS)
    if unknown:
        raise InvalidInputError("face labels", f"labels among {FACE_LABELS}", f"{sorted(unknown)}")
    for required in ("face_1", "face_2"):
        if required not in points_by_face:
            raise InvalidInputError("points_by_face", "points for both measuring faces face_1 and face_2",
                                    f"no {required!r}")
    faces = {
        label: as_points(pts, element=f"gauge block {label}", min_points=3, name=label)
        for label, pts in points_by_face.items()
    }
    f1, f2 = faces["face_1"], faces["face_2"]
    point1, normal1, resid1 = _plane(f1)
    point2, normal2, resid2 = _plane(f2)
    # orient both normals face 1 -> face 2
    towards = f2.mean(axis=0) - f1.mean(axis=0)
    normal1 = normal1 if normal1 @ towards > 0 else -normal1
    normal2 = normal2 if normal2 @ towards > 0 else -normal2
    if normal1 @ normal2 <= 0:
        raise DegenerateGeometryError("gauge block", "the measuring faces are not facing each other")
    centre1 = f1.mean(axis=0) - float((f1.mean(axis=0) - point1) @ normal1) * normal1
    centre2 = f2.mean(axis=0) - float((f2.mean(axis=0) - point2) @ normal2) * normal2
    one_to_two = float((point2 - centre1) @ normal2)
    two_to_one = float((centre2 - point1) @ normal1)
    variations = []
    if len(f1) >= 4:
        d = (point2 - f1) @ normal2
        variations.append(float(d.max() - d.min()))
    if len(f2) >= 4:
        d = (f2 - point1) @ normal1
        variations.append(float(d.max() - d.min()))
    axis = normal1 + normal2
    axis /= np.linalg.norm(axis)
    seed = None
    projection = math.nan
    if "top" in faces and "side" in faces:
        seed = seed_gauge_block_length(faces["top"], faces["side"], f1[0], f2[0])
        projection = projected_length(faces["top"], faces["side"], f1[0], f2[0])
    return GaugeBlockMeasurement(
        central_length=0.5 * (one_to_two + two_to_one),
        length_face1_to_plane2=one_to_two,
        length_face2_to_plane1=two_to_one,
        variation_in_length=max(variations) if variations else math.nan,
        parallelism=float(math.atan2(np.linalg.norm(np.cross(normal1, normal2)), float(normal1 @ normal2))),
        face_form=(float(np.ptp(resid1)), float(np.ptp(resid2))),
        axis=axis,
        face_centers=np.vstack([centre1, centre2]),
        seed=seed,
        projected_length=projection,
        n_points={label: len(pts) for label, pts in faces.items()},
    )



def read_gauge_block_csv(path: str | Path) -> dict[str, FloatArray]:
    """Read a labelled ``face,x,y,z`` file (mm; ``face`` one of :data:`FACE_LABELS`) into points by face.

    Built on :func:`pcmm_geo.io.read_labelled_points`.

    Raises
    ------
    FileFormatError
        Missing columns, unknown face label, non-numeric coordinates.
    OSError
        Unreadable file.

    Examples
    --------
    >>> from importlib.resources import files
    >>> faces = read_gauge_block_csv(files("pcmm_geo") / "data/examples/gauge_block.csv")
    >>> sorted(faces)
    ['face_1', 'face_2', 'side', 'top']
    """
    from pcmm_geo.io.labelled import read_labelled_points

    found = read_labelled_points(path)
    for label, line in zip(found.labels, found.lines, strict=True):
        if label.lower() not in FACE_LABELS:
            raise FileFormatError(str(path), f"face: expected one of {', '.join(FACE_LABELS)}, got {label!r}", line)
    faces = np.array([label.lower() for label in found.labels])
    return {face: found.points[faces == face] for face in dict.fromkeys(faces.tolist())}
