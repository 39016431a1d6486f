"""An inspection plan's results as a QIF 3.0 results file: features, datums, frames and characteristic measurements.

:func:`inspection_to_qif` converts an :class:`~pcmm_geo.gdt.inspection.InspectionResult` to the
plain records of :mod:`pcmm_geo.io.cmm` (``io`` does not know ``gdt``) and writes them with
:func:`~pcmm_geo.io.cmm.write_qif`:

- every feature of the plan (plane, cylinder, sphere, point) with its nominal (from the plan),
  item, measured actual and its points, all in the coordinates of the part's datum reference frame
  (``[part] frame``; without one, the frame of the most datums the characteristics use -- the
  plan's nominals are in the frame of each characteristic's datums --; without datums, the
  measurement coordinates).  Actuals: a datum feature of the
  file's frame, its associated datum (ISO 5459 tangent minimax plane -- QIF ``ONESIDED`` --, ASME
  constrained least squares -- ``OtherSubstituteFeatureAlgorithm`` ``CONSTRAINED_LEASTSQUARES``,
  not QIF's unconstrained ``LEASTSQUARES`` --, MIC / MCC); a cylinder, its toleranced axis over the points' extent
  (ISO least-squares, ASME the unrelated actual mating envelope), its point at the nominal point's
  height along the nominal axis (as :func:`~pcmm_geo.gdt.dimensions.feature_location`) and its
  diameter; a plane, its
  least-squares plane; a sphere, its least-squares sphere; a point, the mean of its points;
- a ``Diameter`` characteristic for each cylinder with a size tolerance (value: the actual's
  diameter; PASS / FAIL against the limits);
- ``DatumDefinitions`` (label, the datum feature's nominal) and one ``DatumReferenceFrame`` per
  datum sequence the frames use (simple datums; ``MaterialModifier`` NONE, or MAXIMUM / LEAST for a datum
  referenced at MMB / LMB -- one frame per datums and modifiers; the datum shift used is not written; a
  characteristic to a common datum ``A-B`` or to a datum from targets is listed as not written, by name);
- the characteristics: position (``DiametricalZone`` / ``SphericalZone`` / ``NonDiametricalZone``,
  ``MaterialCondition`` MAXIMUM / LEAST / NONE and the ``Bonus``), perpendicularity,
  parallelism, angularity (``DiametricalZone`` / ``PlanarZone``), flatness, circular and total
  runout, coaxiality, concentricity and symmetry (on its first face), each naming its DRF; a composite
  position frame's FRTZF as the PLTZF position's ``SecondCompositeSegmentPosition`` definition and
  measurement (a stacked ISO segment with ``><``, orientation only, is not written, by name);
  coordinates (``LinearCoordinate``,
  ``Direction`` XAXIS / YAXIS / ZAXIS), distances (``DistanceBetween``, ``AnalysisMode
  THREEDIMENSIONAL``) -- both only in the file's frame -- and angles (``AngleBetween``) with
  their nominal and limits.  Profile of a surface (its feature has no QIF feature type the writer
  writes) and a coordinate or distance in another frame are reported as not written, by name.

A characteristic with an expanded uncertainty U (stated ``uncertainty_mm``, or propagated from the points'
``point_u_mm``) has its measured value's ``combinedUncertainty`` written as U / 2 (a standard uncertainty).

Status: ``PASS`` and ``FAIL`` as the verdict; ``NOT PROVEN`` is written as QIF
``INDETERMINATE`` (the ``CharacteristicStatusEnum`` value for "the measurement does not decide";
``NOT_ANALYZED`` would claim it was not evaluated).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pcmm_geo.gdt.characteristics import CharacteristicResult, FeatureData, toleranced_axis
from pcmm_geo.gdt.inspection import InspectionResult
from pcmm_geo.gdt.reference.frame import DatumReferenceFrame

if TYPE_CHECKING:
    from pcmm_geo.io.cmm import Characteristic, CmmDocument

__all__ = ["QifExport", "STATUS_OF_VERDICT", "inspection_to_qif"]

#: QIF CharacteristicStatusEnum value of each verdict
STATUS_OF_VERDICT = {"PASS": "PASS", "FAIL": "FAIL", "NOT PROVEN": "INDETERMINATE"}
_TYPES = {"position": "position", "perpendicularity": "perpendicularity", "parallelism": "parallelism",
          "angularity": "angularity", "flatness": "flatness", "circular runout": "circular_runout",
          "total runout": "total_runout", "coaxiality": "coaxiality", "concentricity": "concentricity",
          "profile of a surface": "surface_profile", "profile of a line": "line_profile", "symmetry": "symmetry"}
_DIMENSIONS = {"coordinate": "linear_coordinate", "distance": "distance_between", "angle": "angle_between"}
_FEATURE_TYPES = {"plane": "plane", "cylinder": "cylinder", "sphere": "sphere", "point": "point"}
_CONDITIONS = {"MMC": "MAXIMUM", "LMC": "LEAST", "RFS": "NONE"}


@dataclass(frozen=True)
class QifExport:
    """What :func:`inspection_to_qif` wrote.

    Attributes
    ----------
    path : Path
    written : tuple of str
        Names of the plan characteristics written (in plan order).
    not_written : tuple of (str, str)
        ``(name, reason)`` of each plan characteristic with no QIF record here.
    features : tuple of str
        Names of the features written.
    frames : tuple of str
        The datum reference frames written (``"A|B|C"``).
    """

    path: Path
    written: tuple[str, ...]
    not_written: tuple[tuple[str, str], ...]
    features: tuple[str, ...]
    frames: tuple[str, ...]

    def to_dict(self) -> dict[str, object]:
        """JSON-ready record."""
        return {"path": str(self.path), "written": list(self.written),
                "not_written": [{"name": n, "reason": r} for n, r in self.not_written],
                "features": list(self.features), "frames": list(self.frames)}


def _kind(result: CharacteristicResult) -> str | None:
    return _TYPES.get(result.characteristic) or _DIMENSIONS.get(result.characteristic.split()[0])


def _reason(result: CharacteristicResult, features: list[FeatureData | None],
            part_frame: tuple[str, ...], targets: frozenset[str] = frozenset()) -> str | None:
    kind = _kind(result)
    if kind is None:
        return f"{result.characteristic}: no QIF characteristic type is written for it"
    if result.details.get("orientation_only") and result.details.get("segment") != "FRTZF":
        return ("a stacked segment whose datums constrain orientation only (ISO '><'): QIF has no such flag, and "
                "a plain position to those datums would claim they locate it")
    if kind in ("linear_coordinate", "distance_between") and result.datums != part_frame:
        # a coordinate, and a distance taken at the nominal heights, depend on the frame they are in
        return (f"a {result.characteristic.split()[0]} in the frame {'|'.join(result.datums) or 'of the measurement'}: "
                "QIF's LinearCoordinate / DistanceBetween are in the file's coordinates, which are the frame "
                f"{'|'.join(part_frame) or 'of the measurement'}")
    if any(feature is None or feature.element not in _FEATURE_TYPES for feature in features):
        return ("QIF has SurfaceProfile, but its feature (a nominal surface given by points and normals) has no "
                "QIF feature type pcmm_geo's writer writes")
    if not np.isfinite(result.value_mm):
        return "its value is not finite"
    special = [label for label in result.datums if "-" in label or label in targets]
    if special:
        return (f"datum {special[0]} is a common datum or a datum from targets: pcmm_geo's writer writes a datum "
                "definition from one datum feature only")
    return None


#: datum feature modifiers -> QIF MaterialModifierEnum
_DATUM_MODIFIERS = {"RMB": "NONE", "MMB": "MAXIMUM", "LMB": "LEAST"}


def _key(result: CharacteristicResult) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """A characteristic's datum reference frame: its datums and their modifiers (MMB / LMB)."""
    modifiers = tuple(result.details.get("datum_modifiers") or ("RMB",) * len(result.datums))
    return result.datums, modifiers


