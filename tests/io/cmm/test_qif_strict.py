"""QIF reader strictness (issue 31): xs:double numbers only, no duplicated single elements, no overflow to inf."""

from __future__ import annotations

import os
import tracemalloc
from pathlib import Path

import pytest

from pcmm_geo.errors import InvalidInputError, QifError
from pcmm_geo.io.cmm import read_qif

SAMPLES = Path(__file__).resolve().parents[2] / "data" / "qif" / "samples"
PTS_SAMPLE = SAMPLES / "QIF_PTS_SAMPLE.QIF"
INCH_UNIT = ("<UnitName>mm</UnitName>\n        <UnitConversion>\n          <Factor>0.001</Factor>",
             "<UnitName>inch</UnitName>\n        <UnitConversion>\n          <Factor>0.0254</Factor>")


def _edited(tmp_path: Path, *edits: tuple[str, str]) -> Path:
    text = PTS_SAMPLE.read_text(encoding="utf-8")
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new, 1)
    path = tmp_path / "edited.qif"
    path.write_text(text, encoding="utf-8")
    return path


# float() reads every one of these as 33.2 (or 3.545...): numbers nobody wrote in a QIF file
NOT_XS_DOUBLE = ["3_3.2", "\u0663\u0663.\u0662", "\uff13\uff13.2", "33,2", "0x21"]


@pytest.mark.parametrize("bad", NOT_XS_DOUBLE)
def test_a_size_that_is_not_an_xs_double_is_refused(tmp_path: Path, bad: str) -> None:
    path = _edited(tmp_path, ("<Diameter>12.091599179226</Diameter>", f"<Diameter>{bad}</Diameter>"))
    with pytest.raises(QifError, match="expected a number") as caught:
        read_qif(path)
    assert caught.value.element.endswith("CircleFeatureMeasurement/Diameter") and caught.value.line == 999


@pytest.mark.parametrize("bad", NOT_XS_DOUBLE)
def test_a_streamed_coordinate_that_is_not_an_xs_double_is_refused(tmp_path: Path, bad: str) -> None:
    path = _edited(tmp_path, ("3.54516458565 0.0037440421", f"{bad} 0.0037440421"))
    with pytest.raises(QifError, match="expected a number") as caught:
        read_qif(path)
    assert caught.value.element.endswith("MeasuredPointSet/Points") and caught.value.line == 1095


@pytest.mark.parametrize("bad", ["0.0008_0940233", "\uff10 0 -1"])
def test_a_location_or_normal_that_is_not_xs_double_is_refused(tmp_path: Path, bad: str) -> None:
    old = "<Location>0.00080940233 0.00031692348" if "_" in bad else "<Normal>0 0 -1"
    new = f"<Location>{bad} 0.00031692348" if "_" in bad else f"<Normal>{bad}"
    with pytest.raises(QifError, match="expected a number"):
        read_qif(_edited(tmp_path, (old, new)))


def test_an_integer_with_an_underscore_or_foreign_digits_is_refused(tmp_path: Path) -> None:
    with pytest.raises(QifError, match="count: expected an integer"):
        read_qif(_edited(tmp_path, ('<MeasuredPointSet id="29" count="219">',
                                    '<MeasuredPointSet id="29" count="2_19">')))
    with pytest.raises(QifError, match="expected an integer"):
        read_qif(_edited(tmp_path, ("<WholePointSetId>29</WholePointSetId>",
                                    "<WholePointSetId>\u0662\u0669</WholePointSetId>")))


def test_valid_xs_double_forms_are_read(tmp_path: Path) -> None:
    """Exponents, a leading point and a trailing point are xs:double: read, not refused."""
    path = _edited(tmp_path, ("<Diameter>12.091599179226</Diameter>", "<Diameter>1.2091599179226E1</Diameter>"),
                   ("3.54516458565 0.0037440421", "+3.54516458565 .0037440421"))
    document = read_qif(path)
    assert document.feature("DATUMB").actual.diameter == pytest.approx(12.091599179226, rel=1e-15)
    assert document.points_of(document.feature("DATUMB")).points[0, :2].tolist() == [3.54516458565, 0.0037440421]


@pytest.mark.parametrize(("old", "new", "element"), [
    ("<Diameter>12.091599179226</Diameter>", "<Diameter>12.091599179226</Diameter><Diameter>13</Diameter>",
     "Diameter"),
    ("<Compensated>false</Compensated>", "<Compensated>false</Compensated><Compensated>true</Compensated>",
     "Compensated"),
    ("<ProbeRadius>2.49978271104</ProbeRadius>",
     "<ProbeRadius>2.49978271104</ProbeRadius><ProbeRadius>1</ProbeRadius>", "ProbeRadius"),
    ("<Normal>0 0 -1</Normal>", "<Normal>0 0 -1</Normal><Normal>0 0 1</Normal>", "Normal"),
])
def test_a_duplicated_single_element_is_refused_naming_it(tmp_path: Path, old: str, new: str, element: str) -> None:
    with pytest.raises(QifError, match=f"a second {element}") as caught:
        read_qif(_edited(tmp_path, (old, new)))
    assert caught.value.element.endswith("/" + element)


def test_duplicated_points_are_refused(tmp_path: Path) -> None:
    path = _edited(tmp_path, ('<MeasuredPointSet id="29" count="219">\n            <Points>',
                              '<MeasuredPointSet id="29" count="219">\n            <Points>' + "0 0 0 " * 219 +
                              "</Points><Points>"))
    with pytest.raises(QifError, match="a second Points element") as caught:
        read_qif(path)
    assert caught.value.element.endswith("MeasuredPointSet/Points")


