"""``pcmm batch``: many files over a Dask cluster, one JSON line per file, failures reported and counted."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.cli.measure.batch import evaluate_file

PCMM = str(Path(sys.executable).with_name("pcmm"))
EXAMPLES = files("pcmm_geo") / "data/examples"

pytest.importorskip("distributed")


def _ball(path: Path, center: tuple[float, float, float], radius: float, seed: int) -> Path:
    direction = np.random.default_rng(seed).normal(size=(60, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    np.savetxt(path, np.asarray(center) + radius * direction, delimiter=",", header="x,y,z", comments="")
    return path


def test_batch_on_a_local_cluster_reports_every_file_and_fails_softly(tmp_path: Path) -> None:
    balls = {_ball(tmp_path / f"ball{k}.csv", (10.0 * k, -5.0, 100.0), 5.0 + k, k): (10.0 * k, 5.0 + k)
             for k in range(3)}
    flat = tmp_path / "flat.csv"
    np.savetxt(flat, np.c_[np.random.default_rng(9).normal(size=(30, 2)), np.zeros(30)], delimiter=",",
               header="x,y,z", comments="")
    missing = tmp_path / "missing.csv"
    done = subprocess.run([PCMM, "batch", "fit-sphere", *map(str, balls), str(flat), str(missing), "--workers", "1"],
                          capture_output=True, text=True, timeout=240)
    assert done.returncode == 1, done.stderr  # two of five failed
    records = {Path(record["file"]).name: record for record in map(json.loads, done.stdout.splitlines())}
    assert len(records) == 5 and len(done.stdout.splitlines()) == 5
    for path, (x, radius) in balls.items():
        record = records[path.name]
        assert record["ok"] is True and record["task"] == "fit-sphere"
        np.testing.assert_allclose(record["result"]["center"], [x, -5.0, 100.0], rtol=0, atol=1e-9)
        assert record["result"]["radius"] == pytest.approx(radius, abs=1e-9)
    assert records["flat.csv"]["ok"] is False
    assert records["flat.csv"]["error"]["type"] == "DegenerateGeometryError"
    assert records["missing.csv"]["error"]["type"] == "FileNotFoundError"
    assert "3 of 5 files evaluated, 2 failed" in done.stderr


def test_each_task_evaluates_a_file_as_its_sub_command_does() -> None:
    gauge = evaluate_file("gauge-block", str(EXAMPLES / "gauge_block.csv"), {})
    assert gauge["ok"] is True and abs(gauge["result"]["central_length_mm"] - 100.0) < 1e-3
    compared = evaluate_file("compare", str(EXAMPLES / "gauge_block_scan.csv"),
                             {"mesh": str(EXAMPLES / "gauge_block_nominal.stl"), "tolerance": 0.005})
    assert compared["ok"] is True and compared["result"]["passed"] is True
    assert 0.0009 < compared["result"]["registration"]["inlier_rms_mm"] < 0.0011
    wrong = evaluate_file("fit-line", str(EXAMPLES / "gauge_block_scan.csv"), {"radius": 3.0})
    assert wrong["ok"] is False and wrong["error"]["type"] == "InvalidInputError"


def test_batch_argument_errors() -> None:
    done = subprocess.run([PCMM, "batch", "compare", str(EXAMPLES / "gauge_block_scan.csv")],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and "exactly one nominal surface" in done.stderr and done.stdout == ""


def test_batch_leaves_nothing_in_the_temporary_folder(tmp_path: Path) -> None:
    """dask's workers kept ``dask-scratch-space/`` in $TMPDIR after the command (issue 31)."""
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    ball = _ball(tmp_path / "ball.csv", (1.0, 2.0, 3.0), 4.0, 1)
    env = dict(os.environ, TMPDIR=str(scratch), TEMP=str(scratch), TMP=str(scratch))
    done = subprocess.run([PCMM, "batch", "fit-sphere", str(ball), "--workers", "1"], capture_output=True, text=True,
                          timeout=240, env=env)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["ok"] is True
    assert sorted(p.name for p in scratch.iterdir()) == []
