"""Write a :class:`CmmDocument` as a QIF 3.0 results document that validates against the QIF 3.0 schema.

Written, in schema order: ``QPId``, ``Header``, ``FileUnits`` (mm or inch, degree), the feature
definitions, nominals and items, the characteristic definitions, nominals and items, and per
``MeasurementResults`` the feature measurements (actuals, ``PointList``, substitute algorithm,
form, ``combinedUncertainty``), the measured point sets (points, normals, ``Compensated`` or
``Compensations``, ``ProbeRadius`` or ``ProbeRadii``), the characteristic measurements (status,
value, uncertainty) and the inspection status.

Numbers read back exactly (:mod:`~pcmm_geo.io.cmm.qif._xml_out`); point lists are written in blocks.

Feature types written: circle, cylinder, sphere, plane, line, point, cone.  Characteristic types
written: diameter, spherical_diameter, radius, spherical_radius, length, width (size: tolerance
``MaxValue``/``MinValue`` or ``NonTolerance``) and flatness, circularity, cylindricity,
sphericity, straightness, conicity (form: ``ToleranceValue``, required by QIF -- a form value
without a tolerance belongs in the feature's ``actual.form``).

Examples
--------
>>> import numpy as np, pathlib, tempfile
>>> from pcmm_geo.io.cmm import FeatureGeometry, FeatureReport, read_qif, results_document
>>> ball = FeatureReport("sphere", "BALL", FeatureGeometry(location=np.array([1.0, 2.0, 3.0]), diameter=25.0))
>>> path = write_qif(results_document([ball]), pathlib.Path(tempfile.mkdtemp()) / "ball.qif")
>>> read_qif(path).feature("BALL").actual.diameter
25.0
"""

from __future__ import annotations

import math
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import IO

import numpy as np

from pcmm_geo._atomic import write_atomic
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.io.cmm.document import CmmDocument
from pcmm_geo.io.cmm.model import (
    FEATURE_TYPES,
    Characteristic,
    FeatureDefinition,
    FeatureGeometry,
    FeatureItem,
    FeatureNominal,
    MeasuredFeature,
    MeasuredPointSet,
    MeasurementResults,
)
from pcmm_geo.io.cmm.qif._xml_out import (
    ALGORITHMS,
    CHARACTERISTIC_STATUSES,
    INSPECTION_STATUSES,
    XmlText,
    camel,
    decimal_text,
    double_text,
)

__all__ = ["FORM_CHARACTERISTICS", "SIZE_CHARACTERISTICS", "write_qif"]

SIZE_CHARACTERISTICS = ("diameter", "spherical_diameter", "radius", "spherical_radius", "length", "width")
FORM_CHARACTERISTICS = ("flatness", "circularity", "cylindricity", "sphericity", "straightness", "conicity")
_LINEAR_UNITS = {"mm": ("mm", 1.0), "inch": ("inch", 25.4)}
_BLOCK = 4096  # points formatted at a time


