"""``pcmm qif show|verify``, ``pcmm fit|form`` on QIF point sets with probe compensation, and ``--qif OUT``.

In process through :func:`pcmm_geo.cli.main` (the installed ``pcmm``'s code path).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.cli import main
from pcmm_geo.io.cmm import read_qif, validate_qif

DATA = Path(__file__).parents[1] / "data" / "qif"
SAMPLE = DATA / "samples" / "QIF_PTS_SAMPLE.QIF"
RING = Path(__file__).parents[2] / "pcmm_geo" / "data" / "examples" / "roundness_ring.csv"
PROBE_RADIUS = 2.49978271104


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_verify_json_contract_and_exit_code(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(["qif", "verify", str(SAMPLE), "--json"], capsys)
    assert code == 1, err  # the single-point features disagree (uncompensated probe centres)
    data = json.loads(out)
    assert data["file"] == str(SAMPLE) and len(data["features"]) == 14
    by_id = {feature["id"]: feature for feature in data["features"]}
    circle = by_id[261]
    assert set(circle) >= {"id", "type", "name", "n_points", "method", "compensation", "reported", "refit",
                           "difference", "agrees", "reason"}
    assert (circle["type"], circle["name"], circle["n_points"], circle["method"]) == ("circle", "CIRCLE1", 219,
                                                                                      "gaussian")
    assert circle["compensation"]["probe_radius_mm"] == PROBE_RADIUS
    assert (circle["compensation"]["side"], circle["compensation"]["inferred"]) == ("internal", False)
    assert set(circle["reported"]) == set(circle["refit"]) == {"diameter_mm", "location_mm", "direction"}
    assert circle["difference"]["diameter_mm"] == pytest.approx(
        circle["refit"]["diameter_mm"] - circle["reported"]["diameter_mm"], abs=1e-15)
    assert len(circle["difference"]["location_mm"]) == 3 and "location_distance_mm" in circle["difference"]
    assert circle["agrees"] is True and abs(circle["difference"]["diameter_mm"]) < 2e-5
    assert by_id[28]["compensation"]["inferred"] is True
    plane = by_id[11]
    assert "diameter_mm" not in plane["reported"] and "diameter_mm" not in plane["difference"]  # absent, not null
    assert by_id[776]["agrees"] is None and by_id[776]["reason"]
    assert by_id[756]["agrees"] is False and by_id[756]["compensation"]["side"] == "external"
    assert data["summary"] == {"agree": 4, "disagree": 5, "not_checked": 5}


def test_verify_text_report_and_tolerance(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    report = tmp_path / "verify.md"
    code, out, err = run(["qif", "verify", str(SAMPLE), "--report", str(report)], capsys)
    assert code == 1
    assert "Second opinion on" in out and "Δ diameter / µm" in out and "4 features agree, 5 disagree" in out
    text = report.read_text()
    assert "4 features agree, 5 disagree, 5 not checked" in text and "QIF\\_PTS\\_SAMPLE.QIF" in text
    # refit as minimum-zone circles: the diameters then differ from the CMM's least-squares ones
    code, out, _ = run(["qif", "verify", str(SAMPLE), "--criterion", "chebyshev", "--json"], capsys)
    chebyshev = {f["id"]: f for f in json.loads(out)["features"]}
    assert chebyshev[261]["method"] == "chebyshev" and chebyshev[261]["method_source"] == "requested"
    assert chebyshev[261]["agrees"] is False
    for bad in (["--tolerance-mm", "0"], ["--tolerance-mm", "nan"], ["--max-mb", "-1"]):
        code, _, err = run(["qif", "verify", str(SAMPLE), *bad], capsys)
        assert code == 2 and len(err.strip().splitlines()) == 1


def test_show_lists_features_point_sets_and_characteristics(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(["qif", "show", str(SAMPLE), "--json"], capsys)
    assert code == 0
    data = json.loads(out)
    assert len(data["features"]) == 14 and len(data["point_sets"]) == 12
    assert {c["type"] for c in data["characteristics"]} >= {"diameter", "circularity", "flatness", "position"}
    cylinder = next(f for f in data["features"] if f["id"] == 796)
    assert cylinder["n_points"] == 18 and cylinder["actual"]["diameter_mm"] == 30.11094079809
    assert len(data["problems"]) == 1 and "828" in data["problems"][0]
    code, out, _ = run(["qif", "show", str(SAMPLE)], capsys)
    assert "Measured point sets" in out and "CYL_1" in out and "left out: " in out


def test_fit_a_feature_of_a_qif_file(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(["fit", "circle", str(SAMPLE)], capsys)
    assert code == 2 and "28 DATUMB" in err and "261 CIRCLE1" in err and "509 CIRCLE2" in err
    code, out, err = run(["fit", "circle", str(SAMPLE), "--feature", "CIRCLE1", "--method", "projected", "--json"],
                         capsys)
    assert code == 0, err
    data = json.loads(out)
    assert 2 * data["radius"] == pytest.approx(12.095569950907, abs=2e-5)
    assert data["probe_compensation"]["side"] == "internal"
    assert data["probe_compensation"]["side_source"] == "the file's InternalExternal"
    assert data["feature"] == {"id": 261, "name": "CIRCLE1", "type": "circle"}
    # the only cylinder is chosen without --feature; its side is inferred from the nominal 30 mm
    code, out, _ = run(["fit", "cylinder", str(SAMPLE), "--json"], capsys)
    data = json.loads(out)
    assert 2 * data["radius"] == pytest.approx(30.110940798089999, abs=2e-5)
    assert data["probe_compensation"]["inferred"] is True
    # a fixed --radius-mm is the surface radius: the probe centres are fitted with it minus the probe radius
    code, out, _ = run(["fit", "cylinder", str(SAMPLE), "--radius-mm", "15.05", "--json"], capsys)
    assert json.loads(out)["radius"] == pytest.approx(15.05, abs=1e-12)
    # the points are probe centres: --compensated yes contradicts the file
    code, _, err = run(["fit", "circle", str(SAMPLE), "--feature", "261", "--compensated", "yes"], capsys)
    assert code == 2 and "Compensated=false" in err
    code, out, _ = run(["fit", "circle", str(SAMPLE), "--feature", "261", "--probe-radius-mm", "2", "--method",
                        "projected", "--json"], capsys)
    assert 2 * json.loads(out)["radius"] == pytest.approx(12.095569950907 - 2 * (PROBE_RADIUS - 2), abs=2e-5)


def test_plain_points_with_a_probe_radius(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(["form", str(RING), "--element", "circle", "--two-d", "--tolerance-mm", "0.010", "--json"],
                       capsys)
    plain = json.loads(out)
    code, out, err = run(["form", str(RING), "--element", "circle", "--two-d", "--tolerance-mm", "0.010",
                          "--probe-radius-mm", "1.5", "--material-side", "external", "--json"], capsys)
    assert code == 0, err
    compensated = json.loads(out)
    assert compensated["deviation_mm"] == pytest.approx(plain["deviation_mm"], abs=1e-12)  # the zone stays
    assert compensated["fit"]["r_in"] == pytest.approx(plain["fit"]["r_in"] - 1.5, abs=1e-12)
    assert compensated["fit"]["radius"] == pytest.approx(plain["fit"]["radius"] - 1.5, abs=1e-12)
    # the side is needed, and must be asked for; --compensated no needs a radius
    for argv, message in ((["--probe-radius-mm", "1.5"], "--material-side"),
                          (["--compensated", "no"], "--probe-radius-mm"),
                          (["--material-side", "internal"], "a probe radius to apply")):
        code, _, err = run(["fit", "circle", str(RING), "--two-d", *argv], capsys)
        assert code == 2 and message in err and len(err.strip().splitlines()) == 1


def test_qif_output_validates_reads_back_and_verifies(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out_file = tmp_path / "out" / "cylinder.qif"
    code, out, err = run(["form", str(SAMPLE), "--element", "cylinder", "--tolerance-mm", "0.01", "--qif",
                          str(out_file), "--json"], capsys)
    assert code == 0, err
    form = json.loads(out)
    assert validate_qif(out_file) == ()
    document = read_qif(out_file)
    (feature,) = document.measured_features
    assert feature.substitute_algorithm == "MINMAX" and feature.name == "CYL_1"
    assert abs(feature.actual.diameter - 2 * form["fit"]["radius"]) < 1e-12
    assert abs(feature.actual.form - form["deviation_mm"]) < 1e-12
    cylindricity = next(c for c in document.characteristics if c.type == "cylindricity")
    assert (cylindricity.status, cylindricity.tolerance.value) == ("PASS", 0.01)
    points = document.points_of(feature)
    assert (points.compensated, points.probe_radius) == (False, PROBE_RADIUS) and points.normals is not None
    source = read_qif(SAMPLE)
    np.testing.assert_array_equal(points.points, source.points_of(source.feature(796)).points)
    # a second opinion on our own file: the minimum-zone cylinder, refitted, agrees
    code, out, _ = run(["qif", "verify", str(out_file), "--json"], capsys)
    assert code == 0 and json.loads(out)["features"][0]["agrees"] is True
    # outputs are declared: an existing file is refused before any work, --overwrite-qif replaces it
    code, _, err = run(["fit", "cylinder", str(SAMPLE), "--qif", str(out_file)], capsys)
    assert code == 2 and "--overwrite-qif" in err
    assert read_qif(out_file).measured_features[0].substitute_algorithm == "MINMAX"
    code, _, _ = run(["fit", "cylinder", str(SAMPLE), "--qif", str(out_file), "--overwrite-qif"], capsys)
    assert code == 0 and read_qif(out_file).measured_features[0].substitute_algorithm == "LEASTSQUARES"


def test_a_failed_run_writes_no_qif(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out_file = tmp_path / "out.qif"
    code, _, err = run(["fit", "torus", str(SAMPLE), "--feature", "CYL_1", "--qif", str(out_file)], capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert not out_file.exists() and list(tmp_path.iterdir()) == []


def test_xyzijk_export_needs_the_compensation_stated(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from pcmm_geo.fit.reference import make_reference_data

    data = make_reference_data("cylinder", n_points=40, radius=6.0, length=20.0, form=0.002, offset=50.0, rng=8)
    axis, point = data.parameters["axis"], data.parameters["point"]
    radial = data.points - point - np.outer((data.points - point) @ axis, axis)
    outward = -radial / np.linalg.norm(radial, axis=1, keepdims=True)  # a bore: normals toward the axis
    centres = data.points + 0.5 * outward
    export = tmp_path / "bore.txt"
    export.write_text("XYZIJK    METRIC\n" + "".join(",".join(repr(float(v)) for v in (*c, *n)) + "\n"
                                                  for c, n in zip(centres, outward, strict=True)))
    code, _, err = run(["fit", "cylinder", str(export)], capsys)
    assert code == 2 and "--compensated" in err and "bore.txt" in err
    code, out, err = run(["fit", "cylinder", str(export), "--compensated", "no", "--probe-radius-mm", "0.5", "--json"],
                         capsys)
    assert code == 0, err
    fitted = json.loads(out)
    assert fitted["radius"] == pytest.approx(6.0, abs=1e-9)  # the known least-squares bore
    assert (fitted["probe_compensation"]["side"], fitted["probe_compensation"]["side_source"]) == (
        "internal", "the point normals")
    code, out, _ = run(["fit", "cylinder", str(export), "--compensated", "yes", "--json"], capsys)
    assert json.loads(out)["radius"] == pytest.approx(5.5, abs=1e-9)


def test_show_reads_dmis_output_and_calypso_tables(capsys: pytest.CaptureFixture[str]) -> None:
    cmm = Path(__file__).parents[1] / "data" / "cmm"
    code, out, err = run(["qif", "show", str(cmm / "standard.dmo"), "--json"], capsys)
    assert code == 0, err
    data = json.loads(out)
    assert data["format"] == "dmis" and {f["type"] for f in data["features"]} >= {"circle", "sphere", "plane"}
    code, _, err = run(["qif", "show", str(cmm / "flange_chr.txt")], capsys)
    assert code == 2 and "units" in err  # a CALYPSO table does not state its unit: never guessed
    code, out, _ = run(["qif", "show", str(cmm / "flange_chr.txt"), "--units", "mm", "--json"], capsys)
    assert code == 0 and json.loads(out)["format"] == "calypso"
    code, _, err = run(["qif", "show", str(SAMPLE), "--units", "inch"], capsys)
    assert code == 2 and "states its units" in err
    code, _, err = run(["fit", "plane", str(cmm / "standard.dmo")], capsys)
    assert code == 2 and "no points" in err


def test_validate_exit_codes_and_first_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``pcmm qif validate``: 0 valid, 1 schema errors listed with their lines, 2 unreadable or hostile."""
    code, out, err = run(["qif", "validate", str(SAMPLE)], capsys)
    assert (code, out.strip(), err) == (0, f"{SAMPLE}: valid QIF 3.0", "")
    text = SAMPLE.read_text(encoding="utf-8")
    broken = tmp_path / "broken.qif"
    broken.write_text(text.replace('count="219"', 'count="two hundred"').replace(
        "<Compensated>false</Compensated>", "<Compensated>no</Compensated>"), encoding="utf-8")
    # independent truth: the lines holding the edits, in file order
    edited = [number for number, line in enumerate(broken.read_text(encoding="utf-8").splitlines(), start=1)
              if 'count="two hundred"' in line or "<Compensated>no<" in line]
    assert len(edited) > 3
    code, out, err = run(["qif", "validate", str(broken), "--errors", "3"], capsys)
    lines = out.strip().splitlines()
    assert code == 1 and err == ""
    assert lines[0] == f"{broken}: not valid QIF 3.0, {len(edited)} schema errors (the first 3 listed)"
    assert [int(line.split(":")[0].split()[1]) for line in lines[1:]] == edited[:3]
    assert "attribute 'count': 'two hundred' is not a valid value" in lines[1] and "'no'" in lines[2]
    assert "{http" not in out  # element names without the QIF namespace
    code, out, _ = run(["qif", "validate", str(broken), "--json"], capsys)
    data = json.loads(out)
    assert code == 1 and (data["valid"], data["n_errors"]) == (False, len(edited))
    assert [error["line"] for error in data["errors"]] == edited
    # not well-formed, hostile, missing: exit 2, one line naming the file
    truncated = tmp_path / "truncated.qif"
    truncated.write_text(text[:5000], encoding="utf-8")
    bomb = tmp_path / "bomb.qif"
    bomb.write_text('<?xml version="1.0"?>\n<!DOCTYPE QIFDocument [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;">]>\n'
                    + text.split("\n", 1)[1], encoding="utf-8")
    for path, message in ((truncated, "not well-formed XML"), (bomb, ":2: has a document type declaration"),
                          (tmp_path / "missing.qif", "cannot be read")):
        code, out, err = run(["qif", "validate", str(path)], capsys)
        assert code == 2 and out == "" and len(err.strip().splitlines()) == 1, err
        assert str(path) in err and message in err
    code, _, err = run(["qif", "validate", str(SAMPLE), "--max-mb", "0.05"], capsys)
    assert code == 2 and "exceeds the limit of 52428 bytes" in err


def test_validate_without_lxml_names_the_extra(monkeypatch: pytest.MonkeyPatch,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    import sys

    from pcmm_geo.io.cmm.qif import schema

    schema._schema.cache_clear()
    for module in [m for m in sys.modules if m == "lxml" or m.startswith("lxml.")]:
        monkeypatch.delitem(sys.modules, module)
    monkeypatch.setitem(sys.modules, "lxml", None)
    try:
        code, out, err = run(["qif", "validate", str(SAMPLE)], capsys)
    finally:
        schema._schema.cache_clear()
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert "lxml" in err and "pip install 'pcmm_geo[qif]'" in err
