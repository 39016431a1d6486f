"""``pcmm calibrate`` and ``pcmm numcal`` run as the installed command."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest
from pcmm_runner import run_pcmm

from pcmm_geo.machine.calibration.numerical.numcal_data import (
    NumcalParameters,
    synthesise_design_data,
    synthesise_numcal_data,
    write_numcal_csv,
)
from pcmm_geo.machine.calibration.seed import TABLE_7_1, appendix_cd_files


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return run_pcmm(*args)


@pytest.fixture(scope="module")
def files() -> tuple[str, str]:
    export, lasers = appendix_cd_files()
    return str(export), str(lasers)


def test_calibrate_json_reproduces_table_7_1(files):
    done = run("calibrate", *files, "--json")
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)
    for arm, pair in zip("abc", ("ab", "bc", "ca"), strict=True):
        assert data["dead_distance"][arm] == pytest.approx(TABLE_7_1[arm][0], abs=0.01)
        assert data["beta_deg"][pair] == pytest.approx(TABLE_7_1[arm][1], abs=0.01)


def test_calibrate_text_output_and_files(tmp_path, files):
    out = tmp_path / "cal.json"
    plot = tmp_path / "cal.png"
    done = run("calibrate", *files, "--out", str(out), "--plot", str(plot))
    assert done.returncode == 0, done.stderr
    assert "Tetrahedron calibration" in done.stdout and "314.47" in done.stdout
    assert json.loads(out.read_text())["schema"] == "pcmm_geo.machine.calibration/1"
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    again = run("calibrate", *files, "--out", str(out))
    assert again.returncode == 2
    assert "exists" in again.stderr and len(again.stderr.strip().splitlines()) == 1
    assert run("calibrate", *files, "--out", str(out), "--overwrite").returncode == 0


def test_calibrate_bad_file_is_one_line_error(tmp_path, files):
    bad = tmp_path / "probings.csv"
    bad.write_text("feature,position,x,y,z\njoint_a,1,0,0,oops\n")
    done = run("calibrate", str(bad), files[1])
    assert done.returncode == 2
    assert f"{bad}:2" in done.stderr and len(done.stderr.strip().splitlines()) == 1


def test_numcal_json(tmp_path):
    truth = NumcalParameters.from_seed_table()
    design = np.random.default_rng(2).uniform(0.0, 200.0, (24, 3))  # pivots together over 200 mm
    path = write_numcal_csv(synthesise_design_data(truth, design), tmp_path / "numcal.csv")
    done = run("numcal", str(path), "--json", "--pairs", "all", "--search", "multistart")
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert result["converged"] is True and result["pairs"] == "all"
    assert result["rms"] < 1e-9 and result["dof"] == 3 * 24 - 9
    assert result["condition_number"] < 1e5
    for arm in "abc":
        assert abs(result["d"][arm] - truth.d[arm]) < 1e-6
    assert len(result["height_errors"]) == 24
    # the seed's own design (one pivot at a time, 50 mm, one pair per sample) is not determined: exit 1, one warning
    seed_path = write_numcal_csv(synthesise_numcal_data(truth, seed=2), tmp_path / "seed.csv")
    text = run("numcal", str(seed_path), "--search", "none", "--method", "sequential")
    assert text.returncode == 1 and "converged: NO" in text.stdout and "weak combination" in text.stdout
    warning_lines = [line for line in text.stderr.splitlines() if "CalibrationNotConvergedWarning" in line]
    assert len(warning_lines) == 1
    arm = run("numcal", str(seed_path), "--single-arm", "a", "--search", "none", "--json")
    single = json.loads(arm.stdout)
    assert arm.returncode == 1 and single["method"] == "single-arm" and single["converged"] is False
    assert single["estimated"] == ["d_a", "d_c", "beta_ca", "b_ca"]