def _at_nominal_height(point: np.ndarray, axis: np.ndarray, feature: FeatureData) -> np.ndarray:
    """The point of an actual axis at the nominal point's height along the nominal axis (the CMM convention)."""
    t = float((feature.point - point) @ feature.direction) / float(axis @ feature.direction)
    return point + t * axis


def _actual(feature: FeatureData, frame: DatumReferenceFrame, association: object | None, standard: str) -> dict:
    """Actual geometry (part-frame coordinates) of ``feature`` and the substitute algorithm's QIF name."""
    from pcmm_geo.fit import fit_plane, fit_sphere
    from pcmm_geo.io.cmm import FeatureGeometry

    points = frame.to_frame(feature.points)
    if association is not None:  # a datum of the part frame: its associated datum
        point = frame.to_frame(association.point[None, :])[0]  # type: ignore[attr-defined]
        direction = frame.direction_to_frame(association.direction[None, :])[0]  # type: ignore[attr-defined]
        criterion = association.criterion  # type: ignore[attr-defined]
        algorithm = {"minimax": "ONESIDED", "constrained-lsq": "CONSTRAINED_LEASTSQUARES", "mic": "MAXINSCRIBED",
                     "mcc": "MINCIRCUMSCRIBED"}.get(criterion, "DEFAULT")
        if feature.element == "plane":
            return {"actual": FeatureGeometry(location=point, normal=-direction), "algorithm": algorithm}
        if feature.element == "cylinder":
            if direction @ feature.direction < 0:
                direction = -direction
            location = _at_nominal_height(point, direction, feature)
            return {"actual": FeatureGeometry(location=location, direction=direction,
                                              diameter=2.0 * association.radius),  # type: ignore[attr-defined]
                    "algorithm": algorithm}
        return {"actual": FeatureGeometry(location=point, diameter=None if feature.element == "point"
                                          else 2.0 * association.radius), "algorithm": algorithm}  # type: ignore[attr-defined]
    if feature.element == "plane":
        fit = fit_plane(points)
        normal = np.asarray(fit.normal, dtype=float)
        if normal @ feature.direction < 0:
            normal = -normal
        return {"actual": FeatureGeometry(location=np.asarray(fit.point, dtype=float), normal=normal),
                "algorithm": "LEASTSQUARES"}
    if feature.element == "cylinder":
        ends, axis, fit = toleranced_axis(points, feature, standard)
        algorithm = "LEASTSQUARES" if standard == "ISO" else (
            "MAXINSCRIBED" if feature.side == "internal" else "MINCIRCUMSCRIBED")
        location = _at_nominal_height(ends[0], axis, feature)
        return {"actual": FeatureGeometry(location=location, direction=axis, diameter=2.0 * float(fit.radius)),
                "algorithm": algorithm}
    if feature.element == "sphere":
        fit = fit_sphere(points)
        return {"actual": FeatureGeometry(location=np.asarray(fit.center, dtype=float), diameter=float(fit.diameter)),
                "algorithm": "LEASTSQUARES"}
    return {"actual": FeatureGeometry(location=points.mean(axis=0)), "algorithm": "DEFAULT"}


