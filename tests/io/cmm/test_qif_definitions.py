"""QIF characteristic definitions, nominals, items, datums and datum reference frames, counted against the XML.

The public qif-community samples shipped in tests/data/qif/samples (Boost licence) are read
here, with an extract of the NIST CTC 01 model (its PMI sections, NIST_EXTRACT.md); the whole
NIST CTC / FTC product models (0.7 to 3 MB each, not shipped) are read from a local
checkout of github.com/QualityInformationFramework/qif-community named by the environment
variable PCMM_QIF_COMMUNITY, and skipped without one.  Counts are checked against an
independent count of the elements in the XML text (regular expressions, not the parser).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.errors import QifError, UnsafeXmlError
from pcmm_geo.io.cmm.qif.characteristic_definitions import read_qif_definitions

SAMPLES = Path(__file__).resolve().parents[2] / "data" / "qif" / "samples"
COMMUNITY = os.environ.get("PCMM_QIF_COMMUNITY")
NIST_MODELS = ("nist_ctc_01_asme1_ap242.qif", "nist_ctc_03_asme1_ap242.qif", "nist_ctc_05_asme1_ap242.qif",
               "nist_ftc_06_asme1_ap242.qif", "nist_ftc_08_asme1_ap242-1.qif", "nist_ftc_09_asme1_ap242.qif")


def _xml_counts(text: str) -> dict[str, int]:
    """Counts of the elements by regular expressions over the text (independent of the parser)."""
    frames = re.search(r"<DatumReferenceFrames\b.*?</DatumReferenceFrames>", text, re.DOTALL)
    return {"characteristic_definitions": len(re.findall(r"<\w+CharacteristicDefinition[ >]", text)),
            "characteristic_nominals": len(re.findall(r"<\w+CharacteristicNominal[ >]", text)),
            "characteristic_items": len(re.findall(r"<\w+CharacteristicItem[ >]", text)),
            "datum_definitions": len(re.findall(r"<DatumDefinition[ >]", text)),
            "datum_reference_frames": len(re.findall(r"<DatumReferenceFrame[ >/]", text)),
            # datums of the frames (a compound datum's parts are SimpleDatums inside CompoundDatum)
            "datums": 0 if frames is None else
            len(re.findall(r"<Datum>", frames.group(0))) - _compound_parts(frames.group(0)),
            "datum_references": 0 if frames is None else len(re.findall(r"<DatumDefinitionId>", frames.group(0)))}


def _compound_parts(frames: str) -> int:
    return sum(len(re.findall(r"<Datum>", block)) for block in
               re.findall(r"<CompoundDatum[ >].*?</CompoundDatum>", frames, re.DOTALL))


def _counts(path: Path) -> tuple[dict[str, int], dict[str, int]]:
    definitions = read_qif_definitions(path)
    read = definitions.counts()
    frames = definitions.datum_reference_frames.values()
    read["datums"] = sum(len(frame.datums) for frame in frames)
    read["datum_references"] = sum(len(d.datum_definition_ids) for frame in frames for d in frame.datums)
    return read, _xml_counts(path.read_text(encoding="utf-8", errors="replace"))


@pytest.mark.parametrize(("name", "definitions", "frames"), [
    ("WIDGET_QIF_RESULTS.QIF", 26, 7),
    ("QIF_PTS_SAMPLE.QIF", 23, 3),
    ("QIF_Results_Sample.QIF", 11, 3),
    ("SheetMetal_QIF_Results_6_samples.QIF", 21, 2),
    ("testPython30.qif", 6, 3),
])
def test_every_definition_and_frame_of_the_shipped_samples_is_read(name: str, definitions: int, frames: int) -> None:
    read, xml = _counts(SAMPLES / name)
    assert read == xml
    assert (read["characteristic_definitions"], read["datum_reference_frames"]) == (definitions, frames)


def test_the_shipped_extract_of_nist_ctc_01_reads_every_definition() -> None:
    read, xml = _counts(SAMPLES / "nist_ctc_01_asme1_ap242_pmi.qif")  # see NIST_EXTRACT.md
    assert read == xml
    assert (read["characteristic_definitions"], read["characteristic_nominals"], read["datum_definitions"],
            read["datum_reference_frames"], read["datums"]) == (14, 14, 3, 2, 4)
    definitions = read_qif_definitions(SAMPLES / "nist_ctc_01_asme1_ap242_pmi.qif")
    assert sorted(d.label for d in definitions.datum_definitions.values()) == ["A", "B", "C"]
    assert all(len(d.feature_nominal_ids) == 1 for d in definitions.datum_definitions.values())
    kinds = sorted(d.type for d in definitions.characteristic_definitions.values())
    assert kinds.count("diameter") == 7 and kinds.count("position") == 2 and kinds.count("surface_profile") == 2


@pytest.mark.skipif(COMMUNITY is None, reason="set PCMM_QIF_COMMUNITY to a checkout of qif-community")
@pytest.mark.parametrize("name", NIST_MODELS)
def test_nist_models_nothing_dropped(name: str) -> None:
    path = Path(COMMUNITY or ".") / "samples" / "NISTmodels" / name
    if not path.is_file():
        pytest.skip(f"{path} is not there")
    read, xml = _counts(path)
    assert read == xml and read["characteristic_definitions"] > 10 and read["datum_reference_frames"] >= 2
    assert read_qif_definitions(path).problems == ()


def test_widget_frames_datums_and_modifiers() -> None:
    definitions = read_qif_definitions(SAMPLES / "WIDGET_QIF_RESULTS.QIF")
    labels = {key: datum.label for key, datum in definitions.datum_definitions.items()}
    assert labels == {19: "B", 53: "A", 54: "C", 72: "J", 163: "H"}
    frame = definitions.datum_reference_frames[52]
    assert [labels[d.datum_definition_ids[0]] for d in frame.datums] == ["B", "A", "C"]
    assert [d.precedence for d in frame.datums] == ["PRIMARY", "SECONDARY", "TERTIARY"]
    assert definitions.datum_reference_frames[71].datums[0].material_modifiers == ("MAXIMUM",)
    position = definitions.characteristic_definitions[51]
    assert (position.type, position.material_condition, position.zone_shape) == ("position", "MAXIMUM", "diametrical")
    assert position.tolerance.value == 0.5 and position.datum_reference_frame_ids == (52,)
    diameter = definitions.characteristic_definitions[66]
    assert (diameter.tolerance.max_value, diameter.tolerance.min_value) == (0.15, -0.15)
    assert definitions.characteristic_nominals[67].target_value == pytest.approx(25.4, abs=1e-12)
    item = definitions.characteristic_items[56]
    assert (item.name, item.nominal_id, item.feature_item_ids) == ("11", 55, (45,))


def test_distance_analysis_vector_and_linear_coordinate_direction() -> None:
    definitions = read_qif_definitions(SAMPLES / "QIF_PTS_SAMPLE.QIF")
    distance = definitions.characteristic_nominals[854]
    assert distance.analysis_mode == "ONEDIMENSIONAL" and distance.target_value == 78.0
    np.testing.assert_array_equal(distance.analysis_vector, [0.0, 1.0, 0.0])
    directions = {n.direction for n in definitions.characteristic_nominals.values() if n.type == "linear_coordinate"}
    assert directions == {"XAXIS", "YAXIS", "ZAXIS"}


_FRAME = """<QIFDocument xmlns="http://qifstandards.org/xsd/qif3" versionQIF="3.0.0">
  <DatumDefinitions n="2"><DatumDefinition id="1"><DatumLabel>A</DatumLabel></DatumDefinition>
    <DatumDefinition id="2"><DatumLabel>B</DatumLabel></DatumDefinition></DatumDefinitions>
  <DatumReferenceFrames n="1"><DatumReferenceFrame id="3"><Datums n="2">
    <Datum><SimpleDatum><DatumDefinitionId>1</DatumDefinitionId><MaterialModifier>NONE</MaterialModifier>
      <ReferencedComponent>ACTUAL</ReferencedComponent></SimpleDatum>
      <Precedence><PrecedenceEnum>PRIMARY</PrecedenceEnum></Precedence></Datum>
    <Datum><SimpleDatum><DatumDefinitionId>2</DatumDefinitionId><MaterialModifier>LEAST</MaterialModifier>
      <ReferencedComponent>ACTUAL</ReferencedComponent></SimpleDatum>
      <Precedence><PrecedenceEnum>SECONDARY</PrecedenceEnum></Precedence></Datum>
  </Datums></DatumReferenceFrame></DatumReferenceFrames>
