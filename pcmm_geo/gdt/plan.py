"""TOML inspection plans and the feature-control-frame grammar.

A plan (UTF-8 TOML, read with :mod:`tomllib`)::

    units = "mm"
    standard = "ISO"          # or "ASME"; ISO by default
    [part]
    frame = "A|B|C"           # the nominals below are in this DRF
    [features.A]
    element = "plane"         # plane | cylinder | sphere | point
    points = "A.csv"          # relative to the plan
    normal = [0, 0, -1]       # outward nominal normal
    point = [0, 0, 0]         # optional for planes (default: the origin)
    [features.H1]
    element = "cylinder"
    points = "H1.csv"
    side = "internal"         # internal (hole) | external (shaft)
    point = [30, 20, 0]
    axis = [0, 0, 1]
    diameter = 10
    size_tolerance = [0.0, 0.1]
    [datums]
    A = "A"                   # or A = {feature = "A", criterion = "constrained-lsq"}
    [[characteristics]]
    name = "pos H1"
    feature = "H1"
    frame = "position dia 0.1 MMC | A | B | C"

Frames are written as on the drawing, compartments separated by ``|``: the characteristic (a word or
its ISO symbol), ``dia`` / ``⌀`` / ``Ø`` for a cylindrical zone, the tolerance in mm, an optional
``MMC`` / ``Ⓜ``, ``LMC`` / ``Ⓛ`` or ``RFS``; then up to three datums, each a letter with an optional
datum feature modifier (``B(M)``, ``B MMB``, ``BⓂ``; ``B(L)``, ``B LMB``, ``BⓁ``) or a common datum
``A-B``.  Errors name the plan's file and line (:class:`~pcmm_geo.errors.FileFormatError`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pcmm_geo.errors import FileFormatError

__all__ = ["SYMBOLS", "FrameSpec", "dimension_entry", "locate_lines", "parse_frame", "read_plan_text"]

#: characteristic words and ISO 1101 symbols -> characteristic name
SYMBOLS = {
    "position": "position", "⌖": "position",
    "perpendicularity": "perpendicularity", "⊥": "perpendicularity",
    "parallelism": "parallelism", "∥": "parallelism", "//": "parallelism",
    "angularity": "angularity", "∠": "angularity",
    "flatness": "flatness", "⏥": "flatness",
    "profile-surface": "profile of a surface", "⌓": "profile of a surface",
    "profile-line": "profile of a line", "⌒": "profile of a line",
    "circular-runout": "circular runout", "runout": "circular runout", "↗": "circular runout",
    "total-runout": "total runout", "⌰": "total runout",
    "concentricity": "concentricity", "◎": "concentricity",
    "symmetry": "symmetry", "⌯": "symmetry",
}
_DIA = {"dia", "⌀", "Ø", "ø"}
_SDIA = {"sdia", "s⌀", "sø", "sØ"}
_MODIFIERS = {"MMC": "MMC", "Ⓜ": "MMC", "LMC": "LMC", "Ⓛ": "LMC", "RFS": "RFS", "Ⓢ": "RFS"}
_SPLIT = re.compile(r"(⌖|⊥|∥|∠|⏥|⌓|⌒|↗|⌰|◎|⌯|⌀|Ø|ø|Ⓜ|Ⓛ|Ⓢ)")


@dataclass(frozen=True)
class FrameSpec:
    """A parsed feature control frame.

    Attributes
    ----------
    characteristic : str
        Name from :data:`SYMBOLS` (``"position"``, ``"total runout"`` ...).
    zone : {"width", "dia", "sdia"}
    tolerance_mm : float
    modifier : {"RFS", "MMC", "LMC"}
    datums : tuple of str
        Datum labels, primary first; a common datum is one label ``"A-B"``.
    text : str
        The frame as written.
    datum_modifiers : tuple of str
        Per datum: ``"RMB"`` (none written), ``"MMB"`` (``B(M)``, ``B MMB``, ``BⓂ``; ISO 2692 MMR on the
        datum) or ``"LMB"`` (``B(L)``, ``B LMB``, ``BⓁ``).
    """

    characteristic: str
    zone: str
    tolerance_mm: float
    modifier: str
    datums: tuple[str, ...]
    text: str
    datum_modifiers: tuple[str, ...] = ()

    @property
    def modifiers_of_datums(self) -> tuple[str, ...]:
        """``datum_modifiers``, ``"RMB"`` for each datum when none were given."""
        return self.datum_modifiers or ("RMB",) * len(self.datums)


def parse_frame(text: str, *, path: str = "<plan>", line: int | None = None) -> FrameSpec:
    """Parse a feature control frame (``"position dia 0.1 MMC | A | B | C"``, ``"⊥ ⌀0.02 | A"``).

    Raises
    ------
    FileFormatError
        Unknown characteristic or token, no tolerance, more than three datums, an unknown datum feature
        modifier or one on a common datum; names ``path`` and ``line``.
    """
    def fail(reason: str) -> FileFormatError:
        return FileFormatError(path, f"frame {text!r}: {reason}", line)

    compartments = [c.strip() for c in text.replace("//", " // ").split("|")]
    if not compartments[0]:
        raise fail("no characteristic before the first '|'")
    tokens = _SPLIT.sub(r" \1 ", compartments[0]).split()
    name = tokens[0] if tokens[0] in SYMBOLS else tokens[0].lower()
    if name not in SYMBOLS:
        raise fail(f"unknown characteristic {tokens[0]!r} (known: {', '.join(k for k in SYMBOLS if k.isascii())} "
                   "or their ISO symbols)")
    zone, tolerance, modifier = "width", None, "RFS"
    for token in tokens[1:]:
        low = token.lower()
        if token in _DIA or low == "dia":
            zone = "dia"
        elif low in _SDIA:
            zone = "sdia"
        elif token.upper() in _MODIFIERS or token in _MODIFIERS:
            modifier = _MODIFIERS.get(token.upper(), _MODIFIERS.get(token, "RFS"))
        else:
            try:
                value = float(token)
            except ValueError:
                raise fail(f"unknown token {token!r} in the tolerance compartment") from None
            if tolerance is not None or not value > 0 or value != value or value == float("inf"):
                raise fail(f"{token!r}: expected one positive tolerance in mm")
            tolerance = value
    if tolerance is None:
        raise fail("no tolerance value")
    datums: list[str] = []
    datum_modifiers: list[str] = []
    for compartment in compartments[1:]:
        label, datum_modifier = _datum_compartment(compartment, fail)
        datums.append(label)
        datum_modifiers.append(datum_modifier)
    if len(datums) > 3:
        raise fail("more than three datums")
    if len(set(datums)) != len(datums) or len({p for d in datums for p in d.split("-")}) != sum(
            len(d.split("-")) for d in datums):
        raise fail("a datum named twice")
    return FrameSpec(SYMBOLS[name], zone, tolerance, modifier, tuple(datums), text, tuple(datum_modifiers))


#: datum feature modifiers as written after the datum letter -> ASME Y14.5-2018 name (ISO 2692 / 5459: MMR, LMR)
_DATUM_MODIFIER_NAMES = {"(M)": "MMB", "MMB": "MMB", "Ⓜ": "MMB", "(L)": "LMB", "LMB": "LMB", "Ⓛ": "LMB",
                         "(S)": "RMB", "RMB": "RMB", "Ⓢ": "RMB", "MMC": "MMB", "LMC": "LMB", "[MMR]": "MMB",
                         "[LMR]": "LMB"}


def _datum_compartment(compartment: str, fail: Any) -> tuple[str, str]:
    """One datum compartment: (label, ``"RMB"`` / ``"MMB"`` / ``"LMB"``).

    ``B``, ``B(M)``, ``B MMB``, ``BⓂ``, ``B(L)``, ``B LMB``, ``BⓁ``; a common datum ``A-B`` (its modifier
    refused: a common datum at MMB / LMB is not handled).
    """
    text = compartment.strip()
    if not text:
        raise fail("an empty datum compartment")
    match = re.fullmatch(r"([A-Z][A-Z0-9]*(?:\s*-\s*[A-Z][A-Z0-9]*)?)\s*(\([MLS]\)|Ⓜ|Ⓛ|Ⓢ|\[[ML]MR\]|[A-Za-z]+)?",
                         text)
    if match is None:
        raise fail(f"datum compartment {compartment!r}: expected a datum letter, an optional modifier "
                   "((M), MMB, Ⓜ, (L), LMB, Ⓛ) or a common datum A-B")
    label = re.sub(r"\s+", "", match.group(1))
    written = match.group(2)
    modifier = "RMB"
    if written is not None:
        modifier = _DATUM_MODIFIER_NAMES.get(written.upper() if written.isascii() else written, "")
        if not modifier:
            raise fail(f"datum compartment {compartment!r}: unknown datum feature modifier {written!r} (known: "
                       "(M), MMB, Ⓜ, (L), LMB, Ⓛ, RMB)")
    if "-" in label and modifier != "RMB":
        raise fail(f"common datum {label!r} at {modifier}: datum mobility of a common datum is not handled")
    return label, modifier


def locate_lines(text: str) -> dict[tuple[Any, ...], int]:
    """Line numbers (1-based) of the plan's tables and keys.

    Keys: ``("features", "H1")`` (its header), ``("features", "H1", "points")``, ``("datums", "A")``,
    ``("characteristics", 0)``, ``("characteristics", 0, "frame")``, ``("part", "frame")``, ``(key,)`` at top level.
    """
    where: dict[tuple[Any, ...], int] = {}
    table: tuple[Any, ...] = ()
    counts: dict[str, int] = {}
    for number, raw in enumerate(text.splitlines(), start=1):
        stripped = raw.strip()
        if stripped.startswith("[["):
            name = stripped.strip("[] ").strip()
            counts[name] = counts.get(name, -1) + 1
            table = (name, counts[name])
            where.setdefault(table, number)
        elif stripped.startswith("["):
            table = tuple(part.strip().strip('"') for part in stripped.strip("[] ").split("."))
            where.setdefault(table, number)
        elif "=" in stripped and not stripped.startswith("#"):
            key = stripped.split("=", 1)[0].strip().strip('"')
            where.setdefault((*table, key), number)
    return where


def read_plan_text(path: str | Path) -> tuple[dict[str, Any], dict[tuple[Any, ...], int]]:
    """The plan's TOML document and its line index.

    Raises
    ------
    FileFormatError
        Not UTF-8 text, over-long lines, or a TOML syntax error (its line).
    FileNotFoundError
    """
    import tomllib

    from pcmm_geo.io.text import read_text_file

    text = read_text_file(path)
    try:
        document = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        match = re.search(r"line (\d+)", str(exc))
        raise FileFormatError(str(path), f"TOML: {exc}", int(match.group(1)) if match else None) from None
    return document, locate_lines(text)


_DIMENSIONS = ("coordinate", "distance", "angle")


def dimension_entry(entry: dict[str, Any], index: int, keys: tuple[Any, ...], lines: dict[tuple[Any, ...], int],
                    features: Any, datums: Any, error: Any) -> tuple[str, list[str], int | None, dict[str, Any]]:
    """A ``type = "coordinate" | "distance" | "angle"`` entry, checked: (name, feature names, line, dimension).

    ``error(keys, reason)`` makes the :class:`FileFormatError` naming the plan's line.
    """
    name = str(entry.get("name", f"characteristic {index + 1}"))
    kind = entry["type"]
    line = lines.get((*keys, "type"), lines.get(keys))
    if kind not in _DIMENSIONS:
        raise error((*keys, "type"), f"{name}: type = {kind!r}: expected one of {', '.join(_DIMENSIONS)}")
    names = [entry.get("feature")] if kind == "coordinate" else entry.get("features")
    if not isinstance(names, list) or len(names) != (1 if kind == "coordinate" else 2):
        key = "feature" if kind == "coordinate" else "features"
        raise error((*keys, key), f"{name}: {key} = " + ('"NAME"' if kind == "coordinate" else '["NAME", "NAME"]') +
                    " is required")
    for feature in names:
        if feature not in features:
            raise error((*keys, "feature" if kind == "coordinate" else "features"),
                        f"{name}: unknown feature {feature!r}")
    unit = "deg" if kind == "angle" else ""
    nominal_key, limits_key = ("nominal_deg", "limits_deg") if unit else ("nominal", "limits")
    nominal, limits = entry.get(nominal_key), entry.get(limits_key)
    if not isinstance(nominal, (int, float)) or isinstance(nominal, bool):
        raise error((*keys, nominal_key), f"{name}: {nominal_key} = NUMBER is required")
    if (not isinstance(limits, list) or len(limits) != 2 or not all(isinstance(v, (int, float)) for v in limits)
            or limits[0] > limits[1]):
        raise error((*keys, limits_key), f"{name}: {limits_key} = [lower, upper] deviations are required")
    frame = entry.get("datums", "")
    labels = tuple(p.strip() for p in frame.split("|") if p.strip()) if isinstance(frame, str) else ()
    for label in labels:
        if label not in datums:
            raise error((*keys, "datums"), f"{name}: unknown datum {label!r}")
    if kind == "coordinate" and entry.get("axis") not in ("x", "y", "z"):
        raise error((*keys, "axis"), f"{name}: axis = \"x\" | \"y\" | \"z\" is required")
    dimension = {"type": kind, "features": names, "nominal": float(nominal), "limits": (float(limits[0]),
                 float(limits[1])), "datums": labels, "axis": entry.get("axis")}
    return name, names, line, dimension
