"""The reader contract on the command line (issue 31): refusals are one line and exit 2, never a hang."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest
from pcmm_runner import run_pcmm

DATA = Path(__file__).parents[1] / "data"
SAMPLES = DATA / "qif" / "samples"
PTS_SAMPLE = SAMPLES / "QIF_PTS_SAMPLE.QIF"
EXPLODED = SAMPLES / "Exploded_Results1.QIF"  # a public sample without FileUnits


def _refused(done: subprocess.CompletedProcess[str], command: str, *texts: str) -> str:
    assert done.returncode == 2, done.stdout + done.stderr
    assert done.stdout == "" and done.stderr.count("\n") == 1, done.stderr
    assert done.stderr.startswith(f"pcmm {command}: error: "), done.stderr
    assert "Traceback" not in done.stderr
    for text in texts:
        assert text in done.stderr, done.stderr
    return done.stderr


@pytest.mark.parametrize("radius", ["-1", "nan", "0", "inf"])
def test_qif_verify_refuses_a_probe_radius_that_is_not_positive(radius: str) -> None:
    _refused(run_pcmm("qif", "verify", PTS_SAMPLE, "--probe-radius-mm", radius), "qif verify",
             "--probe-radius-mm: expected a positive probe radius")


def test_qif_without_file_units_says_so_and_takes_units() -> None:
    done = run_pcmm("qif", "show", EXPLODED)
    assert done.returncode == 0, done.stderr
    assert "units not stated in the file, read as mm" in done.stdout and "file units mm" not in done.stdout
    assert "the QIF 3.0 schema states no default" in done.stdout
    assumed = json.loads(run_pcmm("qif", "show", EXPLODED, "--json").stdout)
    inch = json.loads(run_pcmm("qif", "show", EXPLODED, "--units", "inch", "--json").stdout)
    assert assumed["units"]["stated"] is False and inch["units"]["linear_unit"] == "inch"
    for mm, inches in zip(assumed["characteristics"], inch["characteristics"], strict=True):
        assert inches["value"] == pytest.approx(25.4 * mm["value"], rel=1e-15)
    _refused(run_pcmm("qif", "show", PTS_SAMPLE, "--units", "inch"), "qif show",
             "the file states its units (FileUnits/PrimaryUnits); --units is for a file without them")


def test_qif_verify_takes_a_material_side() -> None:
    done = run_pcmm("qif", "verify", PTS_SAMPLE, "--material-side", "internal", "--json")
    assert done.returncode in (0, 1), done.stderr
    assert json.loads(done.stdout)["features"]
    assert "--material-side" in run_pcmm("qif", "verify", "--help").stdout