class _Writer:
    def __init__(self, document: CmmDocument, xml: XmlText, linear_unit: str) -> None:
        self.document = document
        self.xml = xml
        self.unit_name, self.mm_per_unit = _LINEAR_UNITS[linear_unit]

    # -- values in the file's units ------------------------------------------------------------
    def length(self, value: float) -> str:
        return decimal_text(value / self.mm_per_unit)

    def angle(self, value: float) -> str:
        return decimal_text(math.degrees(value))

    def point(self, values: np.ndarray) -> str:
        return " ".join(double_text(v / self.mm_per_unit) for v in values)

    @staticmethod
    def vector(values: np.ndarray) -> str:
        return " ".join(double_text(v) for v in values)

    def measured(self, tag: str, value: float, uncertainty: float | None, quantity: str = "linear") -> None:
        text = self.angle(value) if quantity == "angular" else self.length(value) if quantity == "linear" else (
            decimal_text(value))
        u = None if uncertainty is None else (self.angle(uncertainty) if quantity == "angular" else self.length(
            uncertainty) if quantity == "linear" else decimal_text(uncertainty))
        self.xml.leaf(tag, text, combinedUncertainty=u)

    # -- document ------------------------------------------------------------------------------
    def write(self, qpid: str) -> None:
        xml, document = self.xml, self.document
        characteristics = self._unique_characteristics()
        next_id = max(self._all_ids(), default=0) + 1
        standard_id = next_id if characteristics else None
        xml.raw('<?xml version="1.0" encoding="UTF-8"?>\n')
        xml.open("QIFDocument", xmlns="http://qifstandards.org/xsd/qif3", versionQIF="3.0.0",
                 idMax=next_id + len(document.results))
        xml.leaf("QPId", qpid)
        xml.open("Header")
        xml.open("Application")
        xml.leaf("Name", document.application or "pcmm_geo")
        xml.leaf("Organization", "pcmm_geo")
        xml.close("Application")
        xml.close("Header")
        if standard_id is not None:  # QIF characteristics name the standard they follow
            xml.open("StandardsDefinitions", n=1)
            xml.open("Standard", id=standard_id)
            xml.chain("Organization", "StandardsOrganizationEnum", text="ISO")
            xml.leaf("Designator", "1101")
            xml.leaf("Year", "2017")
            xml.close("Standard")
            xml.close("StandardsDefinitions")
        self._units()
        if document.feature_definitions or document.feature_nominals or document.feature_items:
            self._features()
        if characteristics:
            self._characteristics(characteristics, standard_id)  # type: ignore[arg-type]
        if document.results:
            xml.open("Results")
            xml.open("MeasurementResultsSet", n=len(document.results))
            for number, results in enumerate(document.results, start=1):
                self._results(results, next_id + number)
            xml.close("MeasurementResultsSet")
            xml.close("Results")
        xml.close("QIFDocument")

    def _all_ids(self) -> list[int]:
        document = self.document
        ids = [*document.feature_definitions, *document.feature_nominals, *document.feature_items]
        for results in document.results:
            ids += [results.id or 0, *results.point_sets, *(f.id for f in results.features)]
            for c in results.characteristics:
                ids += [c.id, c.item_id or 0, c.nominal_id or 0, c.definition_id or 0]
        return ids

    def _units(self) -> None:
        xml = self.xml
        xml.open("FileUnits")
        xml.open("PrimaryUnits")
        xml.open("AngularUnit")
        xml.leaf("SIUnitName", "radian")
        xml.leaf("UnitName", "degree")
        xml.chain("UnitConversion", "Factor", text=decimal_text(math.pi / 180.0))
        xml.close("AngularUnit")
        xml.open("LinearUnit")
        xml.leaf("SIUnitName", "meter")
        xml.leaf("UnitName", self.unit_name)
        xml.chain("UnitConversion", "Factor", text=decimal_text(self.mm_per_unit / 1000.0))
        xml.close("LinearUnit")
        xml.close("PrimaryUnits")
        xml.close("FileUnits")

    # -- features -------------------------------------------------------------------------------
    def _features(self) -> None:
        xml, document = self.xml, self.document
        xml.open("Features")
        for group, records, write in (
                ("FeatureDefinitions", document.feature_definitions, self._definition),
                ("FeatureNominals", document.feature_nominals, self._nominal),
                ("FeatureItems", document.feature_items, self._item)):
            if records:
                xml.open(group, n=len(records))
                for record in records.values():
                    _check_type(record.type, f"{group} id {record.id}")
                    write(record)
                xml.close(group)
        xml.close("Features")

    def _definition(self, definition: FeatureDefinition) -> None:
        tag = f"{camel(definition.type)}FeatureDefinition"
        xml = self.xml
        if definition.type not in ("circle", "cylinder", "sphere", "cone"):
            xml.leaf(tag, id=definition.id)
            return
        xml.open(tag, id=definition.id)
        xml.leaf("InternalExternal", definition.internal_external or "NOT_APPLICABLE")
        if definition.diameter is None:
            raise InvalidInputError(f"feature definition {definition.id}", "a diameter (QIF requires it)", "None")
        xml.leaf("Diameter", self.length(definition.diameter))
        if definition.type == "cylinder" and definition.length is not None:
            xml.leaf("Length", self.length(definition.length))
        if definition.type == "cone":
            if definition.half_angle is None:
                raise InvalidInputError(f"feature definition {definition.id}", "a half angle (QIF requires it)",
                                        "None")
            xml.leaf("HalfAngle", self.angle(definition.half_angle))
        xml.close(tag)

    def _nominal(self, nominal: FeatureNominal) -> None:
        tag = f"{camel(nominal.type)}FeatureNominal"
        xml, geometry = self.xml, nominal.geometry
        xml.open(tag, id=nominal.id)
        if nominal.definition_id is None:
            raise InvalidInputError(f"feature nominal {nominal.id}", "a definition id (QIF requires it)", "None")
        xml.leaf("FeatureDefinitionId", str(nominal.definition_id))
        needed = {"circle": ("location", "normal"), "cylinder": ("location", "direction"), "sphere": ("location",),
                  "plane": ("location", "normal"), "line": ("location", "direction"), "point": ("location",),
                  "cone": ("location", "direction")}[nominal.type]
        missing = [name for name in needed if getattr(geometry, name) is None]
        if missing:
            raise InvalidInputError(f"feature nominal {nominal.id}", f"{', '.join(needed)} (QIF requires them)",
                                    f"none for {', '.join(missing)}")
        self._placement(nominal.type, geometry, nominal=True)
        xml.close(tag)

    def _placement(self, kind: str, geometry: FeatureGeometry, *, nominal: bool) -> None:
        """Location / Normal / Direction / Axis in schema order (nominal line: Location, Direction, Length, Normal)."""
        xml, u = self.xml, geometry.uncertainty

        def location(tag: str) -> None:
            xml.leaf(tag, self.point(geometry.location), combinedUncertainty=None if "location" not in u else
                     self.length(u["location"]))  # type: ignore[arg-type]

        if kind in ("cylinder", "cone"):
            if geometry.location is not None and geometry.direction is not None:
                xml.open("Axis")
                location("AxisPoint")
                xml.leaf("Direction", self.vector(geometry.direction))
                xml.close("Axis")
            return
        if geometry.location is not None:
            location("Location")
        if kind == "line":
            if geometry.direction is not None:
                xml.leaf("Direction", self.vector(geometry.direction))
            if geometry.length is not None:
                self.measured("Length", geometry.length, u.get("length")) if not nominal else xml.leaf(
                    "Length", self.length(geometry.length))
        if kind != "sphere" and geometry.normal is not None:
            xml.leaf("Normal", self.vector(geometry.normal))

    def _item(self, item: FeatureItem) -> None:
        tag = f"{camel(item.type)}FeatureItem"
        xml = self.xml
        xml.open(tag, id=item.id)
        if item.nominal_id is None:
            raise InvalidInputError(f"feature item {item.id}", "a nominal id (QIF requires it)", "None")
        xml.leaf("FeatureNominalId", str(item.nominal_id))
        xml.leaf("FeatureName", item.name or f"F{item.id}")
        xml.chain("DeterminationMode", "Checked", "CheckDetails", "Measured")
        xml.close(tag)

    # -- characteristics --------------------------------------------------------------------------
    def _unique_characteristics(self) -> list[Characteristic]:
        seen: set[int] = set()
        unique = []
        for characteristic in self.document.characteristics:
            if characteristic.type not in SIZE_CHARACTERISTICS + FORM_CHARACTERISTICS:
                raise InvalidInputError(f"characteristic {characteristic.id}",
                                        f"one of {', '.join(SIZE_CHARACTERISTICS + FORM_CHARACTERISTICS)}",
                                        repr(characteristic.type))
            missing = [n for n in ("item_id", "nominal_id", "definition_id") if getattr(characteristic, n) is None]
            if missing:
                raise InvalidInputError(f"characteristic {characteristic.id}", "item, nominal and definition ids "
                                        "(build the document with results_document)", f"none for {', '.join(missing)}")
            if characteristic.type in FORM_CHARACTERISTICS and (characteristic.tolerance is None
                                                                or characteristic.tolerance.value is None):
                raise InvalidInputError(f"characteristic {characteristic.id} ({characteristic.type})",
                                        "a tolerance zone value (QIF requires one for form characteristics; a form "
                                        "value without tolerance goes in the feature's actual.form)", "none")
            if characteristic.type == "straightness" and characteristic.zone_shape not in ("diametrical",
                                                                                           "non_diametrical"):
                raise InvalidInputError(f"characteristic {characteristic.id} (straightness).zone_shape",
                                        "'diametrical' (a 3-D line's cylinder zone) or 'non_diametrical' (two "
                                        "parallel lines)", repr(characteristic.zone_shape))
            if characteristic.item_id not in seen:
                seen.add(characteristic.item_id)  # type: ignore[arg-type]
                unique.append(characteristic)
        return unique

    def _characteristics(self, characteristics: list[Characteristic], standard_id: int) -> None:
        xml = self.xml
        xml.open("Characteristics")
        xml.leaf("FormalStandardId", str(standard_id))
        for group, suffix, write in (("CharacteristicDefinitions", "CharacteristicDefinition", self._char_definition),
                                     ("CharacteristicNominals", "CharacteristicNominal", self._char_nominal),
                                     ("CharacteristicItems", "CharacteristicItem", self._char_item)):
            xml.open(group, n=len(characteristics))
            for characteristic in characteristics:
                tag = f"{camel(characteristic.type)}{suffix}"
                write(tag, characteristic)
            xml.close(group)
        xml.close("Characteristics")

    def _char_definition(self, tag: str, characteristic: Characteristic) -> None:
        xml, tolerance = self.xml, characteristic.tolerance
        xml.open(tag, id=characteristic.definition_id)
        if characteristic.type in FORM_CHARACTERISTICS:
            xml.leaf("ToleranceValue", self.length(tolerance.value))  # type: ignore[union-attr,arg-type]
            if characteristic.type == "straightness":
                xml.chain("ZoneShape", f"{camel(characteristic.zone_shape)}Zone")  # type: ignore[arg-type]
        elif tolerance is None or (tolerance.max_value is None and tolerance.min_value is None):
            xml.leaf("NonTolerance", "MEASURED")
        else:
            xml.open("Tolerance")
            if tolerance.max_value is not None:
                xml.leaf("MaxValue", self.length(tolerance.max_value))
            if tolerance.min_value is not None:
                xml.leaf("MinValue", self.length(tolerance.min_value))
            xml.leaf("DefinedAsLimit", "true" if tolerance.defined_as_limit else "false")
            xml.close("Tolerance")
        xml.close(tag)

    def _char_nominal(self, tag: str, characteristic: Characteristic) -> None:
        xml = self.xml
        xml.open(tag, id=characteristic.nominal_id)
        xml.leaf("CharacteristicDefinitionId", str(characteristic.definition_id))
        if characteristic.type in SIZE_CHARACTERISTICS and characteristic.nominal is not None:
            xml.leaf("TargetValue", self.length(characteristic.nominal))
        xml.close(tag)

    def _char_item(self, tag: str, characteristic: Characteristic) -> None:
        xml = self.xml
        xml.open(tag, id=characteristic.item_id)
        if characteristic.name:
            xml.leaf("Name", characteristic.name)
        if characteristic.feature_item_ids:
            xml.ids("FeatureItemIds", characteristic.feature_item_ids)
        xml.leaf("CharacteristicNominalId", str(characteristic.nominal_id))
        xml.close(tag)

    # -- results --------------------------------------------------------------------------------
    def _results(self, results: MeasurementResults, spare_id: int) -> None:
        xml = self.xml
        xml.open("MeasurementResults", id=results.id if results.id is not None else spare_id)
        if results.features:
            xml.open("MeasuredFeatures", n=len(results.features))
            for feature in results.features:
                self._measurement(feature)
            xml.close("MeasuredFeatures")
        if results.point_sets:
            xml.open("MeasuredPointSets", n=len(results.point_sets))
            for key, point_set in results.point_sets.items():
                self._point_set(key, point_set)
            xml.close("MeasuredPointSets")
        if results.characteristics:
            xml.open("MeasuredCharacteristics")
            xml.open("CharacteristicMeasurements", n=len(results.characteristics))
            for characteristic in results.characteristics:
                self._char_measurement(characteristic)
            xml.close("CharacteristicMeasurements")
            xml.close("MeasuredCharacteristics")
        status = results.inspection_status or "UNDEFINED"
        if status not in INSPECTION_STATUSES:
            raise InvalidInputError(f"results {results.id}.inspection_status",
                                    f"one of {', '.join(INSPECTION_STATUSES)}", repr(status))
        xml.chain("InspectionStatus", "InspectionStatusEnum", text=status)
        xml.close("MeasurementResults")

    def _measurement(self, feature: MeasuredFeature) -> None:
        _check_type(feature.type, f"feature measurement {feature.id}")
        tag = f"{camel(feature.type)}FeatureMeasurement"
        xml, actual = self.xml, feature.actual
        u = actual.uncertainty
        xml.open(tag, id=feature.id)
        if feature.item_id is not None:
            xml.leaf("FeatureItemId", str(feature.item_id))
        if feature.name:
            xml.leaf("FeatureName", feature.name)
        if feature.point_set_refs:
            xml.open("PointList", n=len(feature.point_set_refs))
            for ref in feature.point_set_refs:
                if ref.start == 0 and ref.stop is None:
                    xml.leaf("WholePointSetId", str(ref.point_set_id))
                elif ref.stop == ref.start + 1:
                    xml.leaf("SinglePointSetId", str(ref.point_set_id), index=ref.start + 1)
                else:
                    count = len(self.document.point_sets[ref.point_set_id])
                    xml.leaf("RangePointSetId", str(ref.point_set_id),
                             range=f"{ref.start + 1} {count if ref.stop is None else ref.stop}")
            xml.close("PointList")
        if feature.substitute_algorithm:
            known = feature.substitute_algorithm in ALGORITHMS
            xml.chain("SubstituteFeatureAlgorithm", "SubstituteFeatureAlgorithmEnum" if known
                      else "OtherSubstituteFeatureAlgorithm", text=feature.substitute_algorithm)
        self._placement(feature.type, actual, nominal=False)
        sizes = {"circle": ("diameter", "diameter_min", "diameter_max"),
                 "cylinder": ("diameter", "length", "diameter_min", "diameter_max"),
                 "sphere": ("diameter", "diameter_min", "diameter_max"),
                 "cone": ("diameter", "diameter_min", "diameter_max")}.get(feature.type, ())
        for name in sizes:
            value = getattr(actual, name)
            if value is not None:
                self.measured(camel(name), value, u.get(name))
        if feature.type == "cone" and actual.half_angle is not None:
            self.measured("HalfAngle", actual.half_angle, u.get("half_angle"), "angular")
        if feature.type != "point" and actual.form is not None:
            self.measured("Form", actual.form, u.get("form"))
        xml.close(tag)

    def _point_set(self, key: int, point_set: MeasuredPointSet) -> None:
        xml = self.xml
        n = len(point_set)
        if point_set.compensated is None and point_set.compensated_per_point is None:
            raise InvalidInputError(f"point set {key}.compensated", "True or False (QIF requires the flag)", "None")
        xml.open("MeasuredPointSet", id=key, count=n)
        self._number_list("Points", point_set.points, lambda block: block / self.mm_per_unit)
        if point_set.normals is not None:
            self._number_list("Normals", point_set.normals, lambda block: block)
        if point_set.compensated_per_point is not None:
            xml.leaf("Compensations", " ".join("true" if f else "false" for f in point_set.compensated_per_point))
        else:
            xml.leaf("Compensated", "true" if point_set.compensated else "false")
        if point_set.probe_radii is not None:
            self._number_list("ProbeRadii", point_set.probe_radii.reshape(-1, 1), lambda b: b / self.mm_per_unit)
        elif point_set.probe_radius is not None:
            xml.leaf("ProbeRadius", self.length(point_set.probe_radius))
        xml.close("MeasuredPointSet")

    def _number_list(self, tag: str, values: np.ndarray, scale: Callable[[np.ndarray], np.ndarray]) -> None:
        pad = "  " * self.xml.depth
        self.xml.raw(f"{pad}<{tag}>")
        for start in range(0, len(values), _BLOCK):
            block = scale(np.asarray(values[start:start + _BLOCK], dtype=np.float64))
            if not np.isfinite(block).all():
                raise InvalidInputError(tag, "finite numbers", "NaN or inf")
            self.xml.raw("".join("\n" + pad + "  " + " ".join(map(repr, row)) for row in block.tolist()))
        self.xml.raw(f"\n{pad}</{tag}>\n")

    def _char_measurement(self, characteristic: Characteristic) -> None:
        xml = self.xml
        tag = f"{camel(characteristic.type)}CharacteristicMeasurement"
        xml.open(tag, id=characteristic.id)
        status = characteristic.status or "NOT_ANALYZED"
        known = status in CHARACTERISTIC_STATUSES
        xml.chain("Status", "CharacteristicStatusEnum" if known else "OtherCharacteristicStatus", text=status)
        xml.leaf("CharacteristicItemId", str(characteristic.item_id))
        if characteristic.feature_measurement_ids:
            xml.ids("FeatureMeasurementIds", characteristic.feature_measurement_ids)
        if characteristic.value is not None:
            self.measured("Value", characteristic.value, characteristic.uncertainty)
        xml.close(tag)


