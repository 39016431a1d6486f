"""Per-row tip uncertainty of process_log against seeded Monte Carlo over synthesised logs, and its limit.

The truth is independent of the first-order propagation: many noisy copies of a noise-free
synthesised log are processed, and the scatter of each row's tip is compared with the predicted
covariance.  Tolerances: 200 trials estimate a standard deviation to about 5 % (1/sqrt(2N)); the
test allows 20 %.
"""

from __future__ import annotations

import json
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest
from pcmm_runner import run_pcmm

from pcmm_geo.errors import IllConditionedWarning, InvalidInputError
from pcmm_geo.machine.analysis.logproc import (
    DEFAULT_MAX_TIP_UNCERTAINTY,
    SEED_LASER_SIGMA,
    MeasurementLog,
    process_log,
    synthesise_log,
    write_log,
)
from pcmm_geo.machine.analysis.logproc.uncertainty import flag_uncertain_tips
from pcmm_geo.machine.kinematics.model import RigidBodyMachine

MOVES = [(1, 6.0, True), (2, -5.0, True), (3, 4.0, True)]
TRIALS = 200
#: count step of the ILD1302 lasers as a standard uncertainty (12.46 um / sqrt(12)), mm
COUNT_SIGMA = 0.0036


def noisy_copy(log: MeasurementLog, rng: np.random.Generator, sigma: float) -> MeasurementLog:
    """Gaussian laser noise per reading; a start row repeats the previous stop row's reading (as logged)."""
    lasers = log.lasers.copy()
    for row in range(len(log)):
        if row > 0 and log.start_stop[row] == 1:
            lasers[row] = lasers[row - 1]
        else:
            lasers[row] = log.lasers[row] + rng.normal(0.0, sigma, 3)
    return MeasurementLog(log.start_stop, log.probe, log.motor, log.direction, lasers)


def monte_carlo(offsets, sigma: float, seed: int = 1):
    machine = RigidBodyMachine.from_dpkm()
    start = machine.reference_heights + np.asarray(offsets, dtype=float)
    log = synthesise_log(machine, start, MOVES)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IllConditionedWarning)  # near level: ambiguity flags, tested elsewhere
        predicted = process_log(machine, log, initial_heights=start, laser_sigma=sigma, laser_steps=(0, 0, 0),
                                max_tip_uncertainty=np.inf)
        rng = np.random.default_rng(seed)
        tips = np.array([
            process_log(machine, noisy_copy(log, rng, sigma), initial_heights=start, laser_sigma=sigma,
                        laser_steps=(0, 0, 0), on_inconsistent="flag", max_tip_uncertainty=np.inf).tips
            for _ in range(TRIALS)
        ])
    errors = tips - predicted.tips  # noise-free processing is exact (test_logproc): the truth
    return predicted, errors


@pytest.mark.parametrize(
    ("offsets", "sigma", "expected_range"),
    [
        # issue 22: every height from every reading, start heights held: u fell from 0.11-0.14 mm (first case)
        ((0.0, 60.0, -50.0), SEED_LASER_SIGMA, (0.06, 0.13)),  # well conditioned, thesis lasers
        ((0.0, 20.0, -15.0), SEED_LASER_SIGMA, (0.18, 0.43)),
        ((0.0, 8.0, -6.0), COUNT_SIGMA, (0.04, 0.18)),  # near level: gain ~40, first order holds for small noise
        ((0.0, 5.0, -4.0), COUNT_SIGMA, (0.05, 0.24)),
    ],
)
def test_first_order_tip_uncertainty_matches_monte_carlo(offsets, sigma, expected_range) -> None:
    predicted, errors = monte_carlo(offsets, sigma)
    stop_rows = np.array([1, 3, 5])  # the start rows repeat them
    u_predicted = predicted.tip_uncertainty[stop_rows]
    assert expected_range[0] < u_predicted.min() and u_predicted.max() < expected_range[1]
    u_mc = np.sqrt((errors[:, stop_rows] ** 2).sum(axis=-1).mean(axis=0))
    np.testing.assert_allclose(u_mc, u_predicted, rtol=0.2)
    # per axis, and the full covariance's largest principal spread, on the last row (carried the longest)
    np.testing.assert_allclose(errors[:, -1].std(axis=0), predicted.tip_u[-1], rtol=0.2)
    largest_mc = np.linalg.eigvalsh(np.cov(errors[:, -1].T))[-1]
    largest = np.linalg.eigvalsh(predicted.tip_covariance[-1])[-1]
    assert abs(np.sqrt(largest_mc / largest) - 1.0) < 0.2
    assert not predicted.uncertain.any()  # limit inf


