"""``pcmm kinematics``, ``pcmm process-log`` and ``pcmm sensitivity`` run as the installed command."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
from pcmm_runner import run_pcmm

from pcmm_geo.machine.analysis.logproc import synthesise_log, write_log
from pcmm_geo.machine.kinematics.model import RigidBodyMachine


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


def test_trilaterate_closed_form() -> None:
    out = run_json("kinematics", "trilaterate", "--pivots-mm", "0", "0", "0", "4", "0", "0", "0", "4", "0",
                   "--lengths-mm", "3", "3", "3")
    np.testing.assert_allclose(out["point"], [2.0, 2.0, -1.0], atol=1e-12)
    np.testing.assert_allclose(out["upper"], [2.0, 2.0, 1.0], atol=1e-12)
    assert_usage_error(run("kinematics", "trilaterate", "--pivots-mm", "0", "0", "0", "10", "0", "0", "0", "10", "0",
                           "--lengths-mm", "3", "3", "3"), "no real solution")


def test_inverse_forward_round_trip_and_vertical_lift() -> None:
    inverse = run_json("kinematics", "inverse", "--tip-mm", "5", "-10", "80")
    heights = [repr(h) for h in inverse["heights"]]
    lasers = [repr(v) for v in inverse["lasers"]]
    forward = run_json("kinematics", "forward", "--heights-mm", *heights, "--lasers-mm", *lasers)
    np.testing.assert_allclose(forward["tip"], [5.0, -10.0, 80.0], atol=1e-9)
    assert max(abs(r) for r in forward["residuals"]) < 1e-9
    # vertical columns: all three motors 10 mm higher lift the tip by exactly 10 mm
    lifted = run_json("kinematics", "forward", "--heights-mm", *[repr(h + 10.0) for h in inverse["heights"]])
    np.testing.assert_allclose(lifted["tip"], [5.0, -10.0, 90.0], atol=1e-9)
    np.testing.assert_allclose(lifted["lasers"], inverse["lasers"], atol=1e-9)
    assert_usage_error(run("kinematics", "forward"), "neither")


def test_model_json_as_calibration(tmp_path: Path) -> None:
    machine = RigidBodyMachine.from_dpkm(column_slopes={"a": (0.01, 0.0), "b": (0.0, 0.01), "c": (0.0, 0.0)})
    path = tmp_path / "model.json"
    path.write_text(json.dumps(machine.to_dict()))
    out = run_json("kinematics", "inverse", "--tip-mm", "0", "0", "85", "--calibration", str(path))
    expected = machine.inverse([0.0, 0.0, 85.0])
    np.testing.assert_allclose(out["heights"], expected.heights, atol=1e-9)
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    assert_usage_error(run("kinematics", "inverse", "--tip-mm", "0", "0", "85", "--calibration", str(bad)), "JSON")


def test_process_log(tmp_path: Path) -> None:
    machine = RigidBodyMachine.from_dpkm()
    h0 = machine.reference_heights + np.array([0.0, 60.0, -50.0])
    moves = [(1, 6.0, True), (2, -4.0, False), (3, 5.0, True), (1, -3.0, True)]
    log_path = write_log(tmp_path / "log.csv", synthesise_log(machine, h0, moves))
    model = tmp_path / "model.json"
    model.write_text(json.dumps(machine.to_dict()))
    out = run_json("process-log", str(log_path), "--calibration", str(model), "--initial-heights-mm",
                   *[repr(float(h)) for h in h0])
    heights = h0 + np.array([[6.0, 0.0, 0.0], [6.0, -4.0, 5.0], [3.0, -4.0, 5.0]])
    truth = machine.forward(heights=heights).tip
    assert out["probe_rows"] == [3, 7, 9]  # file lines (header is line 1)
    np.testing.assert_allclose(out["probe_points"], truth, atol=1e-6)
    assert all(out["direction_consistent"])
    bad = tmp_path / "bad.csv"
    bad.write_text("start_stop,probe,motor,direction,laser_a,laser_b,laser_c\n1,0,7,1,50,51,52\n")
    assert_usage_error(run("process-log", str(bad)), "bad.csv:2")
    assert_usage_error(run("process-log", str(tmp_path / "missing.csv")), "missing.csv")


def test_sensitivity_plot(tmp_path: Path) -> None:
    png = tmp_path / "sens.png"
    out = run_json("sensitivity", "--points-per-axis", "3", "--plot", str(png))
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert out["points"] == 27
    assert out["path_ratio"]["z"] is None  # infinite: lasers do not see a vertical translation
    assert out["path_ratio"]["x"] > 10.0 and out["path_ratio"]["y"] > 10.0
    assert out["laser_gain"]["infinite"] == 3  # the level-pivot column through the centre
    assert_usage_error(run("sensitivity", "--points-per-axis", "3", "--plot", str(png)), "exists")
