"""CALYPSO tables and PC-DMIS XYZIJK files under attack (issue 31): shifted rows, truncation, overflow."""

from __future__ import annotations

from pathlib import Path

import pytest

from pcmm_geo.errors import FileFormatError
from pcmm_geo.io.cmm import read_calypso_table, read_pcdmis_xyzijk

DATA = Path(__file__).resolve().parents[2] / "data" / "cmm"
FLANGE = DATA / "flange_chr.txt"
RING = DATA / "ring_xyzijk_metric.xyz"


def _flange_lines() -> list[str]:
    return FLANGE.read_text(encoding="utf-8").split("\n")


def _write(tmp_path: Path, text: str, name: str) -> Path:
    path = tmp_path / name
    path.write_bytes(text.encode("utf-8"))
    return path


def test_every_shift_of_one_row_by_a_lost_tab_is_refused(tmp_path: Path) -> None:
    """Drop any one tab of a characteristic row (columns before featureid): the row is refused, never read
    with its value, nominal and limits in the wrong columns."""
    lines = _flange_lines()
    header = lines[0].split("\t")
    stop = header.index("featureid")
    refused = 0
    for row in range(1, len(lines)):
        fields = lines[row].split("\t")
        if len(fields) < stop:
            continue
        for column in range(2, stop):  # merge field `column` into the one before it
            shifted = [*fields[:column - 1], fields[column - 1] + fields[column], *fields[column + 1:]]
            edited = [*lines[:row], "\t".join(shifted), *lines[row + 1:]]
            path = _write(tmp_path, "\n".join(edited), "shifted_chr.txt")
            with pytest.raises(FileFormatError) as caught:
                read_calypso_table(path, units="mm", angle_unit="degree")
            assert caught.value.line == row + 1
            refused += 1
    assert refused > 30


def test_the_shifted_row_of_the_issue_names_its_type_and_limits(tmp_path: Path) -> None:
    lines = _flange_lines()
    fields = lines[1].split("\t")  # planid, partnb, id, type, idsymbol, actual, ...
    shifted = [*fields[:2], fields[2] + fields[3], *fields[4:]]  # idsymbol now holds the actual value
    path = _write(tmp_path, "\n".join([lines[0], "\t".join(shifted), *lines[2:]]), "row_chr.txt")
    with pytest.raises(FileFormatError, match="expected a characteristic type, got the number") as caught:
        read_calypso_table(path, units="mm", angle_unit="degree")
    assert caught.value.line == 2


def test_lower_tolerance_above_the_upper_is_refused(tmp_path: Path) -> None:
    lines = _flange_lines()
    lines[2] = lines[2].replace("\t0.0250000\t0.0000000\t0.0123456", "\t0.0250000\t0.0300000\t0.0123456", 1)
    with pytest.raises(FileFormatError, match=r"lowertol 0\.03 above uppertol 0\.025") as caught:
        read_calypso_table(_write(tmp_path, "\n".join(lines), "limits_chr.txt"), units="mm", angle_unit="degree")
    assert caught.value.line == 3


def test_calypso_values_that_overflow_in_inch_are_refused(tmp_path: Path) -> None:
    text = ("planid\tid\tidsymbol\tactual\tnominal\tuppertol\tlowertol\n"
            "P\tBig\tdiameter\t1e307\t1e307\t0\t0\nEND\n")
    path = _write(tmp_path, text, "big_chr.txt")
    assert read_calypso_table(path, units="mm").characteristics[0].value == 1e307
    with pytest.raises(FileFormatError, match="overflows the float range") as caught:
        read_calypso_table(path, units="inch")
    assert caught.value.line == 2


def test_xyzijk_cut_inside_a_line_is_refused_at_every_cut(tmp_path: Path) -> None:
    text = RING.read_text(encoding="utf-8")
    whole = read_pcdmis_xyzijk(RING)
    first_end = text.index("\n") + 1
    for cut in range(first_end + 1, len(text)):
        piece = text[:cut]
        path = _write(tmp_path, piece, "cut.xyz")
        if piece.endswith("\n"):  # at a line end: the undetectable class, the whole points before it are read
            assert len(read_pcdmis_xyzijk(path).points) == piece.count("\n") - 1 < len(whole.points) or \
                cut == len(text)
            continue
        with pytest.raises(FileFormatError, match="ends in the middle of a line") as caught:
            read_pcdmis_xyzijk(path)
        assert caught.value.line == piece.count("\n") + 1


@pytest.mark.parametrize(("text", "message"), [
    ("XYZIJK    METRIC\n1,2,3,1e308,0,0\n", r"has length 1e\+308, expected a unit vector"),
    ("XYZIJK    METRIC\n1,2,3,1e308,1e308,1e308\n", "expected a unit vector"),
    ("XYZIJK\n1e307,2,3\n", "overflows the float range"),
])
def test_xyzijk_huge_numbers_are_refused_without_a_traceback(tmp_path: Path, text: str, message: str) -> None:
    with pytest.raises(FileFormatError, match=message):
        read_pcdmis_xyzijk(_write(tmp_path, text, "huge.xyz"))
