"""``pcmm inspect --qif`` / :func:`inspection_to_qif`: the plan's results as a schema-valid QIF 3.0 results file.

Truth: the inspection's own results (the numbers written must read back), the QIF 3.0 XSD (lxml),
the plan's frames (labels and precedence), and an independent recomputation of every written
characteristic from the written feature actuals and points (``pcmm qif verify``'s second opinion,
:mod:`pcmm_geo.gdt.qif`), which must agree -- and must disagree with a value changed by hand.
"""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import pytest
from pcmm_runner import run_pcmm

from pcmm_geo.errors import InvalidInputError, OutputExistsError
from pcmm_geo.gdt import inspect_plan
from pcmm_geo.gdt.qif.results import inspection_to_qif

EXAMPLE_DIR = Path(__file__).parents[2] / "pcmm_geo" / "data" / "examples" / "gdt"
WRITTEN = ("flatness A", "parallelism TOP", "perpendicularity H1", "position H1", "position H2", "position H3",
           "x H1", "H1 to H2", "H1 to TOP")
SIZES = ("H1 diameter", "H2 diameter", "H3 diameter")


def _width(tolerance) -> float:
    """A zone's value, or the width of a dimension's limits."""
    return tolerance.value if tolerance.value is not None else tolerance.max_value - tolerance.min_value


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    result = inspect_plan(EXAMPLE_DIR / "plan.toml")
    path = tmp_path_factory.mktemp("qif") / "inspect.qif"
    return result, inspection_to_qif(result, path), path


def test_the_example_plans_qif_is_schema_valid_and_says_what_it_left_out(written):
    from pcmm_geo.io.cmm.qif.schema import validate_qif

    _, export, path = written
    assert validate_qif(path) == ()
    assert export.written == WRITTEN
    assert export.not_written == ()
    assert export.features == ("A", "B", "C", "TOP", "H1", "H2", "H3") and export.frames == ("A", "A|B|C")


def test_values_statuses_and_bonuses_read_back(written):
    from pcmm_geo.io.cmm import read_qif

    result, _, path = written
    document = read_qif(path)
    read = {c.name: c for c in document.characteristics}
    expected = {c.name: c for c in result.characteristics if c.name in WRITTEN}
    assert set(expected) <= set(read)
    for name, outcome in expected.items():
        got = read[name]
        assert got.value == pytest.approx(outcome.value_mm, rel=0, abs=1e-12), name
        assert _width(got.tolerance) == pytest.approx(outcome.tolerance_mm, rel=0, abs=1e-12), name
        assert got.status == outcome.verdict, name  # PASS / FAIL written as such
    assert read["position H3"].status == "FAIL" and read["position H1"].zone_shape == "diametrical"
    assert read["perpendicularity H1"].zone_shape == "diametrical" and read["parallelism TOP"].zone_shape == "planar"
    # dimensions: nominal and limits as the plan states them (the angle in degrees there, radians here)
    assert read["x H1"].nominal == 30.0 and read["x H1"].tolerance.limits(30.0) == pytest.approx((29.95, 30.05))
    assert read["H1 to H2"].tolerance.limits(read["H1 to H2"].nominal) == pytest.approx((59.9, 60.1))
    angle = read["H1 to TOP"]
    assert angle.quantity == "angular" and angle.nominal == 0.0
    assert angle.tolerance.limits(0.0) == pytest.approx((0.0, 0.05 * 3.141592653589793 / 180), abs=1e-15)
    # size characteristics of the holes: [10, 10.1] limits, the actual diameter
    diameter = read["H1 diameter"]
    assert diameter.tolerance.limits(diameter.nominal) == pytest.approx((10.0, 10.1), abs=1e-12)
    assert diameter.value == pytest.approx(document.feature("H1").actual.diameter, abs=1e-12)
    # the MMC bonus is written in the Bonus element of each position measurement
    from lxml import etree

    tree = etree.parse(str(path))
    ns = {"q": "http://qifstandards.org/xsd/qif3"}
    for name in ("position H1", "position H2", "position H3"):
        bonus = tree.xpath(f"//q:PositionCharacteristicMeasurement[q:CharacteristicItemId = "
                           f"//q:PositionCharacteristicItem[q:Name='{name}']/@id]/q:Bonus", namespaces=ns)
        assert len(bonus) == 1 and float(bonus[0].text) == pytest.approx(expected[name].bonus_mm, abs=1e-12), name
    assert not tree.xpath("//q:FlatnessCharacteristicMeasurement/q:Bonus", namespaces=ns)


