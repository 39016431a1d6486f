"""Geometric characteristics from measured points in a datum reference frame (ISO 1101:2017, ASME Y14.5-2018).

Definitions (one per clause and standard; ``docs/guide/gdt.md`` has the table):

- **toleranced axis** of a cylinder: ISO 1101 / ISO 17450-3: the median line, approximated by the axis of
  the associated least-squares cylinder over the points' extent along it (its two end points);
  ASME: the axis of the unrelated actual mating envelope (MIC of a hole, MCC of a shaft), same extent;
- **orientation** (parallelism, perpendicularity, angularity; ISO 1101 clauses 18.9-18.11): the zone
  has the nominal orientation in the DRF and floats in every translation; a plane's value is the
  distance between two parallel planes of that orientation containing its points, an axis's the
  diameter of the cylinder (``dia``) or the width of the planes holding its end points.  When the DRF
  leaves a rotation free, the zone turns about it to its narrowest (branch and bound over the angle
  with a Lipschitz bound: value and proven lower bound);
- **position** (ISO 1101 18.12; ASME 10.5): twice the largest distance of the axis's end points (or of the
  centre / point) from the true position, minimised over the translations and rotations the DRF leaves
  free (to first order in the rotation); MMC adds the bonus from the actual mating size (hole: MIC,
  shaft: MCC), LMC from the actual minimum material size (hole: MCC, shaft: MIC).  A size outside its
  limits is FAIL, never a negative bonus;
- **flatness**: the minimum zone (:func:`pcmm_geo.fit.zone.evaluate_form`);
- **runout** (ISO 1101 18.16-18.17): radial: spread of the distances from the DRF's z axis (total: all
  points; circular: per cross-section, the points' heights rounded to 1 µm); axial: spread of the heights.

Verdicts: ``PASS`` when the value (of a zone that contains every point) is within the tolerance plus a
proven bonus; ``FAIL`` when a proven lower bound of the value exceeds the largest possible allowance
(or the size is outside its limits); otherwise ``NOT PROVEN``.  No measurement uncertainty is included.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.gdt._sizes import allowed_zone, size_evaluation
from pcmm_geo.gdt.reference._floating import float_position, minimise_angle
from pcmm_geo.gdt.reference.frame import DatumReferenceFrame

__all__ = [
    "CharacteristicResult",
    "apply_uncertainty",
    "FeatureData",
    "evaluate_flatness",
    "evaluate_orientation",
    "evaluate_position",
    "evaluate_runout",
    "size_evaluation",
    "toleranced_axis",
]

FloatArray = NDArray[np.float64]
_UNIT = {"x": np.array([1.0, 0, 0]), "y": np.array([0, 1.0, 0]), "z": np.array([0, 0, 1.0])}


@record
class FeatureData:
    """A toleranced feature: its points (measurement coordinates) and nominal (DRF coordinates).

    Attributes
    ----------
    name : str
    element : {"plane", "cylinder", "sphere", "point", "surface"}
    points : ndarray, shape (N, 3)
        Measured points, mm, measurement coordinates.
    point : ndarray, shape (3,)
        Nominal point of the plane / axis, or centre, DRF coordinates, mm.
    direction : ndarray, shape (3,)
        Nominal outward normal (plane) or axis (cylinder), unit, DRF coordinates; NaN otherwise.
    side : {"internal", "external"}
        Material side of a feature of size (hole: internal).
    diameter : float
        Nominal diameter, mm (NaN when not a feature of size).
    size_tolerance : tuple of float
        Lower and upper deviations of the size, mm.
    nominal_points, nominal_normals : ndarray, shape (M, 3), optional
        A ``"surface"`` (profile): the nominal surface's points and outward normals, DRF coordinates.
    nominal_mesh : SurfaceIndex, optional
        A ``"surface"`` (profile) given by a closed mesh instead, DRF coordinates
        (:func:`pcmm_geo.gdt.profile.read_nominal_mesh`).
    point_u_mm : float or ndarray of shape (N,), optional
        Standard uncertainty of each point's coordinates (mm, per axis, uncorrelated), when known: the
        characteristics' U is then propagated from it (:mod:`pcmm_geo.gdt.propagation`).
    """

    name: str
    element: str
    points: FloatArray
    point: FloatArray
    direction: FloatArray
    side: str = "external"
    diameter: float = float("nan")
    size_tolerance: tuple[float, float] = (0.0, 0.0)
    nominal_points: FloatArray | None = None
    nominal_normals: FloatArray | None = None
    nominal_mesh: Any = None
    point_u_mm: float | FloatArray | None = None


@dataclass(frozen=True)
class CharacteristicResult:
    """A characteristic's value and verdict.

    Attributes
    ----------
    name : str
    characteristic : str
        ``"position"``, ``"perpendicularity"`` ...
    value_mm : float
        Value of a zone that contains the feature (mm).
    bound_mm : float
        Proven lower bound of the value (= ``value_mm`` when exact), mm.
    tolerance_mm : float
    bonus_mm : float or None
        Bonus from a material condition modifier (None without one).
    verdict : {"PASS", "FAIL", "NOT PROVEN"}
    datums : tuple of str
    standard : str
    details : dict
        Sizes, end points, the reason of a FAIL on size, ...
    """

    name: str
    characteristic: str
    value_mm: float
    bound_mm: float
    tolerance_mm: float
    bonus_mm: float | None
    verdict: str
    datums: tuple[str, ...]
    standard: str
    details: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready record (``bonus_mm`` only where a modifier applies; an angle's values as ``*_rad``)."""
        unit = self.details.get("unit", "mm")
        bound = self.bound_mm if np.isfinite(self.bound_mm) else None
        out: dict[str, Any] = {"name": self.name, "characteristic": self.characteristic, f"value_{unit}": self.value_mm,
                               f"bound_{unit}": bound, f"tolerance_{unit}": self.tolerance_mm,
                               "verdict": self.verdict, "datums": list(self.datums), "standard": self.standard}
        if self.bonus_mm is not None:
            out["bonus_mm"] = self.bonus_mm
        out.update({k: v for k, v in self.details.items() if k != "unit"})
        return out


