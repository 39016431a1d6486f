"""Run an inspection plan: associate its datums, build each frame's DRF, evaluate every characteristic.

:func:`load_plan` reads and checks a TOML plan (:mod:`pcmm_geo.gdt.plan`) and its points files;
:func:`inspect_plan` evaluates it.  Every error names the plan's file and line
(:class:`~pcmm_geo.errors.FileFormatError`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pcmm_geo.errors import FileFormatError, PcmmGeoError
from pcmm_geo.gdt.characteristics import (
    CharacteristicResult,
    FeatureData,
    apply_uncertainty,
    evaluate_flatness,
    evaluate_orientation,
    evaluate_position,
    evaluate_runout,
)
from pcmm_geo.gdt.plan import FrameSpec, dimension_entry, frame_extras, parse_frame, read_plan_text, segment_entries
from pcmm_geo.gdt.reference.datums import DATUM_CRITERIA, DatumAssociation, default_criterion
from pcmm_geo.gdt.reference.drf import build_drf, nominal_of
from pcmm_geo.gdt.reference.frame import DatumReferenceFrame

__all__ = ["InspectionPlan", "InspectionResult", "PlannedCharacteristic", "inspect_plan", "load_plan"]

_ELEMENTS = ("plane", "cylinder", "sphere", "point", "surface")
_SUPPORTED = {"position", "perpendicularity", "parallelism", "angularity", "flatness", "circular runout",
              "total runout", "profile of a surface", "concentricity", "symmetry", "profile of a line"}


@dataclass(frozen=True)
class PlannedCharacteristic:
    """One ``[[characteristics]]`` entry: its name, feature, parsed frame and plan line."""

    name: str
    feature: str
    frame: FrameSpec | None
    line: int | None
    dimension: dict[str, Any] | None = None
    pattern: str | None = None
    uncertainty_mm: float | None = None
    extra: dict[str, Any] | None = None  # segments of a multi-segment frame, symmetry's faces, a line's section


@dataclass(frozen=True)
class InspectionPlan:
    """A checked plan with its points loaded.

    Attributes
    ----------
    path : str
    standard : {"ISO", "ASME"}
    part_frame : tuple of str
        The datums of ``[part] frame`` (the DRF the nominals are in).
    features : dict of str to FeatureData
    datums : dict of str to tuple (feature name, criterion)
    characteristics : tuple of PlannedCharacteristic
    lines : dict
        The plan's line index (:func:`pcmm_geo.gdt.plan.locate_lines`).
    point_u_trials, point_u_seed : int
        Monte Carlo trials and seed of the U propagated from the features' ``point_u_mm``
        (:mod:`pcmm_geo.gdt.propagation`).
    datum_options : dict of str to dict
        Per datum label: ``boundary_diameter`` (a datum at MMB / LMB); ``feature`` and ``targets`` (a datum
        from point targets: its stand-in plane feature and the target names).
    """

    path: str
    standard: str
    part_frame: tuple[str, ...]
    features: dict[str, FeatureData]
    datums: dict[str, tuple[str, str]]
    characteristics: tuple[PlannedCharacteristic, ...]
    lines: dict[tuple[Any, ...], int]
    point_u_trials: int = 100
    point_u_seed: int = 0
    datum_options: dict[str, dict[str, Any]] = field(default_factory=dict)


@dataclass(frozen=True)
class InspectionResult:
    """Results of a plan: every characteristic, the part frame's datums and each DRF used."""

    plan: InspectionPlan
    characteristics: tuple[CharacteristicResult, ...]
    datums: dict[str, DatumAssociation]
    frames: dict[str, DatumReferenceFrame]

    @property
    def passed(self) -> bool:
        """True when every characteristic is PASS."""
        return all(c.verdict == "PASS" for c in self.characteristics)

    def to_dict(self) -> dict[str, Any]:
        """``{"plan", "standard", "characteristics": [...], "datums": {...}, "frames": {...}}`` (mm)."""
        return {
            "plan": self.plan.path, "standard": self.plan.standard,
            "characteristics": [c.to_dict() for c in self.characteristics],
            "datums": {k: v.to_dict() for k, v in self.datums.items()},
            "frames": {k: f.to_dict() for k, f in self.frames.items()},
        }


