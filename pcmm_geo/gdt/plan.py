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

A position frame of several segments is a list, top segment first, with ``features = [...]`` naming the
pattern (:func:`segment_entries`): ``frame = ["position dia 0.5 | A | B | C", "dia 0.1 | A"]`` -- a lower
segment without the symbol is a composite frame's FRTZF (ASME), one with it a stacked frame; ISO's ``CZ``,
``SZ`` and ``><`` are read there.  Symmetry names its two faces (``features = ["S1", "S2"]``) and profile of
a line its intersection planes' normal (``section = [0, 0, 1]``) (:func:`frame_extras`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pcmm_geo.errors import FileFormatError

__all__ = ["SYMBOLS", "FrameSpec", "dimension_entry", "frame_extras", "locate_lines", "parse_frame", "read_plan_text",
           "segment_entries"]

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


_ISO_PATTERN = {"CZ": "CZ", "SZ": "SZ", "><": "><"}


def _segment_spec(text: str, composite_lower: bool, path: str, line: int | None) -> tuple[FrameSpec, set[str]]:
    """One segment of a multi-segment position frame: its FrameSpec and the ISO pattern modifiers it carries."""
    tokens = text.replace("><", " >< ").split("|", 1)
    words = tokens[0].split()
    found = {w.upper() for w in words if w.upper() in _ISO_PATTERN}
    head = " ".join(w for w in words if w.upper() not in _ISO_PATTERN)
    rebuilt = ("position " if composite_lower else "") + head + ("|" + tokens[1] if len(tokens) > 1 else "")
    spec = parse_frame(rebuilt, path=path, line=line)
    return FrameSpec(spec.characteristic, spec.zone, spec.tolerance_mm, spec.modifier, spec.datums, text), found


