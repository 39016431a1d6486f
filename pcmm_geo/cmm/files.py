"""Reading a CMM file into one :class:`~pcmm_geo.io.cmm.CmmDocument`, whichever format it is.

Which format a file is is told by :func:`pcmm_geo.io.cmm.detect.detect_format` (by content;
re-exported here): a QIF document, a DMIS output, a CALYPSO table, a PC-DMIS XYZIJK point file or
points.

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
from pcmm_geo.io.cmm.detect import CMM_FORMATS, DMIS_SUFFIXES, detect_format

if TYPE_CHECKING:
    from pcmm_geo.io.cmm import CmmDocument
    from pcmm_geo.io.cmm.qif.characteristic_definitions import QifDefinitions

__all__ = ["CMM_FORMATS", "DMIS_SUFFIXES", "detect_format", "read_cmm_document", "read_cmm_document_and_definitions"]


def read_cmm_document(path: str | Path, *, units: str | None = None, angle_unit: str | None = None,
                      size_values: str | None = None, encoding: str = "utf-8",
                      max_bytes: int | None = None, spell_setting: SpellSetting = python_setting,
                      format: str | None = None, max_elements: int | None = None) -> CmmDocument:
    """Read a QIF document, a DMIS output or a CALYPSO table (:func:`detect_format`, or ``format``).

    Parameters
    ----------
    path : str or Path
    units, angle_unit, size_values, encoding
        For the text formats that do not state them (see :func:`~pcmm_geo.io.cmm.read_dmis` and
        :func:`~pcmm_geo.io.cmm.read_calypso_table`); for QIF ``units`` and ``angle_unit`` only
        when the file has no ``FileUnits`` (refused when it states its units).
    max_bytes : int, optional
        Largest file read: QIF default :data:`~pcmm_geo.io.cmm.DEFAULT_MAX_BYTES` (1 GiB), DMIS and
        CALYPSO :data:`~pcmm_geo.io.cmm.settings.DEFAULT_MAX_TEXT_BYTES` (32 MiB).
    format : {"qif", "dmis", "calypso"}, optional
        The file's format, stated (else told by its content).
    max_elements : int, optional
        QIF: most XML elements accepted (default: the reader's, 10^6).
    spell_setting : callable
        How messages name these settings (:mod:`pcmm_geo.io.cmm.settings`; the command line
        passes its option names).

    Raises
    ------
    FileFormatError
        A file of none of these formats (points only: nothing to show or verify), one without any
        measured feature, characteristic or inspection status (a status-only file is read), or
        the readers' errors (QifError, UnsafeXmlError naming file and line).
    InvalidInputError
        Units given for a QIF file; unknown units.
    """
    return read_cmm_document_and_definitions(path, units=units, angle_unit=angle_unit, size_values=size_values,
                                             encoding=encoding, max_bytes=max_bytes, spell_setting=spell_setting,
                                             format=format, max_elements=max_elements, definitions=False)[0]


def read_cmm_document_and_definitions(
    path: str | Path, *, units: str | None = None, angle_unit: str | None = None, size_values: str | None = None,
    encoding: str = "utf-8", max_bytes: int | None = None, spell_setting: SpellSetting = python_setting,
    format: str | None = None, max_elements: int | None = None, definitions: bool = True,
) -> tuple[CmmDocument, QifDefinitions | None]:
    """:func:`read_cmm_document` and, for a QIF file, its characteristic definitions and datums, from one parse.

    The definitions (:func:`~pcmm_geo.io.cmm.qif.characteristic_definitions.read_qif_definitions`)
    come from the same bounded tree as the document; None for DMIS and CALYPSO files (or with
    ``definitions=False``).  Parameters and errors as :func:`read_cmm_document`.
    """
    from pcmm_geo.errors import FileFormatError, InvalidInputError
    from pcmm_geo.io.cmm import DEFAULT_MAX_BYTES, read_calypso_table, read_dmis, read_qif
    from pcmm_geo.io.cmm.qif.characteristic_definitions import read_qif_with_definitions
    from pcmm_geo.io.text import refuse_irregular

    refuse_irregular(path)  # a FIFO would block the reader forever
    kind = detect_format(path, format)
    limit = {} if max_bytes is None else {"max_bytes": max_bytes}
    document, read = None, None
    if kind == "qif":
        if size_values is not None:
            raise InvalidInputError(spell_setting("size_values"), "nothing for a QIF file (DMIS only)", size_values)
        bounds = {"max_bytes": DEFAULT_MAX_BYTES if max_bytes is None else max_bytes}
        if max_elements is not None:  # else the readers' default
            bounds["max_elements"] = max_elements
        if definitions:
            document, read = read_qif_with_definitions(path, units=units, angle_unit=angle_unit,
                                                       spell_setting=spell_setting, **bounds)
        else:
            document = read_qif(path, units=units, angle_unit=angle_unit, spell_setting=spell_setting, **bounds)
    elif kind == "dmis":
        document = read_dmis(path, units=units, angle_unit=angle_unit, size_values=size_values,
                             encoding=encoding, spell_setting=spell_setting, **limit)
    elif kind == "calypso":
        document = read_calypso_table(path, units=units, angle_unit=angle_unit, encoding=encoding,
                                      spell_setting=spell_setting, **limit)
    if document is not None:
        if not document.measured_features and not document.characteristics and \
                not any(results.inspection_status for results in document.results):
            raise FileFormatError(str(path), "expected measured features, characteristics or an inspection status, "
                                  "got none")
        return document, read
    what = f"a PC-DMIS XYZIJK point file (points to fit, saying with {spell_setting('compensated')} whether they " \
        "are probe centres)" if kind == "pcdmis" else "not a CMM results file"
    raise FileFormatError(str(path), f"expected a QIF 3.0 document, a DMIS output (.dmo) or a CALYPSO table "
                          f"(*_chr.txt), got {what}")
