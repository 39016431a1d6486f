"""Which CMM format a file is, told by its content (its name only breaks ties), or stated by the user.

=========  ====================================================================================
format     recognised by
=========  ====================================================================================
qif        an XML start naming ``QIFDocument`` (UTF-8, or UTF-16 with or without a byte-order
           mark), or the suffix ``.qif`` when the start is not readable text
dmis       a first statement ``DMISMN/``, ``FILNAM/``, ``UNITS/`` or ``F|FA|T|TA(label)=FEAT|TOL/``
           after ``$$`` comments (a GEOPAK report saved as ``.IGS`` or ``.txt`` too), or a DMIS
           suffix (``.dmo``, ``.dmi``, ``.dms``, ``.dmis``)
calypso    a tab-separated header naming ``id``, ``actual``, ``nominal``, ``uppertol`` and
           ``lowertol``, or a name ending in ``_chr.txt``
pcdmis     a first line starting with ``XYZIJK`` (PC-DMIS XYZ export: points and normals)
points     anything else (CSV, XYZ, PLY, ...: :func:`pcmm_geo.io.read_points`)
=========  ====================================================================================

Only the first 4 KiB are looked at, and only when the path is a regular file (a FIFO is never
opened here: the reader that follows refuses it); the readers then check the whole file.
``format=`` states the format instead (``--format`` on the command line), for a file whose
start says nothing or says something else.

Examples
--------
>>> import pathlib, tempfile
>>> folder = pathlib.Path(tempfile.mkdtemp())
>>> _ = (folder / "probe.txt").write_text("XYZIJK    METRIC\\n1,2,3,0,0,1\\n")
>>> detect_format(folder / "probe.txt")
'pcdmis'
>>> _ = (folder / "REPORT.IGS").write_text("$$ GEOPAK\\nFA(P1) = FEAT/POINT, CART, 1, 2, 3, 0, 0, 1\\n")
>>> detect_format(folder / "REPORT.IGS")
'dmis'
>>> _ = (folder / "export.xml").write_bytes('<?xml version="1.0" encoding="UTF-16"?><QIFDocument/>'.encode("utf-16"))
>>> detect_format(folder / "export.xml")
'qif'
"""

from __future__ import annotations

import re
from pathlib import Path

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.io._lines import open_regular

__all__ = ["CMM_FORMATS", "DMIS_SUFFIXES", "HEAD_BYTES", "detect_format"]

#: formats :func:`detect_format` tells apart (and ``format=`` may state)
CMM_FORMATS = ("qif", "dmis", "calypso", "pcdmis", "points")
DMIS_SUFFIXES = (".dmo", ".dmi", ".dms", ".dmis")
#: bytes of the file's start looked at
HEAD_BYTES = 4096
_DMIS_START = re.compile(r"(?:DMISMN|FILNAM|UNITS|WKPLAN)[ \t]*/|(?:FA|F|TA|T)[ \t]*\([^)\n]{0,256}\)[ \t]*=[ \t]*"
                         r"(?:FEAT|TOL)[ \t]*/", re.IGNORECASE)
_CALYPSO_COLUMNS = frozenset({"id", "actual", "nominal", "uppertol", "lowertol"})


def _head(path: Path) -> bytes:
    """The first :data:`HEAD_BYTES` of a regular file (empty for anything else: its reader names the problem)."""
    try:
        with open_regular(path) as stream:
            return stream.read(HEAD_BYTES)
    except (OSError, ValueError):  # missing, a folder, a FIFO (FileFormatError is a ValueError)
        return b""


def _text(head: bytes) -> str:
    """The head as text: UTF-16 by its byte-order mark or its zero bytes, else UTF-8 (bad bytes replaced)."""
    if head.startswith((b"\xff\xfe", b"\xfe\xff")):
        return head.decode("utf-16", "replace")
    if head[:2] == b"<\x00":
        return head.decode("utf-16-le", "replace")
    if head[:2] == b"\x00<":
        return head.decode("utf-16-be", "replace")
    return head.removeprefix(b"\xef\xbb\xbf").decode("utf-8", "replace")


def _is_dmis(text: str) -> bool:
    for line in text.splitlines():
        code = line.split("$$", 1)[0].strip()
        if code:
            return _DMIS_START.match(code) is not None
    return False


def _is_calypso(text: str) -> bool:
    first = next((line for line in text.splitlines() if line.strip()), "")
    columns = {column.strip().lower() for column in first.split("\t")}
    return "\t" in first and _CALYPSO_COLUMNS <= columns


def detect_format(path: str | Path, format: str | None = None) -> str:
    """``"qif"``, ``"dmis"``, ``"calypso"``, ``"pcdmis"`` or ``"points"`` (see the module table).

    Parameters
    ----------
    path : str or Path
    format : str, optional
        The format, stated: returned as it is (checked to be one of :data:`CMM_FORMATS`).

    Raises
    ------
    InvalidInputError
        ``format`` is not one of :data:`CMM_FORMATS`.
    """
    if format is not None:
        if format not in CMM_FORMATS:
            raise InvalidInputError("format", f"one of {', '.join(CMM_FORMATS)}", repr(format))
        return format
    file = Path(path)
    suffix = file.suffix.lower()
    text = _text(_head(file))
    stripped = text.lstrip()
    if stripped.startswith("<") and "QIFDocument" in text:
        return "qif"
    if text.startswith("XYZIJK"):
        return "pcdmis"
    if _is_dmis(text):
        return "dmis"
    if _is_calypso(text):
        return "calypso"
    if suffix == ".qif":
        return "qif"
    if suffix in DMIS_SUFFIXES:
        return "dmis"
    if file.name.lower().endswith("_chr.txt"):
        return "calypso"
    return "points"
