"""``pcmm thermal`` sub-actions, run as the installed command."""

from __future__ import annotations

import json
import math
import subprocess
from importlib.resources import files
from pathlib import Path

import pytest
from pcmm_runner import run_pcmm


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return run_pcmm(*args)


def run_json(*args: str) -> dict:
    proc = run(*args, "--json")
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def assert_usage_error(proc: subprocess.CompletedProcess[str], text: str) -> None:
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and text in lines[0], proc.stderr


def test_rtd() -> None:
    assert run_json("thermal", "rtd", "--temperature", "100")["resistance_ohm"] == pytest.approx(138.5055, abs=1e-9)
    hand = 100.0 * (1 - 0.39083 - 0.005775 - 4.183e-12 * 2e8)
    assert run_json("thermal", "rtd", "--resistance", repr(hand))["temperature_degC"] == pytest.approx(-100, abs=1e-9)
    assert_usage_error(run("thermal", "rtd", "--temperature", "900"), "temperature: expected values in")


def test_thermistor() -> None:
    a, b, c = 1.009249522e-3, 2.378405444e-4, 2.019202697e-7
    data = run_json("thermal", "thermistor", "--coefficients", str(a), str(b), str(c), "--resistance", "10000")
    log_r = math.log(10000.0)
    assert data["temperature_degC"] == pytest.approx(1 / (a + b * log_r + c * log_r**3) - 273.15, abs=1e-9)
    table = str(files("pcmm_geo") / "data/examples/thermistor_calibration.csv")
    fitted = run_json("thermal", "thermistor", "--calibration", table, "--resistance", "10000")
    # the example table was derived from the same coefficients (5 significant digits)
    assert fitted["temperature_degC"] == pytest.approx(1 / (a + b * log_r + c * log_r**3) - 273.15, abs=2e-3)


def test_thermistor_bad_calibration(tmp_path: Path) -> None:
    short = tmp_path / "short.csv"
    short.write_text("temperature,resistance\n0,32650\n25,10000\n")
    assert_usage_error(run("thermal", "thermistor", "--calibration", str(short)), "needs at least 3 points, got 2")
    assert_usage_error(run("thermal", "thermistor", "--calibration", str(tmp_path / "none.csv")), "No such file")


def test_correct_length() -> None:
    data = run_json("thermal", "correct-length", "--length-mm", "100", "--temperature", "22", "--alpha", "11.5e-6",
                    "--u-alpha", "1e-6", "--u-temperature", "0.1")
    assert data["length_20C_mm"] == pytest.approx(100 / (1 + 2 * 11.5e-6), abs=1e-12)
    assert data["standard_uncertainty_mm"] == pytest.approx(math.hypot(2e-4, 1.15e-4), rel=1e-4)
    assert_usage_error(run("thermal", "correct-length", "--length-mm", "-5", "--temperature", "22", "--alpha", "1e-5"),
                       "measured_length: expected a positive value")


def test_triangle() -> None:
    data = run_json("thermal", "triangle", "--temperatures", "20", "20", "20")
    corners = data["corners"]
    assert corners["a"]["x_mm"] == pytest.approx(-650 / math.sqrt(3), abs=1e-9)  # Table 4.1: -375.27
    assert corners["b"]["x_mm"] == pytest.approx(650 / (2 * math.sqrt(3)), abs=1e-9)  # 187.63
    assert corners["c"]["y_mm"] == pytest.approx(-325.0, abs=1e-9)
    warm = run_json("thermal", "triangle", "--temperatures", "21", "21", "21")
    assert warm["sides_mm"] == pytest.approx([650.015015] * 3, abs=1e-9)
    assert_usage_error(run("thermal", "triangle", "--temperatures", "20", "20", "20", "--side-mm", "-650"),
                       "side_ab: expected a positive finite length")


def test_table() -> None:
    data = run_json("thermal", "table", "--points-per-axis", "1")
    members = {m["member"]: m for m in data["members"]}
    assert len(members) == 9
    # symmetric machine, one column warmed: linear theory gives dz = alpha * z / 3 (23.1e-6 * 400 mm / 3)
    assert members["column_a"]["max_dz_um_per_k"] == pytest.approx(23.1e-3 * 400 / 3, rel=1e-4)
    assert_usage_error(run("thermal", "table", "--points-per-axis", "0"), "points_per_axis")
