"""The GD&T part of the QIF writer: datum definitions, datum reference frames and geometric characteristic definitions.

QIF 3.0 (``QIFDocument.xsd``, ``Characteristics.xsd``) keeps the datums at the document level --
``DatumDefinitions`` (a ``DatumLabel`` and the datum feature's ``FeatureNominalIds``) after
``FileUnits`` and ``DatumReferenceFrames`` (``Datums``, each a ``SimpleDatum`` with its
``MaterialModifier`` and its ``Precedence``) before ``Features`` -- and a geometric characteristic
definition names its frame by ``DatumReferenceFrameId``.  The records written are the reader's
(:mod:`pcmm_geo.io.cmm.qif.datums`, :class:`~pcmm_geo.io.cmm.qif.characteristic_definitions.CharacteristicDefinition`),
so what is written reads back as the same records.

Definition bodies, in schema order (ISO 23952:2020 / QIF 3.0):

- position: ``ToleranceValue``, ``DatumReferenceFrameId``, ``MaterialCondition``
  (``MAXIMUM`` / ``LEAST`` / ``REGARDLESS``), ``ZoneShape`` (``DiametricalZone``,
  ``SphericalZone``, ``NonDiametricalZone``);
- perpendicularity, parallelism, angularity: ``ToleranceValue``, ``DatumReferenceFrameId``,
  ``MaterialCondition``, ``ZoneShape`` (``DiametricalZone`` or ``PlanarZone``);
- coaxiality / concentricity: ``ToleranceValue``, ``DatumReferenceFrameId``, ``ZoneShape``;
- circular_runout, total_runout: ``ToleranceValue``, ``DatumReferenceFrameId``;
- surface_profile, line_profile, symmetry: ``ToleranceValue``, ``DatumReferenceFrameId`` (none: no datums).

A position or orientation measurement carries its ``Bonus`` (MMC / LMC) after ``Value``.

A composite position frame's lower segment (:class:`CompositeSegment`, ASME Y14.5-2018 10.5.1):
``SecondCompositeSegmentPositionDefinition`` (``DatumReferenceFrameId``, ``ToleranceValue``,
``MaterialCondition``, ``ZoneShape``) closes the position definition, and
``SecondCompositeSegmentPositionMeasurement`` (``Value``, ``Status``) follows the ``Bonus``.

Dimensions: a ``LinearCoordinate`` nominal holds ``TargetValue`` and ``Direction`` (``XAXIS``,
``YAXIS``, ``ZAXIS``; its measurement ``TypeOfCoordinates`` ``CARTESIAN_3D``, written by the
writer), a ``DistanceBetween`` / ``AngleBetween`` nominal ``TargetValue``, the optional
``AnalysisVector`` and ``AnalysisMode`` (:func:`write_dimension_nominal`); their definitions are
the writer's limits (``Tolerance`` ``MaxValue`` / ``MinValue``, degrees for an angle).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.io.cmm.model import Characteristic
from pcmm_geo.io.cmm.qif.characteristic_definitions import CharacteristicDefinition, CharacteristicNominal
from pcmm_geo.io.cmm.qif.datums import DatumDefinition, DatumReferenceFrame
from pcmm_geo.io.cmm.qif.write._xml_out import QifText, camel

__all__ = ["DIMENSION_CHARACTERISTICS", "GDT_CHARACTERISTICS", "CompositeSegment", "GdtRecords", "check_gdt_definition",
           "write_bonus", "write_datums", "write_dimension_nominal", "write_frames", "write_gdt_definition",
           "write_segment_measurement"]

#: geometric characteristic types this module writes (flatness and the other form types are the writer's)
GDT_CHARACTERISTICS = ("position", "perpendicularity", "parallelism", "angularity", "coaxiality", "concentricity",
                       "circular_runout", "total_runout", "surface_profile", "line_profile", "symmetry")
#: dimensional characteristic types whose nominal this module writes (Direction / AnalysisMode from the records)
DIMENSION_CHARACTERISTICS = ("linear_coordinate", "distance_between", "angle_between")
_AXES = ("XAXIS", "YAXIS", "ZAXIS")
_MODES = {"distance_between": ("ONEDIMENSIONAL", "TWODIMENSIONAL", "THREEDIMENSIONAL"),
          "angle_between": ("TWODIMENSIONAL", "THREEDIMENSIONAL")}
_ORIENTATION = ("perpendicularity", "parallelism", "angularity")
_ZONES = {"position": ("diametrical", "spherical", "non_diametrical"), "perpendicularity": ("diametrical", "planar"),
          "parallelism": ("diametrical", "planar"), "angularity": ("diametrical", "planar"),
          "coaxiality": ("diametrical",), "concentricity": ("spherical", "diametrical")}
_CONDITIONS = ("MAXIMUM", "LEAST", "REGARDLESS", "NONE")
_PRECEDENCES = ("PRIMARY", "SECONDARY", "TERTIARY")


@dataclass(frozen=True)
class CompositeSegment:
    """The second segment of a composite position frame: its definition and its measured value.

    Attributes
    ----------
    datum_reference_frame_id : int or None
        QIF id of the segment's frame (its datums constrain orientation only), None without datums.
    tolerance_value : float
        Zone diameter, mm.
    material_condition : {"MAXIMUM", "LEAST", "NONE"}
    value : float
        Measured zone diameter, mm.
    status : str
        A ``CharacteristicStatusEnum`` value.
    zone_shape : str
        ``"diametrical"`` (a pattern's cylindrical zones).
    """

    datum_reference_frame_id: int | None
    tolerance_value: float
    material_condition: str
    value: float
    status: str
    zone_shape: str = "diametrical"


@dataclass(frozen=True)
class GdtRecords:
    """What the writer needs beyond a :class:`~pcmm_geo.io.cmm.document.CmmDocument` for GD&T characteristics.

    Attributes
    ----------
    datum_definitions : dict of int to DatumDefinition
        By QIF id; ``feature_nominal_ids`` name the datum features' nominals in the document.
    datum_reference_frames : dict of int to DatumReferenceFrame
        By QIF id; simple datums only (``kind="simple"``).
    characteristic_definitions : dict of int to CharacteristicDefinition
        By the ``definition_id`` of the document's characteristics: the definition written for it
        (tolerance zone value in ``tolerance.value``, mm; zone shape; material condition; frame).
    bonuses : dict of int to float
        Bonus tolerance (mm) by characteristic measurement id, where a material modifier applies.
    characteristic_nominals : dict of int to CharacteristicNominal
        By the ``nominal_id`` of the document's linear coordinates (``direction``), distances and
        angles between (``analysis_mode``, optional ``analysis_vector``); the target value is the
        characteristic's ``nominal``.
    """

    datum_definitions: Mapping[int, DatumDefinition] = field(default_factory=dict)
    datum_reference_frames: Mapping[int, DatumReferenceFrame] = field(default_factory=dict)
    characteristic_definitions: Mapping[int, CharacteristicDefinition] = field(default_factory=dict)
    bonuses: Mapping[int, float] = field(default_factory=dict)
    characteristic_nominals: Mapping[int, CharacteristicNominal] = field(default_factory=dict)
    composite_segments: Mapping[int, CompositeSegment] = field(default_factory=dict)

    def ids(self) -> list[int]:
        """Every QIF id these records use."""
        return [*self.datum_definitions, *self.datum_reference_frames]


def write_datums(out: QifText, records: GdtRecords, nominal_ids: set[int]) -> None:
    """``DatumDefinitions`` (after ``FileUnits``); call :func:`write_frames` before ``Features``.

    Raises
    ------
    InvalidInputError
        A datum naming a feature nominal the document does not hold, a frame naming an unknown
        datum, a datum that is not simple, a precedence other than PRIMARY / SECONDARY / TERTIARY.
    """
    if not records.datum_definitions:
        return
    out.open("DatumDefinitions", n=len(records.datum_definitions))
    for key, datum in records.datum_definitions.items():
        missing = [i for i in datum.feature_nominal_ids if i not in nominal_ids]
        if missing:
            raise InvalidInputError(f"datum definition {key}.feature_nominal_ids", "ids of feature nominals of the "
                                    "document", str(missing))
        out.open("DatumDefinition", id=key)
        out.leaf("DatumLabel", datum.label)
        if datum.feature_nominal_ids:
            out.ids("FeatureNominalIds", datum.feature_nominal_ids)
        out.close("DatumDefinition")
    out.close("DatumDefinitions")


def write_frames(out: QifText, records: GdtRecords) -> None:
    """``DatumReferenceFrames`` (before ``Features``); an empty frame is written with no ``Datums``."""
    if not records.datum_reference_frames:
        return
    out.open("DatumReferenceFrames", n=len(records.datum_reference_frames))
    for key, frame in records.datum_reference_frames.items():
        out.open("DatumReferenceFrame", id=key)
        if frame.datums:
            out.open("Datums", n=len(frame.datums))
            for datum in frame.datums:
                if datum.kind != "simple" or len(datum.datum_definition_ids) != 1 \
                        or datum.datum_definition_ids[0] not in records.datum_definitions:
                    raise InvalidInputError(f"datum reference frame {key}", "simple datums naming a datum "
                                            "definition of the records", f"{datum.kind} {datum.datum_definition_ids}")
                if datum.precedence not in _PRECEDENCES:
                    raise InvalidInputError(f"datum reference frame {key}.precedence", ", ".join(_PRECEDENCES),
                                            repr(datum.precedence))
                modifier = datum.material_modifiers[0] if datum.material_modifiers else "NONE"
                out.open("Datum")
                out.open("SimpleDatum")
                out.leaf("DatumDefinitionId", str(datum.datum_definition_ids[0]))
                out.leaf("MaterialModifier", modifier)
                out.leaf("ReferencedComponent", datum.referenced_component or "ACTUAL")
                out.close("SimpleDatum")
                out.chain("Precedence", "PrecedenceEnum", text=datum.precedence)
                out.close("Datum")
            out.close("Datums")
        out.close("DatumReferenceFrame")
    out.close("DatumReferenceFrames")


def check_gdt_definition(characteristic: Characteristic, definition: CharacteristicDefinition | None,
                         records: GdtRecords) -> None:
    """Refuse a geometric characteristic whose definition the writer cannot write (names the characteristic)."""
    what = f"characteristic {characteristic.id} ({characteristic.type})"
    if characteristic.type in DIMENSION_CHARACTERISTICS:
        nominal = records.characteristic_nominals.get(characteristic.nominal_id or -1)
        if nominal is None:
            raise InvalidInputError(what, "a CharacteristicNominal in GdtRecords.characteristic_nominals", "none")
        if characteristic.type == "linear_coordinate" and nominal.direction not in _AXES:
            raise InvalidInputError(f"{what}.direction", " or ".join(_AXES), repr(nominal.direction))
        if characteristic.type in _MODES and nominal.analysis_mode not in _MODES[characteristic.type]:
            raise InvalidInputError(f"{what}.analysis_mode", " or ".join(_MODES[characteristic.type]),
                                    repr(nominal.analysis_mode))
        return
    if definition is None:
        raise InvalidInputError(what, "a CharacteristicDefinition in GdtRecords.characteristic_definitions", "none")
    if definition.tolerance is None or definition.tolerance.value is None or definition.tolerance.value < 0:
        raise InvalidInputError(f"{what}.tolerance.value", "a tolerance zone value >= 0 mm", "none")
    zones = _ZONES.get(characteristic.type)
    if zones is not None and definition.zone_shape not in zones:
        raise InvalidInputError(f"{what}.zone_shape", " or ".join(zones), repr(definition.zone_shape))
    if (characteristic.type == "position" or characteristic.type in _ORIENTATION) \
            and (definition.material_condition or "NONE") not in _CONDITIONS:
        raise InvalidInputError(f"{what}.material_condition", ", ".join(_CONDITIONS),
                                repr(definition.material_condition))
    for frame in definition.datum_reference_frame_ids:
        if frame not in records.datum_reference_frames:
            raise InvalidInputError(f"{what}.datum_reference_frame_ids", "frames of the records", str(frame))


def write_gdt_definition(out: QifText, tag: str, characteristic: Characteristic,
                         definition: CharacteristicDefinition, segment: CompositeSegment | None = None) -> None:
    """The ``<Type>CharacteristicDefinition`` of a geometric characteristic (see :func:`check_gdt_definition`)."""
    kind = characteristic.type
    out.open(tag, id=characteristic.definition_id)
    out.leaf("ToleranceValue", out.length(definition.tolerance.value))  # type: ignore[union-attr,arg-type]
    if definition.datum_reference_frame_ids:
        out.leaf("DatumReferenceFrameId", str(definition.datum_reference_frame_ids[0]))
    if kind == "position" or kind in _ORIENTATION:
        out.leaf("MaterialCondition", definition.material_condition or "NONE")
    if kind in _ZONES:
        out.chain("ZoneShape", f"{camel(definition.zone_shape)}Zone")  # type: ignore[arg-type]
    if segment is not None:
        if kind != "position" or segment.material_condition not in _CONDITIONS or segment.tolerance_value < 0:
            raise InvalidInputError(f"characteristic {characteristic.id}.composite_segment", "a position's segment "
                                    "with a tolerance >= 0 and a material condition", kind)
        out.open("SecondCompositeSegmentPositionDefinition")
        if segment.datum_reference_frame_id is not None:
            out.leaf("DatumReferenceFrameId", str(segment.datum_reference_frame_id))
        out.leaf("ToleranceValue", out.length(segment.tolerance_value))
        out.leaf("MaterialCondition", segment.material_condition)
        out.chain("ZoneShape", f"{camel(segment.zone_shape)}Zone")
        out.close("SecondCompositeSegmentPositionDefinition")
    out.close(tag)


def write_bonus(out: QifText, characteristic: Characteristic, records: GdtRecords | None) -> None:
    """``Bonus`` of a position or orientation measurement (after ``Value``), where one is recorded."""
    if records is None or characteristic.id not in records.bonuses:
        return
    if characteristic.type != "position" and characteristic.type not in _ORIENTATION:
        raise InvalidInputError(f"characteristic {characteristic.id}.bonus", "a position or orientation "
                                "characteristic (QIF has a Bonus only there)", characteristic.type)
    out.measured("Bonus", records.bonuses[characteristic.id], None)


def write_segment_measurement(out: QifText, characteristic: Characteristic, records: GdtRecords | None) -> None:
    """``SecondCompositeSegmentPositionMeasurement`` of a composite position (after ``Bonus``), where recorded."""
    if records is None or characteristic.definition_id not in records.composite_segments:
        return
    segment = records.composite_segments[characteristic.definition_id]  # type: ignore[index]
    out.open("SecondCompositeSegmentPositionMeasurement")
    out.measured("Value", segment.value, None)
    out.chain("Status", "CharacteristicStatusEnum", text=segment.status)
    out.close("SecondCompositeSegmentPositionMeasurement")


def write_dimension_nominal(out: QifText, tag: str, characteristic: Characteristic, records: GdtRecords) -> None:
    """The ``<Type>CharacteristicNominal`` of a linear coordinate, distance or angle between (schema order)."""
    nominal = records.characteristic_nominals[characteristic.nominal_id]  # type: ignore[index]
    out.open(tag, id=characteristic.nominal_id)
    out.leaf("CharacteristicDefinitionId", str(characteristic.definition_id))
    if characteristic.nominal is not None:
        out.leaf("TargetValue", out.angle(characteristic.nominal) if characteristic.type == "angle_between"
                 else out.length(characteristic.nominal))
    if characteristic.type == "linear_coordinate":
        out.leaf("Direction", nominal.direction)  # type: ignore[arg-type]
    else:
        if nominal.analysis_vector is not None:
            out.leaf("AnalysisVector", out.vector(nominal.analysis_vector))
        out.leaf("AnalysisMode", nominal.analysis_mode)  # type: ignore[arg-type]
    out.close(tag)