def decide(value: float, bound: float, allowed_low: float, allowed_high: float) -> str:
    """PASS when ``value <= allowed_low``; FAIL when ``bound > allowed_high``; else NOT PROVEN."""
    if value <= allowed_low:
        return "PASS"
    if np.isfinite(bound) and bound > allowed_high:
        return "FAIL"
    return "NOT PROVEN"


def _free_axes(drf: DatumReferenceFrame) -> tuple[list[FloatArray], list[FloatArray]]:
    """DRF unit vectors of the free translations and of the free rotation axes."""
    trans = [_UNIT[n[1]] for n in drf.free if n.startswith("t")]
    rots = [_UNIT[n[1]] for n in drf.free if n.startswith("r")]
    return trans, rots


def _rotate(v: FloatArray, axis: FloatArray, theta: float) -> FloatArray:
    c, s = np.cos(theta), np.sin(theta)
    return v * c + np.cross(axis, v) * s + axis * (axis @ v) * (1 - c)


def toleranced_axis(points: FloatArray, feature: FeatureData, standard: str) -> tuple[FloatArray, FloatArray, Any]:
    """End points (2, 3) of the toleranced axis over the points' extent, its direction and the fit.

    ``points`` in DRF coordinates.  ISO: least-squares cylinder; ASME: unrelated actual mating
    envelope (MIC for a hole, MCC for a shaft).
    """
    from pcmm_geo.fit import fit_cylinder

    if standard == "ASME":
        fit = fit_cylinder(points, criterion="mic" if feature.side == "internal" else "mcc")
    else:
        fit = fit_cylinder(points, axis_hint=feature.direction)
    axis = np.asarray(fit.axis, dtype=float)
    if axis @ feature.direction < 0:
        axis = -axis
    base = np.asarray(fit.point, dtype=float)
    heights = (points - base) @ axis
    ends = base + np.outer([heights.min(), heights.max()], axis)
    return ends, axis, fit


