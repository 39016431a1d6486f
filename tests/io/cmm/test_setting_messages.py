"""The readers' requests for a setting: Python keywords by default, the caller's spelling when given.

The command line passes its own spelling (``--units mm``); see tests/cli/test_cli_cmm_files.py.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pcmm_geo.errors import FileFormatError, InvalidInputError, UnsafeXmlError
from pcmm_geo.io.cmm import python_setting, read_calypso_table, read_dmis, read_qif, validate_qif

DATA = Path(__file__).parents[2] / "data"
GEOPAK = DATA / "cmm" / "geopak_style.dmo"  # no UNITS, direction angles
SAMPLE = DATA / "qif" / "samples" / "QIF_PTS_SAMPLE.QIF"
TABLE = ("planid\tid\ttype\tidsymbol\tactual\tnominal\tuppertol\tlowertol\tdeviation\texceed\tfeatureid\n"
         "P\tAngle Face\tAngle\tangleXZ\t89.9950\t90.0000\t0.0100\t-0.0100\t-0.0050\t\tPlane_Face\nEND\n")


def _shouted(parameter: str, value: str | None = None) -> str:
    return parameter.upper() + ("" if value is None else f"={value}")


def test_python_wording_by_default() -> None:
    assert python_setting("units", "mm") == "units='mm'" and python_setting("max_bytes") == "max_bytes"
    with pytest.raises(FileFormatError, match="pass units='mm' or units='inch' \\(never assumed\\)"):
        read_dmis(GEOPAK)
    with pytest.raises(FileFormatError, match="pass angle_unit='degree' or angle_unit='radian'"):
        read_dmis(GEOPAK, units="inch")
    with pytest.raises(UnsafeXmlError, match="raise max_bytes for larger files") as refused:
        read_qif(SAMPLE, max_bytes=1000)
    assert refused.value.limit == 1000


def test_the_callers_spelling(tmp_path: Path) -> None:
    with pytest.raises(FileFormatError, match="pass UNITS=mm or UNITS=inch"):
        read_dmis(GEOPAK, spell_setting=_shouted)
    with pytest.raises(InvalidInputError) as missing:
        read_calypso_table(tmp_path / "none_chr.txt", spell_setting=_shouted)
    assert (missing.value.what, missing.value.got) == ("UNITS", "nothing")
    table = tmp_path / "t_chr.txt"
    table.write_text(TABLE)
    with pytest.raises(FileFormatError, match="pass ANGLE_UNIT=degree or ANGLE_UNIT=radian"):
        read_calypso_table(table, units="mm", spell_setting=_shouted)
    with pytest.raises(UnsafeXmlError, match="raise MAX_BYTES for larger files"):
        read_qif(SAMPLE, max_bytes=1000, spell_setting=_shouted)
    pytest.importorskip("lxml")
    with pytest.raises(UnsafeXmlError, match="raise MAX_BYTES for larger files"):
        validate_qif(SAMPLE, max_bytes=1000, spell_setting=_shouted)
