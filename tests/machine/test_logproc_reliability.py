"""Redundancy, external reliability and the calibration's covariance of processed logs (issue 22).

Each statement is checked against an independent computation: redundancy numbers against the
hat matrix of a design matrix built by central differences of the pose solver's forward
kinematics; external reliability against the tip shifts of logs with a fault of MDB size
injected and processed with the gate off; the calibration's part of the tip covariance against
a seeded Monte Carlo over perturbed machines; the w-test's power against a Monte Carlo of noisy
logs with MDB faults.
"""

from __future__ import annotations

import json
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from pcmm_runner import run_pcmm
from scipy.stats import binom

from pcmm_geo.errors import InconsistentMeasurementError
from pcmm_geo.machine.analysis.logproc import (
    GEOMETRY_PARAMETERS,
    MeasurementLog,
    process_log,
    synthesise_log,
    write_log,
)
from pcmm_geo.machine.analysis.logproc.synthesis import with_laser_noise, with_reading_fault
from pcmm_geo.machine.kinematics.model import RigidBodyMachine, SliderLine, Tetrahedron

MOVES = [(1, 5.0, True), (2, -4.0, True), (3, 6.0, True), (1, -3.0, True), (2, 7.0, True), (3, -5.0, True),
         (2, 3.0, True), (1, 4.0, True)]
OBSERVED = np.r_[0, np.arange(1, 2 * len(MOVES), 2)]  # row 1 and the stop rows (start rows repeat them)


@pytest.fixture(scope="module")
def clean():
    machine = RigidBodyMachine.from_dpkm()
    h0 = machine.reference_heights + np.array([0.0, 60.0, -50.0])
    log = synthesise_log(machine, h0, MOVES)
    return machine, h0, log, process_log(machine, log, initial_heights=h0)


def test_redundancy_numbers_are_the_diagonal_of_an_independent_hat_matrix(clean) -> None:
    """r = diag(I - A (A^T W A)^-1 A^T W) with A from central differences of the pose solver."""
    machine, _, _, out = clean
    heights = out.heights[OBSERVED]
    # unknowns: the height of each move (the datum is held); each observed stop row k begins unknown k
    moved = [motor - 1 for motor, _, _ in MOVES]
    design = np.zeros((3 * len(OBSERVED), len(MOVES)))
    step = 1e-3
    for unknown, arm in enumerate(moved):
        standing = np.zeros(len(OBSERVED), dtype=bool)  # rows on which this height stands
        for row in range(1 + unknown, len(OBSERVED)):
            later = [k for k in range(unknown + 1, row) if moved[k] == arm]
            standing[row] = not later
        shift = np.zeros_like(heights)
        shift[standing, arm] = step
        up = machine.forward(heights=heights + shift).lasers
        down = machine.forward(heights=heights - shift).lasers
        design[:, unknown] = ((up - down) / (2 * step)).ravel()
    weights = np.tile(1.0 / out.laser_sigmas**2, len(OBSERVED))
    normal = design.T @ (weights[:, None] * design)
    hat = design @ np.linalg.solve(normal, design.T * weights)
    np.testing.assert_allclose(out.redundancy[OBSERVED].ravel(), 1.0 - np.diag(hat), atol=1e-6)


@pytest.mark.parametrize("row", [1, 5, 9, 15])
def test_external_reliability_is_the_tip_shift_of_an_undetected_mdb_fault(clean, row: int) -> None:
    """For every reading of a row: a fault of its MDB, processed with the gate off, moves each tip by at most
    tip_reliability; and the largest over the log's readings is tip_reliability itself."""
    machine, h0, log, out = clean
    worst = np.zeros(len(log))
    for index in OBSERVED:
        for arm in range(3):
            size = float(out.mdb[index, arm])
            faulty = with_reading_fault(log, int(index), arm, size)
            if index + 1 < len(log) and log.start_stop[index + 1] == 1:  # the start row repeats the reading
                faulty = with_reading_fault(faulty, int(index) + 1, arm, size)
            shifted = process_log(machine, faulty, initial_heights=h0, closure_tolerance=1e6)
            worst = np.maximum(worst, np.linalg.norm(shifted.tips - out.tips, axis=1))
    assert np.all(worst <= out.tip_reliability * 1.03 + 1e-9)  # first order; MDBs of 0.1-0.3 mm
    np.testing.assert_allclose(worst[row], out.tip_reliability[row], rtol=0.03)
    assert np.all(out.bound[1:] < 2.0) and out.tip_reliability[0] == 0.0  # row 1 stands on the datum


