"""``pcmm calibrate --probing-u-mm/--laser-u-mm``, ``pcmm uncertainty`` and the demo's U, run as ``pcmm``."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest
from pcmm_runner import run_pcmm


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return run_pcmm(*args)


@pytest.fixture(scope="module")
def raw_files(tmp_path_factory: pytest.TempPathFactory) -> tuple[str, str]:
    from pcmm_geo.demo import CALIBRATION_LASERS, DemoSettings, simulate_probings, true_machine
    from pcmm_geo.machine.calibration.probings import write_lasers_csv, write_probings_csv

    folder = tmp_path_factory.mktemp("raw")
    settings = DemoSettings(seed=7)
    probings = simulate_probings(true_machine(settings), settings, np.random.default_rng(7))
    points = {("tip", None): probings["tip"]}
    for arm in "abc":
        for position, pts in probings[f"joint_{arm}"].items():
            points[(f"joint_{arm}", position)] = pts
    probe_file = write_probings_csv(folder / "probings.csv", points)
    laser_file = write_lasers_csv(folder / "lasers.csv", [1, 2, 3], CALIBRATION_LASERS)
    return str(probe_file), str(laser_file)


def test_calibrate_reports_and_stores_the_covariance(raw_files: tuple[str, str], tmp_path: Path) -> None:
    out = tmp_path / "cal.json"
    done = run("calibrate", *raw_files, "--probing-u-mm", "0.0005", "--laser-u-mm", "0.0005",
               "--out", str(out), "--json")
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)
    u = data["uncertainty"]["standard_uncertainties"]
    assert 1e-4 < u["dead_distance_a"] < 2e-3 and 1e-4 < u["tip_radius"] < 1e-3
    stored = json.loads(out.read_text())["covariance"]
    assert stored["names"] == data["uncertainty"]["names"]
    text = run("calibrate", *raw_files, "--probing-u-mm", "0.0005", "--laser-u-mm", "0.0005")
    assert "Standard uncertainties (GUM linear" in text.stdout and "beta_ab" in text.stdout
    assert run("calibrate", *raw_files, "--probing-u-mm", "0.0005").returncode == 2


def test_uncertainty_command_from_a_calibration_file(raw_files: tuple[str, str], tmp_path: Path) -> None:
    cal = tmp_path / "cal.json"
    written = run("calibrate", *raw_files, "--probing-u-mm", "0.0005", "--laser-u-mm", "0.0005", "--out", str(cal))
    assert written.returncode == 0, written.stderr
    plot = tmp_path / "mc.png"
    done = run("uncertainty", "gauge-block", "--calibration", str(cal), "--trials", "4000", "--seed", "3",
               "--plot", str(plot), "--json")
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)
    result = data["result"]
    assert result["method"] == "Monte Carlo" and result["n_trials"] == 4000
    # the demo's error sources give a sub-micrometre U on 100 mm; GUM agrees within 5 %
    assert 2e-4 < result["expanded_uncertainty"] < 2e-3
    assert data["gum"]["expanded_uncertainty"] == pytest.approx(result["expanded_uncertainty"], rel=0.05)
    assert {entry["name"] for entry in result["budget"]} == {"calibration", "laser_noise", "encoder_noise"}
    assert plot.stat().st_size > 10_000
    text = run("uncertainty", "distance", "--calibration", str(cal), "--trials", "2000", "--length-mm", "50")
    assert text.returncode == 0 and "Budget: contribution of each input group to u" in text.stdout


def test_demo_json_states_the_expanded_uncertainty() -> None:
    done = run("demo", "--json", "--no-plots", "--seed", "5")
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)
    expanded = data["expanded_uncertainty_calibrated_mm"]
    assert 1e-4 < expanded < 2e-3
    low, high = data["uncertainty_calibrated"]["coverage_interval_mm"]
    assert low < data["measured_length_calibrated_mm"] < high
    text = run("demo", "--no-plots", "--seed", "5")
    assert "calibrated length L = " in text.stdout and "(U, k = " in text.stdout


def test_iso10360_commands_apply_the_iso14253_rule() -> None:
    examples = Path(__file__).resolve().parents[2] / "pcmm_geo" / "data" / "examples"
    lengths = str(examples / "iso10360_2_lengths.csv")
    done = run("iso10360-2", lengths, "--mpe-a-um", "1.5", "--mpe-k", "333", "--uncertainty-um", "0.6", "--json")
    assert done.returncode == 1  # NOT PROVEN is not a pass
    data = json.loads(done.stdout)
    assert data["verdict"] == "NOT PROVEN" and data["test_uncertainty_um"] == pytest.approx(0.6)
    assert {e["verdict"] for e in data["errors"]} == {"PASS", "NOT PROVEN"}
    sphere = str(examples / "iso10360_5_sphere.csv")
    done = run("iso10360-5", sphere, "--reference-diameter-mm", "25.0004", "--mpe-form-um", "1.5",
               "--mpe-size-um", "1.5",
               "--uncertainty-um", "0.3", "0.4", "--json")
    assert done.returncode == 0
    data = json.loads(done.stdout)
    assert (data["form_verdict"], data["size_verdict"]) == ("PASS", "PASS")
    assert "ISO 14253-1" in data["decision_rule"]