def _vector(table: dict[str, Any], key: str, fail: Any, *, default: Any = None) -> np.ndarray:
    value = table.get(key, default)
    if value is None:
        raise fail(key, f"{key} = [x, y, z] is required")
    arr = np.asarray(value, dtype=float) if isinstance(value, list) and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) for v in value) else None
    if arr is None or arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise fail(key, f"{key}: expected three numbers, got {value!r}")
    return arr


def _unit(v: np.ndarray, key: str, fail: Any) -> np.ndarray:
    n = float(np.linalg.norm(v))
    if n == 0:
        raise fail(key, f"{key}: a zero vector")
    return v / n


def load_plan(path: str | Path) -> InspectionPlan:
    """Read and check a TOML inspection plan and load its points files (relative to the plan).

    Beyond :mod:`pcmm_geo.gdt.plan`'s keys: a ``surface`` feature's ``nominal_mesh = "FILE"``
    (:func:`pcmm_geo.gdt.profile.surface_nominal`); ``point_u_mm`` (top level, or a feature's, there also a
    file of one value per point), ``point_u_trials`` and ``point_u_seed`` (:mod:`pcmm_geo.gdt.propagation`).

    Raises
    ------
    FileFormatError
        Anything the plan gets wrong, naming its line: units other than mm, an unknown element, side or
        standard, a missing points file, an unknown feature or datum, a frame the grammar does not know.
    """
    from pcmm_geo.io.points import read_points

    path = Path(path)
    doc, lines = read_plan_text(path)
    where = str(path)

    def error(keys: tuple[Any, ...], reason: str) -> FileFormatError:
        for k in range(len(keys), 0, -1):
            if keys[:k] in lines:
                return FileFormatError(where, reason, lines[keys[:k]])
        return FileFormatError(where, reason, None)

    if doc.get("units", "mm") != "mm":
        raise error(("units",), f"units = {doc.get('units')!r}: only \"mm\" is supported")
    standard = str(doc.get("standard", "ISO")).upper()
    if standard not in ("ISO", "ASME"):
        raise error(("standard",), f"standard = {doc.get('standard')!r}: expected \"ISO\" or \"ASME\"")
    features: dict[str, FeatureData] = {}
    raw_features = doc.get("features", {})
    if not isinstance(raw_features, dict) or not raw_features:
        raise error(("features",), "the plan has no [features.NAME] tables")
    for name, table in raw_features.items():
        def fail(key: str, reason: str, name: str = name) -> FileFormatError:
            return error(("features", name, key), f"features.{name}: {reason}")

        if not isinstance(table, dict):
            raise fail("", "expected a table")
        element = table.get("element")
        if element not in _ELEMENTS:
            raise fail("element", f"element = {element!r}: expected one of {', '.join(_ELEMENTS)}")
        if not isinstance(table.get("points"), str):
            raise fail("points", "points = \"FILE\" is required")
        file = (path.parent / table["points"]).resolve()
        if not file.is_file():
            raise fail("points", f"points file {table['points']!r} not found (looked for {file})")
        try:
            pts = read_points(file)
        except PcmmGeoError as exc:
            raise fail("points", f"points file {table['points']!r}: {exc}") from None
        side = table.get("side", "external")
        if side not in ("internal", "external"):
            raise fail("side", f"side = {side!r}: expected \"internal\" or \"external\"")
        point = _vector(table, "point", fail, default=table.get("center", [0.0, 0.0, 0.0]))
        direction = np.full(3, np.nan)
        if element == "plane":
            direction = _unit(_vector(table, "normal", fail), "normal", fail)
        elif element == "cylinder":
            direction = _unit(_vector(table, "axis", fail), "axis", fail)
        surface: dict[str, Any] = {}
        if element == "surface":
            from pcmm_geo.gdt.profile import surface_nominal

            surface = surface_nominal(table, path.parent, fail)
        diameter = table.get("diameter", float("nan"))
        if not isinstance(diameter, (int, float)) or (diameter == diameter and diameter <= 0):
            raise fail("diameter", f"diameter = {diameter!r}: expected a positive number of mm")
        tol = table.get("size_tolerance", [0.0, 0.0])
        if (not isinstance(tol, list) or len(tol) != 2 or not all(isinstance(t, (int, float)) for t in tol)
                or tol[0] > tol[1]):
            raise fail("size_tolerance", f"size_tolerance = {tol!r}: expected [lower, upper] deviations in mm")
        from pcmm_geo.gdt.propagation import plan_point_u

        u = plan_point_u(table, doc, path.parent, len(pts), fail if "point_u_mm" in table else
                         lambda key, reason: error((key,), reason))
        features[name] = FeatureData(name, element, pts, point, direction, side, float(diameter),
                                     (float(tol[0]), float(tol[1])), **surface, point_u_mm=u)
    datums: dict[str, tuple[str, str]] = {}
    datum_options: dict[str, dict[str, Any]] = {}
    for label, spec in doc.get("datums", {}).items():
        def dfail(reason: str, label: str = label) -> FileFormatError:
            return error(("datums", label), f"datums.{label}: {reason}")

        entry = {"feature": spec} if isinstance(spec, str) else spec
        if isinstance(entry, dict) and "targets" in entry:  # datum targets: a stand-in plane feature
            from pcmm_geo.gdt.reference.common import targets_entry

            datum_options[label] = {"feature": targets_entry(label, entry, features, dfail),
                                    "targets": list(entry["targets"])}
            datums[label] = (entry["targets"][0], "targets")
            continue
        if not isinstance(entry, dict) or entry.get("feature") not in features:
            raise dfail(f"unknown feature {entry.get('feature') if isinstance(entry, dict) else spec!r}")
        feature = features[entry["feature"]]
        criterion = entry.get("criterion", default_criterion(feature.element, standard, feature.side))
        if criterion not in DATUM_CRITERIA[feature.element]:
            raise dfail(f"criterion {criterion!r}: expected one of {DATUM_CRITERIA[feature.element]}")
        datums[label] = (entry["feature"], criterion)
        boundary = entry.get("boundary_diameter")
        if boundary is not None:
            if not isinstance(boundary, (int, float)) or isinstance(boundary, bool) or not 0 < boundary < float("inf"):
                raise dfail(f"boundary_diameter = {boundary!r}: expected the MMB / LMB boundary's diameter in mm")
            datum_options.setdefault(label, {})["boundary_diameter"] = float(boundary)
    frame_text = doc.get("part", {}).get("frame", "")
    part_frame = tuple(p.strip() for p in frame_text.split("|") if p.strip()) if isinstance(frame_text, str) else ()
    for label in part_frame:
        if not all(part in datums for part in label.split("-")):
            raise error(("part", "frame"), f"part.frame: unknown datum {label!r}")
    planned = []
    for index, entry in enumerate(doc.get("characteristics", [])):
        keys = ("characteristics", index)
        u = entry.get("uncertainty_mm") if isinstance(entry, dict) else None
        if u is not None and (not isinstance(u, (int, float)) or isinstance(u, bool) or not 0 <= u < float("inf")):
            raise error((*keys, "uncertainty_mm"), f"characteristics[{index}]: uncertainty_mm = {u!r}: expected "
                        "the expanded uncertainty U >= 0 in mm")
        if isinstance(entry, dict) and "type" in entry:
            name, names, line, dimension = dimension_entry(entry, index, keys, lines, features, datums, error)
            if u is not None and dimension["type"] == "angle":
                raise error((*keys, "uncertainty_mm"), f"{name}: uncertainty_mm does not apply to an angle")
            planned.append(PlannedCharacteristic(name, names[0], None, line, dimension, None,
                                                 None if u is None else float(u)))
            continue
        if isinstance(entry, dict) and isinstance(entry.get("frame"), list):  # composite / stacked segments
            planned += [PlannedCharacteristic(n, f, sp, ln, None, f"segments {index}", None if u is None else float(u),
                                              ex) for n, f, sp, ln, ex in segment_entries(
                entry, index, keys, lines, features, datums, standard, where, error)]
            continue
        if not isinstance(entry, dict) or not isinstance(entry.get("frame"), str):
            raise error((*keys, "frame"), f"characteristics[{index}]: frame = \"...\" is required")
        line = lines.get((*keys, "frame"), lines.get(keys))
        spec = parse_frame(entry["frame"], path=where, line=line)
        name = str(entry.get("name", f"characteristic {index + 1}"))
        toleranced, extra = frame_extras(entry, spec, keys, features, error)
        if toleranced not in features:
            raise error((*keys, "feature"), f"{name}: unknown feature {entry.get('feature')!r}")
        for label in spec.datums:
            if not all(part in datums for part in label.split("-")):
                raise FileFormatError(where, f"{name}: unknown datum {label!r} in frame {spec.text!r}", line)
        if spec.characteristic not in _SUPPORTED or (spec.characteristic == "symmetry" and standard == "ASME"):
            if spec.characteristic in ("concentricity", "symmetry") and standard == "ASME":
                reason = f"{spec.characteristic} was removed in ASME Y14.5-2018 (use position or runout)"
            else:
                reason = f"{spec.characteristic} is not supported yet"
            raise FileFormatError(where, f"{name}: {reason}", line)
        pattern = entry.get("pattern")
        if pattern is not None and (not isinstance(pattern, str) or spec.characteristic != "position"):
            raise error((*keys, "pattern"), f"{name}: pattern = \"NAME\" groups position frames only")
        if pattern is None and standard == "ASME" and spec.characteristic == "position" and spec.datums \
                and not entry.get("separate", False):
            pattern = "simultaneous " + "|".join(  # ASME Y14.5-2018 7.19: the default
                d if m == "RMB" else f"{d}({m[0]})" for d, m in zip(spec.datums, spec.modifiers_of_datums, strict=True))
        planned.append(PlannedCharacteristic(name, toleranced, spec, line, None, pattern,
                                             None if u is None else float(u), extra))
    monte_carlo = []
    for key, default, least in (("point_u_trials", 100, 10), ("point_u_seed", 0, 0)):
        value = doc.get(key, default)
        if not isinstance(value, int) or isinstance(value, bool) or value < least:
            raise error((key,), f"{key} = {value!r}: expected an integer >= {least}")
        monte_carlo.append(value)
    return InspectionPlan(where, standard, part_frame, features, datums, tuple(planned), lines, *monte_carlo,
                          datum_options=datum_options)