</QIFDocument>"""


def test_a_small_frame_and_its_bad_variants(tmp_path: Path) -> None:
    path = tmp_path / "frame.qif"
    path.write_text(_FRAME)
    frame = read_qif_definitions(path).datum_reference_frames[3]
    assert [(d.precedence, d.datum_definition_ids, d.material_modifiers) for d in frame.datums] == [
        ("PRIMARY", (1,), ("NONE",)), ("SECONDARY", (2,), ("LEAST",))]
    for old, new, words in (
            ("<DatumDefinitionId>2<", "<DatumDefinitionId>9<", "dangling id"),
            ("SECONDARY", "PRIMARY", "two datums of the same precedence"),
            ("<Precedence><PrecedenceEnum>SECONDARY</PrecedenceEnum></Precedence>", "", "expected a Precedence"),
            ("<DatumLabel>B</DatumLabel>", "", "expected a DatumLabel")):
        path.write_text(_FRAME.replace(old, new))
        with pytest.raises(QifError, match=words) as caught:
            read_qif_definitions(path)
        assert caught.value.line is not None and str(path) in str(caught.value)


@pytest.mark.parametrize("name", ["billion_laughs.qif", "external_entity_file.qif", "deeply_nested.qif"])
def test_hostile_files_are_refused_before_anything_is_read(name: str) -> None:
    from pcmm_geo.errors import UnsafeXmlError

    with pytest.raises(UnsafeXmlError):
        read_qif_definitions(SAMPLES.parent / "hostile" / name)


def test_the_command_names_a_bad_frame_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from pcmm_geo.cli import main

    text = (SAMPLES / "WIDGET_QIF_RESULTS.QIF").read_text()
    path = tmp_path / "two_primaries.qif"
    second, first = "<PrecedenceEnum>SECONDARY</PrecedenceEnum>", "<PrecedenceEnum>PRIMARY</PrecedenceEnum>"
    path.write_text(text.replace(second, first, 1))
    assert main(["qif", "verify", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "two datums of the same precedence" in err and "id=52" in err


def test_a_duplicated_element_or_too_many_elements_are_typed_refusals(tmp_path: Path) -> None:
    """The definitions reader shares read_qif's parse: a second MaxValue is a QifError naming its line (not a
    bare ValueError), and the element-count bound applies to it too."""
    text = (SAMPLES / "QIF_Results_Sample.QIF").read_text(encoding="utf-8")
    first = text.index("<MaxValue>0.4</MaxValue>")
    path = tmp_path / "two_max.qif"
    path.write_text(text.replace("<MaxValue>0.4</MaxValue>", "<MaxValue>0.4</MaxValue><MaxValue>0.5</MaxValue>", 1),
                    encoding="utf-8")
    with pytest.raises(QifError, match="a second MaxValue element") as refused:
        read_qif_definitions(path)
    assert refused.value.line == text[:first].count("\n") + 1
    assert len(read_qif_definitions(SAMPLES / "QIF_Results_Sample.QIF").characteristic_definitions) > 0
    with pytest.raises(UnsafeXmlError, match="more than 50 elements"):
        read_qif_definitions(SAMPLES / "QIF_Results_Sample.QIF", max_elements=50)
