"""``pcmm qif|fit|form|calibrate`` on files from CMMs, as a user meets them: in a subprocess.

Messages name the command-line options (``--units``, ``--angle-unit``, ``--size-values``,
``--max-mb``) and the whole sub-command; a stated material side that contradicts the file is
refused; a file in which nothing could be verified does not pass; CALYPSO characteristics show
the features they name; every command that reads QIF takes ``--max-mb``.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest
from pcmm_runner import run_pcmm

DATA = Path(__file__).parents[1] / "data"
SAMPLE = DATA / "qif" / "samples" / "QIF_PTS_SAMPLE.QIF"  # 102259 bytes
CMM = DATA / "cmm"
SAMPLES = DATA / "qif" / "samples"
RING = CMM / "ring_xyzijk_metric.xyz"  # normals pointing away from the axis: an external feature
PROBINGS = Path(__file__).parents[2] / "pcmm_geo" / "data" / "appendix_cd"

BRACKET_CHR = ("planid\tid\ttype\tidsymbol\tactual\tnominal\tuppertol\tlowertol\tdeviation\texceed\tfeatureid\n"
               "BRACKET\tDiameter Bore\tDiameter\tdiameter\t16.0074\t16.0000\t0.0180\t0.0000\t0.0074\t\tCircle_Bore\n"
               "BRACKET\tAngle Face\tAngle\tangleXZ\t89.9950\t90.0000\t0.0100\t-0.0100\t-0.0050\t\tPlane_Face\n"
               "END\n")


def _run(*args: str | Path) -> subprocess.CompletedProcess[str]:
    return run_pcmm(*args)


def _refused(done: subprocess.CompletedProcess[str], command: str, *texts: str) -> str:
    """One error line on stderr starting with the whole sub-command, exit 2, nothing on stdout."""
    assert done.returncode == 2, done.stdout + done.stderr
    assert done.stdout == "" and done.stderr.count("\n") == 1, done.stderr
    assert done.stderr.startswith(f"pcmm {command}: error: "), done.stderr
    for text in texts:
        assert text in done.stderr, done.stderr
    return done.stderr


def test_reader_messages_name_the_options(tmp_path: Path) -> None:
    table = tmp_path / "X_chr.txt"
    table.write_text(BRACKET_CHR)
    error = _refused(_run("qif", "show", table), "qif show", "--units: expected 'mm' or 'inch'", "got nothing")
    assert "None" not in error
    error = _refused(_run("qif", "show", table, "--units", "mm"), "qif show",
                     "'Angle Face': pass --angle-unit degree or --angle-unit radian")
    assert "angle_unit" not in error
    report = tmp_path / "nounits.dmo"
    report.write_text("".join(line for line in (CMM / "standard.dmo").read_text().splitlines(keepends=True)
                              if not line.startswith("UNITS")))
    error = _refused(_run("qif", "verify", report), "qif verify", "no UNITS", "pass --units mm or --units inch")
    assert "units=" not in error
    shown = _run("qif", "show", CMM / "standard.dmo")  # a size result left out: how to have it read
    assert shown.returncode == 0 and "(pass --size-values actual or --size-values deviation)" in shown.stdout
    assert "size_values" not in shown.stdout
    for action in ("show", "verify", "validate"):
        error = _refused(_run("qif", action, SAMPLE, "--max-mb", "0.05"), f"qif {action}",
                         "exceeds the limit of 52428 bytes (raise --max-mb for larger files)")
        assert "max_bytes" not in error
    _refused(_run("qif", "show", SAMPLE, "--units", "mm"), "qif show",
             "the file states its units (FileUnits/PrimaryUnits); --units is for a file without them")


def test_a_stated_material_side_that_contradicts_the_file_is_refused(tmp_path: Path) -> None:
    _refused(_run("fit", "circle", SAMPLE, "--feature", "CIRCLE1", "--material-side", "external"), "fit",
             "--material-side: expected internal", "CIRCLE1", "InternalExternal=INTERNAL", "got external")
    _refused(_run("form", SAMPLE, "--element", "circle", "--feature", "CIRCLE1", "--material-side", "external"),
             "form", "InternalExternal=INTERNAL")
    agreeing = _run("fit", "circle", SAMPLE, "--feature", "CIRCLE1", "--material-side", "internal", "--json")
    assert agreeing.returncode == 0, agreeing.stderr
    assert 2 * json.loads(agreeing.stdout)["radius"] == pytest.approx(12.09557, abs=2e-5)  # the CMM's diameter
    probe = ("--compensated", "no", "--probe-radius-mm", "1")
    _refused(_run("fit", "circle", RING, *probe, "--material-side", "internal"), "fit",
             "--material-side: expected external", "point normals", "got internal")
    _refused(_run("fit", "circle", RING, *probe, "--material-side", "internal", "--radius-mm", "8"), "fit",
             "point normals")  # a fixed surface radius needs the side before the fit: checked there too
    _refused(_run("form", RING, "--element", "circle", *probe, "--material-side", "internal"), "form",
             "point normals")
    stated = _run("fit", "circle", RING, *probe, "--material-side", "external", "--json")
    assert stated.returncode == 0, stated.stderr
    assert json.loads(stated.stdout)["radius"] == pytest.approx(9.0, abs=1e-9)  # centres on r = 10, shaft


def test_verify_fails_a_file_in_which_nothing_was_verified(tmp_path: Path) -> None:
    told = _run("qif", "verify", SAMPLE, "--compensated", "yes")  # contradicts Compensated=false: none checked
    assert told.returncode == 1, told.stderr  # ... but its characteristics are recomputed, one disagrees
    assert "verdict: 0 features agree, 0 disagree, 14 not checked; 14 characteristics agree, 1 disagree" in told.stdout
    data = json.loads(_run("qif", "verify", SAMPLE, "--compensated", "yes", "--json").stdout)
    assert (data["verified"], data["agrees"], data["overall_agrees"]) == (0, None, False)
    nothing = _run("qif", "verify", SAMPLES / "Exploded_Results1.QIF")  # no feature, no characteristic computable
    assert nothing.returncode == 1 and "verdict: nothing verified: 0 features agree" in nothing.stdout
    dmis = _run("qif", "verify", CMM / "standard.dmo", "--json")  # DMIS output: results without points
    data = json.loads(dmis.stdout)  # no feature refitted, but the position recomputed from the actuals agrees
    assert dmis.returncode == 0 and data["agrees"] is None and data["characteristics_summary"]["agrees"] == 1
    sample = _run("qif", "verify", SAMPLE, "--json")
    data = json.loads(sample.stdout)
    assert sample.returncode == 1 and (data["verified"], data["agrees"]) == (9, False)
    written = tmp_path / "circle1.qif"
    assert _run("fit", "circle", SAMPLE, "--feature", "CIRCLE1", "--qif", written).returncode == 0
    own = _run("qif", "verify", written, "--json")
    data = json.loads(own.stdout)
    assert own.returncode == 0 and (data["verified"], data["agrees"]) == (1, True)
    assert "Exit status 0 when at least one feature or characteristic was compared" in " ".join(
        _run("qif", "verify", "--help").stdout.split())


def test_show_names_the_features_of_a_calypso_table() -> None:
    shown = _run("qif", "show", CMM / "flange_chr.txt", "--units", "mm")
    assert shown.returncode == 0, shown.stderr
    rows = {line.split("  ")[1].strip(): line for line in shown.stdout.splitlines() if line[:2].strip().isdigit()}
    assert rows["Bore Dia"].rstrip().endswith("Cylinder_Bore")
    assert rows["Hole Pattern Distance"].rstrip().endswith("Circle_H1, Circle_H2")
    data = json.loads(_run("qif", "show", CMM / "flange_chr.txt", "--units", "mm", "--json").stdout)
    pattern = next(c for c in data["characteristics"] if c["name"] == "Hole Pattern Distance")
    assert pattern["feature_names"] == ["Circle_H1", "Circle_H2"] and len(pattern["feature_item_ids"]) == 2
    assert pattern["feature_measurement_ids"] == []  # a table has no feature measurements


def test_fit_form_calibrate_take_max_mb(tmp_path: Path) -> None:
    limit = "exceeds the limit of 52428 bytes (raise --max-mb for larger files)"
    _refused(_run("fit", "circle", SAMPLE, "--feature", "CIRCLE1", "--max-mb", "0.05"), "fit", limit)
    _refused(_run("form", SAMPLE, "--element", "circle", "--feature", "CIRCLE1", "--max-mb", "0.05"), "form", limit)
    larger = _run("fit", "circle", SAMPLE, "--feature", "CIRCLE1", "--max-mb", "0.1")  # 104857 bytes: read
    assert larger.returncode == 0, larger.stderr
    probings = PROBINGS / "cmm_export.qif"
    size = probings.stat().st_size
    _refused(_run("calibrate", probings, PROBINGS / "lasers.csv", "--max-mb", str(size / 2 / 2**20)), "calibrate",
             "(raise --max-mb for larger files)")
    _refused(_run("calibrate", PROBINGS / "cmm_export.csv", PROBINGS / "lasers.csv", "--max-mb", "1"), "calibrate",
             "--max-mb: expected a QIF probings file")
    _refused(_run("fit", "circle", CMM / "ring_xyzijk_metric.xyz", "--max-mb", "1"), "fit",
             "--max-mb: expected a QIF file")
    _refused(_run("fit", "circle", SAMPLE, "--feature", "CIRCLE1", "--max-mb", "0"), "fit",
             "--max-mb: expected a positive size in MiB")
    for command in (("fit", "--help"), ("form", "--help"), ("calibrate", "--help"), ("qif", "show", "--help")):
        assert "in MiB (2^20 bytes" in " ".join(_run(*command).stdout.split()), command