def _evaluate_dimension(planned: PlannedCharacteristic, frames: _Frames) -> CharacteristicResult:
    from pcmm_geo.gdt.dimensions import evaluate_angle, evaluate_coordinate, evaluate_distance

    plan, dim = frames.plan, planned.dimension
    assert dim is not None
    feats = [plan.features[n] for n in dim["features"]]
    labels = dim["datums"] or plan.part_frame
    drf = frames.drf(labels) if labels else DatumReferenceFrame.measurement()
    if dim["type"] == "coordinate":
        return evaluate_coordinate(feats[0], drf, dim["axis"], dim["nominal"], dim["limits"], name=planned.name)
    if dim["type"] == "distance":
        return evaluate_distance(feats[0], feats[1], drf, dim["nominal"], dim["limits"], name=planned.name)
    return evaluate_angle(feats[0], feats[1], float(np.radians(dim["nominal"])),
                          (float(np.radians(dim["limits"][0])), float(np.radians(dim["limits"][1]))),
                          name=planned.name)


class _Frames:
    """Datum associations and DRFs of a plan, computed once per datum sequence."""

    def __init__(self, plan: InspectionPlan) -> None:
        self.plan = plan
        self.assoc: dict[tuple[str, ...], DatumAssociation] = {}
        self.frames: dict[tuple[str, ...], DatumReferenceFrame] = {}

    def association(self, sequence: tuple[str, ...]) -> DatumAssociation:
        """The last datum of ``sequence`` associated under the constraints of those before it."""
        if sequence in self.assoc:
            return self.assoc[sequence]
        from pcmm_geo.gdt.reference.common import associate_in_sequence

        before = [self.association(sequence[:k]) for k in range(1, len(sequence))]
        assoc = associate_in_sequence(self, sequence[-1], before)  # type: ignore[assignment]
        self.assoc[sequence] = assoc
        return assoc

    def _nominal_direction(self, label: str) -> np.ndarray:
        feature = self.datum_feature(label)
        return -feature.direction if feature.element == "plane" else feature.direction

    nominal_direction = _nominal_direction

    def datum_feature(self, label: str) -> FeatureData:
        """The datum feature of ``label`` (a common datum's and a target datum's stand-in feature)."""
        if "feature" in self.plan.datum_options.get(label, {}) or "-" in label:
            from pcmm_geo.gdt.reference.common import stand_in_feature

            return stand_in_feature(self, label)  # type: ignore[return-value]
        return self.plan.features[self.plan.datums[label][0]]

    def drf(self, datums: tuple[str, ...]) -> DatumReferenceFrame:
        if datums not in self.frames:
            pairs = []
            for k in range(1, len(datums) + 1):
                assoc = self.association(datums[:k])
                feature = self.datum_feature(datums[k - 1])
                direction = None if feature.element in ("sphere", "point") else self._nominal_direction(datums[k - 1])
                pairs.append((assoc, nominal_of(feature.point, direction)))
            self.frames[datums] = build_drf(pairs, standard=self.plan.standard)
        return self.frames[datums]