def _dimension(outcome: CharacteristicResult, dimension: dict[str, Any], kind: str) -> Characteristic:
    """A coordinate, distance or angle as an io Characteristic: nominal and deviations from the plan."""
    from pcmm_geo.io.cmm import Characteristic, Tolerance

    scale = np.pi / 180.0 if kind == "angle_between" else 1.0  # the plan states angles in degrees
    low, high = (scale * float(v) for v in dimension["limits"])
    ok = outcome.verdict
    return Characteristic(id=0, type=kind, name=outcome.name, value=outcome.value_mm,
                          nominal=scale * float(dimension["nominal"]),
                          tolerance=Tolerance(max_value=high, min_value=low), status=STATUS_OF_VERDICT[ok],
                          quantity="angular" if kind == "angle_between" else "linear", uncertainty=_standard_u(outcome))


def _standard_u(outcome: CharacteristicResult) -> float | None:
    """QIF ``combinedUncertainty`` (a combined standard uncertainty): U / 2 of the stated or propagated U (k = 2)."""
    expanded = outcome.details.get("expanded_uncertainty_mm", outcome.details.get("expanded_uncertainty_rad"))
    return None if expanded is None else float(expanded) / 2.0


def _link_second_features(document: CmmDocument, result: InspectionResult,
                          meta: list[tuple[int, str | None] | None]) -> CmmDocument:
    """A distance or angle between names both features' measurements and items (results_document links one).

    ``meta``: per characteristic of the document, in order, its plan index (None: a size).
    """
    import dataclasses

    sets = []
    for results in document.results:
        by_name = {f.name: f for f in results.features}
        changed = []
        for c, entry in zip(results.characteristics, meta, strict=True):
            dimension = None if entry is None else result.plan.characteristics[entry[0]].dimension
            if dimension is not None and len(dimension["features"]) == 2:
                features = [by_name[n] for n in dimension["features"]]
                c = dataclasses.replace(c, feature_measurement_ids=tuple(f.id for f in features),
                                        feature_item_ids=tuple(f.item_id for f in features if f.item_id is not None))
            changed.append(c)
        sets.append(dataclasses.replace(results, characteristics=tuple(changed)))
    return dataclasses.replace(document, results=tuple(sets))