def test_definitions_datum_labels_and_frames_read_back(written):
    from pcmm_geo.io.cmm import read_qif
    from pcmm_geo.io.cmm.qif.characteristic_definitions import read_qif_definitions

    result, _, path = written
    definitions = read_qif_definitions(path)
    document = read_qif(path)
    assert definitions.counts()["datum_definitions"] == 3 and definitions.counts()["datum_reference_frames"] == 2
    item_of_nominal = {item.nominal_id: item.name for item in document.feature_items.values()}
    labels = {d.id: d.label for d in definitions.datum_definitions.values()}
    for datum in definitions.datum_definitions.values():  # each datum names its plan feature's nominal
        assert [item_of_nominal[i] for i in datum.feature_nominal_ids] == [result.plan.datums[datum.label][0]]
    by_name = {c.name: c for c in document.characteristics}
    planned = {c.name: c for c in result.characteristics}
    for name in WRITTEN:
        definition = definitions.definition_of(by_name[name].definition_id)
        assert _width(definition.tolerance) == pytest.approx(planned[name].tolerance_mm, abs=1e-12)
        frames = [definitions.datum_reference_frames[i] for i in definition.datum_reference_frame_ids]
        read_labels = tuple(labels[d.datum_definition_ids[0]] for f in frames for d in f.datums)
        # a QIF dimension names no DRF: it is in the file's coordinates, the part frame A|B|C
        assert read_labels == (() if name in ("x H1", "H1 to H2", "H1 to TOP") else planned[name].datums), name
        if frames:
            assert [d.precedence for d in frames[0].datums] == ["PRIMARY", "SECONDARY", "TERTIARY"][:len(read_labels)]
            assert all(d.material_modifiers == ("NONE",) for d in frames[0].datums)
        expected = "MAXIMUM" if name.startswith("position") else "NONE" if name.split()[0] in (
            "parallelism", "perpendicularity") else None
        assert definition.material_condition == expected, name


def test_the_second_opinion_recomputes_every_written_characteristic_and_agrees(written, tmp_path):
    from pcmm_geo.gdt.qif.characteristics import verify_characteristics
    from pcmm_geo.io.cmm import read_qif

    _, _, path = written
    verification = verify_characteristics(read_qif(path))
    statuses = {c.name: c.status for c in verification.checks}
    assert statuses == dict.fromkeys(WRITTEN + SIZES, "agrees"), \
        [(c.name, c.reported, c.recomputed, c.reason) for c in verification.checks]
    # a wrong answer is caught: position H3 reported 0.05 mm smaller than written (its tolerance is 0.1 mm)
    text = path.read_text()
    measured = verification.checks[[c.name for c in verification.checks].index("position H3")]
    marker = f'<PositionCharacteristicMeasurement id="{measured.id}">'
    head, tail = text.split(marker)
    value_at = tail.index("<Value>") + len("<Value>")
    end = tail.index("</Value>")
    edited = tmp_path / "edited.qif"
    edited.write_text(head + marker + tail[:value_at] + repr(float(tail[value_at:end]) - 0.05) + tail[end:])
    wrong = {c.name: c.status for c in verify_characteristics(read_qif(edited)).checks}
    assert wrong["position H3"] == "disagrees" and wrong["position H2"] == "agrees"