def _evaluate(planned: PlannedCharacteristic, frames: _Frames) -> CharacteristicResult:
    plan = frames.plan
    spec = planned.frame
    if spec is None:
        return _evaluate_dimension(planned, frames)
    feature = plan.features[planned.feature]
    kind = spec.characteristic
    if kind == "flatness":
        if spec.datums:
            raise FileFormatError(plan.path, f"{planned.name}: flatness takes no datums", planned.line)
        return evaluate_flatness(feature, spec.tolerance_mm, name=planned.name)
    mobile = any(m != "RMB" for m in spec.modifiers_of_datums)
    if mobile:
        if kind != "position":
            raise FileFormatError(plan.path, f"{planned.name}: {kind} with a datum at MMB / LMB is not supported "
                                  "(datum mobility is evaluated for position only)", planned.line)
        from pcmm_geo.gdt.reference.shift import mobility_results

        return mobility_results(frames, [planned], None)[0]
    drf = frames.drf(spec.datums) if spec.datums else DatumReferenceFrame.measurement()
    if kind == "position":
        return evaluate_position(feature, drf, spec.tolerance_mm, name=planned.name, modifier=spec.modifier,
                                 zone="dia" if spec.zone in ("dia", "sdia") else "width")
    if spec.modifier != "RFS" and kind != "position":
        raise FileFormatError(plan.path, f"{planned.name}: {spec.modifier} on {kind} is not supported", planned.line)
    if kind == "concentricity":
        return _concentricity(planned, frames, feature, drf)
    if kind in ("symmetry", "profile of a line"):
        from pcmm_geo.gdt.derived import evaluate_planned

        return evaluate_planned(planned, plan, drf)
    if kind == "profile of a surface":
        if feature.element != "surface":
            raise FileFormatError(plan.path, f"{planned.name}: profile needs a feature of element \"surface\" "
                                  "(nominal_points and nominal_normals, or nominal_mesh)", planned.line)
        from pcmm_geo.gdt.profile import evaluate_profile

        return evaluate_profile(feature.points, drf, spec.tolerance_mm, feature.nominal_points,
                                feature.nominal_normals, nominal_mesh=feature.nominal_mesh, name=planned.name)
    if kind in ("perpendicularity", "parallelism", "angularity"):
        if not spec.datums:
            raise FileFormatError(plan.path, f"{planned.name}: {kind} needs a datum", planned.line)
        primary = frames.datum_feature(spec.datums[0])
        normal = None
        if primary.element == "plane" and feature.element == "cylinder" and \
                abs(float(primary.direction @ feature.direction)) < 1e-9:
            normal = primary.direction
        return evaluate_orientation(feature, drf, spec.tolerance_mm, characteristic=kind, name=planned.name,
                                    zone="dia" if spec.zone == "dia" else "width", zone_normal=normal)
    primary = frames.datum_feature(spec.datums[0]) if spec.datums else None
    if primary is None or primary.element != "cylinder":
        raise FileFormatError(plan.path, f"{planned.name}: runout needs a cylinder as its primary datum",
                              planned.line)
    return evaluate_runout(feature, drf, spec.tolerance_mm, total=kind == "total runout", name=planned.name,
                           axis_point=primary.point, axis_direction=primary.direction)