def segment_entries(entry: dict[str, Any], index: int, keys: tuple[Any, ...], lines: dict[tuple[Any, ...], int],
                    features: Any, datums: Any, standard: str, path: str,
                    error: Any) -> list[tuple[str, str, FrameSpec, int | None, dict[str, Any]]]:
    """A position frame of two or more segments, written as on the drawing, expanded per segment and feature.

    ``frame = ["position dia 0.5 MMC | A | B | C", "dia 0.1 MMC | A"]``: a lower segment without the
    characteristic symbol shares the upper one's -- a composite frame (ASME Y14.5-2018 10.5.1: the lower
    segment's datums constrain orientation only); a lower segment with its own symbol is a stacked
    single-segment frame (10.5.2).  Under ISO (ISO 5458:2018, ISO 1101:2017) the segments are stacked
    frames whose ``CZ`` makes the zones one pattern (default: each zone on its own, ``SZ``) and whose
    ``><`` constrains orientation only; an ASME composite frame is refused under ISO, and CZ / SZ / ><
    under ASME.  ``features = ["H1", "H2", ...]`` (or ``feature``) names the pattern.

    Returns
    -------
    list of (name, feature, FrameSpec, line, extra)
        Segment by segment, feature by feature; ``extra["segments"]`` holds every segment (``datums``,
        ``tolerance_mm``, ``modifier``, ``simultaneous``, ``orientation_only``, ``label``) and
        ``extra["features"]`` the pattern.
    """
    name = str(entry.get("name", f"characteristic {index + 1}"))
    line = lines.get((*keys, "frame"), lines.get(keys))
    frames = entry["frame"]
    if len(frames) < 2 or not all(isinstance(f, str) for f in frames):
        raise error((*keys, "frame"), f"{name}: frame = [\"upper segment\", \"lower segment\", ...]: two or more "
                    "strings")
    names = entry.get("features", [entry.get("feature")])
    if not isinstance(names, list) or not names or any(n not in features for n in names):
        raise error((*keys, "features"), f"{name}: features = [\"H1\", ...] must name features of the plan "
                    f"(got {names!r})")
    def has_symbol(text: str) -> bool:
        first = (text.split() or [""])[0]
        return first in SYMBOLS or first.lower() in SYMBOLS or first[:1] in SYMBOLS

    composite = [k > 0 and not has_symbol(text) for k, text in enumerate(frames)]
    segments: list[dict[str, Any]] = []
    specs: list[FrameSpec] = []
    for k, text in enumerate(frames):
        lower_composite = composite[k]
        spec, iso = _segment_spec(text, lower_composite, path, line)
        if spec.characteristic != "position":
            raise FileFormatError(path, f"{name}: frame {text!r}: segments of a {spec.characteristic} frame are not "
                                  "supported (only position)", line)
        if lower_composite and standard != "ASME":
            raise FileFormatError(path, f"{name}: frame {text!r}: a composite frame is ASME Y14.5-2018 10.5.1; "
                                  "under ISO write stacked frames (ISO 5458: 'position dia 0.1 CZ >< | A', '><' for "
                                  "orientation only)", line)
        if iso and standard == "ASME":
            raise FileFormatError(path, f"{name}: frame {text!r}: {'/'.join(sorted(iso))} are ISO 5458 / ISO 1101 "
                                  "modifiers, not ASME Y14.5", line)
        for label in spec.datums:
            if label not in datums:
                raise FileFormatError(path, f"{name}: unknown datum {label!r} in frame {text!r}", line)
        if lower_composite:
            upper = specs[0]
            if spec.datums != upper.datums[:len(spec.datums)]:
                raise FileFormatError(path, f"{name}: frame {text!r}: a composite lower segment repeats the upper "
                                      f"segment's datums in order (ASME 10.5.1), got {'|'.join(spec.datums)} under "
                                      f"{'|'.join(upper.datums)}", line)
            if spec.tolerance_mm >= upper.tolerance_mm:
                raise FileFormatError(path, f"{name}: frame {text!r}: the FRTZF tolerance must be smaller than the "
                                      "PLTZF's", line)
        if spec.zone != "dia":
            raise FileFormatError(path, f"{name}: frame {text!r}: a pattern's position zones are cylindrical (dia)",
                                  line)
        label = ("FRTZF" if lower_composite else f"segment {k + 1}") if k else \
            ("PLTZF" if any(composite) else "segment 1")
        specs.append(spec)
        segments.append({"datums": spec.datums, "tolerance_mm": spec.tolerance_mm, "modifier": spec.modifier,
                         "simultaneous": standard == "ASME" or "CZ" in iso,
                         "orientation_only": lower_composite or "><" in iso, "label": label, "text": text})
    extra = {"segments": segments, "features": names, "name": name}
    return [(f"{name} {feature} ({seg['label']})", feature, spec, line, extra)
            for spec, seg in zip(specs, segments, strict=True) for feature in names]


def frame_extras(entry: dict[str, Any], spec: FrameSpec, keys: tuple[Any, ...], features: Any,
                 error: Any) -> tuple[str | None, dict[str, Any] | None]:
    """The toleranced feature and the frame's extra plan keys: symmetry's ``features = ["FACE1", "FACE2"]``
    (the slot's or tab's two opposite faces), profile of a line's ``section = [x, y, z]`` (the normal of the
    intersection planes in the DRF).  Other frames: ``(entry["feature"], None)``."""
    name = str(entry.get("name", ""))
    if spec.characteristic == "symmetry":
        faces = entry.get("features")
        if not isinstance(faces, list) or len(faces) != 2 or any(f not in features for f in faces):
            raise error((*keys, "features"), f"{name}: symmetry needs features = [\"FACE1\", \"FACE2\"], the two "
                        "opposite faces of the slot or tab")
        return faces[0], {"faces": faces}
    if spec.characteristic == "profile of a line":
        section = entry.get("section")
        if not isinstance(section, list) or len(section) != 3 or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in section) or not any(section):
            raise error((*keys, "section"), f"{name}: profile of a line needs section = [x, y, z], the normal of the "
                        "intersection planes in the DRF")
        return entry.get("feature"), {"section_normal": [float(v) for v in section]}
    return entry.get("feature"), None