def _position_targets(feature: FeatureData, drf: DatumReferenceFrame, name: str,
                      zone: str, fitted: dict[str, Any] | None = None) -> tuple[FloatArray, FloatArray]:
    """What a position zone holds, DRF coordinates: an axis's end points, a centre, a point, a plane's points;
    and the projection (3, 3) onto the zone's cross-section.  ``fitted`` (a dict) receives a cylinder's
    DRF points and its toleranced axis's fit, for the size evaluation to reuse."""
    pts = drf.to_frame(feature.points)
    if feature.element == "cylinder":
        if zone != "dia":
            raise InvalidInputError(f"{name or feature.name}: zone", "dia for the position of an axis", zone)
        ends, _, fit = toleranced_axis(pts, feature, drf.standard)
        if fitted is not None:
            fitted["points"] = pts
            if drf.standard == "ASME":  # the unrelated actual mating envelope over the default region
                fitted["envelope"] = ("mic" if feature.side == "internal" else "mcc", fit)
            else:
                fitted["gauss"] = fit
        d = feature.direction / np.linalg.norm(feature.direction)
        return ends, np.eye(3) - np.outer(d, d)
    if feature.element == "sphere":
        from pcmm_geo.fit import fit_sphere

        return np.asarray(fit_sphere(pts).center, dtype=float)[None, :], np.eye(3)
    if feature.element == "point":
        return pts.mean(axis=0)[None, :], np.eye(3)
    if feature.element == "plane":
        return pts, np.eye(3)
    raise InvalidInputError(f"{name or feature.name}: element", "cylinder, sphere, point or plane", feature.element)


def evaluate_position(
    feature: FeatureData,
    drf: DatumReferenceFrame,
    tolerance_mm: float,
    *,
    name: str = "",
    modifier: str = "RFS",
    zone: str = "dia",
) -> CharacteristicResult:
    """Position of an axis (cylinder), a centre (sphere) or a point / plane (ISO 1101 18.12, ASME 10.5).

    Parameters
    ----------
    feature : FeatureData
    drf : DatumReferenceFrame
    tolerance_mm : float
        Zone diameter (``zone="dia"``) or width (plane), mm.
    modifier : {"RFS", "MMC", "LMC"}
    zone : {"dia", "width"}
        Cylindrical / spherical zone, or two parallel planes (planes only).

    Returns
    -------
    CharacteristicResult
        ``details`` hold the end points' deviations and, with a modifier, the sizes.  ``bound_mm`` is the
        dual certificate of the floating minimax (equal to the value to about 1e-12 relative when proven);
        FAIL is decided on it, so a gap the solver did not close gives NOT PROVEN.
    """
    if modifier not in ("RFS", "MMC", "LMC"):
        raise InvalidInputError("modifier", "RFS, MMC or LMC", repr(modifier))
    trans, rots = _free_axes(drf)
    details: dict[str, Any] = {}
    fitted: dict[str, Any] = {}
    targets, proj = _position_targets(feature, drf, name, zone, fitted)
    if feature.element == "plane":
        n = feature.direction / np.linalg.norm(feature.direction)
        dev = (targets - feature.point) @ n
        floats = any(abs(t @ n) > 1e-12 for t in trans)
        value = float(np.ptp(dev)) if floats else 2.0 * float(np.abs(dev).max())
        bound = value
    else:  # a FAIL needs the proven (dual) bound: a gap the solver did not close gives NOT PROVEN
        value, bound, vectors = float_position(targets, feature.point, proj, trans, rots, drf.pivot)
        value, bound = 2.0 * value, 2.0 * bound
        details["deviations_mm"] = vectors.tolist()
    if modifier != "RFS" and (feature.element not in ("cylinder", "sphere") or not np.isfinite(feature.diameter)):
        raise InvalidInputError(f"{name or feature.name}: {modifier}", "a feature of size with a diameter",
                                feature.element)
    low, high, size_ok, bonus = allowed_zone(feature, tolerance_mm, modifier, details, **fitted)
    verdict = decide(value, bound, low, high)
    if not size_ok:
        verdict = "FAIL"
        details["reason"] = "size outside its limits"
        bonus = 0.0
    return CharacteristicResult(name or feature.name, "position", value, bound, tolerance_mm, bonus, verdict,
                                drf.datums, drf.standard, details)