def inspection_to_qif(result: InspectionResult, path: str | Path, *, overwrite: bool = False) -> QifExport:
    """Write an inspection's results as a schema-valid QIF 3.0 results file (see the module docstring).

    Parameters
    ----------
    result : InspectionResult
        From :func:`~pcmm_geo.gdt.inspection.inspect_plan`.
    path : str or Path
        The ``.qif`` file to write.
    overwrite : bool
        Replace an existing file (default: refuse).

    Returns
    -------
    QifExport
        The path, the characteristics written and those not written (by name, with the reason).

    Raises
    ------
    OutputExistsError
        ``path`` exists and ``overwrite`` is False.
    InvalidInputError
        A record QIF cannot hold (a non-finite number).
    """
    from pcmm_geo.io.cmm import Characteristic, FeatureGeometry, FeatureReport, MeasuredPointSet, Tolerance, write_qif
    from pcmm_geo.io.cmm.qif.characteristic_definitions import CharacteristicDefinition, CharacteristicNominal
    from pcmm_geo.io.cmm.qif.datums import DatumDefinition, DrfDatum
    from pcmm_geo.io.cmm.qif.datums import DatumReferenceFrame as QifFrame
    from pcmm_geo.io.cmm.qif.write.gdt_out import CompositeSegment, GdtRecords

    plan = result.plan
    # the file's coordinates: the part frame; without one, the frame of the most datums the plan uses
    # (the plan's nominals are in the frame of each characteristic's datums)
    keys = [key for key in result.frames if key]
    file_frame = plan.part_frame or (tuple(max(keys, key=lambda k: len(k.split("|"))).split("|")) if keys else ())
    frame = result.frames["|".join(file_frame)] if file_frame else DatumReferenceFrame.measurement()
    associations = dict(result.datums)  # the part frame's datums, associated in precedence
    if not plan.part_frame and file_frame:
        from pcmm_geo.gdt.inspection import _Frames

        frames_of_plan = _Frames(plan)
        associations = {file_frame[k - 1]: frames_of_plan.association(file_frame[:k])
                        for k in range(1, len(file_frame) + 1)}
    targets = frozenset(label for label, options in plan.datum_options.items() if "targets" in options)
    datum_of_feature = {feature: label for label, (feature, _) in plan.datums.items() if label not in targets}
    written: list[str] = []
    not_written: list[tuple[str, str]] = []
    wanted: dict[str, list[int]] = {}
    upper: dict[tuple[str, str], int] = {}  # (pattern, feature) -> index of a composite frame's PLTZF
    second: dict[int, int] = {}  # PLTZF index -> its FRTZF index (QIF SecondCompositeSegmentPosition)
    for index, (planned, outcome) in enumerate(zip(plan.characteristics, result.characteristics, strict=True)):
        segment = outcome.details.get("segment")
        if segment in ("PLTZF", "FRTZF"):
            key = (str(outcome.details.get("pattern")), planned.feature)
            if segment == "PLTZF":
                upper[key] = index
            elif key in upper and upper[key] in {i for ids in wanted.values() for i in ids}:
                second[upper[key]] = index
                written.append(outcome.name)
                continue
            else:
                not_written.append((outcome.name, "its composite frame's upper segment is not written"))
                continue
        names = planned.dimension["features"] if planned.dimension is not None else [planned.feature]
        reason = _reason(outcome, [plan.features.get(n) for n in names], file_frame, targets)
        if reason is None:
            wanted.setdefault(planned.feature, []).append(index)
            written.append(outcome.name)
        else:
            not_written.append((outcome.name, reason))
    sequences = sorted({_key(result.characteristics[i]) for ids in [*wanted.values(), list(second.values())]
                        for i in ids if result.characteristics[i].datums}, key=lambda s: (len(s[0]), s))
    reports = []
    meta: list[tuple[int, str | None] | None] = []  # per characteristic, in document order: plan index, zone
    for name, feature in plan.features.items():
        if feature.element not in _FEATURE_TYPES:
            continue
        label = datum_of_feature.get(name)
        association = associations.get(label) if label is not None else None
        actual = _actual(feature, frame, association, plan.standard)
        sized = feature.element in ("cylinder", "sphere") and np.isfinite(feature.diameter)
        nominal = FeatureGeometry(
            location=np.asarray(feature.point, dtype=float),
            normal=feature.direction if feature.element == "plane" else None,
            direction=feature.direction if feature.element == "cylinder" else None,
            diameter=feature.diameter if sized else None)
        characteristics = []
        low, high = feature.size_tolerance
        if feature.element == "cylinder" and sized and (low, high) != (0.0, 0.0):
            diameter = float(actual["actual"].diameter)
            ok = feature.diameter + low <= diameter <= feature.diameter + high
            characteristics.append(Characteristic(
                id=0, type="diameter", name=f"{name} diameter", value=diameter, nominal=feature.diameter,
                tolerance=Tolerance(max_value=high, min_value=low), status="PASS" if ok else "FAIL"))
            meta.append(None)
        for index in wanted.get(name, ()):
            outcome, planned = result.characteristics[index], plan.characteristics[index]
            kind = _kind(outcome)
            if planned.dimension is not None:
                characteristics.append(_dimension(outcome, planned.dimension, kind))  # type: ignore[arg-type]
                meta.append((index, None))
                continue
            zone = None
            if planned.frame is not None and kind not in ("flatness", "circular_runout", "total_runout"):
                dia = {"dia": "diametrical", "sdia": "spherical"}.get(planned.frame.zone)
                zone = dia or ("non_diametrical" if kind == "position" else "planar")
                if kind in ("coaxiality", "concentricity"):
                    zone = "spherical" if feature.element in ("sphere", "point") else "diametrical"
            meta.append((index, zone))
            characteristics.append(Characteristic(
                id=0, type=kind, name=outcome.name, value=outcome.value_mm,
                tolerance=Tolerance(value=outcome.tolerance_mm),
                status=STATUS_OF_VERDICT[outcome.verdict], zone_shape=zone, uncertainty=_standard_u(outcome)))
        reports.append(FeatureReport(
            type=_FEATURE_TYPES[feature.element], name=name, actual=actual["actual"], nominal=nominal,
            internal_external=("INTERNAL" if feature.side == "internal" else "EXTERNAL") if sized else None,
            points=MeasuredPointSet(id=None, points=frame.to_frame(feature.points), compensated=True),
            characteristics=tuple(characteristics), substitute_algorithm=actual["algorithm"]))
    from pcmm_geo.io.cmm import results_document

    document = _link_second_features(results_document(reports, application="pcmm_geo inspect", source=plan.path),
                                     result, meta)
    used = [*document.feature_definitions, *document.feature_nominals, *document.feature_items]
    for results in document.results:
        used += [results.id or 0, *results.point_sets, *(f.id for f in results.features)]
        used += [k for c in results.characteristics for k in (c.id, c.item_id or 0, c.nominal_id or 0,
                                                                c.definition_id or 0)]
    counter = iter(range(max(used) + 1, 1 << 31))
    nominal_of_feature = {item.name: item.nominal_id for item in document.feature_items.values()}
    labels = sorted({label for sequence, _ in sequences for label in sequence})
    datum_ids = {label: next(counter) for label in labels}
    datum_definitions = {datum_ids[label]: DatumDefinition(
        id=datum_ids[label], label=label, feature_nominal_ids=(nominal_of_feature[plan.datums[label][0]],))
        for label in labels}
    frame_ids = {sequence: next(counter) for sequence in sequences}
    precedences = ("PRIMARY", "SECONDARY", "TERTIARY")
    frames = {key: QifFrame(id=key, datums=tuple(
        DrfDatum(precedence=precedences[k], kind="simple", datum_definition_ids=(datum_ids[label],),
                 material_modifiers=(_DATUM_MODIFIERS[sequence[1][k]],), referenced_component="ACTUAL")
        for k, label in enumerate(sequence[0]))) for sequence, key in frame_ids.items()}
    definitions, bonuses, nominals, segments = {}, {}, {}, {}
    for characteristic, entry in zip(document.characteristics, meta, strict=True):
        if entry is None:
            continue
        index, zone = entry
        outcome, planned = result.characteristics[index], plan.characteristics[index]
        if planned.dimension is not None:
            nominals[characteristic.nominal_id] = CharacteristicNominal(
                id=characteristic.nominal_id, type=characteristic.type,  # type: ignore[arg-type]
                definition_id=characteristic.definition_id, target_value=characteristic.nominal,
                direction=f"{planned.dimension.get('axis', 'x').upper()}AXIS"
                if characteristic.type == "linear_coordinate" else None,
                analysis_mode=None if characteristic.type == "linear_coordinate" else "THREEDIMENSIONAL")
            continue
        modifier = planned.frame.modifier if planned.frame is not None else "RFS"
        definitions[characteristic.definition_id] = CharacteristicDefinition(
            id=characteristic.definition_id, type=characteristic.type,  # type: ignore[arg-type]
            tolerance=Tolerance(value=outcome.tolerance_mm),
            material_condition=_CONDITIONS[modifier] if characteristic.type in (
                "position", "perpendicularity", "parallelism", "angularity") else None,
            zone_shape=zone, datum_reference_frame_ids=(frame_ids[_key(outcome)],) if outcome.datums else ())
        if outcome.bonus_mm is not None:
            bonuses[characteristic.id] = float(outcome.bonus_mm)
        if index in second:
            lower = result.characteristics[second[index]]
            lower_frame = plan.characteristics[second[index]].frame
            segments[characteristic.definition_id] = CompositeSegment(
                frame_ids[_key(lower)] if lower.datums else None, lower.tolerance_mm,
                _CONDITIONS[lower_frame.modifier if lower_frame is not None else "RFS"], lower.value_mm,
                STATUS_OF_VERDICT[lower.verdict])
    gdt = GdtRecords(composite_segments=segments, datum_definitions=datum_definitions, datum_reference_frames=frames,
                     characteristic_definitions=definitions, bonuses=bonuses, characteristic_nominals=nominals)
    written_path = write_qif(document, path, overwrite=overwrite, gdt=gdt)
    return QifExport(path=written_path, written=tuple(written), not_written=tuple(not_written),
                     features=tuple(r.name for r in reports),
                     frames=tuple("|".join(d if m == "RMB" else f"{d}({m[0]})" for d, m in zip(*s, strict=True))
                                  for s in sequences))
