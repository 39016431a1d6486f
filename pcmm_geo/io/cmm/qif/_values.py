"""QIF values: units, numbers, vectors, geometry, references -- each error naming the QIF id and element path."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from pcmm_geo.errors import QifError
from pcmm_geo.io._lines import excerpt
from pcmm_geo.io.cmm.model import FeatureGeometry, Units
from pcmm_geo.io.cmm.qif._xml import XS_DOUBLE, Node
from pcmm_geo.io.cmm.settings import SpellSetting, python_setting

__all__ = ["QIF_ANGLE_UNITS", "QIF_LENGTH_UNITS", "QifContext", "short_id", "snake_type", "xs_double", "xs_integer"]

#: millimetres per unit, by the unit names QIF files use (lower case)
_MM_PER = {
    "mm": 1.0, "millimeter": 1.0, "millimetre": 1.0, "millimeters": 1.0, "millimetres": 1.0,
    "inch": 25.4, "in": 25.4, "inches": 25.4,
    "m": 1000.0, "meter": 1000.0, "metre": 1000.0, "meters": 1000.0, "metres": 1000.0,
    "cm": 10.0, "centimeter": 10.0, "centimetre": 10.0,
    "um": 1e-3, "µm": 1e-3, "micrometer": 1e-3, "micrometre": 1e-3, "micron": 1e-3, "microns": 1e-3,
    "ft": 304.8, "foot": 304.8, "feet": 304.8,
}
#: radians per unit
_RAD_PER = {
    "radian": 1.0, "radians": 1.0, "rad": 1.0,
    "degree": math.pi / 180.0, "degrees": math.pi / 180.0, "deg": math.pi / 180.0,
    "arcminute": math.pi / 10800.0, "arcsecond": math.pi / 648000.0,
    "gradian": math.pi / 200.0, "grad": math.pi / 200.0,
}
#: ``units`` a QIF file without FileUnits may be read in
QIF_LENGTH_UNITS = ("mm", "cm", "m", "inch", "feet")
#: ``angle_unit`` a QIF file without FileUnits may be read in
QIF_ANGLE_UNITS = ("degree", "radian")
#: a stated conversion factor may differ from the exact one by this much (files truncate pi / 180)
_FACTOR_TOLERANCE = 1e-9
#: a unit vector's length may differ from 1 by this much
UNIT_VECTOR_TOLERANCE = 1e-3
#: longest id quoted whole in a message
_ID_CHARS = 40
_CAMEL = re.compile(r"(?<=[a-z0-9])(?=[A-Z])")
#: the lexical space of ``xs:integer`` (and its restrictions such as ``xs:unsignedInt``)
XS_INTEGER = re.compile(r"[+-]?[0-9]+")


def xs_double(text: str) -> float:
    """A number in the lexical space of ``xs:double`` (surrounding XML whitespace allowed); else ValueError.

    Stricter than :class:`float`, which also reads ``3_3.2``, Arabic-Indic or full-width digits
    (all as 33.2): numbers nobody wrote in a QIF file.

    Examples
    --------
    >>> xs_double(" 1.5E3 "), xs_double("-.5")
    (1500.0, -0.5)
    >>> for bad in ("3_3.2", "\u0663\u0663.\u0662", "\uff13\uff13.2", "1,5", "inf"):
    ...     try:
    ...         xs_double(bad)
    ...     except ValueError:
    ...         print("refused", ascii(bad))
    refused '3_3.2'
    refused '\u0663\u0663.\u0662'
    refused '\uff13\uff13.2'
    refused '1,5'
    refused 'inf'
    """
    stripped = text.strip(" \t\r\n")
    if not XS_DOUBLE.fullmatch(stripped):
        raise ValueError(f"not an xs:double: {stripped[:40]!r}")
    return float(stripped)


def xs_integer(text: str) -> int:
    """An integer in the lexical space of ``xs:integer`` (ASCII digits); else ValueError."""
    stripped = text.strip(" \t\r\n")
    if not XS_INTEGER.fullmatch(stripped) or len(stripped) > 30:
        raise ValueError(f"not an xs:integer: {stripped[:40]!r}")
    return int(stripped)


#: geometry elements of a feature nominal / measurement -> the quantities each sets (each at most once)
_GEOMETRY_TAGS = {"Location": ("location",), "Normal": ("normal",), "Direction": ("direction",),
                  "Axis": ("location", "direction"), "Diameter": ("diameter",), "DiameterMin": ("diameter_min",),
                  "DiameterMax": ("diameter_max",), "Length": ("length",), "Width": ("width",), "Form": ("form",),
                  "HalfAngle": ("half_angle",), "FullAngle": ("half_angle",)}


def snake_type(tag: str, suffix: str) -> str:
    """``"EdgePointFeatureMeasurement", "FeatureMeasurement"`` -> ``"edge_point"``."""
    return _CAMEL.sub("_", tag[: -len(suffix)] if tag.endswith(suffix) else tag).lower()


def short_id(text: str | None) -> str | None:
    """An id attribute as messages quote it: whole when short, else an excerpt (a 10 MB id is not echoed)."""
    return text if text is None or len(text) <= _ID_CHARS else excerpt(text, _ID_CHARS)


def owner_id(node: Node) -> str | None:
    """QIF id of the nearest element at or above ``node`` that has one."""
    current: Node | None = node
    while current is not None:
        if "id" in current.attrib:
            return short_id(current.attrib["id"])
        current = current.parent
    return None


@dataclass
class _Unit:
    name: str
    factor: float  # mm per unit or rad per unit


@dataclass
class QifContext:
    """What reading one document needs everywhere: its path, units, ids and the problems found."""

    path: str
    linear: _Unit = field(default_factory=lambda: _Unit("mm", 1.0))
    angular: _Unit = field(default_factory=lambda: _Unit("degree", math.pi / 180.0))
    pmi_linear: _Unit | None = None
    pmi_angular: _Unit | None = None
    named_linear: dict[str, float] = field(default_factory=dict)
    named_angular: dict[str, float] = field(default_factory=dict)
    units_stated: bool = True
    units_given: bool = False
    spell: SpellSetting = python_setting
    _assumption_noted: bool = False
    ids: dict[int, Node] = field(default_factory=dict)
    problems: list[str] = field(default_factory=list)

    # -- errors -----------------------------------------------------------------------------
    def error(self, node: Node, reason: str) -> QifError:
        """A :class:`QifError` about ``node`` (its owner's QIF id, its path, its line)."""
        return QifError(self.path, reason, qif_id=owner_id(node), element=node.path(), line=node.line or None)

    def problem(self, node: Node, reason: str) -> str:
        """Record something left out; returns the text recorded."""
        owner = owner_id(node)
        text = f"{node.path()}{f' (id {owner})' if owner else ''}, line {node.line}: {reason}"
        self.problems.append(text)
        return text

    # -- units ------------------------------------------------------------------------------
    def read_units(self, root: Node, *, units: str | None = None, angle_unit: str | None = None) -> None:
        """Primary (and PMI, other) units of ``FileUnits``; without them ``units`` / ``angle_unit``, else mm and degree.

        The QIF 3.0 schema makes ``FileUnits`` optional and states no default unit; a file
        without it is read in the units given, else in mm and degrees, and the document's
        problems say which (never "the file states").  Units given for a file that states its
        own are refused.
        """
        file_units = root.child("FileUnits")
        primary = None if file_units is None else file_units.child("PrimaryUnits")
        if primary is None:
            self.units_stated = False
            if units is not None:
                self.linear, self.units_given = _Unit(units, _MM_PER[units]), True
            if angle_unit is not None:
                self.angular, self.units_given = _Unit(angle_unit, _RAD_PER[angle_unit]), True
        elif units is not None or angle_unit is not None:
            raise self.error(primary, f"the file states its units (FileUnits/PrimaryUnits); "
                             f"{self.spell('units' if units is not None else 'angle_unit')} is for a file without them")
        else:
            for tag, attribute in (("LinearUnit", "linear"), ("AngularUnit", "angular"),
                                   ("PMILinearUnit", "pmi_linear"), ("PMIAngularUnit", "pmi_angular")):
                unit_node = primary.child(tag)
                if unit_node is not None:
                    setattr(self, attribute, self._unit(unit_node, angular="Angular" in tag))
        for unit in (self.linear, self.pmi_linear):
            if unit is not None:
                self.named_linear[unit.name.lower()] = unit.factor
        for unit in (self.angular, self.pmi_angular):
            if unit is not None:
                self.named_angular[unit.name.lower()] = unit.factor
        other = None if file_units is None else file_units.child("OtherUnits")
        for unit_node in [] if other is None else other.children:
            if unit_node.tag.endswith("LinearUnit"):
                unit = self._unit(unit_node, angular=False)
                self.named_linear[unit.name.lower()] = unit.factor
            elif unit_node.tag.endswith("AngularUnit"):
                unit = self._unit(unit_node, angular=True)
                self.named_angular[unit.name.lower()] = unit.factor

    def _unit(self, node: Node, *, angular: bool) -> _Unit:
        name_node = node.child("UnitName")
        name = (name_node.text.strip() if name_node is not None else "")
        table, si = (_RAD_PER, 1.0) if angular else (_MM_PER, 1000.0)  # UnitConversion goes to rad / m
        factor_node = None if node.child("UnitConversion") is None else node.child("UnitConversion").child("Factor")
        offset_node = None if node.child("UnitConversion") is None else node.child("UnitConversion").child("Offset")
        if offset_node is not None and self.number(offset_node) != 0.0:
            raise self.error(offset_node, "a unit conversion with an offset is not a length or angle unit")
        known = table.get(name.lower())
        if factor_node is None:
            if known is None:
                raise self.error(node, f"unknown unit {name!r} without a UnitConversion factor")
            return _Unit(name, known)
        stated = self.number(factor_node) * si
        if known is not None:
            if abs(stated - known) > _FACTOR_TOLERANCE * known:
                raise self.error(factor_node, f"unit {name!r} with the conversion factor {stated / si!r}, "
                                 f"expected {known / si!r}")
            return _Unit(name, known)
        if not (0.0 < stated < math.inf):
            raise self.error(factor_node, f"expected a positive finite conversion factor, got "
                             f"{factor_node.text.strip()[:40]}")
        return _Unit(name or "(unnamed)", stated)

    def units(self) -> Units:
        return Units(linear_unit=self.linear.name, mm_per_linear_unit=self.linear.factor,
                     angular_unit=self.angular.name, rad_per_angular_unit=self.angular.factor,
                     stated=self.units_stated)

    def factor(self, node: Node, quantity: str, *, pmi: bool = False) -> float:
        """mm (or rad) per unit of ``node``'s value: its ``linearUnit`` / ``angularUnit`` or the file's."""
        if quantity == "other":
            return 1.0
        if not self.units_stated and not self._assumption_noted:
            self._assumption_noted = True
            how = "as given" if self.units_given else \
                f"assumed; {self.spell('units')} and {self.spell('angle_unit')} say otherwise"
            self.problems.append(f"units not stated in the file (no FileUnits/PrimaryUnits; the QIF 3.0 schema states "
                                 f"no default): lengths read as {self.linear.name}, angles as {self.angular.name} "
                                 f"({how})")
        angular = quantity == "angular"
        attribute = node.attrib.get("angularUnit" if angular else "linearUnit")
        if attribute is not None:
            table = self.named_angular if angular else self.named_linear
            factor = table.get(attribute.strip().lower())
            if factor is None:
                raise self.error(node, f"value in the unit {attribute!r}, which FileUnits does not define")
            return factor
        if angular:
            return (self.pmi_angular if pmi and self.pmi_angular else self.angular).factor
        return (self.pmi_linear if pmi and self.pmi_linear else self.linear).factor

    # -- numbers ----------------------------------------------------------------------------
    def number(self, node: Node) -> float:
        text = node.text.strip()
        try:
            value = xs_double(text)
        except ValueError:
            raise self.error(node, f"expected a number, got {text[:40]!r}") from None
        if not math.isfinite(value):
            raise self.error(node, f"expected a finite number, got {text[:40]!r}")
        return value

    def numbers(self, node: Node, count: int) -> np.ndarray:
        tokens = node.text.split()
        if len(tokens) != count:
            raise self.error(node, f"expected {count} numbers, got {len(tokens)}")
        values = []
        for token in tokens:
            try:
                value = xs_double(token)
            except ValueError:
                raise self.error(node, f"expected a number, got {token[:40]!r}") from None
            if not math.isfinite(value):
                raise self.error(node, f"expected a finite number, got {token[:40]!r}")
            values.append(value)
        return np.array(values)

    def value(self, node: Node, quantity: str = "linear", *, pmi: bool = False) -> float:
        """A length (mm) or angle (rad) from the element's text and unit (finite after the conversion too)."""
        return self.converted(node, self.number(node) * self.factor(node, quantity, pmi=pmi), node.text)

    def converted(self, node: Node, value: float, text: str) -> float:
        """``value`` (already in mm or rad) when finite: ``1e307`` inch would overflow to inf."""
        if not math.isfinite(value):
            raise self.error(node, f"{text.strip()[:40]} overflows the float range when converted to mm or rad")
        return value

    def point(self, node: Node) -> np.ndarray:
        with np.errstate(over="ignore"):
            point = self.numbers(node, 3) * self.factor(node, "linear")
        if not np.isfinite(point).all():
            raise self.error(node, f"{' '.join(node.text.split())[:60]} overflows the float range when converted "
                             "to mm")
        return point

    def unit_vector(self, node: Node) -> np.ndarray:
        vector = self.numbers(node, 3)
        length = float(np.linalg.norm(vector))
        if abs(length - 1.0) > UNIT_VECTOR_TOLERANCE:
            raise self.error(node, f"expected a unit vector, got one of length {length:.6g}")
        return vector

    def integer(self, node: Node, text: str, what: str, *, minimum: int = 1) -> int:
        try:
            value = xs_integer(text)
        except ValueError:
            raise self.error(node, f"{what}: expected an integer, got {text.strip()[:40]!r}") from None
        if value < minimum:
            raise self.error(node, f"{what}: expected an integer >= {minimum}, got {value}")
        return value

    def boolean(self, node: Node) -> bool:
        text = node.text.strip().lower()
        if text not in ("true", "false", "1", "0"):
            raise self.error(node, f"expected true or false, got {text[:40]!r}")
        return text in ("true", "1")

    def text(self, node: Node | None) -> str | None:
        return None if node is None else (" ".join(node.text.split()) or None)

    def uncertainty(self, node: Node, quantity: str, *, pmi: bool = False) -> float | None:
        text = node.attrib.get("combinedUncertainty")
        if text is None:
            return None
        try:
            value = xs_double(text)
        except ValueError:
            raise self.error(node, f"combinedUncertainty: expected a number, got {text[:40]!r}") from None
        if not math.isfinite(value) or value < 0:
            raise self.error(node, f"combinedUncertainty: expected a finite number >= 0, got {text[:40]!r}")
        return self.converted(node, value * self.factor(node, quantity, pmi=pmi), text)

    # -- references -------------------------------------------------------------------------
    def reference(self, node: Node | None, kinds: tuple[str, ...]) -> int | None:
        """The id a reference element names when it names an element whose tag ends with one of ``kinds``.

        A dangling id is a :class:`QifError`; an id of an element of another kind is recorded as a
        problem and gives None; an external reference (``xId``) is recorded and gives None.
        """
        if node is None:
            return None
        referenced = self.integer(node, node.text, f"reference {node.tag}", minimum=0)
        if "xId" in node.attrib:
            self.problem(node, f"refers to id {node.attrib['xId']} of the external document {referenced}; not read")
            return None
        target = self.ids.get(referenced)
        if target is None:
            raise self.error(node, f"{node.tag} {referenced} is a dangling id: no element of the document has it")
        if not target.tag.endswith(kinds):
            self.problem(node, f"{node.tag} {referenced} names a {target.tag}, not a {' or '.join(kinds)}; "
                         "the reference is left out")
            return None
        return referenced

    def id_of(self, node: Node) -> int:
        if "id" not in node.attrib:
            raise self.error(node, "expected an id attribute")
        return self.integer(node, node.attrib["id"], "id", minimum=0)

    # -- geometry ---------------------------------------------------------------------------
    def geometry(self, node: Node) -> FeatureGeometry:
        """Location, normal, direction, sizes, form and their uncertainties of a feature nominal/measurement."""
        values: dict[str, object] = {}
        uncertainty: dict[str, float] = {}

        def note(name: str, child: Node, quantity: str) -> None:
            u = self.uncertainty(child, quantity)
            if u is not None:
                uncertainty[name] = u

        seen: dict[str, Node] = {}
        for child in node.children:
            tag = child.tag
            if tag in _GEOMETRY_TAGS:
                for name in _GEOMETRY_TAGS[tag]:
                    if name in seen:
                        first = seen[name]
                        raise self.error(child, f"a second {tag} element ({name} is also given by the {first.tag} "
                                         f"on line {first.line}): which one is meant?")
                    seen[name] = child
            if tag == "Location":
                values["location"] = self.point(child)
                note("location", child, "linear")
            elif tag == "Normal":
                values["normal"] = self.unit_vector(child)
            elif tag == "Direction":
                values["direction"] = self.unit_vector(child)
            elif tag == "Axis":
                point, direction = child.child("AxisPoint"), child.child("Direction")
                if point is None or direction is None:
                    raise self.error(child, "expected AxisPoint and Direction")
                values["location"] = self.point(point)
                values["direction"] = self.unit_vector(direction)
                note("location", point, "linear")
            elif tag in ("Diameter", "DiameterMin", "DiameterMax", "Length", "Width", "Form"):
                name = {"DiameterMin": "diameter_min", "DiameterMax": "diameter_max"}.get(tag, tag.lower())
                values[name] = self.value(child)
                note(name, child, "linear")
            elif tag in ("HalfAngle", "FullAngle"):
                values["half_angle"] = self.value(child, "angular") / (2.0 if tag == "FullAngle" else 1.0)
                note("half_angle", child, "angular")
        return FeatureGeometry(**values, uncertainty=uncertainty)  # type: ignore[arg-type]