def test_near_level_rows_are_flagged_and_first_order_is_not_pessimistic() -> None:
    """Pivots within ~5 mm of level, thesis lasers: u reaches millimetres; the true scatter is at least that."""
    predicted, errors = monte_carlo((0.0, 5.0, -4.0), SEED_LASER_SIGMA)
    stop_rows = np.array([1, 3, 5])
    u_mc = np.sqrt((errors[:, stop_rows] ** 2).sum(axis=-1).mean(axis=0))
    assert np.all(predicted.tip_uncertainty[stop_rows] > 0.5)  # 0.55, 0.96, 1.51 mm
    assert np.all(u_mc > 0.9 * predicted.tip_uncertainty[stop_rows])  # MC 0.61-1.55 mm: first order is optimistic
    machine = RigidBodyMachine.from_dpkm()
    start = machine.reference_heights + np.array([0.0, 5.0, -4.0])
    with pytest.warns(IllConditionedWarning, match=r"1 of 6 log rows have a tip uncertainty above 1 mm"):
        flagged = process_log(machine, synthesise_log(machine, start, MOVES), initial_heights=start)
    assert flagged.uncertain.tolist() == [False] * 5 + [True]
    assert flagged.max_tip_uncertainty == DEFAULT_MAX_TIP_UNCERTAINTY
    assert flagged.probe_rows.size == 3  # kept (consistent), but marked


def test_well_conditioned_log_is_not_flagged_and_uncertainty_grows_along_the_log() -> None:
    machine = RigidBodyMachine.from_dpkm()
    start = machine.reference_heights + np.array([0.0, 60.0, -50.0])
    out = process_log(machine, synthesise_log(machine, start, MOVES), initial_heights=start)  # no warning
    assert not out.uncertain.any()
    # the unobservable common height random-walks from the datum: z uncertainty grows row by row
    assert np.all(np.diff(out.tip_u[1::2, 2]) > 0)
    np.testing.assert_allclose(out.tip_uncertainty, np.sqrt(np.trace(out.tip_covariance, axis1=1, axis2=2)))
    assert np.all(np.linalg.eigvalsh(out.tip_covariance) > -1e-12)  # positive semi-definite


@pytest.mark.parametrize("slopes", [None, {"a": (0.0075, 0.0201), "b": (0.0082, 0.0192), "c": (0.0069, 0.0153)}])
def test_first_row_holds_the_start_heights(slopes) -> None:
    """Row 1 is the start position (issue 22): its tip is the forward tip of the start heights, u = 0 relative to
    that datum, and its lasers only check it (a 2 um change moves no tip of the log).

    Before issue 22 row 1 held only the datum's common height and took the height differences from its
    lasers: u 81/59/15 um; at the level start the lasers' 12.5 um steps made them +-1 mm wrong.
    """
    machine = RigidBodyMachine.from_dpkm(column_slopes=slopes)
    start = machine.reference_heights + np.array([0.0, 60.0, -50.0])
    log = synthesise_log(machine, start, [(1, 3.0, True), (2, -4.0, True)])
    out = process_log(machine, log, initial_heights=start)  # no warning
    np.testing.assert_allclose(out.tips[0], machine.forward(heights=start).tip, atol=1e-9)
    assert np.all(out.tip_u[0] == 0.0) and out.redundancy[0].tolist() == [1.0, 1.0, 1.0]
    for arm in range(3):
        lasers = log.lasers.copy()
        lasers[0, arm] += 0.002  # row 1 only
        moved = MeasurementLog(log.start_stop, log.probe, log.motor, log.direction, lasers)
        processed = process_log(machine, moved, initial_heights=start, max_tip_uncertainty=np.inf)
        np.testing.assert_allclose(processed.tips, out.tips, atol=1e-9)
        assert abs(processed.w_test[0, arm]) == pytest.approx(0.002 / out.laser_sigmas[arm], rel=1e-3)


