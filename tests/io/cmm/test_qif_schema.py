"""The QIF 3.0 schema shipped with pcmm_geo, and what ``validate_qif`` refuses before libxml2 parses."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from pcmm_geo.errors import FileFormatError, InvalidInputError, UnsafeXmlError
from pcmm_geo.io.cmm import validate_qif
from pcmm_geo.io.cmm.qif.schema import bundled_schema_dir

ROOT = Path(__file__).resolve().parents[3]
DATA = ROOT / "tests" / "data" / "qif"
SAMPLE = DATA / "samples" / "QIF_PTS_SAMPLE.QIF"
#: the files QIFDocument.xsd includes, directly or through the files it includes
SCHEMA_FILES = {"Auxiliary", "Characteristics", "Expressions", "Features", "Geometry", "IntermediatesPMI",
                "Primitives", "PrimitivesPD", "PrimitivesPMI", "QIFDocument", "QIFMeasurementResources", "QIFPlan",
                "QIFProduct", "QIFResults", "QIFRules", "QIFStatistics", "Statistics", "Topology", "Traceability",
                "Units", "Visualization"}


def test_the_schema_ships_with_its_licence_as_package_data() -> None:
    """Also in the core-only run, against the installed package (``./dev core-test``)."""
    folder = bundled_schema_dir()
    assert folder.name == "qif-3.0-xsd" and folder.parent.name == "data"
    assert {p.stem for p in folder.glob("*.xsd")} == SCHEMA_FILES
    assert "Boost Software License - Version 1.0" in (folder / "LICENSE.md").read_text(encoding="utf-8")
    assert "LICENSE.md" in (folder / "README.md").read_text(encoding="utf-8")


def test_the_schema_files_match_the_package_data_patterns() -> None:
    """Every schema file matches a package-data pattern of pyproject.toml (setuptools globs them the same way)."""
    folder = ROOT / "pcmm_geo" / "data" / "qif-3.0-xsd"
    patterns = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"][
        "package-data"]["pcmm_geo"]
    packaged = {path for pattern in patterns for path in (ROOT / "pcmm_geo").glob(pattern)}
    assert len(list(folder.iterdir())) == len(SCHEMA_FILES) + 2
    assert set(folder.iterdir()) <= packaged


def test_validates_without_a_schema_dir() -> None:
    assert validate_qif(SAMPLE) == ()
    assert validate_qif(SAMPLE, bundled_schema_dir()) == ()


def test_a_folder_without_the_schema_is_refused(tmp_path: Path) -> None:
    with pytest.raises(InvalidInputError, match=r"QIFDocument\.xsd"):
        validate_qif(SAMPLE, tmp_path)


@pytest.mark.parametrize("prolog", [
    "",
    '<?xml version="1.0" encoding="UTF-8"?>\n',
    "\ufeff<?xml version='1.0'?>\n<!-- a comment <QIFDocument> -->\n<?pi data?>\n",
])
def test_a_doctype_is_refused_before_parsing_with_its_line(tmp_path: Path, prolog: str) -> None:
    """An entity bomb's DTD is refused as hostile (libxml2 would report only an amplification limit)."""
    path = tmp_path / "bomb.qif"
    lol = "".join(f'<!ENTITY l{k + 1} "' + f"&l{k};" * 10 + '">' for k in range(9))
    path.write_text(prolog + f'<!DOCTYPE QIFDocument [<!ENTITY l0 "lol">{lol}]>\n'
                    '<QIFDocument xmlns="http://qifstandards.org/xsd/qif3">&l9;</QIFDocument>', encoding="utf-8")
    with pytest.raises(UnsafeXmlError, match="document type declaration") as caught:
        validate_qif(path)
    assert caught.value.line == prolog.count("\n") + 1


def test_deep_nesting_is_refused_as_hostile(tmp_path: Path) -> None:
    path = tmp_path / "deep.qif"
    path.write_text('<QIFDocument xmlns="http://qifstandards.org/xsd/qif3">' + "<a>" * 5000 + "</a>" * 5000
                    + "</QIFDocument>", encoding="utf-8")
    with pytest.raises(UnsafeXmlError, match="nested deeper than 2048") as caught:
        validate_qif(path)
    assert caught.value.limit == 2048
    shallow = tmp_path / "shallow.qif"
    shallow.write_text('<QIFDocument xmlns="http://qifstandards.org/xsd/qif3">' + "<a>" * 100 + "</a>" * 100
                       + "</QIFDocument>", encoding="utf-8")
    errors = validate_qif(shallow)  # parsed: wrong content, a schema error, not a refusal
    assert len(errors) >= 1 and errors[0].startswith("line 1: ")


def test_not_well_formed_is_a_file_format_error_with_the_line(tmp_path: Path) -> None:
    path = tmp_path / "cut.qif"
    lines = SAMPLE.read_text(encoding="utf-8").splitlines()[:40]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(FileFormatError, match="not well-formed XML") as caught:
        validate_qif(path)
    assert not isinstance(caught.value, UnsafeXmlError) and caught.value.line == 41