def _concentricity(planned: PlannedCharacteristic, frames: _Frames, feature: FeatureData,
                   drf: DatumReferenceFrame) -> CharacteristicResult:
    """ISO 1101 18.13: coaxiality of an axis (concentricity of a centre) to the primary datum's axis (centre).

    The zone (``dia``) is centred on the datum: the position of the feature whose true position is the
    datum's nominal axis or centre, floating in what the DRF leaves free.
    """
    import dataclasses

    spec, plan = planned.frame, frames.plan
    if plan.standard != "ISO":
        raise FileFormatError(plan.path, f"{planned.name}: concentricity was removed in ASME Y14.5-2018",
                              planned.line)
    if not spec.datums or spec.zone == "width":
        raise FileFormatError(plan.path, f"{planned.name}: concentricity needs dia and a datum", planned.line)
    datum = frames.datum_feature(spec.datums[0])
    if datum.element not in ("cylinder", "sphere", "point") or feature.element not in ("cylinder", "sphere", "point"):
        raise FileFormatError(plan.path, f"{planned.name}: concentricity relates an axis or a centre to a datum "
                              "axis or centre", planned.line)
    direction = datum.direction if datum.element == "cylinder" else feature.direction
    nominal = dataclasses.replace(feature, point=datum.point, direction=direction)
    result = evaluate_position(nominal, drf, spec.tolerance_mm, name=planned.name)
    return dataclasses.replace(result, characteristic="coaxiality" if feature.element == "cylinder" else
                               "concentricity")


