"""The recomputations behind :func:`~pcmm_geo.gdt.qif.characteristics.verify_characteristics`, one per type.

Each takes a characteristic measurement of a :class:`~pcmm_geo.io.cmm.CmmDocument`, the
definitions of :func:`~pcmm_geo.io.cmm.qif.characteristic_definitions.read_qif_definitions`
and the feature actuals, and returns a :class:`Recomputation`: the value (mm or rad) and how
it was obtained, or None and why not.  The definitions are stated in
:mod:`pcmm_geo.gdt.qif.characteristics`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from pcmm_geo.gdt.qif.frames import (
    AXIS_TYPES,
    PLANE_TYPES,
    POINT_TYPES,
    DatumFeatureGeometry,
    FrameMap,
    datum_frame,
    frame_map,
)

if TYPE_CHECKING:
    from pcmm_geo.io.cmm import Characteristic, CmmDocument, FeatureGeometry, MeasuredFeature
    from pcmm_geo.io.cmm.qif.characteristic_definitions import QifDefinitions

__all__ = ["FORM_TYPES", "SIZE_TYPES", "Recomputation", "alignment", "datum_substitutes",
           "form_from_points", "recompute"]

#: size characteristics -> (actual attribute, factor)
SIZE_TYPES = {"diameter": ("diameter", 1.0), "spherical_diameter": ("diameter", 1.0), "radius": ("diameter", 0.5),
              "spherical_radius": ("diameter", 0.5), "width": ("width", 1.0), "length": ("length", 1.0)}
#: form characteristics -> the feature type whose points give them
FORM_TYPES = {"flatness": "plane", "circularity": "circle", "cylindricity": "cylinder", "sphericity": "sphere"}
#: circles are centres for a distance (their axis is a normal, not a line of the part)
_CENTRE_TYPES = POINT_TYPES | {"circle", "circular_arc", "elongated_circle"}
_AXES = {"XAXIS": 0, "YAXIS": 1, "ZAXIS": 2}
_RAW = "the deviation in the file's coordinates without the datum reference frame (the actuals taken as aligned)"


@dataclass(frozen=True)
class Recomputation:
    """A recomputed value (mm or rad) or None, how (or why not), and other conventions' values.

    ``alternatives``: ``(description, value, accepted)``; a reported value matching an accepted
    one agrees (another standard definition), an unaccepted one still disagrees (the reason names it).
    ``accepted_range``: ``(low, high)``, every value between which is right (a datum shift's range);
    ``below``: why a reported value below ``value`` cannot be judged (an unbounded datum shift).
    """

    value: float | None
    reason: str
    source: str | None = None
    alternatives: tuple[tuple[str, float, bool], ...] = ()
    accepted_range: tuple[float, float] | None = None
    below: str | None = None


class NotComputable(Exception):
    """A characteristic whose inputs the file does not hold (the message says which); :func:`recompute` catches it."""


def _direction(geometry: FeatureGeometry) -> np.ndarray | None:
    return geometry.direction if geometry.direction is not None else geometry.normal


def _substitute(kind: str, geometry: FeatureGeometry, label: str, which: str) -> DatumFeatureGeometry:
    if geometry.location is None:
        raise NotComputable(f"datum {label}'s {which} feature has no location")
    if kind in PLANE_TYPES or kind in AXIS_TYPES:
        direction = _direction(geometry)
        if direction is None:
            raise NotComputable(f"datum {label}'s {which} feature has no direction")
        return DatumFeatureGeometry("plane" if kind in PLANE_TYPES else "axis", geometry.location, direction, label)
    if kind in POINT_TYPES:
        return DatumFeatureGeometry("point", geometry.location, None, label)
    raise NotComputable(f"datum {label} is a {kind} feature, which pcmm_geo does not make a datum of")


def _datum_feature(document: CmmDocument, definitions: QifDefinitions, definition_id: int,
                   results_id: int | None) -> tuple[MeasuredFeature, str]:
    datum = definitions.datum_definitions.get(definition_id)
    if datum is None:
        raise NotComputable(f"datum definition {definition_id} is not in the file")
    measured = [f for f in document.measured_features if f.results_id == results_id]
    if datum.feature_nominal_ids:
        found = [f for f in measured if (n := document.nominal_of(f)) is not None and n.id in datum.feature_nominal_ids]
        if not found:
            raise NotComputable(f"datum {datum.label}'s feature (nominal {datum.feature_nominal_ids[0]}) was not "
                                 "measured")
        return found[0], datum.label
    names = {f"DATUM_{datum.label}".upper(), f"DATUM{datum.label}".upper(), f"DATUM {datum.label}".upper(),
             datum.label.upper()}
    found = [f for f in measured if f.name is not None and f.name.upper() in names]
    if len(found) != 1:
        raise NotComputable(f"the file does not link datum {datum.label} to a feature (DatumDefinition has no "
                            f"FeatureNominalIds) and no single feature is named DATUM_{datum.label} or {datum.label}")
    return found[0], f"{datum.label} (the feature named {found[0].name}: the file links none)"


def datum_substitutes(document: CmmDocument, definitions: QifDefinitions | None, characteristic: Characteristic,
                      shifts: list[Any] | None = None,
                      ) -> tuple[list[DatumFeatureGeometry], list[DatumFeatureGeometry], list[str], str]:
    """Nominal and actual substitutes of the datums of the characteristic's frame, their labels, and the frame's words.

    Empty lists: no frame or an empty one (the file's coordinates).  Raises ``NotComputable``
    with the reason when a datum cannot be placed.  A datum at MMB / LMB is refused, unless
    ``shifts`` is a list: then it is fixed at its actual feature and its
    :class:`~pcmm_geo.gdt.qif.shift.DatumShift` is appended to ``shifts``.
    """
    if definitions is None:
        return [], [], [], f"in the file's coordinates ({document.format} datum reference frames are not read)"
    definition = definitions.definition_of(characteristic.definition_id)
    if definition is None or not definition.datum_reference_frame_ids:
        return [], [], [], "in the file's coordinates (no datum reference frame)"
    frame = definitions.datum_reference_frames.get(definition.datum_reference_frame_ids[0])  # type: ignore[union-attr]
    if frame is None or not frame.datums:
        return [], [], [], "in the file's coordinates (an empty datum reference frame)"
    nominal, actual, labels = [], [], []
    for index, datum in enumerate(frame.datums):
        if datum.kind == "compound":
            raise NotComputable("a compound datum (common datum) is not evaluated")
        modifiers = [m for m in datum.material_modifiers if m not in ("NONE", "REGARDLESS")]
        if modifiers and shifts is None:
            raise NotComputable(f"a datum at {modifiers[0]} material boundary (datum feature shift) is not "
                                 f"evaluated for a {characteristic.type.replace('_', ' ')}")
        if datum.kind == "simple":
            feature, label = _datum_feature(document, definitions, datum.datum_definition_ids[0],  # type: ignore[arg-type]
                                            characteristic.results_id)
        else:
            found = [f for f in document.measured_features if f.results_id == characteristic.results_id
                     and (n := document.nominal_of(f)) is not None and n.id in datum.feature_ids]
            if not found:
                raise NotComputable(f"datum feature (nominal {datum.feature_ids}) was not measured")
            feature, label = found[0], found[0].name or str(found[0].id)
        nominal_feature = document.nominal_of(feature)
        if nominal_feature is None:
            raise NotComputable(f"datum {label}'s feature has no nominal")
        nominal.append(_substitute(feature.type, nominal_feature.geometry, label, "nominal"))
        actual.append(_substitute(feature.type, feature.actual, label, "actual"))
        labels.append(label)
        if modifiers and shifts is not None:
            from pcmm_geo.gdt.qif.shift import ShiftNotBounded, boundary_shift

            try:
                shifts.append(boundary_shift(document, feature, modifiers[0], label.split(" ")[0], index))
            except ShiftNotBounded as exc:
                raise NotComputable(str(exc)) from None
    return nominal, actual, labels, f"in the frame {' | '.join(labels)} built from the datum features' actuals"


def alignment(document: CmmDocument, definitions: QifDefinitions | None,
              characteristic: Characteristic, shifts: list[Any] | None = None) -> tuple[FrameMap | None, str]:
    """The measured-to-part map of the characteristic's datum reference frame (None: the file's coordinates).

    Raises ``NotComputable`` with the reason when the frame cannot be built; ``shifts`` as for
    :func:`datum_substitutes`.
    """
    nominal, actual, _, words = datum_substitutes(document, definitions, characteristic, shifts)
    return (frame_map(nominal, actual) if nominal else None), words


def _mapped_deviation(frame: FrameMap | None, actual: np.ndarray, nominal: np.ndarray) -> np.ndarray:
    return actual - nominal if frame is None else frame.deviation(actual, nominal)


def _features(characteristic: Characteristic, features: Mapping[int, MeasuredFeature]) -> list[MeasuredFeature]:
    found = [features[i] for i in characteristic.feature_measurement_ids if i in features]
    if not found:
        raise NotComputable("the characteristic names no feature measurement")
    return found


def _nominal_geometry(document: CmmDocument, feature: MeasuredFeature) -> FeatureGeometry:
    nominal = document.nominal_of(feature)
    if nominal is None:
        raise NotComputable(f"feature {feature.name or feature.id} has no nominal")
    return nominal.geometry


def _refitted_locations(document: CmmDocument, feature: MeasuredFeature, options: Mapping[str, Any]
                        ) -> tuple[list[np.ndarray], str] | None:
    """The refit's centre, or its axis' two ends over the points' extent; None without points or refit."""
    from pcmm_geo.cmm.refit import REFITTED_TYPES, refit_feature
    from pcmm_geo.errors import NotRefittedError

    if not feature.point_set_refs or feature.type not in REFITTED_TYPES or feature.type == "plane":
        return None
    try:
        refit = refit_feature(document, feature, **options)
    except NotRefittedError:
        return None
    if refit.location is None:
        return None
    if feature.type in ("cylinder", "cone", "line") and refit.direction is not None:
        along = (refit.points - refit.location) @ refit.direction
        ends = [refit.location + t * refit.direction for t in (float(along.min()), float(along.max()))]
        return ends, f"the ends of the refitted axis over its {len(refit.points)} points' extent"
    return [refit.location], f"the centre refitted from its {len(refit.points)} points"


def _position(document: CmmDocument, definitions: QifDefinitions | None, characteristic: Characteristic,
              feature: MeasuredFeature, use_points: bool, options: Mapping[str, Any]) -> Recomputation:
    nominal = _nominal_geometry(document, feature)
    if feature.actual.location is None or nominal.location is None:
        raise NotComputable(f"feature {feature.name or feature.id} has no actual or nominal location")
    shifts: list[Any] = []
    substitutes, actual_substitutes, _, where = datum_substitutes(document, definitions, characteristic, shifts)
    frame = frame_map(substitutes, actual_substitutes) if substitutes else None
    definition = None if definitions is None else definitions.definition_of(characteristic.definition_id)
    zone = characteristic.zone_shape or (None if definition is None else definition.zone_shape)

    def value(delta: np.ndarray) -> float:
        if feature.type in AXIS_TYPES and zone in (None, "diametrical"):
            axis = _direction(nominal)
            if axis is None:
                raise NotComputable("the nominal axis has no direction")
            return 2.0 * float(np.linalg.norm(delta - float(axis @ delta) * axis))
        if feature.type in _CENTRE_TYPES or zone == "spherical":
            return 2.0 * float(np.linalg.norm(delta))
        if feature.type in PLANE_TYPES and nominal.normal is not None:
            return 2.0 * abs(float(nominal.normal @ delta))
        raise NotComputable(f"a position of a {feature.type} with a {zone or 'unstated'} zone is not evaluated")

    from_actual = value(_mapped_deviation(frame, feature.actual.location, nominal.location))
    refitted = _refitted_locations(document, feature, options) if use_points else None
    alternatives: list[tuple[str, float, bool]] = []
    if refitted is None:
        recomputed, source = from_actual, "actuals"
        how = f"2 x the deviation of the actual from the nominal location {where}"
    else:
        locations, what = refitted
        recomputed = max(value(_mapped_deviation(frame, point, nominal.location)) for point in locations)
        source, how = "points", f"2 x the largest deviation of {what} from the nominal {where}"
        alternatives.append(("the deviation of the reported actual location (the CMM's feature, not the points)",
                             from_actual, True))
    condition = None if definition is None else definition.material_condition
    if condition in ("MAXIMUM", "LEAST"):
        how += f"; {_bonus(document, characteristic, feature, condition)}"
    if frame is not None:
        alternatives.append((_RAW, value(feature.actual.location - nominal.location), False))
    if shifts and frame is not None:
        from pcmm_geo.gdt.qif.shift import ShiftNotBounded, position_reduction

        try:
            reduction, bounded = position_reduction(
                shifts, [len(datum_frame(actual_substitutes[:shift.precedence]).free_translations) > 0
                         for shift in shifts], frame.actual.origin,
                frame.actual.rotation[:, 2] if frame.actual.z_defined else None, feature.actual.location)
        except ShiftNotBounded as exc:
            how += f"; with the datums fixed at their actual features ({'; '.join(s.words for s in shifts)})"
            return Recomputation(recomputed, how, source, tuple(alternatives), below=str(exc))
        how += (f"; with the datums fixed at their actual features ({'; '.join(s.words for s in shifts)}: the "
                f"shift may lower the value by at most {bounded})")
        return Recomputation(recomputed, how, source, tuple(alternatives),
                             accepted_range=(max(0.0, recomputed - reduction), recomputed))
    return Recomputation(recomputed, how, source, tuple(alternatives))



def _bonus(document: CmmDocument, characteristic: Characteristic, feature: MeasuredFeature, condition: str) -> str:
    """The MMC / LMC bonus from the feature's actual size and its size tolerance, in words (ASME Y14.5 §10.3.3)."""
    name = "MMC" if condition == "MAXIMUM" else "LMC"
    sizes = [c for c in document.characteristics if c.type in ("diameter", "width") and c.tolerance is not None
             and c.feature_measurement_ids == (feature.id,)]
    definition = document.definition_of(feature)
    side = feature.material_side or (None if definition is None else {
        "INTERNAL": "internal", "EXTERNAL": "external"}.get(definition.internal_external or ""))
    if not sizes or side is None:
        return f"{name}: a bonus changes the tolerance, not this value (the size tolerance or the side is not stated)"
    size = sizes[0]
    lower, upper = size.tolerance.limits(size.nominal)  # type: ignore[union-attr]
    actual = feature.actual.diameter if size.type == "diameter" else feature.actual.width
    if lower is None or upper is None or actual is None:
        return f"{name}: a bonus changes the tolerance, not this value (the size limits are not stated)"
    if not lower <= actual <= upper:
        return f"{name}: the actual size {actual:.6g} mm is outside its limits [{lower:.6g}, {upper:.6g}]: no bonus"
    virtual = lower if (side == "internal") == (condition == "MAXIMUM") else upper
    return (f"{name} bonus {abs(actual - virtual):.6g} mm from the actual size {actual:.6g} mm "
            f"({name} size {virtual:.6g} mm)")


def _point_profile(document: CmmDocument, definitions: QifDefinitions | None, characteristic: Characteristic,
                   feature: MeasuredFeature, use_points: bool, options: Mapping[str, Any]) -> Recomputation:
    nominal = _nominal_geometry(document, feature)
    if feature.actual.location is None or nominal.location is None or nominal.normal is None:
        raise NotComputable("a point profile needs the actual location and the nominal location and normal")
    frame, where = alignment(document, definitions, characteristic)
    location, source, what = feature.actual.location, "actuals", "the actual location"
    if use_points and feature.type in POINT_TYPES and feature.point_set_refs:
        from pcmm_geo.cmm.refit import refit_feature
        from pcmm_geo.errors import NotRefittedError

        try:
            refit = refit_feature(document, feature, **options)
        except NotRefittedError as exc:
            raise NotComputable(f"the point could not be compensated: {exc}") from None
        if refit.location is not None:
            location, source = refit.location, "points"
            what = f"the measured point ({refit.compensation.method})"
    recomputed = float(nominal.normal @ _mapped_deviation(frame, location, nominal.location))
    alternatives: list[tuple[str, float, bool]] = []
    if source == "points":
        alternatives.append(("the deviation of the reported actual location (not the compensated point)",
                             float(nominal.normal @ _mapped_deviation(frame, feature.actual.location,
                                                                      nominal.location)), False))
    radii = {round(ps.probe_radius, 9) for ps in document.point_sets.values()
             if ps.probe_radius is not None and ps.compensated is False}
    if source == "actuals" and feature.type in POINT_TYPES and len(radii) == 1:
        radius = radii.pop()
        alternatives.append((f"the actual location taken as an uncompensated probe-ball centre and offset by the "
                             f"file's probe radius {radius:g} mm (how this file reports its other point features)",
                             recomputed - radius, False))
    if frame is not None:
        alternatives.append((_RAW, float(nominal.normal @ (location - nominal.location)), False))
    return Recomputation(recomputed, f"the signed deviation of {what} along the nominal normal {where}", source,
                         tuple(alternatives))


def _linear_coordinate(document: CmmDocument, definitions: QifDefinitions | None, characteristic: Characteristic,
                       feature: MeasuredFeature) -> Recomputation:
    nominal_record = None if definitions is None else definitions.characteristic_nominals.get(
        characteristic.nominal_id or -1)
    axis = None if nominal_record is None else _AXES.get((nominal_record.direction or "").upper())
    if axis is None:
        raise NotComputable("the linear coordinate names no XAXIS, YAXIS or ZAXIS direction")
    if feature.actual.location is None:
        raise NotComputable(f"feature {feature.name or feature.id} has no actual location")
    frame, where = alignment(document, definitions, characteristic)
    mapped = feature.actual.location if frame is None else frame.apply(feature.actual.location)
    alternatives = () if frame is None else ((_RAW, float(feature.actual.location[axis]), False),)
    return Recomputation(float(mapped[axis]), f"the actual location's {'xyz'[axis]} {where}", "actuals",
                         alternatives)


def _distance(first: MeasuredFeature, second: MeasuredFeature) -> tuple[float, str]:
    a, b = first.actual, second.actual
    if a.location is None or b.location is None:
        raise NotComputable("a distance needs both features' actual locations")
    for plane, other, which in ((a, b, "first"), (b, a, "second")):
        if (first if which == "first" else second).type in PLANE_TYPES and plane.normal is not None:
            return abs(float(plane.normal @ (other.location - plane.location))), \
                f"along the {which} feature's (a plane's) actual normal"
    axes = [(f, g) for f, g in ((first, a), (second, b)) if f.type in AXIS_TYPES and f.type not in _CENTRE_TYPES]
    if axes and _direction(axes[0][1]) is not None:
        line, other = (a, b) if axes[0][0] is first else (b, a)
        direction = _direction(line)
        delta = other.location - line.location
        return float(np.linalg.norm(delta - float(direction @ delta) * direction)), \
            "from an actual axis, perpendicular to it"
    return float(np.linalg.norm(a.location - b.location)), "between the actual locations (3-D)"


def _distance_along(first: MeasuredFeature, second: MeasuredFeature, vector: np.ndarray,
                    mode: str) -> Recomputation:
    if first.actual.location is None or second.actual.location is None:
        raise NotComputable("a distance needs both features' actual locations")
    delta = second.actual.location - first.actual.location
    along = float(vector @ delta)
    if mode == "ONEDIMENSIONAL":
        return Recomputation(abs(along), "the distance between the actual locations along the analysis vector "
                             f"{np.round(vector, 6).tolist()}", "actuals")
    return Recomputation(float(np.linalg.norm(delta - along * vector)),
                         "the distance between the actual locations perpendicular to the analysis vector "
                         f"{np.round(vector, 6).tolist()}", "actuals")


def _angle(first: MeasuredFeature, second: MeasuredFeature, nominal: float | None) -> float:
    u, v = _direction(first.actual), _direction(second.actual)
    if u is None or v is None:
        raise NotComputable("an angle between needs both features' actual directions")
    theta = float(np.arccos(np.clip(float(u @ v), -1.0, 1.0)))
    if nominal is None:
        return min(theta, np.pi - theta)
    return min((theta, np.pi - theta), key=lambda t: abs(t - nominal))


def form_from_points(document: CmmDocument, feature: MeasuredFeature, criterion: str, **options: Any) -> float:
    """Form deviation (mm): the range of the compensated points about the refit by ``criterion``.

    Plane: signed distances; circle: radial distances in its plane; cylinder: distances from the
    axis; sphere: distances from the centre; minus the radius.  With ``criterion="chebyshev"``
    this range is the minimum-zone form (ISO 12781, 12181, 12180; the zone's width).  ``options``
    (``compensated``, ``probe_radius``) go to :func:`~pcmm_geo.cmm.refit.refit_feature`.
    """
    from pcmm_geo.cmm.refit import refit_feature

    refit = refit_feature(document, feature, criterion=criterion, **options)
    points = refit.points
    if refit.location is None:
        raise NotComputable("the refit has no location")
    delta = points - refit.location
    if feature.type == "sphere":
        residuals = np.linalg.norm(delta, axis=1)
    else:
        if refit.direction is None:
            raise NotComputable("the refit has no direction")
        along = delta @ refit.direction
        if feature.type == "plane":
            residuals = along
        else:
            residuals = np.linalg.norm(delta - np.outer(along, refit.direction), axis=1)
    return float(residuals.max() - residuals.min())


def _form(document: CmmDocument, characteristic: Characteristic, feature: MeasuredFeature,
          use_points: bool, options: Mapping[str, Any]) -> Recomputation:
    if feature.actual.form is not None:
        return Recomputation(feature.actual.form, "the form the file reports for the feature actual", "actuals")
    if FORM_TYPES[characteristic.type] != feature.type:
        raise NotComputable(f"{characteristic.type} of a {feature.type} feature is not evaluated")
    if not use_points or not feature.point_set_refs:
        raise NotComputable("the feature actual carries no form and the file holds no points for it")
    from pcmm_geo.errors import NotRefittedError

    try:
        zone = form_from_points(document, feature, "chebyshev", **options)
        least_squares = form_from_points(document, feature, "gaussian", **options)
    except NotRefittedError as exc:
        raise NotComputable(f"the points could not be refitted: {exc}") from None
    return Recomputation(zone, f"the minimum-zone range of the feature's {feature.type} points", "points",
                         (("the range about the least-squares feature (an accepted association)", least_squares,
                           True),))


def recompute(document: CmmDocument, definitions: QifDefinitions | None, characteristic: Characteristic,
              features: Mapping[int, MeasuredFeature], *, use_points: bool = True,
              options: Mapping[str, Any] | None = None,
              handlers: Mapping[str, Callable[..., Recomputation]] | None = None) -> Recomputation:
    """Recompute one characteristic measurement (see the module docstring); never raises for a missing input.

    ``options`` (``compensated``, ``probe_radius``) go to the refits of points; ``handlers`` maps
    further characteristic types to functions ``(document, definitions, characteristic, feature,
    use_points, options) -> Recomputation`` that may raise :class:`NotComputable`.
    """
    options = {} if options is None else options
    handlers = {} if handlers is None else handlers
    kind = characteristic.type
    try:
        found = _features(characteristic, features)
        feature = found[0]
        if kind in SIZE_TYPES:
            attribute, factor = SIZE_TYPES[kind]
            value = getattr(feature.actual, attribute)
            if value is None:
                raise NotComputable(f"feature {feature.name or feature.id} has no actual {attribute}")
            return Recomputation(factor * value, f"the feature actual's {attribute}"
                                 + (" / 2" if factor != 1.0 else ""), "actuals")
        if kind == "position":
            return _position(document, definitions, characteristic, feature, use_points, options)
        if kind == "point_profile":
            return _point_profile(document, definitions, characteristic, feature, use_points, options)
        if kind == "linear_coordinate":
            return _linear_coordinate(document, definitions, characteristic, feature)
        if kind in ("distance_between", "angle_between"):
            if len(found) != 2:
                raise NotComputable(f"a {kind.replace('_', ' ')} needs two features, the file names {len(found)}")
            if kind == "angle_between":
                return Recomputation(_angle(found[0], found[1], characteristic.nominal),
                                     "the angle between the two actual directions", "actuals")
            nominal = None if definitions is None else definitions.characteristic_nominals.get(
                characteristic.nominal_id if characteristic.nominal_id is not None else -1)
            if nominal is not None and nominal.analysis_vector is not None and nominal.analysis_mode in (
                    "ONEDIMENSIONAL", "TWODIMENSIONAL"):
                return _distance_along(found[0], found[1], nominal.analysis_vector, nominal.analysis_mode)
            value, how = _distance(found[0], found[1])
            return Recomputation(value, f"the distance {how}", "actuals")
        if kind in FORM_TYPES:
            return _form(document, characteristic, feature, use_points, options)
        if kind in handlers:
            return handlers[kind](document, definitions, characteristic, feature, use_points, options)
        raise NotComputable(f"pcmm_geo does not recompute {kind.replace('_', ' ')} characteristics from actuals")
    except NotComputable as reason:
        return Recomputation(None, str(reason))
