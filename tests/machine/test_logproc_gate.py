"""The gate of log processing (issue 22): Baarda's w-test per laser reading on the network adjustment.

Truth is constructed: logs synthesised from known heights with the rigid-body model, faults
added to single readings, noise drawn from a seeded generator.  Before issue 22 each row was
tested on its own with the held heights taken as exact (a 6-sigma chi-square test); a fault in
the laser of the pivot that moved was absorbed by that pivot's new height and showed only on
later rows, which were refused in its place.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest
from pcmm_runner import run_pcmm

from pcmm_geo.errors import ConvergenceError, InconsistentMeasurementError, InvalidInputError, OutOfRangeError
from pcmm_geo.machine.analysis.logproc import (
    SEED_LASER_SIGMA,
    SEED_LASER_STEPS,
    MeasurementLog,
    process_log,
    synthesise_log,
    write_log,
)
from pcmm_geo.machine.analysis.logproc.gate import gate_limits, reading_sigmas
from pcmm_geo.machine.kinematics.model import RigidBodyMachine

MOVES = [(1, 5.0, True), (2, -4.0, True), (3, 6.0, True), (1, -3.0, True), (2, 7.0, True), (3, -5.0, True)]
FAULT = 5.0  # mm on one laser


def truth_of(machine: RigidBodyMachine, h0: np.ndarray, moves: list) -> np.ndarray:
    heights = [h0.copy()]
    for motor, change, _ in moves:
        heights.append(heights[-1].copy())  # start row: before the move
        after = heights[-1].copy()
        after[motor - 1] += change
        heights.append(after)
    return np.array(heights[1:])


@pytest.fixture(scope="module")
def clean() -> tuple[RigidBodyMachine, np.ndarray, MeasurementLog, np.ndarray]:
    machine = RigidBodyMachine.from_dpkm()
    h0 = machine.reference_heights + np.array([0.0, 60.0, -50.0])
    log = synthesise_log(machine, h0, MOVES)
    return machine, h0, log, machine.forward(heights=truth_of(machine, h0, MOVES)).tip


def with_fault(log: MeasurementLog, rows: list[int], arm: int, size: float = FAULT) -> MeasurementLog:
    lasers = log.lasers.copy()
    lasers[rows, arm] += size
    return MeasurementLog(log.start_stop, log.probe, log.motor, log.direction, lasers)


def test_b_method_constants() -> None:
    limits = gate_limits()
    assert limits.critical == pytest.approx(3.2905, abs=1e-4)  # two-sided 0.1 %
    assert limits.noncentrality == pytest.approx(4.13, abs=0.005)  # Baarda's delta0 for 0.1 % and 80 %
    assert limits.mdb(0.01, 0.25) == pytest.approx(limits.noncentrality * 0.01 / 0.5)
    assert np.isinf(limits.mdb(0.01, 0.0))
    assert SEED_LASER_SIGMA == pytest.approx(0.05 / np.sqrt(3.0), rel=1e-12)  # the thesis' 50 um, rectangular
    np.testing.assert_allclose(SEED_LASER_STEPS, [200 * 1.02 / 16368] * 2 + [200 * 1.02 / 65520])
    np.testing.assert_allclose(reading_sigmas(0.0), np.array(SEED_LASER_STEPS) / np.sqrt(12.0))


def test_clean_log_passes_with_the_redundancy_of_the_log(clean) -> None:
    machine, h0, log, truth = clean
    out = process_log(machine, log, initial_heights=h0)
    assert not out.inconsistent.any() and out.rejected_probe_rows.size == 0 and not out.faulty_readings.any()
    np.testing.assert_allclose(out.tips, truth, atol=1e-6)  # independent truth: forward from the heights
    assert out.closure_residual.max() < 1e-8 and np.nanmax(np.abs(out.w_test)) < 1e-3
    observed = np.r_[0, np.arange(1, len(log), 2)]  # start rows repeat the stop row before them
    # sum of redundancy numbers = readings - unknowns (one new height per move; the datum is fixed)
    assert out.redundancy[observed].sum() == pytest.approx(3 * len(observed) - len(MOVES), abs=1e-6)  # 1e-7: prior
    assert np.all((out.redundancy >= 0) & (out.redundancy <= 1))
    np.testing.assert_allclose(out.redundancy[0], 1.0)  # the first row only checks the start heights
    np.testing.assert_array_equal(out.probe_rows, np.arange(1, len(log), 2))


@pytest.mark.parametrize("row", range(12))
@pytest.mark.parametrize("arm", range(3))
def test_five_mm_fault_is_refused_naming_its_row_and_left_out_when_asked(clean, row: int, arm: int) -> None:
    machine, h0, log, truth = clean
    faulty = with_fault(log, [row], arm)
    with pytest.raises(InconsistentMeasurementError, match=f"closure of log row {row + 1}:") as info:
        process_log(machine, faulty, initial_heights=h0)
    error = info.value
    assert error.unit == "mm" and "w = " in error.detail and "critical value 3.29" in error.detail
    assert 0.01 < error.tolerance < 0.2 < error.residual <= FAULT + 1e-6
    out = process_log(machine, faulty, initial_heights=h0, on_inconsistent="flag")
    np.testing.assert_array_equal(np.flatnonzero(out.inconsistent), [row])
    assert out.faulty_readings[row, arm] and out.faulty_readings.sum() == 1
    if log.probe[row]:
        assert out.rejected_probe_rows.tolist() == [row] and row not in out.probe_rows
    others = np.delete(np.arange(len(log)), row)
    np.testing.assert_allclose(out.tips[others], truth[others], atol=1e-6)  # before and after the bad row


def test_a_fault_on_the_moved_pivots_laser_is_caught_by_the_rows_that_hold_it(clean) -> None:
    """Row 2 moved pivot a; its laser a mostly measures the new height, rows 3-6 (a standing) check it."""
    machine, h0, log, truth = clean
    out = process_log(machine, log, initial_heights=h0)
    assert out.redundancy[1, 0] > 0.9  # laser a of row 2: a stands until row 7
    faulty = with_fault(log, [1, 2], 0, size=0.3)  # the stop row and the start row repeating it
    flagged = process_log(machine, faulty, initial_heights=h0, on_inconsistent="flag")
    np.testing.assert_array_equal(np.flatnonzero(flagged.inconsistent), [1, 2])
    np.testing.assert_allclose(flagged.tips[3:], truth[3:], atol=1e-6)


@pytest.mark.parametrize("arm", range(3))
def test_a_faulty_start_row_reading_is_not_read_as_a_further_move(clean, arm: int) -> None:
    """A start row that differs from the row before in one laser only (0.3 mm, beyond the same-pose tolerance)
    is a wrong reading of the same pose, tested with the rows that hold that pose: refused alone, every other
    point exact.  (Read as the previous motor still moving, a new height absorbed part of the fault.)"""
    machine, h0, log, truth = clean
    faulty = with_fault(log, [4], arm, size=0.3)  # start row of the third move, which repeated row 4
    out = process_log(machine, faulty, initial_heights=h0, on_inconsistent="flag")
    assert out.moved_arm[4] == -1
    np.testing.assert_array_equal(np.flatnonzero(out.inconsistent), [4])
    assert out.faulty_readings[4, arm] and out.faulty_readings.sum() == 1
    others = np.delete(np.arange(len(log)), 4)
    np.testing.assert_allclose(out.tips[others], truth[others], atol=1e-6)


def test_an_unsettled_start_row_is_still_a_further_move_of_the_previous_motor(clean) -> None:
    """Thesis 3.5: the stop row of a move read pivot a 1 mm short of where it came to rest; the start row after it
    shows the rest of the move in all three lasers (the pattern of motor 1), so it begins a new height of a."""
    machine, h0, log, truth = clean
    short = truth_of(machine, h0, MOVES)[1].copy()
    short[0] -= 1.0
    lasers = log.lasers.copy()
    lasers[1] = machine.forward(heights=short).lasers
    out = process_log(machine, MeasurementLog(log.start_stop, log.probe, log.motor, log.direction, lasers),
                      initial_heights=h0)
    assert out.moved_arm[2] == 0 and not out.inconsistent.any()
    np.testing.assert_allclose(out.heights[1], short, atol=1e-6)
    np.testing.assert_allclose(out.tips[2:], truth[2:], atol=1e-6)


def test_first_row_fault_no_longer_costs_the_datum(clean) -> None:
    """The start heights are held: a wrong first-row laser is refused and nothing else moves (was: every point
    shifted by one common vertical offset)."""
    machine, h0, log, truth = clean
    for arm in range(3):
        out = process_log(machine, with_fault(log, [0], arm, 0.2), initial_heights=h0, on_inconsistent="flag")
        np.testing.assert_array_equal(np.flatnonzero(out.inconsistent), [0])
        np.testing.assert_allclose(out.tips, truth, atol=1e-6)


def test_w_statistic_is_standard_normal_under_laser_noise() -> None:
    """400 moves, 1 um Gaussian noise: w has mean 0 and standard deviation 1 (Baarda); MDB as its formula."""
    machine = RigidBodyMachine.from_dpkm()
    rng = np.random.default_rng(1)
    h0 = machine.reference_heights + np.array([0.0, 60.0, -50.0])
    moves = [(int(rng.integers(1, 4)), float(rng.uniform(-10, 10)), bool(rng.random() < 0.3)) for _ in range(400)]
    log = synthesise_log(machine, h0, moves)
    sigma = 1e-3
    lasers = log.lasers + rng.normal(0.0, sigma, log.lasers.shape)
    lasers[2::2] = lasers[1:-1:2]  # a start row repeats the reading of the stop row before it
    noisy = MeasurementLog(log.start_stop, log.probe, log.motor, log.direction, lasers)
    out = process_log(machine, noisy, initial_heights=h0, laser_sigma=sigma, laser_steps=(0, 0, 0),
                      on_inconsistent="flag")
    observed = np.r_[0, np.arange(1, len(log), 2)]
    w = out.w_test[observed][~out.faulty_readings[observed]]
    assert np.isnan(w).sum() <= 3  # readings no test can check (redundancy number ~0)
    w = w[np.isfinite(w)]
    assert abs(np.mean(w)) < 0.08 and 0.92 < np.std(w) < 1.08  # 1200 readings
    assert out.faulty_readings.sum() <= 5  # expected false alarms: 1.2 at alpha0 = 0.1 %
    tested = out.redundancy > 1e-6
    np.testing.assert_allclose(out.mdb[tested], gate_limits().noncentrality * sigma / np.sqrt(out.redundancy[tested]),
                               rtol=1e-9)
    # the same noise with a 30 um fault (~ 30 sigma) on one laser of one stop row is caught there
    lasers[101, 2] += 0.03
    with pytest.raises(InconsistentMeasurementError, match="log row 102"):
        process_log(machine, MeasurementLog(log.start_stop, log.probe, log.motor, log.direction, lasers),
                    initial_heights=h0, laser_sigma=sigma, laser_steps=(0, 0, 0), alpha=1e-6)


def test_seed_laser_counts_pass_with_the_reading_steps_alone() -> None:
    """Lasers rounded to the seed sensors' counts pass with laser_sigma = 0 (the steps' q/sqrt(12) only)."""
    from pcmm_geo.acquisition.drivers.lasers import ild1302_from_mm, ild1302_to_mm, ild1420_from_mm, ild1420_to_mm

    machine = RigidBodyMachine.from_dpkm()
    rng = np.random.default_rng(2)
    h0 = machine.reference_heights + np.array([0.0, 60.0, -50.0])
    moves = [(int(rng.integers(1, 4)), float(rng.uniform(-10, 10)), bool(rng.random() < 0.3)) for _ in range(150)]
    log = synthesise_log(machine, h0, moves)
    counted = np.array([[ild1302_to_mm(ild1302_from_mm(a)), ild1302_to_mm(ild1302_from_mm(b)),
                         ild1420_to_mm(ild1420_from_mm(c))] for a, b, c in log.lasers])
    out = process_log(machine, MeasurementLog(log.start_stop, log.probe, log.motor, log.direction, counted),
                      initial_heights=h0, laser_sigma=0.0)
    assert not out.inconsistent.any() and np.nanmax(np.abs(out.w_test)) < 3.29
    assert 0.6 < np.nanstd(out.w_test[1::2]) < 1.1  # uniform rounding: w spread close to 1


def test_explicit_closure_tolerance_in_mm(clean) -> None:
    machine, h0, log, _ = clean
    faulty = with_fault(log, [5], 0, size=0.05)
    loose = process_log(machine, faulty, initial_heights=h0, closure_tolerance=0.1)
    assert not loose.inconsistent.any() and loose.closure_tolerance == 0.1
    # the MDB of a fixed tolerance T at power 80 %: (T + z_0.8 sigma_v) / r
    r, sigma = loose.redundancy[5, 0], loose.laser_sigmas[0]
    assert loose.mdb[5, 0] == pytest.approx((0.1 + 0.8416 * sigma * np.sqrt(r)) / r, rel=1e-3)
    with pytest.raises(InconsistentMeasurementError, match="log row 6") as info:
        process_log(machine, faulty, initial_heights=h0, closure_tolerance=0.01)
    assert info.value.tolerance == pytest.approx(0.01) and 0.01 < info.value.residual <= 0.05 + 1e-9


@pytest.mark.parametrize("reading", [-500.0, 1e4, 1e8, 100.0])
def test_absurd_laser_reading(clean, reading: float) -> None:
    """A reading far off (outside the laser's 0-200 mm range, or 50 mm off within it): refused; flagged, the other
    rows are exact."""
    machine, h0, log, truth = clean
    lasers = log.lasers.copy()
    lasers[3, 1] = reading
    faulty = MeasurementLog(log.start_stop, log.probe, log.motor, log.direction, lasers)
    with pytest.raises((InconsistentMeasurementError, ConvergenceError, OutOfRangeError), match="log row 4"):
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
    for name, bad in (("alpha", 0.0), ("alpha", 1.0), ("power", 0.0005), ("laser_sigma", -1.0),
                      ("max_bound", 0.0), ("max_tip_uncertainty", -1.0)):
        with pytest.raises(InvalidInputError, match=name):
            process_log(machine, log, initial_heights=h0, **{name: bad})
    with pytest.raises(InvalidInputError, match="laser_steps"):
        process_log(machine, log, initial_heights=h0, laser_steps=(0.01, 0.01))
    with pytest.raises(InvalidInputError, match="model_covariance"):
        process_log(machine, log, initial_heights=h0, model_covariance=np.eye(3))




def run(*args: str) -> subprocess.CompletedProcess[str]:
    return run_pcmm(*args)


def test_cli_refuses_an_inconsistent_row_and_keeps_it_only_when_asked(clean, tmp_path: Path) -> None:
    _, h0, log, truth = clean
    path = write_log(tmp_path / "fault.csv", with_fault(log, [5, 6], 1))  # stop row of move 3 + its start row
    heights = [repr(float(h)) for h in h0]
    refused = run("process-log", str(path), "--initial-heights-mm", *heights)
    assert refused.returncode == 2 and refused.stdout == ""
    lines = refused.stderr.strip().splitlines()
    assert len(lines) == 1 and "fault.csv: closure of log row 6" in lines[0]
    assert "exceeds the tolerance" in lines[0] and "laser b: w = " in lines[0]
    kept = run("process-log", str(path), "--initial-heights-mm", *heights, "--keep-inconsistent", "--json")
    assert kept.returncode == 0, kept.stderr
    data = json.loads(kept.stdout)
    assert data["inconsistent_data_rows"] == [6, 7] and data["rejected_probe_data_rows"] == [6]
    assert data["faulty_readings"][5] == [False, True, False] and data["closure_tolerance_mm"] is None
    assert data["alpha"] == 0.001 and data["power"] == 0.8 and len(data["w_test"]) == len(log)
    good = [k for k in range(1, len(log), 2) if k != 5]
    np.testing.assert_allclose(data["probe_points"], truth[good], atol=1e-6)
    assert data["probe_rows"] == [k + 2 for k in good]  # file lines (header on line 1)
    wide = run("process-log", str(path), "--initial-heights-mm", *heights, "--max-closure-mm", "10", "--json")
    assert wide.returncode == 0 and json.loads(wide.stdout)["inconsistent_data_rows"] == []
    bad = run("process-log", str(path), "--max-closure-mm", "0")
    assert bad.returncode == 2 and "closure_tolerance" in bad.stderr