def evaluate_orientation(
    feature: FeatureData,
    drf: DatumReferenceFrame,
    tolerance_mm: float,
    *,
    characteristic: str,
    name: str = "",
    zone: str = "width",
    zone_normal: FloatArray | None = None,
) -> CharacteristicResult:
    """Parallelism, perpendicularity or angularity of a plane or an axis (ISO 1101 18.9-18.11).

    Parameters
    ----------
    feature : FeatureData
        A plane (zone: two planes with the nominal normal) or a cylinder (its toleranced axis).
    drf : DatumReferenceFrame
        Its constrained rotations orient the zone; free rotations let it turn.
    tolerance_mm : float
    characteristic : {"parallelism", "perpendicularity", "angularity"}
    zone : {"width", "dia"}
        Two parallel planes, or a cylinder (axes only) along the nominal axis.
    zone_normal : ndarray, shape (3,), optional
        Axes with ``zone="width"``: the planes' normal in the DRF (default: the primary datum's direction).

    Returns
    -------
    CharacteristicResult
        ``bound_mm`` is the proven lower bound when a rotation floats (branch and bound), else the value.
    """
    pts = drf.to_frame(feature.points)
    _, rots = _free_axes(drf)
    if len(rots) > 1:
        raise InvalidInputError(f"{name or feature.name}: datums", "a DRF fixing the zone's orientation (a plane or "
                                "an axis datum)", "+".join(drf.datums) or "none")
    details: dict[str, Any] = {}
    if feature.element == "plane":
        rel = pts - pts.mean(axis=0)
        base = feature.direction / np.linalg.norm(feature.direction)

        def width(direction: FloatArray) -> float:
            return float(np.ptp(rel @ direction))

        scale = 2.0 * float(np.linalg.norm(rel, axis=1).max())
    elif feature.element == "cylinder":
        ends, _, _ = toleranced_axis(pts, feature, drf.standard)
        u = ends[1] - ends[0]
        details["axis_end_points_mm"] = ends.tolist()
        if zone == "dia":
            base = feature.direction / np.linalg.norm(feature.direction)

            def width(direction: FloatArray) -> float:
                return float(np.linalg.norm(u - (u @ direction) * direction))
        else:
            if zone_normal is None:
                raise InvalidInputError(f"{name or feature.name}: zone", "dia, or a datum plane parallel to the axis",
                                        "width without one")
            base = np.asarray(zone_normal, dtype=float) / np.linalg.norm(zone_normal)

            def width(direction: FloatArray) -> float:
                return float(abs(u @ direction))
        scale = 2.0 * float(np.linalg.norm(u))
    else:
        raise InvalidInputError(f"{name or feature.name}: element", "a plane or a cylinder", feature.element)
    if rots and np.linalg.norm(np.cross(rots[0], base)) > 1e-12:
        axis = rots[0]
        value, bound, theta = minimise_angle(lambda t: width(_rotate(base, axis, t)), scale)
        details["zone_turned_deg"] = float(np.degrees(theta))
    else:
        value = bound = width(base)
    verdict = decide(value, bound, tolerance_mm, tolerance_mm)
    return CharacteristicResult(name or feature.name, characteristic, value, bound, tolerance_mm, None, verdict,
                                drf.datums, drf.standard, details)


def evaluate_flatness(feature: FeatureData, tolerance_mm: float, *, name: str = "") -> CharacteristicResult:
    """Flatness: minimum-zone width with its proven lower bound (:func:`pcmm_geo.fit.zone.evaluate_form`)."""
    from pcmm_geo.fit.zone.form import evaluate_form

    ev = evaluate_form(feature.points, "plane", tolerance=tolerance_mm)
    bound = ev.deviation if ev.scope == "global" else float(ev.bound)
    return CharacteristicResult(name or feature.name, "flatness", float(ev.deviation), bound, tolerance_mm, None,
                                ev.verdict, (), "ISO", {"scope": ev.scope})