def test_not_proven_is_written_as_indeterminate(written, tmp_path):
    from pcmm_geo.io.cmm import read_qif

    result = written[0]
    changed = tuple(dataclasses.replace(c, verdict="NOT PROVEN") if c.name == "position H2" else c
                    for c in result.characteristics)
    path = inspection_to_qif(dataclasses.replace(result, characteristics=changed), tmp_path / "np.qif").path
    statuses = {c.name: c.status for c in read_qif(path).characteristics}
    assert statuses["position H2"] == "INDETERMINATE" and statuses["position H1"] == "PASS"


def test_an_existing_file_is_refused_and_a_geometric_characteristic_without_definition_too(written, tmp_path):
    from pcmm_geo.io.cmm import read_qif, write_qif
    from pcmm_geo.io.cmm.qif.write.gdt_out import GdtRecords

    result, _, path = written
    before = path.read_bytes()
    with pytest.raises(OutputExistsError):
        inspection_to_qif(result, path)
    assert path.read_bytes() == before
    document = read_qif(path)
    with pytest.raises(InvalidInputError, match="got 'parallelism'"):  # without GdtRecords: refused
        write_qif(document, tmp_path / "plain.qif")
    with pytest.raises(InvalidInputError, match="CharacteristicDefinition"):
        write_qif(document, tmp_path / "empty.qif", gdt=GdtRecords())
    assert not (tmp_path / "plain.qif").exists() and not (tmp_path / "empty.qif").exists()


def test_pcmm_inspect_qif_writes_refuses_an_existing_file_and_overwrites_on_request(tmp_path):
    for f in EXAMPLE_DIR.iterdir():
        if f.suffix in (".toml", ".csv"):
            shutil.copy(f, tmp_path / f.name)
    out = tmp_path / "out.qif"
    out.write_text("an older file")
    done = run_pcmm("inspect", tmp_path / "plan.toml", "--qif", out, "--json", "--overwrite-qif")
    assert done.returncode == 1, done.stderr  # H3 fails
    data = json.loads(done.stdout)
    assert data["qif"]["written"] == list(WRITTEN) and out.read_bytes().startswith(b"<?xml")
    assert data["qif"]["not_written"] == []
    before = out.read_bytes()
    done = run_pcmm("inspect", tmp_path / "plan.toml", "--qif", out)
    assert done.returncode == 2 and "--overwrite-qif" in done.stderr and len(done.stderr.strip().splitlines()) == 1
    assert out.read_bytes() == before and "QIF" not in done.stdout
    done = run_pcmm("qif", "verify", out, "--json")
    summary = json.loads(done.stdout)["characteristics_summary"]
    assert summary.get("agrees") == 12 and not summary.get("disagrees") and not summary.get("not computable"), summary


def test_a_characteristic_with_no_qif_record_is_reported_not_written_by_name(written, tmp_path):
    from pcmm_geo.io.cmm import read_qif

    result = written[0]
    changed = tuple(dataclasses.replace(c, datums=("A",)) if c.name == "x H1" else
                    dataclasses.replace(c, characteristic="circularity") if c.name == "parallelism TOP" else c
                    for c in result.characteristics)
    export = inspection_to_qif(dataclasses.replace(result, characteristics=changed), tmp_path / "some.qif")
    reasons = dict(export.not_written)
    assert set(reasons) == {"x H1", "parallelism TOP"}
    assert "frame A" in reasons["x H1"] and "circularity" in reasons["parallelism TOP"]
    names = {c.name for c in read_qif(export.path).characteristics}
    assert names == set(WRITTEN + SIZES) - set(reasons)


def test_the_guide_pages_excerpt_is_what_is_written(written):
    page = (Path(__file__).parents[2] / "docs" / "guide" / "gdt_with_datums.rst").read_text(encoding="utf-8")
    start = page.index("<PositionCharacteristicDefinition")
    excerpt = page[start:page.index("   ...\n   <PositionCharacteristicMeasurement")]
    text = " ".join(written[2].read_text(encoding="utf-8").split())
    assert " ".join(excerpt.split()) in text
    assert "QIF: 9 characteristic(s), 7 feature(s) and 2 datum reference frame(s) written to results.qif" in page