def test_flag_uncertain_tips_rules() -> None:
    covariance = np.stack([np.eye(3) * 0.01, np.full((3, 3), np.nan), np.eye(3) * 1.0])
    with pytest.warns(IllConditionedWarning, match="1 of 3"):
        u, marked = flag_uncertain_tips(covariance, 1.0, tested=np.array([True, False, True]))
    np.testing.assert_allclose(u[[0, 2]], [np.sqrt(0.03), np.sqrt(3.0)])
    assert marked.tolist() == [False, False, True]  # NaN row untested: not marked
    with pytest.raises(InvalidInputError, match="max_tip_uncertainty"):
        flag_uncertain_tips(covariance, 0.0)
    with pytest.raises(InvalidInputError, match="tip_covariance"):
        flag_uncertain_tips(np.eye(3), 1.0)
    machine = RigidBodyMachine.from_dpkm()
    with pytest.raises(InvalidInputError, match="max_tip_uncertainty"):
        process_log(machine, synthesise_log(machine, machine.reference_heights, MOVES), max_tip_uncertainty=np.nan)


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return run_pcmm(*args)


def test_cli_reports_u_warns_and_refuses_on_request(tmp_path: Path) -> None:
    machine = RigidBodyMachine.from_dpkm()
    start = machine.reference_heights + np.array([0.0, 5.0, -4.0])
    path = write_log(tmp_path / "near_level.csv", synthesise_log(machine, start, MOVES))
    heights = [repr(float(h)) for h in start]
    proc = run("process-log", str(path), "--initial-heights-mm", *heights, "--json")
    assert proc.returncode == 0, proc.stderr
    warning = proc.stderr.strip().splitlines()
    assert len(warning) == 1 and "IllConditionedWarning: 1 of 6 log rows have a tip uncertainty above 1 mm" in \
        warning[0]
    data = json.loads(proc.stdout)
    assert data["uncertain_data_rows"] == [6]
    assert data["max_tip_uncertainty_mm"] == 1.0
    assert [round(u, 2) for u in data["probe_tip_uncertainty_mm"]] == [0.55, 0.96, 1.51]
    assert len(data["tip_u_mm"]) == 6 and len(data["tip_u_mm"][0]) == 3
    table = run("process-log", str(path), "--initial-heights-mm", *heights, "--max-tip-u-mm", "5")
    assert table.returncode == 0 and table.stderr == ""
    assert "u / mm" in table.stdout and "R / mm" in table.stdout
    flags = [line.split()[-1] for line in table.stdout.splitlines() if line[:4].strip() in ("3", "5", "7")]
    assert flags == ["-", "-", "-"]  # the flags column
    flagged = run("process-log", str(path), "--initial-heights-mm", *heights)
    flags = [line.split()[-1] for line in flagged.stdout.splitlines() if line[:4].strip() in ("3", "5", "7")]
    assert flags == ["-", "-", "uncertain"]
    refused = run("process-log", str(path), "--initial-heights-mm", *heights, "--refuse-uncertain")
    assert refused.returncode == 2 and refused.stdout == ""
    error = [line for line in refused.stderr.splitlines() if "error" in line]
    assert len(error) == 1 and "tip uncertainty of log row 6" in error[0] and "<= 1.0 mm" in error[0]
