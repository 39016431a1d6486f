"""DMIS output reader: GEOPAK-style direction angles, units never assumed, F/FA/T/TA/OUTPUT, refusals."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.errors import FileFormatError, InvalidInputError
from pcmm_geo.io.cmm import read_dmis

DATA = Path(__file__).resolve().parents[2] / "data" / "cmm"
GEOPAK = DATA / "geopak_style.dmo"
STANDARD = DATA / "standard.dmo"


def _direction_from_angles(*degrees: float) -> np.ndarray:
    return np.cos(np.radians(degrees))


def test_geopak_style_report_needs_its_unit_and_reads_direction_angles() -> None:
    with pytest.raises(FileFormatError, match="no UNITS before its first length; pass units=") as caught:
        read_dmis(GEOPAK)
    assert caught.value.line == 5 and str(caught.value).startswith(f"{GEOPAK}:5:")
    with pytest.raises(FileFormatError, match="no angle unit"):  # direction angles need their unit too
        read_dmis(GEOPAK, units="inch")
    document = read_dmis(GEOPAK, units="inch", angle_unit="degree")
    assert document.format == "dmis" and document.units.mm_per_linear_unit == 25.4 and not document.units.stated
    plane = document.feature("Datum_Plane")
    np.testing.assert_allclose(plane.actual.location, 25.4 * np.array([0.0000125, 0.25, -1.5]), rtol=1e-15)
    np.testing.assert_allclose(plane.actual.normal, _direction_from_angles(0.005729577951, 90.0, 89.994270422049),
                               rtol=1e-15)
    assert plane.actual.normal[2] == pytest.approx(1e-4, rel=1e-9)  # 0.0057296 degrees = 1e-4 rad
    bore = document.feature("Bore_1")
    assert (bore.type, bore.internal_external, bore.material_side) == ("circle", "INTERNAL", "internal")
    assert bore.actual.diameter == pytest.approx(0.375012 * 25.4, rel=1e-15)
    np.testing.assert_allclose(bore.actual.normal, [0.0, 0.0, 1.0], atol=1e-15)
    pin = document.feature("Pin_1")
    assert (pin.type, pin.internal_external) == ("cylinder", "EXTERNAL")
    np.testing.assert_allclose(pin.actual.direction, [0.5, 0.0, math.sqrt(3) / 2], atol=1e-15)
    assert (pin.actual.diameter, pin.actual.length) == pytest.approx((0.24998 * 25.4, 1.125 * 25.4), rel=1e-15)
    point = document.feature("Probe_Point")  # GEOPAK writes "0, 0, 0": no direction
    assert point.actual.normal is None and point.actual.location.tolist() == pytest.approx([50.8, 25.4, -19.05])


def test_standard_output_links_nominals_tolerances_and_features() -> None:
    document = read_dmis(STANDARD)
    assert (document.units.linear_unit, document.units.angular_unit, document.units.stated) == ("mm", "degree", True)
    hole = document.feature("HOLE_A")
    assert hole.actual.location.tolist() == [20.0031, 29.9987, 0.0002] and hole.actual.diameter == 12.0082
    nominal = document.nominal_of(hole)
    assert nominal.geometry.location.tolist() == [20.0, 30.0, 0.0]
    definition = document.definition_of(hole)
    assert (definition.diameter, definition.internal_external) == (12.0, "INTERNAL")
    boss = document.feature("BOSS")  # POL in the XY plane: r = 50, a = 30 degrees, h = 5
    np.testing.assert_allclose(boss.actual.location, [50 * math.cos(math.pi / 6), 25.0, 5.0], rtol=1e-15)
    assert (boss.actual.diameter, boss.actual.length) == (8.004, 15.0)
    edge = document.feature("EDGE")  # bounded: start, end, plane normal
    assert edge.actual.direction.tolist() == pytest.approx([0.6, 0.8, 0.0]) and edge.actual.length == 50.0
    tip = document.feature("TIP")
    assert tip.actual.half_angle == pytest.approx(math.radians(30.0), rel=1e-15)
    assert document.feature("S1").actual.normal.tolist() == [0.0, 0.0, 1.0]  # "$$ a surface point" was a comment
    by_name = {c.name: c for c in document.characteristics}
    roundness, position, flatness = by_name["RND_A"], by_name["POS_A"], by_name["FLAT_TOP"]
    assert (roundness.type, roundness.value, roundness.tolerance.value, roundness.status) == (
        "circularity", 0.0031, 0.005, "PASS")
    assert (position.value, position.tolerance.value) == (0.0068, 0.05)
    assert (flatness.value, flatness.status, flatness.feature_measurement_ids) == (0.0234, "FAIL",
                                                                                  (document.feature("TOP").id,))
    diameter = by_name["DIA_A"]  # the number of a size result is not interpreted unless asked
    assert diameter.value is None and diameter.deviation is None and diameter.status == "PASS"
    assert diameter.feature_measurement_ids == (hole.id,)
    assert diameter.tolerance.limits(12.0) == pytest.approx((11.99, 12.015))
    assert len(document.problems) == 1 and "size_values" in document.problems[0]


def test_size_results_read_as_deviations_agree_with_the_feature() -> None:
    diameter = next(c for c in read_dmis(STANDARD, size_values="deviation").characteristics if c.name == "DIA_A")
    assert (diameter.nominal, diameter.deviation) == (12.0, 0.0082)
    assert diameter.value == pytest.approx(12.0082, abs=1e-12)  # = the FA(HOLE_A) diameter
    as_actual = next(c for c in read_dmis(STANDARD, size_values="actual").characteristics if c.name == "DIA_A")
    assert (as_actual.value, as_actual.deviation) == (0.0082, None)


def _write(tmp_path: Path, text: str, name: str = "bad.dmo") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize(("text", "line", "message"), [
    ("UNITS/MM,ANGDEC\nFA(P)=FEAT/POINT,CART,1.2.3,0,0,0,0,1\n", 2, "expected a number, got '1.2.3'"),
    ("UNITS/MM,ANGDEC\nFA(P)=FEAT/POINT,CART,1,2,3\n", 2, "expected 6 numbers after CART, got 3"),
    ("UNITS/MM,ANGDEC\nFA(P)=FEAT/PLANE,CART,0,0,0,0.5,0.5,0.5\n", 2, "expected direction cosines"),
    ("UNITS/MM,ANGDEC\nFA(C)=FEAT/CIRCLE,INNER,CART,0,0,0,0,0,0,5\n", 2, "a circle needs a direction"),
    ("UNITS/MM,ANGDEC\n1.0, 2.0, 3.0\n", 2, "not a DMIS statement"),
    ("UNITS/MM,ANGDEC\nFA(P)=FEAT/POINT,CART,$\n", 2, "ends with $ but nothing continues it"),
    ("UNITS/MM,ANGDEC\nTA(F)=TOL/FLAT,0.01\n", 2, "expected INTOL or OUTOL"),
    ("UNITS/MM\nFA(P)=FEAT/POINT,CART,0,0,0,0,0,1\nFA(P)=FEAT/POINT,CART,0,0,0,0,0,1\n", 3, "defined twice"),
    ("UNITS/FURLONG\n", 1, "expected MM, CM, METER, INCH or FEET"),
    ("UNITS/MM,ANGDMS\n", 1, "angle unit ANGDMS not read"),
    ("UNITS/MM\nFA(P)=TOL/FLAT,0.1,INTOL\n", 2, "expected =FEAT/..., got =TOL/"),
    ("UNITS/MM\nFA(L)=FEAT/LINE,CART,0,0,0,1,0,0\n", 2, "expected BND or UNBND"),
])
def test_what_cannot_be_read_names_the_line(tmp_path: Path, text: str, line: int, message: str) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(FileFormatError, match=re.escape(message)) as caught:
        read_dmis(path)
    assert caught.value.line == line and caught.value.path == str(path)


def test_units_given_and_stated_must_agree_and_other_types_are_recorded(tmp_path: Path) -> None:
    path = _write(tmp_path, "UNITS/INCH,ANGDEC\nFA(P)=FEAT/POINT,CART,1,0,0,0,0,1\n"
                  "FA(E)=FEAT/ELLIPS,INNER,CART,0,0,0,0,0,1,4,2\nTA(X)=TOL/PARLEL,0.01,INTOL\n")
    with pytest.raises(FileFormatError, match="disagrees with units='mm'"):
        read_dmis(path, units="mm")
    document = read_dmis(path)
    assert document.feature("P").actual.location.tolist() == [25.4, 0.0, 0.0]
    ellipse = document.feature("E")
    assert ellipse.type == "ellips" and ellipse.actual.location is None
    assert any("FEAT/ELLIPS: feature type not read" in p for p in document.problems)
    assert document.characteristics[0].type == "parallelism" and document.characteristics[0].value == pytest.approx(
        0.254)
    with pytest.raises(InvalidInputError, match="size_values"):
        read_dmis(path, size_values="nominal")


def test_workplanes_and_encodings(tmp_path: Path) -> None:
    path = _write(tmp_path, "UNITS/MM,ANGDEC\nWKPLAN/YZPLAN\nFA(P)=FEAT/POINT,POL,2,90,7,1,0,0\n"
                  "WKPLAN/ZXPLAN\nFA(Q)=FEAT/POINT,POL,2,90,7,0,1,0\n")
    document = read_dmis(path)
    np.testing.assert_allclose(document.feature("P").actual.location, [7.0, 0.0, 2.0], atol=1e-15)  # y=r cos, z=r sin
    np.testing.assert_allclose(document.feature("Q").actual.location, [2.0, 7.0, 0.0], atol=1e-15)  # z=r cos, x=r sin
    latin = tmp_path / "latin.dmo"
    latin.write_bytes("$$ Prüfbericht\nUNITS/MM,ANGDEC\nFA(P)=FEAT/POINT,CART,1,2,3,0,0,1\n".encode("cp1252"))
    with pytest.raises(FileFormatError, match="not UTF-8 text: byte 0xfc") as caught:
        read_dmis(latin)
    assert caught.value.line == 1
    assert read_dmis(latin, encoding="cp1252").feature("P").actual.location.tolist() == [1.0, 2.0, 3.0]
