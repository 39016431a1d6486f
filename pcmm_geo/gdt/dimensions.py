"""Dimensions from features: linear coordinates in a DRF, distances and angles between features.

A feature's location and direction come from its least-squares association (ISO 14405-1 / ISO 17450:
the Gaussian feature, the CMM convention for coordinates and distances):

- cylinder: the axis's point at the nominal point's height along the nominal axis, and the axis;
- sphere: the centre; point: the mean of its points; plane: the points' centroid and the normal.

Distances (:func:`evaluate_distance`; ISO 1101 / ISO 17450-1 derived features -- ISO 14405-2 calls a
distance between derived features ambiguous unless it is defined, so it is defined here).  Every
definition is invariant under a rigid motion of all the points (the part's pose):

- plane to anything: along the plane's least-squares normal (the first plane's when both are
  planes), from the plane's centroid to the other's location;
- axis to axis: with a DRF (datums), between the axes' points at their nominal points' heights
  along their nominal axes in the DRF -- the drawing's place, where the coordinates are taken
  too.  Without a DRF there is no nominal height to go to (measurement coordinates are the part's
  arbitrary pose), so the distance is taken between the two least-squares axes' points at the
  middle of their common extent: with ``u`` the normalised mean of the two axis directions and
  each axis's extent (its points' extent along it, as the toleranced axis) projected onto ``u``,
  the height ``h`` is the middle of the overlap of the two intervals (of the gap between them when
  they do not overlap), and each axis is cut by the plane ``x . u = h``.  For parallel axes both
  are the distance between the lines;
- axis to a centre or point: the distance of the point from the axis line;
- between centres and points: between the locations; a plane's location is its centroid and an
  axis's location (for a plane's distance to it) is the point defined above (without a DRF, the
  middle of its extent).

Angles: between the two directions (normals / axes), in [0, pi/2] for lines and [0, pi] between
planes' normals oriented by their nominals.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.gdt.characteristics import CharacteristicResult, FeatureData
from pcmm_geo.gdt.reference.frame import DatumReferenceFrame

__all__ = ["evaluate_angle", "evaluate_coordinate", "evaluate_distance", "feature_location"]

FloatArray = NDArray[np.float64]
_AXES = {"x": 0, "y": 1, "z": 2}


def feature_location(feature: FeatureData, drf: DatumReferenceFrame) -> tuple[FloatArray, FloatArray]:
    """Location (3,) and unit direction (3,) of ``feature`` in the DRF (direction NaN for a sphere / point)."""
    from pcmm_geo.fit import fit_cylinder, fit_plane, fit_sphere

    pts = drf.to_frame(feature.points)
    nan3 = np.full(3, np.nan)
    if feature.element == "cylinder":
        fit = fit_cylinder(pts, axis_hint=feature.direction)
        axis = np.asarray(fit.axis, dtype=float)
        axis = axis if axis @ feature.direction >= 0 else -axis
        base = np.asarray(fit.point, dtype=float)
        d = feature.direction / np.linalg.norm(feature.direction)
        t = float((feature.point - base) @ d) / float(axis @ d)
        return base + t * axis, axis
    if feature.element == "plane":
        fit = fit_plane(pts)
        normal = np.asarray(fit.normal, dtype=float)
        return pts.mean(axis=0), normal if normal @ feature.direction >= 0 else -normal
    if feature.element == "sphere":
        return np.asarray(fit_sphere(pts).center, dtype=float), nan3
    if feature.element == "point":
        return pts.mean(axis=0), nan3
    raise InvalidInputError(f"{feature.name}: element", "plane, cylinder, sphere or point", feature.element)


def _verdict(value: float, low: float, high: float) -> str:
    return "PASS" if low <= value <= high else "FAIL"


def evaluate_coordinate(feature: FeatureData, drf: DatumReferenceFrame, axis: str, nominal_mm: float,
                        limits_mm: tuple[float, float], *, name: str = "") -> CharacteristicResult:
    """Linear coordinate of a feature's location along a DRF axis (``"x"``, ``"y"``, ``"z"``).

    ``limits_mm`` are the lower and upper deviations from ``nominal_mm``.  The DRF must fix the translation
    along ``axis`` (else the coordinate cannot be placed: refused by name).
    """
    if axis not in _AXES:
        raise InvalidInputError("axis", "x, y or z", repr(axis))
    if f"t{axis}" in drf.free:
        raise InvalidInputError(f"{name or feature.name}: datums", f"a DRF that fixes the {axis} translation",
                                "+".join(drf.datums) or "none")
    location, _ = feature_location(feature, drf)
    value = float(location[_AXES[axis]])
    low, high = nominal_mm + limits_mm[0], nominal_mm + limits_mm[1]
    return CharacteristicResult(name or feature.name, f"coordinate {axis}", value, value, high - low, None,
                                _verdict(value, low, high), drf.datums, drf.standard,
                                {"nominal_mm": nominal_mm, "limits_mm": [low, high]})


def _derived(feature: FeatureData, drf: DatumReferenceFrame) -> tuple[FloatArray, FloatArray, FloatArray | None]:
    """A feature's location, direction (NaN for a centre / point) and, without datums, an axis's end points (2, 3).

    Without datums built only from the points' associations (no nominal height), so equivariant under
    rigid motions; with datums :func:`feature_location` (the axis at its nominal height in the DRF).
    """
    from pcmm_geo.gdt.characteristics import toleranced_axis

    if feature.element == "cylinder" and not drf.datums:
        ends, axis, _ = toleranced_axis(drf.to_frame(feature.points), feature, "ISO")  # least-squares axis
        return ends.mean(axis=0), axis, ends
    location, direction = feature_location(feature, drf)
    return location, direction, None


def _axis_to_axis(ends1: FloatArray, ends2: FloatArray) -> tuple[float, FloatArray]:
    """Distance of two axes (end points (2, 3) each) at the middle of their common extent, and that pair of points."""
    a1, a2 = ends1[1] - ends1[0], ends2[1] - ends2[0]
    a1, a2 = a1 / np.linalg.norm(a1), a2 / np.linalg.norm(a2)
    if a1 @ a2 < 0:
        a2, ends2 = -a2, ends2[::-1]
    u = (a1 + a2) / np.linalg.norm(a1 + a2)
    lo1, hi1 = sorted(ends1 @ u)
    lo2, hi2 = sorted(ends2 @ u)
    h = 0.5 * (max(lo1, lo2) + min(hi1, hi2))
    p1 = ends1[0] + (h - ends1[0] @ u) / (a1 @ u) * a1
    p2 = ends2[0] + (h - ends2[0] @ u) / (a2 @ u) * a2
    return float(np.linalg.norm(p2 - p1)), np.array([p1, p2])


def evaluate_distance(first: FeatureData, second: FeatureData, drf: DatumReferenceFrame, nominal_mm: float,
                      limits_mm: tuple[float, float], *, name: str = "") -> CharacteristicResult:
    """Distance between two features (the module docstring defines it), against ``nominal_mm`` and its deviations.

    A rigid motion of every point leaves the value unchanged.  Between two axes, ``drf`` with datums puts
    the axes' points at their nominal heights in it; without datums
    (:meth:`DatumReferenceFrame.measurement`) at the middle of the axes' common extent.
    ``details["definition"]`` names the definition used, ``details["between_mm"]`` the two points the distance
    is taken between (DRF coordinates) where it is between points.
    """
    loc1, dir1, ends1 = _derived(first, drf)
    loc2, dir2, ends2 = _derived(second, drf)
    between: FloatArray | None = None
    if first.element == "plane" or second.element == "plane":
        normal, origin, other = (dir1, loc1, loc2) if first.element == "plane" else (dir2, loc2, loc1)
        value = abs(float((other - origin) @ normal))
        definition = "along the plane's normal"
    elif ends1 is not None and ends2 is not None:
        value, between = _axis_to_axis(ends1, ends2)
        definition = "between the axes at the middle of their common extent"
    elif (first.element == "cylinder") != (second.element == "cylinder"):
        axis_loc, axis_dir, point = (loc1, dir1, loc2) if first.element == "cylinder" else (loc2, dir2, loc1)
        rel = point - axis_loc
        value = float(np.linalg.norm(rel - (rel @ axis_dir) * axis_dir))
        definition = "of the point from the axis"
    else:
        value = float(np.linalg.norm(loc2 - loc1))
        between = np.array([loc1, loc2])
        definition = "between the axes at their nominal heights in the DRF" if first.element == "cylinder" \
            else "between the locations"
    details: dict[str, object] = {"definition": definition}
    if between is not None:
        details["between_mm"] = between.tolist()
    low, high = nominal_mm + limits_mm[0], nominal_mm + limits_mm[1]
    return CharacteristicResult(name or f"{first.name}-{second.name}", "distance", value, value, high - low, None,
                                _verdict(value, low, high), drf.datums, drf.standard,
                                {"nominal_mm": nominal_mm, "limits_mm": [low, high], **details})


def evaluate_angle(first: FeatureData, second: FeatureData, nominal_rad: float, limits_rad: tuple[float, float],
                   *, name: str = "") -> CharacteristicResult:
    """Angle between two features' directions (radians; ``details`` add degrees for display).

    The result's ``value_mm`` / ``tolerance_mm`` fields carry radians here; ``details["unit"]`` says so
    and :meth:`CharacteristicResult.to_dict` reports them as ``value_rad`` / ``tolerance_rad``.
    """
    frame = DatumReferenceFrame.measurement()
    _, d1 = feature_location(first, frame)
    _, d2 = feature_location(second, frame)
    if not (np.all(np.isfinite(d1)) and np.all(np.isfinite(d2))):
        raise InvalidInputError(f"{name}: features", "planes or cylinders (features with a direction)",
                                f"{first.element}, {second.element}")
    cosine = float(np.clip(d1 @ d2, -1.0, 1.0))
    if "cylinder" in (first.element, second.element):
        cosine = abs(cosine)  # an axis has no sense
    value = float(np.arccos(cosine))
    low, high = nominal_rad + limits_rad[0], nominal_rad + limits_rad[1]
    return CharacteristicResult(name or f"{first.name}-{second.name}", "angle", value, value, high - low, None,
                                _verdict(value, low, high), (), "ISO",
                                {"unit": "rad", "value_deg": float(np.degrees(value)),
                                 "limits_deg": [float(np.degrees(low)), float(np.degrees(high))]})
