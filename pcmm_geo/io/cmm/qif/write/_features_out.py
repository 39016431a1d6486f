"""The features part of the QIF writer: the ``Features`` section, feature measurements and measured point sets.

QIF 3.0 (``Features.xsd``) keeps a feature in four linked records: the ``<Type>FeatureDefinition``
(what it is: ``InternalExternal``, nominal size), the ``<Type>FeatureNominal`` (where it should be;
``FeatureDefinitionId``), the ``<Type>FeatureItem`` (the feature of the part to inspect, with its
``FeatureName``; ``FeatureNominalId``) -- these three in ``Features`` -- and, per
``MeasurementResults``, the ``<Type>FeatureMeasurement`` (its actuals; ``FeatureItemId``).  QIF 3.0
has no separate ``FeatureActuals`` list: the measurements are the actuals.

:func:`check_feature_links` refuses records whose ids do not link (the schema's keyrefs would);
:func:`write_features` writes the section; :func:`write_measured_features` and
:func:`write_point_sets` write the parts of a ``MeasurementResults``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from pcmm_geo.elements import SIZED_FEATURES, SPECS
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.io.cmm.document import CmmDocument
from pcmm_geo.io.cmm.model import (
    FEATURE_TYPES,
    FeatureDefinition,
    FeatureGeometry,
    FeatureItem,
    FeatureNominal,
    MeasuredFeature,
    MeasuredPointSet,
)
from pcmm_geo.io.cmm.qif.write._xml_out import ALGORITHMS, QifText, camel

__all__ = ["check_feature_links", "write_features", "write_measured_features", "write_point_sets"]

_BLOCK = 4096  # points formatted at a time
#: feature types whose definition holds InternalExternal and a diameter
SIZED = SIZED_FEATURES
_PLACEMENT: dict[str, tuple[str, ...]] = {kind: SPECS[kind].placement_fields for kind in FEATURE_TYPES}
#: measured sizes of a sized feature (a cylinder also states its length)
_SIZES: dict[str, tuple[str, ...]] = {
    kind: ("diameter", *(("length",) if kind == "cylinder" else ()), "diameter_min", "diameter_max")
    for kind in SIZED_FEATURES}


def check_type(kind: str, what: str) -> None:
    """Refuse a feature type the writer has no QIF record for."""
    if kind not in FEATURE_TYPES:
        raise InvalidInputError(f"{what}.type", f"one of {', '.join(FEATURE_TYPES)} (the types the writer writes)",
                                repr(kind))


def check_feature_links(document: CmmDocument) -> None:
    """Refuse feature records whose ids name nothing or a record of another type.

    Raises
    ------
    InvalidInputError
        An item naming no nominal (or one of another type), a nominal naming no definition, a
        measurement naming no item -- each naming the record's id.
    """
    links: tuple[tuple[str, Mapping[int, FeatureItem | FeatureNominal], str, Mapping[int, object]], ...] = (
        ("feature item", document.feature_items, "nominal_id", document.feature_nominals),
        ("feature nominal", document.feature_nominals, "definition_id", document.feature_definitions))
    for what, records, field, targets in links:
        for record in records.values():
            key = getattr(record, field)
            target = targets.get(key) if key is not None else None
            if target is None or getattr(target, "type", None) != record.type:
                found = "None" if key is None else f"{key}, which is not a {record.type} record of the document" \
                    if target is not None else f"{key}, which the document does not hold"
                raise InvalidInputError(f"{what} {record.id}.{field}",
                                        f"the id of a {record.type} record of the document (QIF requires it)", found)
    for feature in document.measured_features:
        if feature.item_id is None:
            continue
        item = document.feature_items.get(feature.item_id)
        if item is None or item.type != feature.type:
            raise InvalidInputError(f"feature measurement {feature.id}.item_id",
                                    f"None or the id of a {feature.type} feature item of the document",
                                    str(feature.item_id))


def write_features(out: QifText, document: CmmDocument) -> None:
    """The ``Features`` section (definitions, nominals, items in schema order); nothing without records."""
    groups: tuple[tuple[str, Mapping[int, object], Callable[[QifText, object], None]], ...] = (
        ("FeatureDefinitions", document.feature_definitions, _definition),  # type: ignore[arg-type]
        ("FeatureNominals", document.feature_nominals, _nominal),  # type: ignore[arg-type]
        ("FeatureItems", document.feature_items, _item))  # type: ignore[arg-type]
    if not any(records for _, records, _ in groups):
        return
    out.open("Features")
    for group, records, write in groups:
        if records:
            out.open(group, n=len(records))
            for record in records.values():
                check_type(record.type, f"{group} id {record.id}")  # type: ignore[attr-defined]
                write(out, record)
            out.close(group)
    out.close("Features")


def _definition(out: QifText, definition: FeatureDefinition) -> None:
    tag = f"{camel(definition.type)}FeatureDefinition"
    if definition.type not in SIZED:
        out.leaf(tag, id=definition.id)
        return
    out.open(tag, id=definition.id)
    out.leaf("InternalExternal", definition.internal_external or "NOT_APPLICABLE")
    if definition.diameter is None:
        raise InvalidInputError(f"feature definition {definition.id}", "a diameter (QIF requires it)", "None")
    out.leaf("Diameter", out.length(definition.diameter))
    if definition.type == "cylinder" and definition.length is not None:
        out.leaf("Length", out.length(definition.length))
    if definition.type == "cone":
        if definition.half_angle is None:
            raise InvalidInputError(f"feature definition {definition.id}", "a half angle (QIF requires it)", "None")
        out.leaf("HalfAngle", out.angle(definition.half_angle))
    out.close(tag)


def _nominal(out: QifText, nominal: FeatureNominal) -> None:
    tag = f"{camel(nominal.type)}FeatureNominal"
    geometry = nominal.geometry
    out.open(tag, id=nominal.id)
    out.leaf("FeatureDefinitionId", str(nominal.definition_id))
    needed = _PLACEMENT[nominal.type]
    missing = [name for name in needed if getattr(geometry, name) is None]
    if missing:
        raise InvalidInputError(f"feature nominal {nominal.id}", f"{', '.join(needed)} (QIF requires them)",
                                f"none for {', '.join(missing)}")
    _placement(out, nominal.type, geometry, nominal=True)
    out.close(tag)


def _placement(out: QifText, kind: str, geometry: FeatureGeometry, *, nominal: bool) -> None:
    """Location / Normal / Direction / Axis in schema order (nominal line: Location, Direction, Length, Normal)."""
    u = geometry.uncertainty

    def location(tag: str) -> None:
        out.leaf(tag, out.point(geometry.location), combinedUncertainty=None if "location" not in u else
                 out.length(u["location"]))  # type: ignore[arg-type]

    if kind in ("cylinder", "cone"):
        if geometry.location is not None and geometry.direction is not None:
            out.open("Axis")
            location("AxisPoint")
            out.leaf("Direction", out.vector(geometry.direction))
            out.close("Axis")
        return
    if geometry.location is not None:
        location("Location")
    if kind == "line":
        if geometry.direction is not None:
            out.leaf("Direction", out.vector(geometry.direction))
        if geometry.length is not None:
            if nominal:
                out.leaf("Length", out.length(geometry.length))
            else:
                out.measured("Length", geometry.length, u.get("length"))
    if kind != "sphere" and geometry.normal is not None:
        out.leaf("Normal", out.vector(geometry.normal))


def _item(out: QifText, item: FeatureItem) -> None:
    tag = f"{camel(item.type)}FeatureItem"
    out.open(tag, id=item.id)
    out.leaf("FeatureNominalId", str(item.nominal_id))
    out.leaf("FeatureName", item.name or f"F{item.id}")
    out.chain("DeterminationMode", "Checked", "CheckDetails", "Measured")
    out.close(tag)


def write_measured_features(out: QifText, features: tuple[MeasuredFeature, ...],
                            point_sets: Mapping[int, MeasuredPointSet]) -> None:
    """``MeasuredFeatures``: one ``<Type>FeatureMeasurement`` per feature (``point_sets``: for point ranges)."""
    if not features:
        return
    out.open("MeasuredFeatures", n=len(features))
    for feature in features:
        _measurement(out, feature, point_sets)
    out.close("MeasuredFeatures")


def _measurement(out: QifText, feature: MeasuredFeature, point_sets: Mapping[int, MeasuredPointSet]) -> None:
    check_type(feature.type, f"feature measurement {feature.id}")
    tag = f"{camel(feature.type)}FeatureMeasurement"
    actual = feature.actual
    u = actual.uncertainty
    out.open(tag, id=feature.id)
    if feature.item_id is not None:
        out.leaf("FeatureItemId", str(feature.item_id))
    if feature.name:
        out.leaf("FeatureName", feature.name)
    if feature.point_set_refs:
        out.open("PointList", n=len(feature.point_set_refs))
        for ref in feature.point_set_refs:
            if ref.start == 0 and ref.stop is None:
                out.leaf("WholePointSetId", str(ref.point_set_id))
            elif ref.stop == ref.start + 1:
                out.leaf("SinglePointSetId", str(ref.point_set_id), index=ref.start + 1)
            else:
                count = len(point_sets[ref.point_set_id])
                out.leaf("RangePointSetId", str(ref.point_set_id),
                         range=f"{ref.start + 1} {count if ref.stop is None else ref.stop}")
        out.close("PointList")
    if feature.substitute_algorithm:
        known = feature.substitute_algorithm in ALGORITHMS
        out.chain("SubstituteFeatureAlgorithm", "SubstituteFeatureAlgorithmEnum" if known
                  else "OtherSubstituteFeatureAlgorithm", text=feature.substitute_algorithm)
    _placement(out, feature.type, actual, nominal=False)
    for name in _SIZES.get(feature.type, ()):
        value = getattr(actual, name)
        if value is not None:
            out.measured(camel(name), value, u.get(name))
    if feature.type == "cone" and actual.half_angle is not None:
        out.measured("HalfAngle", actual.half_angle, u.get("half_angle"), "angular")
    if feature.type != "point" and actual.form is not None:
        out.measured("Form", actual.form, u.get("form"))
    out.close(tag)


def write_point_sets(out: QifText, point_sets: Mapping[int, MeasuredPointSet]) -> None:
    """``MeasuredPointSets`` (points, normals, ``Compensated`` or ``Compensations``, probe radii)."""
    if not point_sets:
        return
    out.open("MeasuredPointSets", n=len(point_sets))
    for key, point_set in point_sets.items():
        _point_set(out, key, point_set)
    out.close("MeasuredPointSets")


def _point_set(out: QifText, key: int, point_set: MeasuredPointSet) -> None:
    n = len(point_set)
    if point_set.compensated is None and point_set.compensated_per_point is None:
        raise InvalidInputError(f"point set {key}.compensated", "True or False (QIF requires the flag)", "None")
    out.open("MeasuredPointSet", id=key, count=n)
    _number_list(out, "Points", point_set.points, lambda block: block / out.mm_per_unit)
    if point_set.normals is not None:
        _number_list(out, "Normals", point_set.normals, lambda block: block)
    if point_set.compensated_per_point is not None:
        out.leaf("Compensations", " ".join("true" if f else "false" for f in point_set.compensated_per_point))
    else:
        out.leaf("Compensated", "true" if point_set.compensated else "false")
    if point_set.probe_radii is not None:
        _number_list(out, "ProbeRadii", point_set.probe_radii.reshape(-1, 1), lambda b: b / out.mm_per_unit)
    elif point_set.probe_radius is not None:
        out.leaf("ProbeRadius", out.length(point_set.probe_radius))
    out.close("MeasuredPointSet")


def _number_list(out: QifText, tag: str, values: np.ndarray, scale: Callable[[np.ndarray], np.ndarray]) -> None:
    pad = "  " * out.depth
    out.raw(f"{pad}<{tag}>")
    for start in range(0, len(values), _BLOCK):
        block = scale(np.asarray(values[start:start + _BLOCK], dtype=np.float64))
        if not np.isfinite(block).all():
            raise InvalidInputError(tag, "finite numbers", "NaN or inf")
        out.raw("".join("\n" + pad + "  " + " ".join(map(repr, row)) for row in block.tolist()))
    out.raw(f"\n{pad}</{tag}>\n")