def _evaluate_pattern(pattern: str, members: list[PlannedCharacteristic],
                      frames: _Frames) -> tuple[CharacteristicResult, ...]:
    """A simultaneous requirement: every member a position frame to the same datums."""
    from pcmm_geo.gdt.pattern import evaluate_position_pattern

    plan = frames.plan
    first = members[0]
    if first.extra is not None and "segments" in first.extra:  # a composite or stacked frame
        from pcmm_geo.gdt.composite import evaluate_planned_segments

        try:
            return evaluate_planned_segments(first.extra, plan.features, frames.drf)
        except PcmmGeoError as exc:
            raise FileFormatError(plan.path, f"{first.name}: {exc}", first.line) from None
    for member in members:
        assert member.frame is not None
        if (member.frame.datums, member.frame.modifiers_of_datums) != (  # type: ignore[union-attr]
                first.frame.datums, first.frame.modifiers_of_datums):  # type: ignore[union-attr]
            raise FileFormatError(plan.path, f"{member.name}: pattern {pattern!r} mixes datum references "
                                  f"({'|'.join(member.frame.datums)} and {'|'.join(first.frame.datums)})",  # type: ignore[union-attr]
                                  member.line)
    datums = first.frame.datums  # type: ignore[union-attr]
    datum_modifiers = first.frame.modifiers_of_datums  # type: ignore[union-attr]
    try:
        if any(m != "RMB" for m in datum_modifiers):
            from pcmm_geo.gdt.reference.shift import mobility_results

            return mobility_results(frames, members, pattern)
        drf = frames.drf(datums) if datums else DatumReferenceFrame.measurement()
        return evaluate_position_pattern([plan.features[m.feature] for m in members], drf,
                                         [m.frame.tolerance_mm for m in members],  # type: ignore[union-attr]
                                         names=[m.name for m in members],
                                         modifiers=[m.frame.modifier for m in members],  # type: ignore[union-attr]
                                         pattern=pattern)
    except FileFormatError:
        raise
    except PcmmGeoError as exc:
        raise FileFormatError(plan.path, f"{first.name}: {exc}", first.line) from None