def test_reading_without_redundancy_has_an_infinite_mdb_and_an_unbounded_point() -> None:
    """A height seen by one reading only: no test can check it, its MDB and its point's reliability are infinite."""
    machine = RigidBodyMachine.from_dpkm()
    h0 = machine.reference_heights + np.array([0.0, 60.0, -50.0])
    log = synthesise_log(machine, h0, [(2, 4.0, True)])
    out = process_log(machine, log, initial_heights=h0, laser_steps=(0, 0, 0))
    assert np.all(out.redundancy[1] < 1.0) and out.redundancy[1].sum() == pytest.approx(2.0, abs=1e-6)
    # leave two of the three readings of the stop row out: one reading for the one unknown
    lasers = log.lasers.copy()
    lasers[1, [0, 2]] = 1e4  # outside the laser's range: refused, or left out with on_inconsistent="flag"
    flagged = process_log(machine, MeasurementLog(log.start_stop, log.probe, log.motor, log.direction, lasers),
                          initial_heights=h0, on_inconsistent="flag")
    assert flagged.faulty_readings[1].tolist() == [True, False, True] and flagged.inconsistent[1]
    assert flagged.redundancy[1, 1] < 1e-8 and np.isinf(flagged.mdb[1, 1]) and np.isnan(flagged.w_test[1, 1])
    assert np.isinf(flagged.tip_reliability[1]) and np.isinf(flagged.bound[1])
    np.testing.assert_allclose(flagged.tips[1], machine.forward(heights=h0 + np.array([0.0, 4.0, 0.0])).tip, atol=1e-6)


def _perturbed(machine: RigidBodyMachine, delta: np.ndarray) -> RigidBodyMachine:
    """The machine with its 28 GEOMETRY_PARAMETERS changed by ``delta`` (directions not renormalised)."""
    sliders = {}
    for k, arm in enumerate("abc"):
        line = machine.tetrahedron.sliders[arm]
        part = delta[8 * k:8 * k + 8]
        slider = SliderLine(line.point + part[:3], line.direction, line.laser_scale + part[6],
                            line.laser_offset + part[7])
        object.__setattr__(slider, "direction", line.direction + part[3:6])
        sliders[arm] = slider
    return replace(machine, tetrahedron=Tetrahedron(sliders, machine.tetrahedron.tip_center + delta[24:27]))


def test_calibration_covariance_enters_every_point_as_a_monte_carlo_over_machines_says() -> None:
    """Tips processed with the nominal machine from lasers of perturbed machines scatter as the propagated
    calibration part of the covariance predicts (200 draws, 20 %)."""
    machine = RigidBodyMachine.from_dpkm()
    h0 = machine.reference_heights + np.array([0.0, 60.0, -50.0])
    moves = MOVES[:5]
    sigma = np.array([0.005] * 3 + [2e-5] * 3 + [5e-5, 0.005])  # point, direction, scale, offset
    covariance = np.diag(np.r_[np.tile(sigma, 3), [0.003] * 3, 0.0] ** 2)
    assert covariance.shape == (len(GEOMETRY_PARAMETERS),) * 2
    nominal = process_log(machine, synthesise_log(machine, h0, moves), initial_heights=h0, laser_steps=(0, 0, 0))
    included = process_log(machine, synthesise_log(machine, h0, moves), initial_heights=h0, laser_steps=(0, 0, 0),
                           model_covariance=covariance)
    assert included.calibration_included and not nominal.calibration_included
    calibration_part = included.tip_covariance - nominal.tip_covariance
    rng = np.random.default_rng(7)
    errors = []
    for _ in range(200):
        true_machine = _perturbed(machine, rng.normal(0.0, np.sqrt(np.diag(covariance))))
        truth = true_machine.forward(heights=nominal.heights, check_limits=False).tip
        lasers = true_machine.forward(heights=nominal.heights, check_limits=False).lasers
        log = synthesise_log(machine, h0, moves)
        observed = MeasurementLog(log.start_stop, log.probe, log.motor, log.direction, lasers)
        processed = process_log(machine, observed, initial_heights=h0, laser_steps=(0, 0, 0), closure_tolerance=1.0)
        errors.append(processed.tips - truth)
    errors = np.array(errors)
    predicted = np.sqrt(np.trace(calibration_part, axis1=1, axis2=2))
    observed_rms = np.sqrt((errors**2).sum(axis=-1).mean(axis=0))
    np.testing.assert_allclose(observed_rms[1:], predicted[1:], rtol=0.2)
    assert np.all(predicted[1:] > 0.003)  # the tip centre's own 3 um at least
    assert np.all(included.tip_uncertainty >= nominal.tip_uncertainty)


