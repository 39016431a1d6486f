"""Closure gating of log rows: a row whose lasers do not close the loop gives no point (issue 16, item 4)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.errors import ConvergenceError, InconsistentMeasurementError, InvalidInputError
from pcmm_geo.machine.analysis.logproc import (
    CLOSURE_SIGMAS,
    SEED_LASER_SIGMA,
    MeasurementLog,
    process_log,
    synthesise_log,
    write_log,
)
from pcmm_geo.machine.kinematics.model import RigidBodyMachine

MOVES = [(1, 5.0, True), (2, -4.0, True), (3, 6.0, True), (1, -3.0, True), (2, 7.0, True), (3, -5.0, True)]
FAULT = 5.0  # mm on one laser


@pytest.fixture(scope="module")
def clean() -> tuple[RigidBodyMachine, np.ndarray, MeasurementLog, np.ndarray]:
    machine = RigidBodyMachine.from_dpkm()
    h0 = machine.reference_heights + np.array([0.0, 60.0, -50.0])
    log = synthesise_log(machine, h0, MOVES)
    heights = [h0.copy()]
    for motor, change, _ in MOVES:
        heights.append(heights[-1].copy())  # start row: before the move
        after = heights[-1].copy()
        after[motor - 1] += change
        heights.append(after)
    truth = machine.forward(heights=np.array(heights[1:])).tip
    return machine, h0, log, truth


def with_fault(log: MeasurementLog, rows: list[int], arm: int, size: float = FAULT) -> MeasurementLog:
    lasers = log.lasers.copy()
    lasers[rows, arm] += size
    return MeasurementLog(log.start_stop, log.probe, log.motor, log.direction, lasers)


def test_clean_log_passes_and_gating_changes_nothing(clean) -> None:
    machine, h0, log, truth = clean
    gated = process_log(machine, log, initial_heights=h0)
    ungated = process_log(machine, log, initial_heights=h0, closure_tolerance=1e9, on_inconsistent="flag")
    assert not gated.inconsistent.any() and gated.rejected_probe_rows.size == 0
    assert gated.closure_residual.max() < 1e-8 and gated.closure_sigmas.max() < 1e-2
    assert np.all((gated.closure_tolerance > 0.01) & (gated.closure_tolerance < 1.0))  # 6 sigma of 29 um lasers
    np.testing.assert_allclose(gated.tips, truth, atol=1e-6)  # independent truth: forward from the heights
    np.testing.assert_allclose(gated.tips, ungated.tips, atol=1e-9, rtol=0)
    np.testing.assert_allclose(gated.heights, ungated.heights, atol=1e-9, rtol=0)
    np.testing.assert_array_equal(gated.probe_rows, np.arange(1, len(log), 2))


@pytest.mark.parametrize("row", range(12))
@pytest.mark.parametrize("arm", range(3))
def test_five_mm_laser_fault_raises_naming_the_row(clean, row: int, arm: int) -> None:
    machine, h0, log, _ = clean
    with pytest.raises(InconsistentMeasurementError, match=f"closure of log row {row + 1}:") as info:
        process_log(machine, with_fault(log, [row], arm), initial_heights=h0)
    error = info.value
    assert error.what == f"closure of log row {row + 1}" and error.unit == "mm"
    assert 0.01 < error.tolerance < 0.8  # 6 standard deviations of the predicted scatter along the residual
    assert 0.8 < error.residual <= FAULT + 1e-6  # the part of the fault the pose cannot absorb
    assert "standard deviations of its predicted scatter" in error.detail


@pytest.mark.parametrize("row", range(1, 12))
@pytest.mark.parametrize("arm", range(3))
def test_flagged_row_gives_no_point_and_does_not_corrupt_later_rows(clean, row: int, arm: int) -> None:
    machine, h0, log, truth = clean
    out = process_log(machine, with_fault(log, [row], arm), initial_heights=h0, on_inconsistent="flag")
    np.testing.assert_array_equal(np.flatnonzero(out.inconsistent), [row])
    assert out.closure_residual[row] > 0.8
    if log.probe[row]:
        assert out.rejected_probe_rows.tolist() == [row] and row not in out.probe_rows
    others = np.delete(np.arange(len(log)), row)
    np.testing.assert_allclose(out.tips[others], truth[others], atol=1e-6)  # before and after the bad row
    np.testing.assert_allclose(out.probe_points, truth[out.probe_rows], atol=1e-6)


def test_fault_on_a_start_row_no_longer_corrupts_the_rest_of_the_log(clean) -> None:
    """A start row whose lasers differ re-solves the previous motor; a wrong laser there used to be carried on."""
    machine, h0, log, truth = clean
    faulty = with_fault(log, [4], 1)  # start row of move 3: lasers differ from the stop row before it
    old_behaviour = process_log(machine, faulty, initial_heights=h0, closure_tolerance=1e9, on_inconsistent="flag")
    assert np.abs(old_behaviour.tips[5:] - truth[5:]).max() > 5.0  # the wrong height was held from row 5 on
    out = process_log(machine, faulty, initial_heights=h0, on_inconsistent="flag")
    np.testing.assert_array_equal(np.flatnonzero(out.inconsistent), [4])
    np.testing.assert_allclose(out.tips[5:], truth[5:], atol=1e-6)


def test_start_row_repeating_an_inconsistent_stop_row_is_marked_too(clean) -> None:
    machine, h0, log, truth = clean
    out = process_log(machine, with_fault(log, [5, 6], 1), initial_heights=h0, on_inconsistent="flag")
    np.testing.assert_array_equal(np.flatnonzero(out.inconsistent), [5, 6])
    np.testing.assert_allclose(out.tips[7:], truth[7:], atol=1e-6)


@pytest.mark.parametrize("arm", range(3))
def test_inconsistent_first_row_loses_only_the_datum(clean, arm: int) -> None:
    """Later rows are right up to one common vertical offset (the lasers cannot see a common height)."""
    machine, h0, log, truth = clean
    out = process_log(machine, with_fault(log, [0], arm), initial_heights=h0, on_inconsistent="flag")
    np.testing.assert_array_equal(np.flatnonzero(out.inconsistent), [0])
    offset = out.tips[1:] - truth[1:]
    np.testing.assert_allclose(offset - offset.mean(axis=0), 0.0, atol=1e-6)
    np.testing.assert_allclose(offset.mean(axis=0)[:2], 0.0, atol=1e-6)


def test_closure_statistic_follows_its_chi_square_law_under_laser_noise() -> None:
    """800 rows with 1 um Gaussian laser noise: none refused, mean (r/sd)^2 = 2 (two redundant laser combinations)."""
    machine = RigidBodyMachine.from_dpkm()
    rng = np.random.default_rng(1)
    h0 = machine.reference_heights + np.array([0.0, 60.0, -50.0])
    moves = [(int(rng.integers(1, 4)), float(rng.uniform(-10, 10)), bool(rng.random() < 0.3)) for _ in range(400)]
    log = synthesise_log(machine, h0, moves)
    sigma = 1e-3
    lasers = log.lasers + rng.normal(0.0, sigma, log.lasers.shape)
    lasers[2::2] = lasers[1:-1:2]  # a start row repeats the reading of the stop row before it
    out = process_log(machine, MeasurementLog(log.start_stop, log.probe, log.motor, log.direction, lasers),
                      initial_heights=h0, laser_sigma=sigma)
    assert not out.inconsistent.any()
    statistic = out.closure_sigmas[out.moved_arm >= 0] ** 2
    assert 1.6 < statistic.mean() < 3.0  # 2.52 (the chi-square-2 mean is 2; first-order propagation)
    assert statistic.max() < CLOSURE_SIGMAS**2
    # the same noise with a 30 um fault on one laser of one stop row is caught
    lasers[101, 2] += 0.03
    with pytest.raises(InconsistentMeasurementError, match="log row 102"):
        process_log(machine, MeasurementLog(log.start_stop, log.probe, log.motor, log.direction, lasers),
                    initial_heights=h0, laser_sigma=sigma)


def test_seed_laser_counts_pass_the_default_test() -> None:
    """Lasers rounded to the seed sensors' counts (12.5 um a, b; 3.1 um c) pass with the count step's sigma (3.6 um)."""
    from pcmm_geo.acquisition.drivers.lasers import ild1302_from_mm, ild1302_to_mm, ild1420_from_mm, ild1420_to_mm

    assert SEED_LASER_SIGMA == pytest.approx(0.05 / np.sqrt(3.0), rel=1e-12)  # the thesis' 50 um, rectangular
    count_sigma = 200.0 * 1.02 / 16368 / np.sqrt(12.0)  # ILD1302 count step, uniform rounding: the floor
    machine = RigidBodyMachine.from_dpkm()
    rng = np.random.default_rng(2)
    h0 = machine.reference_heights + np.array([0.0, 60.0, -50.0])
    moves = [(int(rng.integers(1, 4)), float(rng.uniform(-10, 10)), bool(rng.random() < 0.3)) for _ in range(150)]
    log = synthesise_log(machine, h0, moves)
    counted = np.array([[ild1302_to_mm(ild1302_from_mm(a)), ild1302_to_mm(ild1302_from_mm(b)),
                         ild1420_to_mm(ild1420_from_mm(c))] for a, b, c in log.lasers])
    out = process_log(machine, MeasurementLog(log.start_stop, log.probe, log.motor, log.direction, counted),
                      initial_heights=h0, laser_sigma=count_sigma)
    assert not out.inconsistent.any()
    assert out.closure_sigmas.max() < 4.0
    statistic = out.closure_sigmas[out.moved_arm >= 0] ** 2
    assert 1.2 < statistic.mean() < 2.8  # 2.05 (laser c's finer counts pull it below 2, held heights above)


def test_explicit_closure_tolerance_in_mm(clean) -> None:
    machine, h0, log, _ = clean
    faulty = with_fault(log, [5], 0, size=0.05)
    loose = process_log(machine, faulty, initial_heights=h0, closure_tolerance=0.1)
    assert not loose.inconsistent.any() and np.all(loose.closure_tolerance == 0.1)
    with pytest.raises(InconsistentMeasurementError, match="log row 6") as info:
        process_log(machine, faulty, initial_heights=h0, closure_tolerance=0.01)
    assert info.value.tolerance == pytest.approx(0.01) and 0.01 < info.value.residual <= 0.05 + 1e-9


@pytest.mark.parametrize("reading", [-500.0, 1e4, 1e8])
def test_absurd_laser_reading(clean, reading: float) -> None:
    """A reading far off: refused (closure or no convergence); flagged, the other rows are exact."""
    machine, h0, log, truth = clean
    lasers = log.lasers.copy()
    lasers[3, 1] = reading
    faulty = MeasurementLog(log.start_stop, log.probe, log.motor, log.direction, lasers)
    with pytest.raises((InconsistentMeasurementError, ConvergenceError), match="log row 4"):
        process_log(machine, faulty, initial_heights=h0)
    out = process_log(machine, faulty, initial_heights=h0, on_inconsistent="flag")
    np.testing.assert_array_equal(np.flatnonzero(out.inconsistent), [3])
    others = np.delete(np.arange(len(log)), 3)
    np.testing.assert_allclose(out.tips[others], truth[others], atol=1e-6)


def test_bad_gating_arguments(clean) -> None:
    machine, h0, log, _ = clean
    with pytest.raises(InvalidInputError, match="on_inconsistent"):
        process_log(machine, log, initial_heights=h0, on_inconsistent="ignore")
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(InvalidInputError, match="closure_tolerance"):
            process_log(machine, log, initial_heights=h0, closure_tolerance=bad)


PCMM = str(Path(sys.executable).with_name("pcmm"))


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([PCMM, *args], capture_output=True, text=True, timeout=120, check=False)


def test_cli_refuses_an_inconsistent_row_and_keeps_it_only_when_asked(clean, tmp_path: Path) -> None:
    _, h0, log, truth = clean
    path = write_log(tmp_path / "fault.csv", with_fault(log, [5, 6], 1))  # stop row of move 3 + its start row
    heights = [repr(float(h)) for h in h0]
    refused = run("process-log", str(path), "--initial-heights-mm", *heights)
    assert refused.returncode == 2 and refused.stdout == ""
    lines = refused.stderr.strip().splitlines()
    assert len(lines) == 1 and "fault.csv: closure of log row 6" in lines[0]
    assert "exceeds the tolerance" in lines[0] and "standard deviations" in lines[0]
    kept = run("process-log", str(path), "--initial-heights-mm", *heights, "--keep-inconsistent", "--json")
    assert kept.returncode == 0, kept.stderr
    data = json.loads(kept.stdout)
    assert data["inconsistent_data_rows"] == [6, 7] and data["rejected_probe_data_rows"] == [6]
    assert len(data["closure_tolerance_mm"]) == len(log) and data["closure_sigmas"][5] > 50
    good = [k for k in range(1, len(log), 2) if k != 5]
    np.testing.assert_allclose(data["probe_points"], truth[good], atol=1e-6)
    assert data["probe_rows"] == [k + 2 for k in good]  # file lines (header on line 1)
    wide = run("process-log", str(path), "--initial-heights-mm", *heights, "--max-closure-mm", "10", "--json")
    assert wide.returncode == 0 and json.loads(wide.stdout)["inconsistent_data_rows"] == []
    bad = run("process-log", str(path), "--max-closure-mm", "0")
    assert bad.returncode == 2 and "closure_tolerance" in bad.stderr
