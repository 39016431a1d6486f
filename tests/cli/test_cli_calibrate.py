"""``pcmm calibrate`` and ``pcmm numcal`` run as the installed command."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.machine.calibration.numcal import NumcalParameters, synthesise_numcal_data
from pcmm_geo.machine.calibration.seed import TABLE_7_1, appendix_cd_files

PCMM = str(Path(sys.executable).with_name("pcmm"))


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([PCMM, *args], capture_output=True, text=True, timeout=120, check=False)


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
    data = synthesise_numcal_data(NumcalParameters.from_seed_table(), seed=2)
    path = tmp_path / "numcal.csv"
    rows = ["moved,laser_a,laser_b,laser_c,height"]
    rows += [f"{m},{a!r},{b!r},{c!r},{h!r}" for m, (a, b, c), h in
             zip(data.moved, data.lasers.tolist(), data.heights.tolist(), strict=True)]
    path.write_text("\n".join(rows) + "\n")
    done = run("numcal", str(path), "--json", "--method", "sequential")
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert result["method"] == "sequential"
    assert result["rms"] < 1e-4
    assert result["identifiability"]["condition_number"] > 1e5
    assert len(result["height_errors"]) == 45
    assert set(result["d"]) == {"a", "b", "c"} and all(300 <= v <= 400 for v in result["d"].values())
    text = run("numcal", str(path), "--search", "none")
    assert text.returncode == 0 and "weak combination" in text.stdout
    assert np.isfinite(float(text.stdout.split("rms distance residual: ")[1].split()[0]))