def test_a_size_that_overflows_when_converted_to_mm_is_refused(tmp_path: Path) -> None:
    """1e307 inch is 2.54e308 mm: beyond the float range; it would read as inf and 'PASS'."""
    path = _edited(tmp_path, INCH_UNIT, ("<Diameter>12.091599179226</Diameter>", "<Diameter>1e307</Diameter>"))
    with pytest.raises(QifError, match="overflows the float range") as caught:
        read_qif(path)
    assert caught.value.element.endswith("Diameter")
    # 1e306 inch is finite in mm: read (the check is on the converted value, not on the number's size)
    fine = _edited(tmp_path, INCH_UNIT, ("<Diameter>12.091599179226</Diameter>", "<Diameter>1e306</Diameter>"))
    assert read_qif(fine).feature("DATUMB").actual.diameter == pytest.approx(2.54e307, rel=1e-12)


@pytest.mark.parametrize(("old", "new"), [
    ("3.54516458565 0.0037440421", "1e307 0.0037440421"),
    ("<Location>0.00080940233", "<Location>1e307"),
    ("<ProbeRadius>2.49978271104</ProbeRadius>", "<ProbeRadius>1e307</ProbeRadius>"),
])
def test_coordinates_and_radii_that_overflow_in_mm_are_refused(tmp_path: Path, old: str, new: str) -> None:
    with pytest.raises(QifError, match="overflows the float range"):
        read_qif(_edited(tmp_path, INCH_UNIT, (old, new)))


# ---------------------------------------------------------------------------------------------
# a QIF file without FileUnits (9 of 112 public files): said so, and --units applies


EXPLODED = SAMPLES / "Exploded_Results1.QIF"  # a public sample without FileUnits


def test_units_not_stated_are_said_so_and_can_be_given() -> None:
    assumed = read_qif(EXPLODED)
    assert not assumed.units.stated and assumed.units.linear_unit == "mm"
    note = next(p for p in assumed.problems if "units not stated" in p)
    assert "the QIF 3.0 schema states no default" in note and "assumed" in note
    inch = read_qif(EXPLODED, units="inch")
    assert not inch.units.stated and (inch.units.linear_unit, inch.units.mm_per_linear_unit) == ("inch", 25.4)
    assert "as given" in next(p for p in inch.problems if "units not stated" in p)
    for mm, inches in zip(assumed.characteristics, inch.characteristics, strict=True):
        assert inches.value == pytest.approx(25.4 * mm.value, rel=1e-15)


def test_units_given_for_a_file_that_states_them_are_refused() -> None:
    with pytest.raises(QifError, match="the file states its units") as caught:
        read_qif(PTS_SAMPLE, units="mm")
    assert caught.value.element.endswith("FileUnits/PrimaryUnits")
    with pytest.raises(InvalidInputError, match="units"):
        read_qif(EXPLODED, units="furlong")


def test_unknown_encoding_and_non_regular_files_are_typed_errors(tmp_path: Path) -> None:
    from pcmm_geo.errors import FileFormatError
    from pcmm_geo.io.cmm import validate_qif

    path = tmp_path / "encoding.qif"
    path.write_text('<?xml version="1.0" encoding="x-nonexistent"?>\n<QIFDocument/>\n')
    for reader in (read_qif, validate_qif):
        with pytest.raises(FileFormatError, match="names an encoding Python does not know"):
            reader(path)
    fifo = tmp_path / "pipe.qif"
    os.mkfifo(fifo)
    for reader in (read_qif, validate_qif):
        with pytest.raises(FileFormatError, match=r"is a FIFO \(named pipe\)"):
            reader(fifo)


# ---------------------------------------------------------------------------------------------
# memory: bounded by an element count, not only by the file's size


def _many_elements(path: Path, count: int) -> Path:
    """A generated QIF-like file of ``count`` empty elements (4 bytes each in the file, ~250 in a tree)."""
    with path.open("wb") as stream:
        stream.write(b'<QIFDocument xmlns="http://qifstandards.org/xsd/qif3" versionQIF="3.0.0">')
        for _ in range(count // 10_000):
            stream.write(b"<a/>" * 10_000)
        stream.write(b"</QIFDocument>")
    return path


def test_millions_of_empty_elements_are_refused_before_memory_grows(tmp_path: Path) -> None:
    from pcmm_geo.errors import UnsafeXmlError
    from pcmm_geo.io.cmm.qif._xml import parse_xml

    path = _many_elements(tmp_path / "many.qif", 60_000)  # 240 kB of file
    tracemalloc.start()
    try:
        with pytest.raises(UnsafeXmlError, match="more than 2000 elements") as caught:
            read_qif(path, max_elements=2_000)
        _, bounded = tracemalloc.get_traced_memory()
        tracemalloc.reset_peak()
        parse_xml(path, max_elements=1_000_000)  # the control: the same file, its whole tree
        _, whole = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert caught.value.limit == 2_000
    assert whole > 6e6  # some 250 bytes an element
    assert bounded < 3e6 and bounded < whole / 4


def test_a_huge_id_is_not_echoed_whole(tmp_path: Path) -> None:
    huge = "7" * 10_000_000
    path = _edited(tmp_path, ('<MeasuredPointSet id="29" count="219">', f'<MeasuredPointSet id="{huge}" count="2_19">'))
    with pytest.raises(QifError) as caught:
        read_qif(path)
    assert len(str(caught.value)) < 1_000 and "10000000 characters" in str(caught.value)


def test_a_unit_factor_that_overflows_is_refused(tmp_path: Path) -> None:
    old, new = INCH_UNIT
    path = _edited(tmp_path, (old, new.replace("inch", "parsec").replace("0.0254", "1e308")))
    with pytest.raises(QifError, match="expected a positive finite conversion factor, got 1e308"):
        read_qif(path)