def test_power_of_the_w_test_for_faults_of_the_mdb() -> None:
    """Noise at the stated sigma and a fault of exactly the reading's MDB: refused in at least 80 % of trials
    (one-sided binomial test at 0.1 %)."""
    machine = RigidBodyMachine.from_dpkm()
    h0 = machine.reference_heights + np.array([0.0, 60.0, -50.0])
    log = synthesise_log(machine, h0, MOVES)
    sigma = 0.01
    reference = process_log(machine, log, initial_heights=h0, laser_sigma=sigma, laser_steps=(0, 0, 0))
    rng = np.random.default_rng(3)
    refused = trials = 0
    for _ in range(150):
        row = int(rng.choice(OBSERVED[1:]))
        arm = int(rng.integers(3))
        noisy = with_laser_noise(log, rng, sigma)
        faulty = with_reading_fault(noisy, row, arm, float(reference.mdb[row, arm]) * float(rng.choice((-1, 1))))
        trials += 1
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # flags of accepted logs do not matter here
                process_log(machine, faulty, initial_heights=h0, laser_sigma=sigma, laser_steps=(0, 0, 0))
        except InconsistentMeasurementError:
            refused += 1
    assert binom.sf(refused - 1, trials, 0.8) > 1e-3 or refused / trials >= 0.8, (refused, trials)
    assert refused / trials > 0.7


def test_max_bound_leaves_points_out_and_the_cli_reports_r_and_the_bound(clean, tmp_path: Path) -> None:
    machine, h0, log, out = clean
    limit = float(np.median(out.bound[out.probe_rows]))
    bounded = process_log(machine, log, initial_heights=h0, max_bound=limit)
    assert np.all(bounded.bound[bounded.probe_rows] <= limit)
    np.testing.assert_array_equal(np.sort(np.r_[bounded.probe_rows, bounded.rejected_probe_rows]), out.probe_rows)
    assert bounded.over_bound.sum() == np.sum(out.bound > limit) and np.sum(out.bound[out.probe_rows] > limit) > 0
    path = write_log(tmp_path / "log.csv", log)
    heights = [repr(float(h)) for h in h0]
    proc = run_pcmm("process-log", path, "--initial-heights-mm", *heights, "--json", "--max-bound-mm", repr(limit))
    assert proc.returncode == 0, proc.stderr
    data = json.loads(proc.stdout)
    np.testing.assert_allclose(data["tip_reliability_mm"], out.tip_reliability, rtol=1e-9)
    np.testing.assert_allclose(data["bound_mm"], out.bound, rtol=1e-9)
    assert data["over_bound_data_rows"] == (np.flatnonzero(bounded.over_bound) + 1).tolist()
    assert [len(row) for row in data["mdb_mm"]] == [3] * len(log)
    table = run_pcmm("process-log", path, "--initial-heights-mm", *heights)
    assert "R / mm" in table.stdout and "U+R / mm" in table.stdout and "stated bound U (k = 2) + R" in table.stdout


def test_cli_takes_the_calibration_files_covariance_into_every_point(tmp_path: Path) -> None:
    """``pcmm calibrate --probing-u-mm --laser-u-mm --out CAL.json``, then ``pcmm process-log --calibration``."""
    from pcmm_geo.cli.machine.kinematics import load_machine_file
    from pcmm_geo.demo import CALIBRATION_LASERS, DemoSettings, simulate_probings, true_machine
    from pcmm_geo.machine.calibration.probings import write_lasers_csv, write_probings_csv

    settings = DemoSettings(seed=7)
    probings = simulate_probings(true_machine(settings), settings, np.random.default_rng(7))
    points = {("tip", None): probings["tip"]}
    for arm in "abc":
        for position, pts in probings[f"joint_{arm}"].items():
            points[(f"joint_{arm}", position)] = pts
    probe_file = write_probings_csv(tmp_path / "probings.csv", points)
    laser_file = write_lasers_csv(tmp_path / "lasers.csv", [1, 2, 3], CALIBRATION_LASERS)
    run = run_pcmm

    cal, bare = tmp_path / "cal.json", tmp_path / "bare.json"
    assert run("calibrate", str(probe_file), str(laser_file), "--probing-u-mm", "0.002", "--laser-u-mm", "0.002",
               "--out", str(cal)).returncode == 0
    assert run("calibrate", str(probe_file), str(laser_file), "--out", str(bare)).returncode == 0
    machine = load_machine_file(str(cal))  # the calibrated tetrahedron on the thesis' columns
    h0 = machine.reference_heights + np.array([0.0, 60.0, -50.0])
    path = write_log(tmp_path / "log.csv", synthesise_log(machine, h0, MOVES))
    heights = [repr(float(h)) for h in h0]
    with_covariance = run("process-log", str(path), "--calibration", str(cal), "--initial-heights-mm", *heights,
                          "--json")
    without = run("process-log", str(path), "--calibration", str(bare), "--initial-heights-mm", *heights, "--json")
    assert with_covariance.returncode == 0 and without.returncode == 0, with_covariance.stderr
    data, reference = json.loads(with_covariance.stdout), json.loads(without.stdout)
    assert data["calibration_covariance"] and not reference["calibration_covariance"]
    np.testing.assert_allclose(data["tips"], reference["tips"], atol=1e-9)  # the points do not change, their u does
    u, u0 = np.array(data["tip_uncertainty_mm"][1:]), np.array(reference["tip_uncertainty_mm"][1:])
    assert np.all(u > u0) and np.all(u**2 - u0**2 > 1e-6)  # at least (1 um)^2 from the calibration
    text = run("process-log", str(path), "--calibration", str(cal), "--initial-heights-mm", *heights)
    assert "and the calibration's covariance" in text.stdout