def inspect_plan(plan: str | Path | InspectionPlan) -> InspectionResult:
    """Evaluate every characteristic of an inspection plan.

    Parameters
    ----------
    plan : path or InspectionPlan

    Returns
    -------
    InspectionResult

    Raises
    ------
    FileFormatError
        A plan error (its line); a DRF that cannot constrain what a frame needs names the frame's line.
    """
    if not isinstance(plan, InspectionPlan):
        plan = load_plan(plan)
    results, frames = _evaluate_all(plan)
    datums: dict[str, DatumAssociation] = {}
    named: dict[str, DatumReferenceFrame] = {}
    try:
        if plan.part_frame:
            named["|".join(plan.part_frame)] = frames.drf(plan.part_frame)
            for k in range(1, len(plan.part_frame) + 1):
                datums[plan.part_frame[k - 1]] = frames.association(plan.part_frame[:k])
    except PcmmGeoError as exc:
        raise FileFormatError(plan.path, f"part.frame: {exc}", plan.lines.get(("part", "frame"))) from None
    for key, drf in frames.frames.items():
        named.setdefault("|".join(key), drf)
    ordered = tuple(results[i] for i in range(len(plan.characteristics)))
    if any(f.point_u_mm is not None for f in plan.features.values()):  # U from the points (opt-in)
        from pcmm_geo.gdt.propagation import propagate_plan

        ordered = propagate_plan(plan, ordered, lambda trial: _evaluate_all(trial)[0])
    ordered = tuple(apply_uncertainty(r, p.uncertainty_mm) for r, p in zip(ordered, plan.characteristics, strict=True))
    return InspectionResult(plan, ordered, datums, named)


def _evaluate_all(plan: InspectionPlan) -> tuple[dict[int, CharacteristicResult], _Frames]:
    """Every characteristic of ``plan`` (by index; no uncertainty applied) and the frames built for them."""
    frames = _Frames(plan)
    results: dict[int, CharacteristicResult] = {}
    groups: dict[str, list[int]] = {}
    for index, planned in enumerate(plan.characteristics):
        if planned.pattern is not None:
            groups.setdefault(planned.pattern, []).append(index)
            continue
        try:
            results[index] = _evaluate(planned, frames)
        except FileFormatError:
            raise
        except PcmmGeoError as exc:
            raise FileFormatError(plan.path, f"{planned.name}: {exc}", planned.line) from None
    for pattern, members in groups.items():
        results.update(zip(members, _evaluate_pattern(pattern, [plan.characteristics[i] for i in members], frames),
                           strict=True))
    return results, frames