def _check_type(kind: str, what: str) -> None:
    if kind not in FEATURE_TYPES:
        raise InvalidInputError(f"{what}.type", f"one of {', '.join(FEATURE_TYPES)} (the types the writer writes)",
                                repr(kind))


def write_qif(document: CmmDocument, path: str | Path, *, overwrite: bool = False, linear_unit: str = "mm",
              qpid: str | None = None) -> Path:
    """Write ``document`` as a QIF 3.0 results document (see the module docstring).

    Parameters
    ----------
    document : CmmDocument
        Usually built by :func:`~pcmm_geo.io.cmm.results_document`; a document read by
        :func:`~pcmm_geo.io.cmm.read_qif` can be written back when it holds only the types above.
    path : str or Path
    overwrite : bool
        Replace an existing file (default: refuse).
    linear_unit : {"mm", "inch"}
        Length unit of the file (values are converted; angles are written in degrees).
    qpid : str or None
        The document's QIF persistent id (a UUID); default a new random UUID.

    Returns
    -------
    Path

    Raises
    ------
    InvalidInputError
        A type the writer does not write, a missing value QIF requires, a non-finite number.
    OutputExistsError
        ``path`` exists and ``overwrite`` is False.
    """
    if linear_unit not in _LINEAR_UNITS:
        raise InvalidInputError("linear_unit", f"one of {', '.join(_LINEAR_UNITS)}", repr(linear_unit))
    qpid = str(uuid.UUID(qpid)) if qpid is not None else str(uuid.uuid4())

    def content(stream: IO[bytes]) -> None:
        _Writer(document, XmlText(stream), linear_unit).write(qpid)

    return write_atomic(path, content, overwrite=overwrite)