EXTRA = '''
[[characteristics]]
name = "angularity TOP"
feature = "TOP"
frame = "angularity 0.05 | A"

[[characteristics]]
name = "runout H1"
feature = "H1"
frame = "circular-runout 0.1 | D"

[[characteristics]]
name = "total runout H1"
feature = "H1"
frame = "total-runout 0.1 | D"

[[characteristics]]
name = "coaxiality H2"
feature = "H2"
frame = "◎ ⌀0.2 | D"

[[characteristics]]
name = "position H2 LMC"
feature = "H2"
frame = "position dia 0.2 LMC | A | B | C"
'''


def test_angularity_runout_coaxiality_and_lmc_are_schema_valid_and_read_back(tmp_path):
    from pcmm_geo.gdt.qif.characteristics import verify_characteristics
    from pcmm_geo.io.cmm import read_qif
    from pcmm_geo.io.cmm.qif.characteristic_definitions import read_qif_definitions
    from pcmm_geo.io.cmm.qif.schema import validate_qif

    for f in EXAMPLE_DIR.iterdir():
        if f.suffix in (".toml", ".csv"):
            shutil.copy(f, tmp_path / f.name)
    plan = tmp_path / "plan.toml"
    plan.write_text(plan.read_text(encoding="utf-8").replace('C = "C"\n', 'C = "C"\nD = "H1"\n') + EXTRA,
                    encoding="utf-8")
    result = inspect_plan(plan)
    export = inspection_to_qif(result, tmp_path / "more.qif")
    assert validate_qif(export.path) == () and export.not_written == ()
    assert export.frames == ("A", "D", "A|B|C")
    document, definitions = read_qif(export.path), read_qif_definitions(export.path)
    read = {c.name: c for c in document.characteristics}
    labels = {d.id: d.label for d in definitions.datum_definitions.values()}
    expected = {"angularity TOP": ("angularity", "NONE", "planar", ("A",)),
                "runout H1": ("circular_runout", None, None, ("D",)),
                "total runout H1": ("total_runout", None, None, ("D",)),
                "coaxiality H2": ("coaxiality", None, "diametrical", ("D",)),
                "position H2 LMC": ("position", "LEAST", "diametrical", ("A", "B", "C"))}
    outcomes = {c.name: c for c in result.characteristics}
    for name, (kind, condition, zone, datums) in expected.items():
        definition = definitions.definition_of(read[name].definition_id)
        frame = definitions.datum_reference_frames[definition.datum_reference_frame_ids[0]]
        assert (read[name].type, definition.material_condition, definition.zone_shape) == (kind, condition, zone)
        assert tuple(labels[d.datum_definition_ids[0]] for d in frame.datums) == datums
        assert read[name].value == pytest.approx(outcomes[name].value_mm, abs=1e-12)
        assert read[name].status == outcomes[name].verdict
    # the second opinion recomputes each from the written points and datum actuals (gdt.qif.orientation / axial,
    # code apart from inspect's): the LMC position, angularity, runout and coaxiality agree with inspect's values
    checks = {c.name: c for c in verify_characteristics(document).checks}
    assert checks["position H2 LMC"].status == "agrees"
    for name in ("angularity TOP", "runout H1", "total runout H1", "coaxiality H2"):
        assert checks[name].status == "agrees" and checks[name].source == "points"
        assert abs(checks[name].recomputed - outcomes[name].value_mm) < 1e-8


