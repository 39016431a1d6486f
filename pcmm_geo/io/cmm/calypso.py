"""ZEISS CALYPSO characteristic tables (``*_chr.txt``): one row per characteristic, tab-separated.

The table CALYPSO writes next to each measurement: a header naming the columns, one row per
characteristic, a closing line ``END``.  The columns read are

==============  =================================================================
``id``          the characteristic's name
``idsymbol``    its type, language-independent (``diameter``, ``gdtFlat``, ``gdtRound``,
                ``gdtPerp``, ``gdtPosPol2d``, ``distance2d``, ``form``, ...);
                ``type`` (the same in the user's language) when there is no ``idsymbol``
``actual``      measured value
``nominal``     nominal value
``uppertol``    upper tolerance (deviation from nominal; a form tolerance's zone)
``lowertol``    lower tolerance
``deviation``   actual - nominal, as CALYPSO computed it (checked)
``exceed``      amount out of tolerance; empty when in tolerance (the verdict)
``featureid``   the feature(s) evaluated, comma-separated
``planid``      the measurement plan (recorded as the application)
==============  =================================================================

Other columns are kept out.  Rows may end early (CALYPSO leaves trailing empty fields out).
Each row becomes a :class:`~pcmm_geo.io.cmm.Characteristic`: ``status`` ``"FAIL"`` when
``exceed`` holds a number, ``"PASS"`` when it is empty; the ``featureid`` names become
:class:`~pcmm_geo.io.cmm.FeatureItem` records the characteristic refers to.

Never guessed: the table does not state its length unit, so ``units=`` (``"mm"`` or ``"inch"``)
is required; an angle characteristic (``idsymbol`` starting with ``angle``) needs
``angle_unit=``; an ``idsymbol`` pcmm_geo does not know is kept unconverted (``quantity="other"``).
A row whose ``deviation`` disagrees with ``actual - nominal`` or whose ``exceed`` disagrees with
the tolerances, a row whose columns a missing or extra tab has shifted (a number as its type, a
lower tolerance above the upper one, more fields than the header), a value that overflows when
converted to mm, a missing ``END`` (a table cut short), a field that is not a number: each is a
:class:`~pcmm_geo.errors.FileFormatError` naming the file and line.

Examples
--------
>>> import pathlib, tempfile
>>> path = pathlib.Path(tempfile.mkdtemp()) / "ring_chr.txt"
>>> _ = path.write_text("planid\\tid\\tidsymbol\\tactual\\tnominal\\tuppertol\\tlowertol\\tdeviation\\t"
...                     "exceed\\tfeatureid\\n"
...                     "RING\\tBore\\tdiameter\\t23.4009\\t23.4000\\t0.0050\\t0.0000\\t0.0009\\t\\tCircle_B\\n"
...                     "END\\n")
>>> table = read_calypso_table(path, units="mm")
>>> bore = table.characteristics[0]
>>> bore.name, bore.type, bore.value, bore.status, bore.tolerance.limits(bore.nominal)
('Bore', 'diameter', 23.4009, 'PASS', (23.4, 23.405))
>>> [item.name for item in table.feature_items.values()]
['Circle_B']
"""

from __future__ import annotations

import math
import re
from pathlib import Path

from pcmm_geo.errors import FileFormatError, InvalidInputError
from pcmm_geo.io._text import excerpt, iter_text_lines, parse_decimal
from pcmm_geo.io.cmm.document import CmmDocument
from pcmm_geo.io.cmm.model import Characteristic, FeatureItem, MeasurementResults, Tolerance, Units
from pcmm_geo.io.cmm.settings import DEFAULT_MAX_TEXT_BYTES, SpellSetting, check_size, python_setting

__all__ = ["CALYPSO_TYPES", "read_calypso_table"]

#: CALYPSO idsymbol (lower case, prefix) -> characteristic type; all lengths
CALYPSO_TYPES = {
    "gdtflat": "flatness", "gdtround": "circularity", "gdtstraight": "straightness", "gdtcyl": "cylindricity",
    "gdtsphere": "sphericity", "gdtperp": "perpendicularity", "gdtpar": "parallelism", "gdtang": "angularity",
    "gdtpos": "position", "gdtconc": "concentricity", "gdtcoax": "coaxiality", "gdtsym": "symmetry",
    "gdtprofileline": "line_profile", "gdtprofilesurface": "surface_profile", "gdtrunout": "circular_runout",
    "gdttotalrunout": "total_runout", "diameter": "diameter", "radius": "radius", "distance": "distance_between",
    "form": "form", "xvalue": "x_coordinate", "yvalue": "y_coordinate", "zvalue": "z_coordinate",
    "width": "width", "length": "length", "resultelementlength": "length",
}
_UNITS = {"mm": 1.0, "inch": 25.4}
_ANGLES = {"degree": math.pi / 180.0, "radian": 1.0}
_REQUIRED = ("id", "actual", "nominal", "uppertol", "lowertol")
#: CALYPSO writes 7 decimals; deviation and actual - nominal may differ by two roundings
_ROUNDING = 2.5e-7
_CAMEL = re.compile(r"(?<=[a-z0-9])(?=[A-Z])")