def evaluate_runout(
    feature: FeatureData,
    drf: DatumReferenceFrame,
    tolerance_mm: float,
    *,
    total: bool,
    name: str = "",
    axis_point: FloatArray | None = None,
    axis_direction: FloatArray | None = None,
) -> CharacteristicResult:
    """Circular or total runout about the datum axis (ISO 1101 18.16, 18.17).

    The datum axis is the line through ``axis_point`` along ``axis_direction`` in the DRF (default: the
    DRF's z axis); the DRF must locate it (no free translation across it, no free tilt).  A cylinder:
    radial runout (spread of the distances from the axis; circular: per cross-section, the points' heights
    rounded to 1 µm); a plane: axial runout (spread of the heights; circular: per band of radius rounded
    to 1 µm).
    """
    point = np.zeros(3) if axis_point is None else np.asarray(axis_point, dtype=float)
    axis = _UNIT["z"] if axis_direction is None else np.asarray(axis_direction, dtype=float)
    axis = axis / np.linalg.norm(axis)
    trans, rots = _free_axes(drf)
    if any(np.linalg.norm(np.cross(t, axis)) > 1e-9 for t in trans) or \
            any(np.linalg.norm(np.cross(r, axis)) > 1e-9 for r in rots):
        raise InvalidInputError(f"{name or feature.name}: datums", "a DRF that locates the datum axis",
                                "+".join(drf.datums) + " leaves " + " ".join(drf.free))
    rel = drf.to_frame(feature.points) - point
    height = rel @ axis
    radius = np.linalg.norm(rel - np.outer(height, axis), axis=1)
    if feature.element == "cylinder":
        values, keys = radius, np.round(height, 3)
    elif feature.element == "plane":
        values, keys = height, np.round(radius, 3)
    else:
        raise InvalidInputError(f"{name or feature.name}: element", "a cylinder or a plane", feature.element)
    if total:
        value = float(np.ptp(values))
    else:
        order = np.argsort(keys, kind="stable")
        _, starts = np.unique(keys[order], return_index=True)
        groups = np.split(values[order], starts[1:])
        value = float(max(np.ptp(g) for g in groups))
    kind = "total runout" if total else "circular runout"
    return CharacteristicResult(name or feature.name, kind, value, value, tolerance_mm, None,
                                decide(value, value, tolerance_mm, tolerance_mm), drf.datums, drf.standard, {})


def apply_uncertainty(result: CharacteristicResult, u: float | None) -> CharacteristicResult:
    """The verdict under ISO 14253-1 with the characteristic's expanded uncertainty ``u`` (mm, k = 2), when stated.

    :mod:`pcmm_geo.uncertainty.conformity`'s default rule applied to the zone's value (for conformity) and its
    proven lower bound (for nonconformity); ``u=None`` returns ``result`` unchanged.

    Conformity is proven when the zone's value plus U is within the allowance (tolerance plus the proven
    bonus), nonconformity when its proven lower bound minus U exceeds the largest allowance; a size outside
    its limits stays FAIL.
    """
    import dataclasses

    from pcmm_geo.uncertainty.conformity import DECISION_RULE_TEXT, decide_conformity

    if u is None:
        return result
    details = {**result.details, "expanded_uncertainty_mm": u, "decision_rule": DECISION_RULE_TEXT}
    if result.details.get("reason") == "size outside its limits":
        return dataclasses.replace(result, details=details)
    if "limits_mm" in result.details:
        low, high = result.details["limits_mm"]
        verdict = decide_conformity(result.value_mm, u, lower_limit=low, upper_limit=high).verdict
        return dataclasses.replace(result, verdict=verdict, details=details)
    allowed_low = result.tolerance_mm + (result.bonus_mm or 0.0)
    allowed_high = result.tolerance_mm + result.details.get("bonus_high_mm", result.bonus_mm or 0.0)
    if decide_conformity(result.value_mm, u, upper_limit=allowed_low).verdict == "PASS":
        verdict = "PASS"
    elif np.isfinite(result.bound_mm) and decide_conformity(result.bound_mm, u,
                                                            upper_limit=allowed_high).verdict == "FAIL":
        verdict = "FAIL"
    else:
        verdict = "NOT PROVEN"
    return dataclasses.replace(result, verdict=verdict, details=details)
