"""DMIS output files (ISO 22093): feature actuals ``FA(label)=FEAT/...`` and tolerance results ``TA(label)=TOL/...``.

A DMIS output (``.dmo``, or a vendor report in DMIS syntax such as Mitutoyo GEOPAK's) is read
into a :class:`~pcmm_geo.io.cmm.CmmDocument` (``format="dmis"``): every ``FA`` becomes a
:class:`~pcmm_geo.io.cmm.MeasuredFeature` named by its label, every nominal ``F`` a definition,
nominal and item (linked to the ``FA`` of the same label), every ``TA`` a
:class:`~pcmm_geo.io.cmm.Characteristic` with the tolerance of the ``T`` of the same label and
the features an ``OUTPUT/FA(..),TA(..)`` statement reports it with.

Syntax read: statements end at the line end unless the line ends with ``$`` (continued); ``$$``
starts a comment; keywords are case-insensitive.  ``UNITS/MM|CM|METER|INCH|FEET,ANGDEC|ANGRAD``
and ``WKPLAN/XYPLAN|YZPLAN|ZXPLAN`` apply to the statements after them.  Features:

========  =========================================================================
POINT     ``CART|POL, x, y, z, i, j, k``
PLANE     ``CART|POL, x, y, z, i, j, k``
CIRCLE    ``INNER|OUTER, CART|POL, x, y, z, i, j, k, diameter``
CYLNDR    ``INNER|OUTER, CART|POL, x, y, z, i, j, k, diameter[, length]``
SPHERE    ``INNER|OUTER, CART|POL, x, y, z, diameter``
CONE      ``INNER|OUTER, CART|POL, x, y, z, i, j, k, full apex angle``
LINE      ``UNBND, CART|POL, x, y, z, i, j, k[, normal i, j, k]`` or ``BND, CART|POL, start, end[, normal]``
========  =========================================================================

``POL`` gives radius, angle and height in the working plane.  A direction is written either as
direction cosines ``i, j, k`` (a unit vector) or, as GEOPAK does, as the three direction angles
to the X, Y and Z axes in the angle unit (``cos`` of them is the unit vector).  No triple is
both (cosines lie in [-1, 1], so angles of at most one degree or radian would give a vector
of length about sqrt(3)), so each is read as whichever it is; a triple that is neither is an
error, ``0, 0, 0`` means "no direction" (GEOPAK's points).

Never guessed: a file without ``UNITS`` needs ``units=`` (GEOPAK reports often have none, and
their numbers may well be inches); angles without ``ANGDEC``/``ANGRAD`` need ``angle_unit=``;
the number of a size tolerance result (``TA(..)=TOL/DIAM,number,INTOL``) is the actual size for
some writers and its deviation for others, so it is read only with ``size_values="actual"`` or
``"deviation"`` (else only the verdict is kept, and the problem recorded).  ``INTOL`` is
``"PASS"``, ``OUTOL`` ``"FAIL"``.  Anything else that cannot be read is a
:class:`~pcmm_geo.errors.FileFormatError` naming the file and line.

Checked, each refused naming the line: a verdict its numbers contradict (a result beyond its
``T`` zone or size limits marked ``INTOL``, or within them marked ``OUTOL``, allowing half a
unit in the last decimal written; zones with MMC/LMC are not checked, their bonus depends on the
actual size); a negative diameter or length; a value that overflows when converted to mm or rad;
a last line without a line end (the file was cut inside a statement); a statement longer than
:data:`~pcmm_geo.io.cmm._dmis_syntax.MAX_STATEMENT_CHARS`.  A missing ``ENDFIL`` is recorded in
``problems``, not refused (real outputs may lack it): a file cut exactly at a line end is
otherwise indistinguishable from a complete one.

Examples
--------
>>> import pathlib, tempfile
>>> path = pathlib.Path(tempfile.mkdtemp()) / "report.dmo"
>>> _ = path.write_text("UNITS/MM,ANGDEC\\n"
...                     "FA(HOLE)=FEAT/CIRCLE,INNER,CART,10,20,0,$\\n"
...                     "  0,0,1,12.004\\n"
...                     "TA(FLAT)=TOL/FLAT,0.003,INTOL\\n")
>>> document = read_dmis(path)
>>> hole = document.feature("HOLE")
>>> hole.type, hole.internal_external, hole.actual.diameter
('circle', 'INTERNAL', 12.004)
>>> flatness = document.characteristics[0]
>>> flatness.type, flatness.value, flatness.status
('flatness', 0.003, 'PASS')
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pcmm_geo.errors import FileFormatError
from pcmm_geo.io._text import excerpt, parse_decimal
from pcmm_geo.io.cmm._dmis_checks import StatedTolerance, check_verdict
from pcmm_geo.io.cmm._dmis_syntax import (
    MAX_STATEMENT_CHARS,
    half_unit,
    is_statement,
    output_labels,
    split_statement,
    statements,
)
from pcmm_geo.io.cmm.document import CmmDocument
from pcmm_geo.io.cmm.model import (
    Characteristic,
    FeatureDefinition,
    FeatureGeometry,
    FeatureItem,
    FeatureNominal,
    MeasuredFeature,
    MeasurementResults,
    Tolerance,
    Units,
)
from pcmm_geo.io.cmm.settings import DEFAULT_MAX_TEXT_BYTES, SpellSetting, check_size, python_setting

__all__ = ["DMIS_LENGTH_UNITS", "MAX_STATEMENT_CHARS", "read_dmis"]

#: mm per DMIS length unit
DMIS_LENGTH_UNITS = {"MM": 1.0, "CM": 10.0, "METER": 1000.0, "M": 1000.0, "INCH": 25.4, "FEET": 304.8}
_ANGLE_UNITS = {"ANGDEC": ("degree", math.pi / 180.0), "ANGRAD": ("radian", 1.0)}
_USER_UNITS = {"mm": "MM", "cm": "CM", "m": "METER", "inch": "INCH", "feet": "FEET"}
_USER_ANGLES = {"degree": "ANGDEC", "radian": "ANGRAD"}
_FEATURE_TYPES = {"POINT": "point", "PLANE": "plane", "CIRCLE": "circle", "CYLNDR": "cylinder",
                  "SPHERE": "sphere", "CONE": "cone", "LINE": "line"}
#: tolerances whose result number is a measured zone or deviation magnitude (unambiguous)
_GEOMETRIC = {"FLAT": "flatness", "CIRLTY": "circularity", "CYLCTY": "cylindricity", "STRGHT": "straightness",
              "PARLEL": "parallelism", "PERPND": "perpendicularity", "ANGLR": "angularity", "POS": "position",
              "PROFL": "line_profile", "PROFS": "surface_profile", "PROFP": "point_profile",
              "CONCEN": "concentricity", "COAXL": "coaxiality", "SYM": "symmetry", "CRNOUT": "circular_runout",
              "TRNOUT": "total_runout"}
#: size tolerances: (type, quantity); the result number is an actual or a deviation, depending on the writer
_SIZE = {"DIAM": ("diameter", "linear"), "RAD": ("radius", "linear"), "WIDTH": ("width", "linear"),
         "DISTB": ("distance_between", "linear"), "CORTOL": ("linear_coordinate", "linear"),
         "ANGLB": ("angle_between", "angular"), "ANGLWRT": ("angle_from", "angular")}
_UNIT_TOLERANCE = 1e-4


@dataclass
class _State:
    path: str
    units: str | None
    angle_unit: str | None
    size_values: str | None
    spell: SpellSetting = python_setting
    given_units: str | None = None
    workplane: str = "XYPLAN"
    stated_units: bool = False
    ended: bool = False
    problems: list[str] = field(default_factory=list)

    def error(self, line: int, reason: str) -> FileFormatError:
        return FileFormatError(self.path, reason, line)

    def length_factor(self, line: int) -> float:
        if self.units is None:
            raise self.error(line, f"the file states no UNITS before its first length; pass "
                             f"{self.spell('units', 'mm')} or {self.spell('units', 'inch')} (never assumed)")
        return DMIS_LENGTH_UNITS[self.units]

    def angle_factor(self, line: int) -> float:
        if self.angle_unit is None:
            raise self.error(line, "an angle, but the file states no angle unit (UNITS/..,ANGDEC|ANGRAD); pass "
                             f"{self.spell('angle_unit', 'degree')} or {self.spell('angle_unit', 'radian')}")
        return _ANGLE_UNITS[self.angle_unit][1]


def _numbers(state: _State, line: int, fields: list[str], what: str) -> list[float]:
    values = []
    for text in fields:
        try:
            values.append(parse_decimal(text))
        except ValueError:
            raise state.error(line, f"{what}: expected a number, got {excerpt(text)}") from None
        if not math.isfinite(values[-1]):
            raise state.error(line, f"{what}: expected a finite number, got {excerpt(text)}")
    return values


def _direction(state: _State, line: int, triple: list[float], what: str) -> np.ndarray | None:
    vector = np.array(triple)
    if not vector.any():
        return None
    if abs(np.linalg.norm(vector) - 1.0) <= _UNIT_TOLERANCE:
        return vector
    factor = state.angle_factor(line)
    cosines = np.cos(vector * factor)
    if abs(np.linalg.norm(cosines) - 1.0) <= _UNIT_TOLERANCE:
        return cosines
    raise state.error(line, f"{what}: expected direction cosines (a unit vector) or direction angles, got "
                      f"{', '.join(f'{v:g}' for v in triple)}")


def _position(state: _State, line: int, mode: str, values: list[float]) -> np.ndarray:
    length = state.length_factor(line)
    if mode == "CART":
        with np.errstate(over="ignore"):
            return np.array(values) * length
    radius, angle, height = values[0] * length, values[1] * state.angle_factor(line), values[2] * length
    first, second = radius * math.cos(angle), radius * math.sin(angle)
    if state.workplane == "XYPLAN":
        return np.array([first, second, height])
    if state.workplane == "YZPLAN":
        return np.array([height, first, second])
    return np.array([second, height, first])  # ZXPLAN: z = r cos a, x = r sin a, y = h


_COUNTS = {"point": (6,), "plane": (6,), "circle": (7,), "cylinder": (7, 8), "sphere": (4,), "cone": (7,)}


def _checked_feature(state: _State, line: int, label: str,
                     fields: list[str]) -> tuple[str, str | None, FeatureGeometry]:
    """:func:`_feature`, refusing a value that overflows in mm and a negative size."""
    kind, side, geometry = _feature(state, line, label, fields)
    what = f"FEAT/{fields[0].upper()}({label})"
    for name in ("location", "diameter", "length", "half_angle"):
        value = getattr(geometry, name)
        if value is not None and not np.isfinite(value).all():
            raise state.error(line, f"{what}: the {name} overflows the float range when converted to mm or rad")
    for name in ("diameter", "length"):
        value = getattr(geometry, name)
        if value is not None and value < 0:
            raise state.error(line, f"{what}: expected a {name} >= 0, got {value / state.length_factor(line):g}")
    return kind, side, geometry


def _finite(state: _State, line: int, what: str, *values: float | None) -> None:
    """Refuse a value that became inf when converted to mm or rad (``1e307`` feet)."""
    if any(value is not None and not math.isfinite(value) for value in values):
        raise state.error(line, f"{what}: a value overflows the float range when converted to mm or rad")


def _feature(state: _State, line: int, label: str, fields: list[str]) -> tuple[str, str | None, FeatureGeometry]:
    keyword = fields[0].upper()
    if not keyword:
        raise state.error(line, f"F/FA({label})=FEAT/: expected a feature type (POINT, PLANE, CIRCLE, ...)")
    kind = _FEATURE_TYPES.get(keyword)
    if kind is None:
        state.problems.append(f"line {line}: F/FA({label})=FEAT/{keyword}: feature type not read")
        return keyword.lower(), None, FeatureGeometry()
    rest = [f.upper() if not _is_numberish(f) else f for f in fields[1:]]
    side = None
    if rest and rest[0] in ("INNER", "OUTER"):
        side = "INTERNAL" if rest[0] == "INNER" else "EXTERNAL"
        rest = rest[1:]
    bounded = None
    if kind == "line":
        if not rest or rest[0] not in ("BND", "UNBND"):
            raise state.error(line, f"FEAT/LINE({label}): expected BND or UNBND, got {excerpt(','.join(fields[1:]))}")
        bounded, rest = rest[0] == "BND", rest[1:]
    if not rest or rest[0] not in ("CART", "POL"):
        raise state.error(line, f"FEAT/{keyword}({label}): expected CART or POL, got {excerpt(','.join(rest))}")
    mode, values = rest[0], _numbers(state, line, rest[1:], f"FEAT/{keyword}({label})")
    counts = (6, 9) if kind == "line" else _COUNTS[kind]
    if len(values) not in counts:
        raise state.error(line, f"FEAT/{keyword}({label}): expected {' or '.join(map(str, counts))} numbers after "
                          f"{mode}, got {len(values)}")
    location = _position(state, line, mode, values[:3])
    what = f"FEAT/{keyword}({label})"
    if kind == "sphere":
        return kind, side, FeatureGeometry(location=location, diameter=values[3] * state.length_factor(line))
    if kind == "line" and bounded:
        end = _position(state, line, mode, values[3:6])
        span = float(np.linalg.norm(end - location))
        if span == 0.0:
            raise state.error(line, f"{what}: start and end points coincide")
        normal = _direction(state, line, values[6:9], what) if len(values) == 9 else None
        return kind, side, FeatureGeometry(location=location, direction=(end - location) / span, length=span,
                                           normal=normal)
    vector = _direction(state, line, values[3:6], what)
    geometry: dict[str, object] = {"location": location}
    if kind in ("plane", "circle", "point"):
        geometry["normal"] = vector
    else:
        geometry["direction"] = vector
    if kind == "line" and len(values) == 9:
        geometry["normal"] = _direction(state, line, values[6:9], what)
    if kind in ("circle", "cylinder"):
        geometry["diameter"] = values[6] * state.length_factor(line)
        if len(values) == 8:
            geometry["length"] = values[7] * state.length_factor(line)
    if kind == "cone":
        geometry["half_angle"] = values[6] * state.angle_factor(line) / 2.0
    if vector is None and kind != "point":
        raise state.error(line, f"{what}: a {kind} needs a direction, got 0, 0, 0")
    return kind, side, FeatureGeometry(**geometry)  # type: ignore[arg-type]


_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")
_QUALIFIERS = frozenset({"2D", "3D"})


def _is_numberish(text: str) -> bool:
    """Looks like a number (starts with a digit, sign or point) and is not a qualifier such as ``3D``."""
    return bool(text) and (text[0].isdigit() or text[0] in "+-.") and text.upper() not in _QUALIFIERS


def _tolerance(state: _State, line: int, label: str, fields: list[str]) -> StatedTolerance:
    """The tolerance of ``T(label)``, finite in mm or rad, its modifiers noted (:class:`StatedTolerance`)."""
    kind, quantity, tolerance, nominal = _tolerance_values(state, line, label, fields)
    what = f"T({label})=TOL/{fields[0].upper()}"
    if tolerance is not None:
        _finite(state, line, what, tolerance.value, tolerance.min_value, tolerance.max_value, nominal)
        if tolerance.value is not None and tolerance.value < 0:
            raise state.error(line, f"{what}: expected a tolerance zone >= 0")
        if tolerance.min_value is not None and tolerance.max_value is not None and \
                tolerance.min_value > tolerance.max_value:
            raise state.error(line, f"{what}: the lower tolerance is above the upper one")
    modified = any(f.strip().upper() in ("MMC", "LMC") for f in fields[1:])
    return StatedTolerance(kind, quantity, tolerance, nominal, modified)


def _tolerance_values(state: _State, line: int, label: str,
                      fields: list[str]) -> tuple[str, str, Tolerance | None, float | None]:
    keyword = fields[0].upper()
    numbers = _numbers(state, line, [f for f in fields[1:] if _is_numberish(f)], f"T({label})=TOL/{keyword}")
    if keyword in _GEOMETRIC:
        if not numbers:
            raise state.error(line, f"T({label})=TOL/{keyword}: expected a tolerance zone")
        return _GEOMETRIC[keyword], "linear", Tolerance(value=numbers[0] * state.length_factor(line)), None
    if keyword in _SIZE:
        kind, quantity = _SIZE[keyword]
        factor = state.length_factor(line) if quantity == "linear" else state.angle_factor(line)
        if len(numbers) not in (2, 3):
            raise state.error(line, f"T({label})=TOL/{keyword}: expected [nominal,] lower, upper tolerance, got "
                              f"{len(numbers)} numbers")
        nominal = numbers[0] * factor if len(numbers) == 3 else None
        return kind, quantity, Tolerance(min_value=numbers[-2] * factor, max_value=numbers[-1] * factor), nominal
    state.problems.append(f"line {line}: T({label})=TOL/{keyword}: tolerance type not read")
    return keyword.lower(), "other", None, None


def read_dmis(path: str | Path, *, units: str | None = None, angle_unit: str | None = None,
              size_values: str | None = None, encoding: str = "utf-8",
              spell_setting: SpellSetting = python_setting,
              max_bytes: int = DEFAULT_MAX_TEXT_BYTES) -> CmmDocument:
    """Read a DMIS output file (see the module docstring).

    Parameters
    ----------
    path : str or Path
    units : {"mm", "cm", "m", "inch", "feet"} or None
        Length unit for a file without ``UNITS``; when the file has one, it must agree.
    angle_unit : {"degree", "radian"} or None
        Angle unit for a file that states none.
    size_values : {"actual", "deviation"} or None
        What the number of a size tolerance result (DIAM, RAD, WIDTH, DISTB, CORTOL, ANGLB) is.
    encoding : str
        Text encoding of the file (GEOPAK and other Windows software: often ``"cp1252"``).
    max_bytes : int
        Largest file read (default :data:`~pcmm_geo.io.cmm.settings.DEFAULT_MAX_TEXT_BYTES`, 32 MiB).
    spell_setting : callable
        How the messages name ``units``, ``angle_unit`` and ``size_values``
        (:mod:`pcmm_geo.io.cmm.settings`; the command line passes its option names).

    Returns
    -------
    CmmDocument
        ``format="dmis"``, mm and rad; ids numbered from 1 in file order.

    Raises
    ------
    FileFormatError
        A statement that cannot be read, a missing unit, a direction that is not one, naming file and line.
    InvalidInputError
        An unknown ``units``, ``angle_unit`` or ``size_values``.
    FileNotFoundError
        The file does not exist.
    """
    from pcmm_geo.errors import InvalidInputError

    for value, allowed, what in ((units, _USER_UNITS, "units"), (angle_unit, _USER_ANGLES, "angle_unit"),
                                 (size_values, {"actual": 0, "deviation": 0}, "size_values")):
        if value is not None and value not in allowed:
            raise InvalidInputError(spell_setting(what), f"one of {', '.join(allowed)}", repr(value))
    check_size(path, max_bytes, spell_setting)
    state = _State(str(path), _USER_UNITS.get(units or ""), _USER_ANGLES.get(angle_unit or ""), size_values,
                   spell_setting, units)
    features: dict[str, tuple[int, str, str | None, FeatureGeometry]] = {}
    nominals: dict[str, tuple[int, str, str | None, FeatureGeometry]] = {}
    tolerances: dict[str, StatedTolerance] = {}
    results: list[tuple[int, str, list[str]]] = []
    reported_with: dict[str, list[str]] = {}
    for line, text in statements(path, encoding):
        parsed = split_statement(text)
        if parsed is None:
            _other_statement(state, line, text, reported_with)
            continue
        kind, label, major, rest = parsed
        fields = [f.strip() for f in rest.split(",")]
        expected = "FEAT" if kind in ("F", "FA") else "TOL"
        if major != expected:
            raise state.error(line, f"{kind}({label}): expected ={expected}/..., got ={major}/")
        if kind in ("F", "FA"):
            target = features if kind == "FA" else nominals
            if label in target:
                raise state.error(line, f"{kind}({label}) is defined twice (first on line {target[label][0]})")
            target[label] = (line, *_checked_feature(state, line, label, fields))
        elif kind == "T":
            tolerances[label] = _tolerance(state, line, label, fields)
        else:
            results.append((line, label, fields))
    if not state.ended:
        state.problems.append("no ENDFIL statement: the file may have been cut short after a whole line (a cut at a "
                              "line end cannot be told from the end of the output)")
    return _document(state, features, nominals, tolerances, results, reported_with)


def _other_statement(state: _State, line: int, text: str, reported_with: dict[str, list[str]]) -> None:
    if not is_statement(text):
        raise state.error(line, f"not a DMIS statement: {excerpt(text)}")
    major, _, rest = text.partition("/")
    major = major.strip().upper()
    if major == "ENDFIL":
        state.ended = True
    fields = [f.strip().upper() for f in rest.split(",")]
    if major == "UNITS":
        if not fields or fields[0] not in DMIS_LENGTH_UNITS:
            raise state.error(line, f"UNITS: expected MM, CM, METER, INCH or FEET, got {excerpt(rest)}")
        if state.units is not None and not state.stated_units and state.units != fields[0]:
            raise state.error(line, f"UNITS/{fields[0]} disagrees with {state.spell('units', state.given_units)} given")
        state.units, state.stated_units = fields[0], True
        if len(fields) > 1 and fields[1]:
            if fields[1] not in _ANGLE_UNITS:
                raise state.error(line, f"UNITS: angle unit {fields[1]} not read (ANGDEC or ANGRAD)")
            state.angle_unit = fields[1]
    elif major == "WKPLAN":
        if fields[0] not in ("XYPLAN", "YZPLAN", "ZXPLAN"):
            raise state.error(line, f"WKPLAN: expected XYPLAN, YZPLAN or ZXPLAN, got {excerpt(rest)}")
        state.workplane = fields[0]
    elif major == "OUTPUT":
        labels = output_labels(state.path, line, rest)
        reported = [label for kind, label in labels if kind == "FA"]
        for kind, label in labels:
            if kind == "TA":
                reported_with.setdefault(label, []).extend(reported)


def _document(state: _State, features: dict, nominals: dict, tolerances: dict,  # type: ignore[type-arg]
              results: list[tuple[int, str, list[str]]], reported_with: dict[str, list[str]]) -> CmmDocument:
    counter = iter(range(1, 1 << 31))
    definitions, nominal_records, items, item_of = {}, {}, {}, {}
    for label, (_, kind, side, geometry) in nominals.items():
        definition_id, nominal_id, item_id = next(counter), next(counter), next(counter)
        definitions[definition_id] = FeatureDefinition(id=definition_id, type=kind, internal_external=side,
                                                       diameter=geometry.diameter, length=geometry.length,
                                                       half_angle=geometry.half_angle)
        nominal_records[nominal_id] = FeatureNominal(id=nominal_id, type=kind, definition_id=definition_id,
                                                     geometry=geometry)
        items[item_id] = FeatureItem(id=item_id, type=kind, name=label, nominal_id=nominal_id)
        item_of[label] = item_id
    measured, feature_ids = [], {}
    for label, (_, kind, side, geometry) in features.items():
        feature_ids[label] = next(counter)
        measured.append(MeasuredFeature(id=feature_ids[label], type=kind, name=label, actual=geometry,
                                        item_id=item_of.get(label), internal_external=side, results_id=0))
    nominal_sizes = {label: geometry.diameter for label, (_, _, _, geometry) in nominals.items()}
    characteristics = [_characteristic(state, next(counter), line, label, fields, tolerances, reported_with,
                                       feature_ids, nominal_sizes) for line, label, fields in results]
    angle = _ANGLE_UNITS.get(state.angle_unit or "", ("degree", math.pi / 180.0))
    units = Units(linear_unit=(state.units or "MM").lower(), mm_per_linear_unit=DMIS_LENGTH_UNITS[state.units or "MM"],
                  angular_unit=angle[0], rad_per_angular_unit=angle[1], stated=state.stated_units)
    return CmmDocument(source=state.path, format="dmis", units=units, feature_definitions=definitions,
                       feature_nominals=nominal_records, feature_items=items,
                       results=(MeasurementResults(id=0, features=tuple(measured),
                                                   characteristics=tuple(characteristics)),),
                       problems=tuple(state.problems))


def _characteristic(state: _State, key: int, line: int, label: str, fields: list[str], tolerances: dict,  # type: ignore[type-arg]
                    reported_with: dict[str, list[str]], feature_ids: dict[str, int],
                    nominal_sizes: dict[str, float | None]) -> Characteristic:
    keyword = fields[0].upper()
    words = [f.upper() for f in fields[1:]]
    verdicts = [w for w in words if w in ("INTOL", "OUTOL")]
    if not verdicts:
        raise state.error(line, f"TA({label})=TOL/{keyword}: expected INTOL or OUTOL")
    status = "PASS" if verdicts[0] == "INTOL" else "FAIL"
    texts = [f for f in fields[1:words.index(verdicts[0]) + 1] if _is_numberish(f)]
    numbers = _numbers(state, line, texts, f"TA({label})=TOL/{keyword}")
    stated = tolerances.get(label)
    kind, quantity, tolerance, nominal = (None, None, None, None) if stated is None else \
        (stated.kind, stated.quantity, stated.tolerance, stated.nominal)
    features = reported_with.get(label, [])
    sizes = {nominal_sizes.get(name) for name in features} - {None}
    if nominal is None and keyword in ("DIAM", "RAD") and len(sizes) == 1:  # the nominal size of the feature reported
        nominal = sizes.pop() / (2.0 if keyword == "RAD" else 1.0)
    value = deviation = None
    if keyword in _GEOMETRIC:
        kind, quantity = _GEOMETRIC[keyword], "linear"
        value = numbers[0] * state.length_factor(line) if numbers else None
    elif keyword in _SIZE:
        kind, quantity = _SIZE[keyword]
        factor = state.length_factor(line) if quantity == "linear" else state.angle_factor(line)
        number = numbers[0] * factor if numbers else None
        if number is not None and state.size_values is None:
            state.problems.append(f"line {line}: TA({label})=TOL/{keyword}: the number {numbers[0]:g} is the actual "
                                  "size for some writers and its deviation for others; not read (pass "
                                  f"{state.spell('size_values', 'actual')} or "
                                  f"{state.spell('size_values', 'deviation')})")
        elif state.size_values == "actual":
            value = number
        elif number is not None:
            deviation = number
            value = None if nominal is None else nominal + number
    else:
        kind, quantity = kind or keyword.lower(), quantity or "other"
        state.problems.append(f"line {line}: TA({label})=TOL/{keyword}: tolerance type not read; verdict kept")
    _finite(state, line, f"TA({label})=TOL/{keyword}", value, deviation, nominal)
    if stated is not None and numbers and quantity in ("linear", "angular"):
        factor = state.length_factor(line) if quantity == "linear" else state.angle_factor(line)
        check_verdict(state.path, line, f"TA({label})=TOL/{keyword}", status, stated, value, deviation,
                       factor * half_unit(texts[0]),
                       modified=stated.modified or any(w in ("MMC", "LMC") for w in words))
    linked = tuple(feature_ids[name] for name in features if name in feature_ids)
    return Characteristic(id=key, type=kind, name=label, value=value, nominal=nominal, deviation=deviation,
                          tolerance=tolerance, status=status, quantity=quantity, feature_measurement_ids=linked,
                          results_id=0)
