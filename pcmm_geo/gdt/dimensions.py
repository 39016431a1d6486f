"""Dimensions from features: linear coordinates in a DRF, distances and angles between features.

A feature's location and direction come from its least-squares association (ISO 14405-1 / ISO 17450:
the Gaussian feature, the CMM convention for coordinates and distances):

- cylinder: the axis's point at the nominal point's height along the nominal axis, and the axis;
- sphere: the centre; point: the mean of its points; plane: the points' centroid and the normal.

Distances: between two planes, the distance of the second's centroid from the first plane (along its
normal); otherwise between the locations.  Angles: between the two directions (normals / axes), in
[0, pi/2] for lines and [0, pi] between planes' normals oriented by their nominals.
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


def evaluate_distance(first: FeatureData, second: FeatureData, drf: DatumReferenceFrame, nominal_mm: float,
                      limits_mm: tuple[float, float], *, name: str = "") -> CharacteristicResult:
    """Distance between two features (see the module docstring), against ``nominal_mm`` and its deviations."""
    loc1, dir1 = feature_location(first, drf)
    loc2, _ = feature_location(second, drf)
    if first.element == "plane" and second.element == "plane":
        value = abs(float((loc2 - loc1) @ dir1))
    else:
        value = float(np.linalg.norm(loc2 - loc1))
    low, high = nominal_mm + limits_mm[0], nominal_mm + limits_mm[1]
    return CharacteristicResult(name or f"{first.name}-{second.name}", "distance", value, value, high - low, None,
                                _verdict(value, low, high), drf.datums, drf.standard,
                                {"nominal_mm": nominal_mm, "limits_mm": [low, high]})


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