def _is_number(text: str) -> bool:
    try:
        parse_decimal(text)
    except ValueError:
        return False
    return True


def _kind(symbol: str) -> tuple[str, str]:
    """(type, quantity) of a CALYPSO idsymbol."""
    lowered = symbol.lower()
    if lowered.startswith("angle"):
        return _CAMEL.sub("_", symbol).lower(), "angular"
    for prefix in sorted(CALYPSO_TYPES, key=len, reverse=True):
        if lowered.startswith(prefix):
            return CALYPSO_TYPES[prefix], "linear"
    return _CAMEL.sub("_", symbol).lower() or "unknown", "other"


def read_calypso_table(path: str | Path, *, units: str | None = None, angle_unit: str | None = None,
                       encoding: str = "utf-8", spell_setting: SpellSetting = python_setting,
                       max_bytes: int = DEFAULT_MAX_TEXT_BYTES) -> CmmDocument:
    """Read a CALYPSO characteristic table (see the module docstring).

    Parameters
    ----------
    path : str or Path
        The ``*_chr.txt`` file.
    units : {"mm", "inch"}
        Length unit of the table (CALYPSO does not write it); required.
    angle_unit : {"degree", "radian"} or None
        Unit of angle characteristics; required when the table has any.
    encoding : str
        Text encoding (CALYPSO on Windows: often ``"cp1252"``).
    max_bytes : int
        Largest file read (default :data:`~pcmm_geo.io.cmm.settings.DEFAULT_MAX_TEXT_BYTES`, 32 MiB).
    spell_setting : callable
        How the messages name ``units`` and ``angle_unit`` (:mod:`pcmm_geo.io.cmm.settings`;
        the command line passes its option names).

    Returns
    -------
    CmmDocument
        ``format="calypso"``: characteristics and the feature items they name; no feature geometry
        (the table has none).

    Raises
    ------
    FileFormatError
        No header, a row that cannot be read, inconsistent deviation or verdict, no ``END``.
    InvalidInputError
        ``units`` missing or unknown, ``angle_unit`` unknown.
    FileNotFoundError
        The file does not exist.
    """
    if units not in _UNITS:
        raise InvalidInputError(spell_setting("units"), "'mm' or 'inch' (a CALYPSO table does not state its unit)",
                                "nothing" if units is None else repr(units))
    if angle_unit is not None and angle_unit not in _ANGLES:
        raise InvalidInputError(spell_setting("angle_unit"), "'degree' or 'radian'", repr(angle_unit))
    name = str(path)
    check_size(path, max_bytes, spell_setting)
    lines = iter_text_lines(path, encoding=encoding)
    header_line, header = next(((n, t) for n, t in lines if t.strip()), (0, ""))
    columns = [c.strip().lower() for c in header.rstrip("\t").split("\t")]
    missing = [c for c in _REQUIRED if c not in columns]
    if not header or missing or ("idsymbol" not in columns and "type" not in columns):
        raise FileFormatError(name, f"expected a CALYPSO characteristic table header (tab-separated, with "
                              f"{', '.join(_REQUIRED)} and idsymbol or type), got {excerpt(header)}",
                              header_line or 1)
    where = {column: columns.index(column) for column in dict.fromkeys(columns) if column}
    characteristics: list[Characteristic] = []
    items: dict[str, FeatureItem] = {}
    plan = None
    ended = False
    for number, text in lines:
        if ended:
            if text.strip():
                raise FileFormatError(name, f"text after END: {excerpt(text)}", number)
            continue
        if text.strip() == "END":
            ended = True
            continue
        if not text.strip():
            continue
        fields = text.split("\t")
        if len(fields) > len(columns) and any(f.strip() for f in fields[len(columns):]):
            raise FileFormatError(name, f"{len(fields)} fields, the header names {len(columns)}", number)

        def get(column: str, fields: list[str] = fields) -> str:
            index = where.get(column)
            return fields[index].strip() if index is not None and index < len(fields) else ""

        def number_of(column: str, *, required: bool = True, number: int = number, get=get) -> float | None:
            text = get(column)
            if not text:
                if required:
                    raise FileFormatError(name, f"column {column}: expected a number, got nothing", number)
                return None
            try:
                value = parse_decimal(text)
            except ValueError:
                raise FileFormatError(name, f"column {column}: expected a number, got {excerpt(text)}",
                                      number) from None
            if not math.isfinite(value):
                raise FileFormatError(name, f"column {column}: expected a finite number, got {excerpt(text)}",
                                      number)
            return value

        label = get("id")
        if not label:
            raise FileFormatError(name, "column id: a characteristic without a name", number)
        for column in ("idsymbol", "type"):
            if _is_number(get(column)):
                raise FileFormatError(name, f"{label!r}: column {column}: expected a characteristic type, got the "
                                      f"number {excerpt(get(column))} (a tab missing or added shifts a row's "
                                      "columns)", number)
        kind, quantity = _kind(get("idsymbol") or get("type"))
        if quantity == "angular" and angle_unit is None:
            raise FileFormatError(name, f"angle characteristic {label!r}: pass {spell_setting('angle_unit', 'degree')} "
                                  f"or {spell_setting('angle_unit', 'radian')} (the table does not state it)", number)
        factor = {"linear": _UNITS[units], "angular": _ANGLES.get(angle_unit or "", 1.0), "other": 1.0}[quantity]
        actual, nominal = number_of("actual"), number_of("nominal")
        upper, lower = number_of("uppertol"), number_of("lowertol")
        if lower > upper:  # type: ignore[operator]
            raise FileFormatError(name, f"{label!r}: lowertol {lower:g} above uppertol {upper:g} (a tab missing or "
                                  "added shifts a row's columns)", number)
        deviation = number_of("deviation", required=False)
        exceed = number_of("exceed", required=False)
        if deviation is not None and abs(deviation - (actual - nominal)) > _ROUNDING * max(1.0, abs(actual)):  # type: ignore[operator]
            raise FileFormatError(name, f"{label!r}: deviation {deviation:g} disagrees with actual - nominal = "
                                  f"{actual - nominal:g}", number)  # type: ignore[operator]
        outside = not (lower - _ROUNDING <= actual - nominal <= upper + _ROUNDING)  # type: ignore[operator]
        if "exceed" in where and (exceed is not None and exceed != 0.0) != outside:
            raise FileFormatError(name, f"{label!r}: exceed {get('exceed') or 'empty'} disagrees with actual - nominal "
                                  f"= {actual - nominal:g} and the tolerances [{lower:g}, {upper:g}]", number)  # type: ignore[operator]
        if not all(math.isfinite(v * factor) for v in (actual, nominal, upper, lower)):  # type: ignore[operator]
            raise FileFormatError(name, f"{label!r}: a value overflows the float range when converted to mm", number)
        plan = plan or get("planid") or None
        feature_ids = []
        for feature in (f.strip() for f in get("featureid").split(",")):
            if feature:
                if feature not in items:
                    items[feature] = FeatureItem(id=len(items) + 1, type="unknown", name=feature, nominal_id=None)
                feature_ids.append(items[feature].id)
        characteristics.append(Characteristic(
            id=len(characteristics) + 1, type=kind, name=label, value=actual * factor,  # type: ignore[operator]
            nominal=nominal * factor, deviation=None if deviation is None else deviation * factor,  # type: ignore[operator]
            tolerance=Tolerance(max_value=upper * factor, min_value=lower * factor),  # type: ignore[operator]
            status="FAIL" if outside else "PASS", quantity=quantity, feature_item_ids=tuple(feature_ids),
            results_id=0))
    if not ended:
        raise FileFormatError(name, "expected the closing END line: the table may be cut short")
    statuses = {c.status for c in characteristics}
    return CmmDocument(
        source=name, format="calypso",
        units=Units(linear_unit=units, mm_per_linear_unit=_UNITS[units], angular_unit=angle_unit or "degree",
                    rad_per_angular_unit=_ANGLES.get(angle_unit or "degree", 1.0), stated=False),
        feature_items={item.id: item for item in items.values()},
        results=(MeasurementResults(id=0, characteristics=tuple(characteristics),
                                    inspection_status="FAIL" if "FAIL" in statuses else "PASS" if statuses else None),),
        application=plan)