def test_under_asme_the_datum_planes_are_named_constrained_and_the_second_opinion_agrees(tmp_path):
    from pcmm_geo.gdt.qif.characteristics import verify_characteristics
    from pcmm_geo.io.cmm import read_qif
    from pcmm_geo.io.cmm.qif.schema import validate_qif

    for f in EXAMPLE_DIR.iterdir():
        if f.suffix in (".toml", ".csv"):
            shutil.copy(f, tmp_path / f.name)
    plan = tmp_path / "plan.toml"
    plan.write_text(plan.read_text(encoding="utf-8").replace('standard = "ISO"', 'standard = "ASME"'),
                    encoding="utf-8")
    path = inspection_to_qif(inspect_plan(plan), tmp_path / "asme.qif").path
    assert validate_qif(path) == ()
    document = read_qif(path)
    # ASME Y14.5.1 constrained least squares is not QIF's (unconstrained) LEASTSQUARES
    assert {document.feature(n).substitute_algorithm for n in "ABC"} == {"CONSTRAINED_LEASTSQUARES"}
    assert document.feature("H1").substitute_algorithm == "MAXINSCRIBED"  # the hole's mating envelope
    statuses = {c.name: c.status for c in verify_characteristics(document).checks}
    assert statuses == dict.fromkeys(WRITTEN + SIZES, "agrees")


def test_without_a_part_frame_the_file_is_in_the_frame_of_most_datums_and_agrees(tmp_path):
    from pcmm_geo.gdt.qif.characteristics import verify_characteristics
    from pcmm_geo.io.cmm import read_qif
    from pcmm_geo.io.cmm.qif.schema import validate_qif

    for f in EXAMPLE_DIR.iterdir():
        if f.suffix in (".toml", ".csv"):
            shutil.copy(f, tmp_path / f.name)
    plan = tmp_path / "plan.toml"
    text = plan.read_text(encoding="utf-8").replace('[part]\nframe = "A|B|C"\n', "")
    start = text.index('[[characteristics]]\nname = "x H1"')  # a coordinate needs a frame: dropped
    plan.write_text(text[:start] + text[text.index("[[characteristics]]", start + 5):], encoding="utf-8")
    result = inspect_plan(plan)
    assert result.plan.part_frame == () and result.datums == {}
    export = inspection_to_qif(result, tmp_path / "noframe.qif")
    assert validate_qif(export.path) == ()
    # the distance was taken in measurement coordinates (no frame): not in the file's frame A|B|C
    assert [name for name, _ in export.not_written] == ["H1 to H2"]
    document = read_qif(export.path)
    assert {document.feature(n).substitute_algorithm for n in "ABC"} == {"ONESIDED"}  # the datums, not LS planes
    statuses = {c.name: c.status for c in verify_characteristics(document).checks}
    assert statuses == dict.fromkeys(set(WRITTEN + SIZES) - {"x H1", "H1 to H2"}, "agrees")


def test_a_profile_of_a_surface_is_reported_not_written_by_name(maker, tmp_path):
    import numpy as np
    from test_gdt_profile import _patch

    from pcmm_geo.io.cmm import read_qif
    from pcmm_geo.io.cmm.qif.schema import validate_qif

    part = maker.make_part(n_points=maker.EXAMPLE_POINTS)
    nominal, normals, measured, _, _ = _patch(np.random.default_rng(2))
    for f in EXAMPLE_DIR.iterdir():
        if f.suffix in (".toml", ".csv"):
            shutil.copy(f, tmp_path / f.name)
    np.savetxt(tmp_path / "S_nominal.csv", nominal, fmt="%.12f", delimiter=",")
    np.savetxt(tmp_path / "S_normals.csv", normals, fmt="%.12f", delimiter=",")
    np.savetxt(tmp_path / "S.csv", measured @ part.rotation.T + part.translation, fmt="%.12f", delimiter=",")
    plan = tmp_path / "plan.toml"
    text = plan.read_text(encoding="utf-8")
    text = text[:text.index('[[characteristics]]\nname = "perpendicularity H1"')]
    text = text.replace("[datums]", '[features.S]\nelement = "surface"\npoints = "S.csv"\n'
                        'nominal_points = "S_nominal.csv"\nnominal_normals = "S_normals.csv"\n\n[datums]')
    plan.write_text(text + '[[characteristics]]\nname = "profile S"\nfeature = "S"\nframe = "⌓ 0.025 | A | B | C"\n',
                    encoding="utf-8")
    export = inspection_to_qif(inspect_plan(plan), tmp_path / "profile.qif")
    assert validate_qif(export.path) == ()
    assert export.written == ("flatness A", "parallelism TOP") and "S" not in export.features
    ((name, reason),) = export.not_written
    assert name == "profile S" and "SurfaceProfile" in reason
    assert {c.name for c in read_qif(export.path).characteristics} == {"flatness A", "parallelism TOP", *SIZES}


