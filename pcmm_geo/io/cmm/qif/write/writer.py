"""Write a :class:`CmmDocument` as a QIF 3.0 results document that validates against the QIF 3.0 schema.

Written, in schema order: ``QPId``, ``Header``, ``FileUnits`` (mm or inch, degree), the feature
definitions, nominals and items, the characteristic definitions, nominals and items, and per
``MeasurementResults`` the feature measurements (actuals, ``PointList``, substitute algorithm,
form, ``combinedUncertainty``), the measured point sets (points, normals, ``Compensated`` or
``Compensations``, ``ProbeRadius`` or ``ProbeRadii``), the characteristic measurements (status,
value, uncertainty) and the inspection status.

Numbers read back exactly (:mod:`~pcmm_geo.io.cmm.qif.write._xml_out`); point lists are written in blocks.

Layout: one function per section, each taking the output (:class:`~pcmm_geo.io.cmm.qif.write._xml_out.QifText`,
which converts mm and rad to the file's units) and the records.  The features part -- the
``Features`` section (:func:`~pcmm_geo.io.cmm.qif.write._features_out.write_features`, ids checked to
link first), the feature measurements and the point sets -- is
:mod:`~pcmm_geo.io.cmm.qif.write._features_out`.  The characteristics part is here:
:func:`characteristics_to_write` (checks, one record per item), :func:`write_characteristics`
(the ``Characteristics`` section, after ``Features``) and
:func:`write_characteristic_measurements` (``MeasuredCharacteristics`` of each results set, after
the point sets).  A new characteristic type is added there: its name in the accepted types,
its definition body (tolerance, zone shape, datums) in ``_char_definition``, its target in
``_char_nominal``; the item and the measurement are the same for every type.

Feature types written: circle, cylinder, sphere, plane, line, point, cone.  Characteristic types
written: diameter, spherical_diameter, radius, spherical_radius, length, width (size: tolerance
``MaxValue``/``MinValue`` or ``NonTolerance``) and flatness, circularity, cylindricity,
sphericity, straightness, conicity (form: ``ToleranceValue``, required by QIF -- a form value
without a tolerance belongs in the feature's ``actual.form``).  With ``gdt``
(:class:`~pcmm_geo.io.cmm.qif.write.gdt_out.GdtRecords`) also ``DatumDefinitions``,
``DatumReferenceFrames`` and the geometric characteristics (position, orientation, runout,
profile, coaxiality: their definitions and the ``Bonus``) and linear coordinates, distances and
angles between (their nominals): :mod:`~pcmm_geo.io.cmm.qif.write.gdt_out`.

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
from pathlib import Path
from typing import IO

from pcmm_geo._atomic import write_atomic
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.io.cmm.document import CmmDocument
from pcmm_geo.io.cmm.model import Characteristic, MeasurementResults
from pcmm_geo.io.cmm.qif.write._features_out import (
    check_feature_links,
    write_features,
    write_measured_features,
    write_point_sets,
)
from pcmm_geo.io.cmm.qif.write._xml_out import (
    CHARACTERISTIC_STATUSES,
    INSPECTION_STATUSES,
    QifText,
    camel,
    decimal_text,
)
from pcmm_geo.io.cmm.qif.write.gdt_out import (
    DIMENSION_CHARACTERISTICS,
    GDT_CHARACTERISTICS,
    GdtRecords,
    check_gdt_definition,
    write_bonus,
    write_datums,
    write_dimension_nominal,
    write_frames,
    write_gdt_definition,
    write_segment_measurement,
)

__all__ = ["FORM_CHARACTERISTICS", "SIZE_CHARACTERISTICS", "write_qif"]

SIZE_CHARACTERISTICS = ("diameter", "spherical_diameter", "radius", "spherical_radius", "length", "width")
FORM_CHARACTERISTICS = ("flatness", "circularity", "cylindricity", "sphericity", "straightness", "conicity")
_LINEAR_UNITS = {"mm": ("mm", 1.0), "inch": ("inch", 25.4)}


class _Writer:
    """The document in schema order; each section is one function of ``out`` and the document.

    Sections: header, standards, units, :func:`~pcmm_geo.io.cmm.qif.write._features_out.write_features`,
    :func:`write_characteristics`, then per results set the feature measurements, point sets,
    :func:`write_characteristic_measurements` and the inspection status.
    """

    def __init__(self, document: CmmDocument, out: QifText, gdt: GdtRecords | None = None) -> None:
        self.document = document
        self.out = out
        self.gdt = gdt

    def write(self, qpid: str) -> None:
        out, document = self.out, self.document
        check_feature_links(document)
        characteristics = characteristics_to_write(document, self.gdt)
        next_id = max([*self._all_ids(), *(self.gdt.ids() if self.gdt else ())], default=0) + 1
        standard_id = next_id if characteristics else None
        out.raw('<?xml version="1.0" encoding="UTF-8"?>\n')
        out.open("QIFDocument", xmlns="http://qifstandards.org/xsd/qif3", versionQIF="3.0.0",
                 idMax=next_id + len(document.results))
        out.leaf("QPId", qpid)
        out.open("Header")
        out.open("Application")
        out.leaf("Name", document.application or "pcmm_geo")
        out.leaf("Organization", "pcmm_geo")
        out.close("Application")
        out.close("Header")
        if standard_id is not None:  # QIF characteristics name the standard they follow
            out.open("StandardsDefinitions", n=1)
            out.open("Standard", id=standard_id)
            out.chain("Organization", "StandardsOrganizationEnum", text="ISO")
            out.leaf("Designator", "1101")
            out.leaf("Year", "2017")
            out.close("Standard")
            out.close("StandardsDefinitions")
        self._units()
        if self.gdt is not None:
            write_datums(out, self.gdt, set(document.feature_nominals))
            write_frames(out, self.gdt)
        write_features(out, document)
        if characteristics:
            write_characteristics(out, characteristics, standard_id, self.gdt)  # type: ignore[arg-type]
        if document.results:
            out.open("Results")
            out.open("MeasurementResultsSet", n=len(document.results))
            for number, results in enumerate(document.results, start=1):
                self._results(results, next_id + number)
            out.close("MeasurementResultsSet")
            out.close("Results")
        out.close("QIFDocument")

    def _all_ids(self) -> list[int]:
        document = self.document
        ids = [*document.feature_definitions, *document.feature_nominals, *document.feature_items]
        for results in document.results:
            ids += [results.id or 0, *results.point_sets, *(f.id for f in results.features)]
            for c in results.characteristics:
                ids += [c.id, c.item_id or 0, c.nominal_id or 0, c.definition_id or 0]
        return ids

    def _units(self) -> None:
        out = self.out
        out.open("FileUnits")
        out.open("PrimaryUnits")
        out.open("AngularUnit")
        out.leaf("SIUnitName", "radian")
        out.leaf("UnitName", "degree")
        out.chain("UnitConversion", "Factor", text=decimal_text(math.pi / 180.0))
        out.close("AngularUnit")
        out.open("LinearUnit")
        out.leaf("SIUnitName", "meter")
        out.leaf("UnitName", out.unit_name)
        out.chain("UnitConversion", "Factor", text=decimal_text(out.mm_per_unit / 1000.0))
        out.close("LinearUnit")
        out.close("PrimaryUnits")
        out.close("FileUnits")

    def _results(self, results: MeasurementResults, spare_id: int) -> None:
        out = self.out
        out.open("MeasurementResults", id=results.id if results.id is not None else spare_id)
        write_measured_features(out, results.features, self.document.point_sets)
        write_point_sets(out, results.point_sets)
        write_characteristic_measurements(out, results.characteristics, self.gdt)
        status = results.inspection_status or "UNDEFINED"
        if status not in INSPECTION_STATUSES:
            raise InvalidInputError(f"results {results.id}.inspection_status",
                                    f"one of {', '.join(INSPECTION_STATUSES)}", repr(status))
        out.chain("InspectionStatus", "InspectionStatusEnum", text=status)
        out.close("MeasurementResults")


# -- characteristics: the Characteristics section and the MeasuredCharacteristics of a results set -------------
# A new characteristic type needs: its name in the type lists (or a check in characteristics_to_write), its
# definition body in _char_definition, its TargetValue in _char_nominal; the measurement is generic.

def characteristics_to_write(document: CmmDocument, gdt: GdtRecords | None = None) -> list[Characteristic]:
    """One record per characteristic item (checked), in document order: what the section holds.

    ``gdt``: the definitions of geometric characteristics
    (:data:`~pcmm_geo.io.cmm.qif.write.gdt_out.GDT_CHARACTERISTICS`) and their datums; without it
    only size and form characteristics are written.
    """
    seen: set[int] = set()
    unique = []
    for characteristic in document.characteristics:
        if gdt is not None and characteristic.type in GDT_CHARACTERISTICS + DIMENSION_CHARACTERISTICS:
            check_gdt_definition(characteristic, gdt.characteristic_definitions.get(characteristic.definition_id or -1),
                                 gdt)
        elif characteristic.type not in SIZE_CHARACTERISTICS + FORM_CHARACTERISTICS:
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


def write_characteristics(out: QifText, characteristics: list[Characteristic], standard_id: int,
                          gdt: GdtRecords | None = None) -> None:
    """The ``Characteristics`` section: definitions, nominals and items of ``characteristics``."""
    out.open("Characteristics")
    out.leaf("FormalStandardId", str(standard_id))

    def definition(out: QifText, tag: str, characteristic: Characteristic) -> None:
        if gdt is not None and characteristic.type in GDT_CHARACTERISTICS:
            write_gdt_definition(out, tag, characteristic,
                                 gdt.characteristic_definitions[characteristic.definition_id],  # type: ignore[index]
                                 gdt.composite_segments.get(characteristic.definition_id))  # type: ignore[arg-type]
        else:
            _char_definition(out, tag, characteristic)

    def nominal(out: QifText, tag: str, characteristic: Characteristic) -> None:
        if gdt is not None and characteristic.type in DIMENSION_CHARACTERISTICS:
            write_dimension_nominal(out, tag, characteristic, gdt)
        else:
            _char_nominal(out, tag, characteristic)

    for group, suffix, write in (("CharacteristicDefinitions", "CharacteristicDefinition", definition),
                                 ("CharacteristicNominals", "CharacteristicNominal", nominal),
                                 ("CharacteristicItems", "CharacteristicItem", _char_item)):
        out.open(group, n=len(characteristics))
        for characteristic in characteristics:
            write(out, f"{camel(characteristic.type)}{suffix}", characteristic)
        out.close(group)
    out.close("Characteristics")


def _char_definition(out: QifText, tag: str, characteristic: Characteristic) -> None:
    tolerance = characteristic.tolerance
    out.open(tag, id=characteristic.definition_id)
    if characteristic.type in FORM_CHARACTERISTICS:
        out.leaf("ToleranceValue", out.length(tolerance.value))  # type: ignore[union-attr,arg-type]
        if characteristic.type == "straightness":
            out.chain("ZoneShape", f"{camel(characteristic.zone_shape)}Zone")  # type: ignore[arg-type]
    elif tolerance is None or (tolerance.max_value is None and tolerance.min_value is None):
        out.leaf("NonTolerance", "MEASURED")
    else:
        quantity = out.angle if characteristic.type == "angle_between" else out.length
        out.open("Tolerance")
        if tolerance.max_value is not None:
            out.leaf("MaxValue", quantity(tolerance.max_value))
        if tolerance.min_value is not None:
            out.leaf("MinValue", quantity(tolerance.min_value))
        out.leaf("DefinedAsLimit", "true" if tolerance.defined_as_limit else "false")
        out.close("Tolerance")
    out.close(tag)


def _char_nominal(out: QifText, tag: str, characteristic: Characteristic) -> None:
    out.open(tag, id=characteristic.nominal_id)
    out.leaf("CharacteristicDefinitionId", str(characteristic.definition_id))
    if characteristic.type in SIZE_CHARACTERISTICS and characteristic.nominal is not None:
        out.leaf("TargetValue", out.length(characteristic.nominal))
    out.close(tag)


def _char_item(out: QifText, tag: str, characteristic: Characteristic) -> None:
    out.open(tag, id=characteristic.item_id)
    if characteristic.name:
        out.leaf("Name", characteristic.name)
    if characteristic.feature_item_ids:
        out.ids("FeatureItemIds", characteristic.feature_item_ids)
    out.leaf("CharacteristicNominalId", str(characteristic.nominal_id))
    out.close(tag)


def write_characteristic_measurements(out: QifText, characteristics: tuple[Characteristic, ...],
                                      gdt: GdtRecords | None = None) -> None:
    """``MeasuredCharacteristics`` of one results set: status, item, feature measurements, value (and bonus)."""
    if not characteristics:
        return
    out.open("MeasuredCharacteristics")
    out.open("CharacteristicMeasurements", n=len(characteristics))
    for characteristic in characteristics:
        out.open(f"{camel(characteristic.type)}CharacteristicMeasurement", id=characteristic.id)
        status = characteristic.status or "NOT_ANALYZED"
        known = status in CHARACTERISTIC_STATUSES
        out.chain("Status", "CharacteristicStatusEnum" if known else "OtherCharacteristicStatus", text=status)
        out.leaf("CharacteristicItemId", str(characteristic.item_id))
        if characteristic.feature_measurement_ids:
            out.ids("FeatureMeasurementIds", characteristic.feature_measurement_ids)
        if characteristic.type == "linear_coordinate":  # QIF requires the coordinate type of a coordinate
            out.chain("TypeOfCoordinates", "CoordinateEnum", text="CARTESIAN_3D")
        if characteristic.value is not None:
            out.measured("Value", characteristic.value, characteristic.uncertainty,
                         "angular" if characteristic.type == "angle_between" else "linear")
        write_bonus(out, characteristic, gdt)
        write_segment_measurement(out, characteristic, gdt)
        out.close(f"{camel(characteristic.type)}CharacteristicMeasurement")
    out.close("CharacteristicMeasurements")
    out.close("MeasuredCharacteristics")


def write_qif(document: CmmDocument, path: str | Path, *, overwrite: bool = False, linear_unit: str = "mm",
              qpid: str | None = None, gdt: GdtRecords | None = None) -> Path:
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
    gdt : GdtRecords or None
        Datum definitions, datum reference frames and the definitions (and bonuses) of the document's
        geometric characteristics (:mod:`~pcmm_geo.io.cmm.qif.write.gdt_out`).

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
        _Writer(document, QifText(stream, *_LINEAR_UNITS[linear_unit]), gdt).write(qpid)

    return write_atomic(path, content, overwrite=overwrite)
