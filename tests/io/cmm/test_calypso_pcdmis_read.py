"""CALYPSO characteristic tables and PC-DMIS XYZIJK files: values, verdicts, units, normals, refusals."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.errors import FileFormatError, InvalidInputError
from pcmm_geo.io.cmm import read_calypso_table, read_pcdmis_xyzijk
from pcmm_geo.io.cmm.pcdmis import is_pcdmis_xyzijk

DATA = Path(__file__).resolve().parents[2] / "data" / "cmm"
FLANGE = DATA / "flange_chr.txt"


# ---------------------------------------------------------------------------------------------
# CALYPSO


def test_calypso_table_characteristics_verdicts_and_features() -> None:
    table = read_calypso_table(FLANGE, units="mm")
    assert table.format == "calypso" and table.application == "FLANGE_TEST"
    by_name = {c.name: c for c in table.characteristics}
    assert [c.type for c in table.characteristics] == [
        "flatness", "diameter", "circularity", "distance_between", "position", "perpendicularity"]
    bore = by_name["Bore Dia"]
    assert (bore.value, bore.nominal, bore.deviation, bore.status) == (40.0123456, 40.0, 0.0123456, "PASS")
    assert bore.tolerance.limits(bore.nominal) == pytest.approx((40.0, 40.025))
    assert [c.name for c in table.characteristics if c.status == "FAIL"] == ["Roundness Bore", "Position H1"]
    assert table.results[0].inspection_status == "FAIL"
    names = {item.id: item.name for item in table.feature_items.values()}
    assert [names[i] for i in by_name["Hole Pattern Distance"].feature_item_ids] == ["Circle_H1", "Circle_H2"]
    assert [names[i] for i in by_name["Bore Dia"].feature_item_ids] == ["Cylinder_Bore"]


def test_calypso_units_are_never_assumed() -> None:
    with pytest.raises(InvalidInputError, match="does not state its unit"):
        read_calypso_table(FLANGE)
    inch = read_calypso_table(FLANGE, units="inch")
    bore = next(c for c in inch.characteristics if c.name == "Bore Dia")
    assert bore.value == pytest.approx(40.0123456 * 25.4, rel=1e-15)
    assert bore.tolerance.max_value == pytest.approx(0.025 * 25.4, rel=1e-15)
    assert inch.units.mm_per_linear_unit == 25.4 and not inch.units.stated


def _edited(tmp_path: Path, old: str, new: str) -> Path:
    text = FLANGE.read_text(encoding="utf-8")
    assert old in text
    path = tmp_path / "edited_chr.txt"
    path.write_text(text.replace(old, new, 1), encoding="utf-8")
    return path


@pytest.mark.parametrize(("old", "new", "line", "message"), [
    ("END\n", "", None, "expected the closing END line"),
    ("40.0123456\t40.0000000", "40.0123456\t40.0100000", 3, "deviation 0.0123456 disagrees with actual - nominal"),
    ("0.0062000\t0.0012000", "0.0062000\t", 4, "exceed empty disagrees"),
    ("40.0123456", "40,0123456", 3, "column actual: expected a number, got '40,0123456'"),
    ("planid\tpartnb\tid", "plan\tpartnb\tname", 1, "expected a CALYPSO characteristic table header"),
    ("END\n", "END\nmore\n", 9, "text after END"),
])
def test_calypso_refusals_name_the_line(tmp_path: Path, old: str, new: str, line: int | None, message: str) -> None:
    with pytest.raises(FileFormatError, match=re.escape(message)) as caught:
        read_calypso_table(_edited(tmp_path, old, new), units="mm")
    assert caught.value.line == line


def test_calypso_angles_unknown_symbols_and_encodings(tmp_path: Path) -> None:
    header = "planid\tid\ttype\tidsymbol\tactual\tnominal\tuppertol\tlowertol\tdeviation\texceed\tfeatureid\n"
    rows = ("P\tHöhe\tHöhe\tmyHeight\t5.0000000\t5.0000000\t0.1000000\t-0.1000000\t0.0000000\t\t\n"
            "P\tTaper angle\tWinkel\tangle\t30.0100000\t30.0000000\t0.0500000\t-0.0500000\t0.0100000\t\tCone_1\n"
            "END\n")
    path = tmp_path / "angle_chr.txt"
    path.write_bytes((header + rows).encode("cp1252"))
    with pytest.raises(FileFormatError, match="not UTF-8 text") as caught:
        read_calypso_table(path, units="mm")
    assert caught.value.line == 2
    with pytest.raises(FileFormatError, match="pass angle_unit"):
        read_calypso_table(path, units="inch", encoding="cp1252")
    table = read_calypso_table(path, units="inch", angle_unit="degree", encoding="cp1252")
    height, angle = table.characteristics
    assert (angle.type, angle.quantity) == ("angle", "angular")
    assert angle.value == pytest.approx(np.radians(30.01), rel=1e-15)
    assert (height.name, height.type, height.quantity, height.value) == ("Höhe", "my_height", "other", 5.0)


# ---------------------------------------------------------------------------------------------
# PC-DMIS XYZIJK


def test_xyzijk_keeps_the_normals() -> None:
    ring = read_pcdmis_xyzijk(DATA / "ring_xyzijk_metric.xyz")
    assert ring.points.shape == (5, 3) and ring.normals.shape == (5, 3) and ring.compensated is None
    radial = ring.points[:, :2] / np.linalg.norm(ring.points[:, :2], axis=1)[:, None]  # a ring about the z axis
    np.testing.assert_allclose(ring.normals[:, :2], radial, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(ring.points[:, :2], axis=1), 10.0, rtol=1e-15)
    assert is_pcdmis_xyzijk(DATA / "ring_xyzijk_metric.xyz") and not is_pcdmis_xyzijk(FLANGE)


def test_xyzijk_without_metric_is_inches() -> None:
    points = read_pcdmis_xyzijk(DATA / "points_inch.xyz")
    np.testing.assert_allclose(points.points, 25.4 * np.array([[1.0, 0.5, 0.25], [1.5, 0.5, 0.25]]), rtol=1e-15)
    assert points.normals is None


@pytest.mark.parametrize(("text", "line", "message"), [
    ("XYZ\n1,2,3\n", 1, "expected 'XYZIJK' in columns 1-6"),
    ("XYZIJK METRIC\n1,2,3\n", 1, "expected 'METRIC' in columns 11-16"),
    ("XYZIJK    METRIC\n1,2,3,5\n", 2, "a circle (with a diameter), not a point"),
    ("XYZIJK    METRIC\n1,2,3,0,0,1,5\n", 2, "a circle (with a diameter), not a point"),
    ("XYZIJK    METRIC\n1,2,3,0,0,1\n1,2,3\n", 3, "a point without a vector after points with one (line 2)"),
    ("XYZIJK    METRIC\n1,2,3,0,0,2\n", 2, "has length 2, expected a unit vector"),
    ("XYZIJK    METRIC\n1,2,x\n", 2, "expected a number, got 'x'"),
    ("XYZIJK    METRIC\n1,2,nan\n", 2, "expected a finite number"),
    ("XYZIJK    METRIC\n1,2\n", 2, "expected 3, 5, 6 or 8 comma-separated numbers, got 2"),
    ("XYZIJK    METRIC\n\n", None, "holds no points"),
    ("", 1, "an empty file"),
])
def test_xyzijk_refusals_name_the_line(tmp_path: Path, text: str, line: int | None, message: str) -> None:
    path = tmp_path / "bad.xyz"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(FileFormatError, match=re.escape(message)) as caught:
        read_pcdmis_xyzijk(path)
    assert caught.value.line == line and caught.value.path == str(path)


def test_binary_and_missing_files(tmp_path: Path) -> None:
    binary = tmp_path / "cloud.xyz"
    binary.write_bytes(b"XYZIJK    METRIC\n1,2,3\n\x00\x01\x02")
    with pytest.raises(FileFormatError, match="binary data") as caught:
        read_pcdmis_xyzijk(binary)
    assert caught.value.line == 3
    with pytest.raises(FileNotFoundError):
        read_pcdmis_xyzijk(tmp_path / "missing.xyz")
    with pytest.raises(FileFormatError, match="is a directory"):
        read_calypso_table(tmp_path, units="mm")