def test_characteristics_of_the_same_name_keep_their_own_definitions(written, tmp_path):
    from pcmm_geo.io.cmm import read_qif
    from pcmm_geo.io.cmm.qif.characteristic_definitions import read_qif_definitions

    result = written[0]
    renamed = tuple(dataclasses.replace(c, name="same") if c.name in ("position H3", "flatness A") else c
                    for c in result.characteristics)
    path = inspection_to_qif(dataclasses.replace(result, characteristics=renamed), tmp_path / "same.qif").path
    definitions = read_qif_definitions(path)
    same = sorted((c.type, c.value, definitions.definition_of(c.definition_id).material_condition)
                  for c in read_qif(path).characteristics if c.name == "same")
    outcomes = {c.name: c for c in result.characteristics}
    assert [s[0] for s in same] == ["flatness", "position"] and same[1][2] == "MAXIMUM" and same[0][2] is None
    assert same[0][1] == pytest.approx(outcomes["flatness A"].value_mm, abs=1e-12)
    assert same[1][1] == pytest.approx(outcomes["position H3"].value_mm, abs=1e-12)


def test_datum_modifiers_are_written_and_common_datums_listed_by_name(maker, tmp_path):
    from test_gdt_datum_kinds import test_common_datum_axis_in_a_plan_coaxiality_and_runout
    from test_gdt_mobility import _part

    from pcmm_geo.io.cmm.qif.schema import validate_qif

    plan, _, _ = _part(maker, tmp_path, frames=("position dia 0.1 | A | D(M) | E", "position dia 0.1 | A | D | E"))
    export = inspection_to_qif(inspect_plan(plan), tmp_path / "out.qif")
    assert validate_qif(tmp_path / "out.qif") == ()
    assert export.frames == ("A|D(M)|E", "A|D|E") and export.not_written == ()
    xml = (tmp_path / "out.qif").read_text(encoding="utf-8")
    assert xml.count("<MaterialModifier>MAXIMUM</MaterialModifier>") == 1
    # the second opinion (independent: the datums fixed at their actuals, the shift as an interval) agrees,
    # and the best over the mobility is its interval's lower end here (the whole clearance along the deviation)
    from pcmm_geo.gdt.qif.characteristics import verify_characteristics
    from pcmm_geo.io.cmm import read_qif

    checks = {c.name: c for c in verify_characteristics(read_qif(tmp_path / "out.qif")).checks}
    assert checks["pos H1 0"].status == "agrees" and checks["pos H1 1"].status == "agrees"
    assert "[0.0294427, 0.0894427]" in checks["pos H1 0"].reason
    # characteristics to a common datum: listed by name with the reason, the file still valid
    common = tmp_path / "common"
    common.mkdir()
    test_common_datum_axis_in_a_plan_coaxiality_and_runout(common, maker)
    export = inspection_to_qif(inspect_plan(common / "plan.toml"), common / "out.qif")
    assert validate_qif(common / "out.qif") == ()
    assert [n for n, _ in export.not_written] == ["coax M", "runout M"]
    assert "datum A-B is a common datum" in export.not_written[0][1]
