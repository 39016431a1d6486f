"""Which CMM format a file is, and reading it into one :class:`~pcmm_geo.io.cmm.CmmDocument`.

=========  ====================================================================================
format     recognised by
=========  ====================================================================================
qif        suffix ``.qif``, or an XML file whose start names ``QIFDocument``
dmis       suffix ``.dmo``, ``.dmi``, ``.dms``, ``.dmis``, or a first statement ``DMISMN/``
calypso    a name ending in ``_chr.txt``, or a tab-separated header starting ``planid``
pcdmis     a first line starting with ``XYZIJK`` (PC-DMIS XYZ export: points and normals)
points     anything else (CSV, XYZ, PLY, ...: :func:`pcmm_geo.io.read_points`)
=========  ====================================================================================

Only the first 4 KiB are looked at; the readers then check the whole file.

Examples
--------
>>> import pathlib, tempfile
>>> path = pathlib.Path(tempfile.mkdtemp()) / "probe.txt"
>>> _ = path.write_text("XYZIJK    METRIC\\n1,2,3,0,0,1\\n")
>>> detect_format(path)
'pcdmis'
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from pcmm_geo.io.cmm import SpellSetting, python_setting

if TYPE_CHECKING:
    from pcmm_geo.io.cmm import CmmDocument

__all__ = ["DMIS_SUFFIXES", "detect_format", "read_cmm_document"]

DMIS_SUFFIXES = (".dmo", ".dmi", ".dms", ".dmis")


def _head(path: Path) -> bytes:
    try:
        with path.open("rb") as stream:
            return stream.read(4096).removeprefix(b"\xef\xbb\xbf")
    except OSError:  # a folder, a missing file: the reader that follows names the problem
        return b""


def detect_format(path: str | Path) -> str:
    """``"qif"``, ``"dmis"``, ``"calypso"``, ``"pcdmis"`` or ``"points"`` (see the module table)."""
    file = Path(path)
    suffix = file.suffix.lower()
    if suffix == ".qif":
        return "qif"
    if suffix in DMIS_SUFFIXES:
        return "dmis"
    if file.name.lower().endswith("_chr.txt"):
        return "calypso"
    head = _head(file)
    stripped = head.lstrip()
    if suffix == ".xml" and b"QIFDocument" in head:
        return "qif"
    if head.startswith(b"XYZIJK"):
        return "pcdmis"
    if stripped[:7].upper() == b"DMISMN/":
        return "dmis"
    if stripped.lower().startswith(b"planid\t"):
        return "calypso"
    return "points"


def read_cmm_document(path: str | Path, *, units: str | None = None, angle_unit: str | None = None,
                      size_values: str | None = None, encoding: str = "utf-8",
                      max_bytes: int | None = None, spell_setting: SpellSetting = python_setting) -> CmmDocument:
    """Read a QIF document, a DMIS output or a CALYPSO table (:func:`detect_format`).

    Parameters
    ----------
    path : str or Path
    units, angle_unit, size_values, encoding
        For the text formats that do not state them (see :func:`~pcmm_geo.io.cmm.read_dmis` and
        :func:`~pcmm_geo.io.cmm.read_calypso_table`); for QIF ``units`` and ``angle_unit`` only
        when the file has no ``FileUnits`` (refused when it states its units).
    max_bytes : int, optional
        Largest QIF file read (default :data:`~pcmm_geo.io.cmm.DEFAULT_MAX_BYTES`).
    spell_setting : callable
        How messages name these settings (:mod:`pcmm_geo.io.cmm.settings`; the command line
        passes its option names).

    Raises
    ------
    FileFormatError
        A file of none of these formats (points only: nothing to show or verify), one without any
        measured feature or characteristic, or the readers' errors (QifError, UnsafeXmlError
        naming file and line).
    InvalidInputError
        Units given for a QIF file; unknown units.
    """
    from pcmm_geo.errors import FileFormatError, InvalidInputError
    from pcmm_geo.io import cmm

    kind = detect_format(path)
    document = None
    if kind == "qif":
        if size_values is not None:
            raise InvalidInputError(spell_setting("size_values"), "nothing for a QIF file (DMIS only)", size_values)
        document = cmm.read_qif(path, max_bytes=cmm.DEFAULT_MAX_BYTES if max_bytes is None else max_bytes,
                                units=units, angle_unit=angle_unit, spell_setting=spell_setting)
    elif kind == "dmis":
        document = cmm.read_dmis(path, units=units, angle_unit=angle_unit, size_values=size_values,
                                 encoding=encoding, spell_setting=spell_setting)
    elif kind == "calypso":
        document = cmm.read_calypso_table(path, units=units, angle_unit=angle_unit, encoding=encoding,
                                          spell_setting=spell_setting)
    if document is not None:
        if not document.measured_features and not document.characteristics:
            raise FileFormatError(str(path), "expected measured features or characteristics, got none")
        return document
    what = "a PC-DMIS XYZIJK point file (fit it: pcmm fit ELEMENT FILE --compensated yes|no)" if kind == "pcdmis" \
        else "not a CMM results file"
    raise FileFormatError(str(path), f"expected a QIF 3.0 document, a DMIS output (.dmo) or a CALYPSO table "
                          f"(*_chr.txt), got {what}")