def test_mdb_under_either_reading_of_a_start_row_is_that_of_an_independent_hat_matrix() -> None:
    """Near the level pose a fault in laser i of a stop row can make the start row after it look like a further
    move of the motor (where c_i^2 > 1/2 of that motor's gain): the stated MDB of such a reading is the larger of
    its MDBs in both models.  The other model's MDB must equal the one from the hat matrix of that model's design
    matrix (the start row begins a height of the row's motor), built by central differences of the forward
    kinematics at the processed heights, and the criterion must be that gain's."""
    from pcmm_geo.machine.analysis.logproc.gate import gate_limits
    from pcmm_geo.machine.analysis.logproc.segments import segment_log

    machine = RigidBodyMachine.from_dpkm()
    h0 = machine.reference_heights
    sigma = 0.01
    log = with_laser_noise(synthesise_log(machine, h0, MOVES), np.random.default_rng(5), sigma)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # ambiguity near level is not the point here
        out = process_log(machine, log, initial_heights=h0, laser_sigma=sigma, laser_steps=(0, 0, 0),
                          on_inconsistent="flag")
    limits = gate_limits()
    own = limits.mdb(out.laser_sigmas, out.redundancy)
    settled = frozenset(int(r) for r in np.flatnonzero((log.start_stop == 1) & (out.moved_arm < 0)) if r > 0)
    weights = np.tile(1.0 / out.laser_sigmas**2, len(log))
    widened = 0
    for row in np.flatnonzero((log.start_stop == 0) & (out.moved_arm >= 0)):
        start = int(row) + 1
        if start not in settled:
            continue
        arm = int(log.motor[row]) - 1
        step = np.zeros(3)
        step[arm] = 1e-4
        gain = (machine.forward(heights=out.heights[row] + step).lasers
                - machine.forward(heights=out.heights[row] - step).lasers) / 2e-4
        pattern = (gain / out.laser_sigmas) ** 2 / np.sum((gain / out.laser_sigmas) ** 2)
        other = segment_log(log, None, settled - {start})  # the start row begins a height of the row's motor
        assert other.observed.all() and other.count == 3 + np.sum(out.moved_arm >= 0) + 1  # one height more
        design = np.zeros((3 * len(log), other.count - 3))
        for segment in range(3, other.count):
            standing = other.active[:, other.arm[segment]] == segment
            shift = np.zeros((len(log), 3))
            shift[standing, other.arm[segment]] = 1e-4
            up = machine.forward(heights=out.heights + shift).lasers
            down = machine.forward(heights=out.heights - shift).lasers
            design[:, segment - 3] = ((up - down) / 2e-4).ravel()
        hat = design @ np.linalg.solve(design.T @ (weights[:, None] * design), design.T * weights)
        redundancy = (1.0 - np.diag(hat)).reshape(-1, 3)[[row, start]]
        expected = np.where(pattern > 0.5, np.maximum(own[[row, start]], limits.mdb(out.laser_sigmas, redundancy)),
                            own[[row, start]])
        np.testing.assert_allclose(out.mdb[[row, start]], expected, rtol=2e-3)  # r near 0: digits
        widened += int(np.sum(out.mdb[[row, start]] > 1.2 * own[[row, start]]))
    assert widened >= 3  # near level the other model matters
