"""Simulated sessions through ``process-log`` against the simulator's truth (issue 22).

Truth: the simulator's pivot heights from the logged motor positions and its forward kinematics
(:func:`~pcmm_geo.acquisition.simulators.cmm.simulated_truth`), never the processing's own
output.  Sessions are ``pcmm acquire --simulate`` runs (in process, virtual transport): the
default level start of the thesis and the off-level start ``0 60 -60``.  Their readings carry the
sensors' count steps only; "with noise" adds seeded Gaussian noise to every reading and rounds it
to the counts again: 2 um (the simulator's ``--defects`` noise) processed with the default laser
uncertainty (the thesis' 50 um accuracy, which such noise stays within), and 20 um processed
with that as its standard deviation on off-level sessions.  Faults are single readings made
wrong by 0.05-5 mm.  Coverage is counted over the points the processing states a bound for:
rows flagged ambiguous (a mirror pose fits as well) or unbounded are told apart, not counted.

The broad scans (many seeds, every arm and row, Monte Carlo power) are
``tools/process_log_scan.py``; the tests here run a seeded subset (``slow``: more seeds).
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import io
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import binom

from pcmm_geo.acquisition.acqlog import read_log as read_acquisition_log
from pcmm_geo.acquisition.simulators.cmm import OFF_LEVEL_START_OFFSETS, simulated_truth
from pcmm_geo.cli import main
from pcmm_geo.errors import InconsistentMeasurementError
from pcmm_geo.machine.analysis.logproc import SEED_LASER_STEPS, process_log, read_log
from pcmm_geo.machine.analysis.logproc.synthesis import with_laser_noise, with_reading_fault
from pcmm_geo.machine.kinematics.model import RigidBodyMachine

MACHINE = RigidBodyMachine.from_dpkm()  # the simulator's machine
SMALL_NOISE = 0.002  # mm, Gaussian: the simulator's --defects laser noise
NOISE = 0.02  # mm, Gaussian, on off-level sessions, processed with it as laser_sigma


def acquire(folder: Path, seed: int, offsets: tuple[float, ...] | None = None, moves: int = 60) -> Path:
    path = folder / f"session_{seed}_{'level' if offsets is None else 'off'}.csv"
    args = ["acquire", "--simulate", "--seed", str(seed), "--moves", str(moves), "--settle", "0", "--out", str(path)]
    if offsets is not None:
        args += ["--start-offsets-mm", *map(str, offsets)]
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(args) == 0
    return path


@functools.cache
def start_heights(path: Path) -> tuple[float, ...]:
    """The start heights a session's log states (read once per log: the fault scans process each log 168 times)."""
    return tuple(float(v) for v in read_acquisition_log(path).metadata["start_heights_mm"].split())


def process(path: Path, log=None, **options):
    start = list(start_heights(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # uncertain / ambiguous / unbounded rows of level sessions are expected
        return process_log(MACHINE, read_log(path) if log is None else log, initial_heights=start, **options)


def covered(path: Path, out) -> tuple[int, int]:
    """(rows within U (k = 2) of the truth, rows with a stated bound: consistent, not ambiguous, not unbounded)."""
    _, truth = simulated_truth(path)
    error = np.linalg.norm(out.tips - truth, axis=1)
    stated = ~out.inconsistent & ~out.ambiguous & np.isfinite(out.bound)
    return int(np.sum(error[stated] <= 2.0 * out.tip_uncertainty[stated] + 1e-9)), int(stated.sum())


def assert_at_least_95_percent(inside: int, total: int) -> None:
    """One-sided binomial test: coverage >= 95 % is not rejected at 0.1 %."""
    assert binom.cdf(inside, total, 0.95) > 1e-3, f"{inside} of {total} within U (k = 2)"


LEVEL_SEEDS = (1, 2, 3, 4, 5, 6)
OFF_SEEDS = (1, 2)


@pytest.fixture(scope="module")
def sessions(tmp_path_factory: pytest.TempPathFactory) -> dict[tuple[str, int], Path]:
    folder = tmp_path_factory.mktemp("sessions")
    logs = {("level", seed): acquire(folder, seed) for seed in LEVEL_SEEDS}
    logs.update({("off", seed): acquire(folder, seed, OFF_LEVEL_START_OFFSETS) for seed in OFF_SEEDS})
    return logs


def test_the_issue_reproduction_exits_0(sessions, capsys: pytest.CaptureFixture[str]) -> None:
    """``pcmm acquire --simulate --seed 4 --moves 60 --settle 0 && pcmm process-log`` exited 2 before issue 22."""
    assert main(["process-log", str(sessions["level", 4]), "--json"]) == 0
    assert '"inconsistent_data_rows": []' in capsys.readouterr().out


def test_default_sessions_process_and_cover_the_truth(sessions) -> None:
    """Every session processes (no refusal, no ConvergenceError); the tips lie within U (k = 2) of the truth."""
    inside = total = 0
    for (start, _), path in sessions.items():
        out = process(path)
        assert not out.inconsistent.any() and out.converged.all()
        if start == "off":  # well conditioned: tenths of a mm, no flag
            assert not (out.uncertain.any() or out.ambiguous.any() or out.unbounded.any())
            assert np.max(out.bound) < 2.0
        got, count = covered(path, out)
        inside, total = inside + got, total + count
    assert_at_least_95_percent(inside, total)


def test_sessions_with_noise_cover_the_truth(sessions) -> None:
    rng = np.random.default_rng(22)
    inside = total = 0
    for (start, _), path in sessions.items():
        small = with_laser_noise(read_log(path), rng, SMALL_NOISE, SEED_LASER_STEPS)
        out = process(path, small, on_inconsistent="flag")  # default laser_sigma: the stated accuracy
        assert not out.inconsistent.any()
        got, count = covered(path, out)
        inside, total = inside + got, total + count
        if start == "off":
            noisy = with_laser_noise(read_log(path), rng, NOISE, SEED_LASER_STEPS)
            out = process(path, noisy, laser_sigma=NOISE, on_inconsistent="flag")
            assert out.inconsistent.mean() < 0.05  # false alarms of a Gaussian log at alpha0 = 0.1 % per reading
            got, count = covered(path, out)
            inside, total = inside + got, total + count
    # Enough stated rows for the coverage test to have power: n = 610 rows reject a coverage of 90 % (instead of
    # 95 %) with probability >= 0.95 (binomial, the rejection level of assert_at_least_95_percent); see
    # test_the_coverage_count_has_power.  Level sessions legitimately flag most rows ambiguous (a mirror pose fits
    # as well), off-level ones none: about 765 stated rows of 1200 on this seed set.  (A count threshold of 768
    # failed with 767 on another machine: the branch search merged hypotheses on a key rounded to 1e-9 mm, so
    # whether a genuine 2.9 mm competitor survived depended on the last bits of a height, and ~95 rows of a level
    # session flipped; the merge is now by a 1e-6 mm tolerance, see test_branch_search_is_stable_to_rounding.)
    assert total >= MIN_STATED_ROWS, total
    assert_at_least_95_percent(inside, total)


#: stated rows the noise coverage test needs (test_the_coverage_count_has_power)
MIN_STATED_ROWS = 610


def test_the_coverage_count_has_power() -> None:
    """MIN_STATED_ROWS: the fewest rows with which a true coverage of 90 % fails the 95 % test with probability 0.95."""
    def power(n: int) -> float:
        rejected = int(binom.ppf(1e-3, n, 0.95))  # largest count assert_at_least_95_percent rejects
        while binom.cdf(rejected, n, 0.95) > 1e-3:
            rejected -= 1
        return float(binom.cdf(rejected, n, 0.90))

    assert power(MIN_STATED_ROWS) >= 0.95 > power(MIN_STATED_ROWS - 20)


def test_branch_search_is_stable_to_rounding(sessions) -> None:
    """Readings changed in their last bits (1e-13 relative) must not change which poses are ambiguous.

    Level session 2 with 2 um noise has a genuine competing set of branches (tips 2.5 mm apart, fitting as well):
    4 rows.  Before the merge of equal states was a tolerance, the branch search found 2 of them unperturbed and
    none in three of four perturbations (with the test's other noise draw, ~95 rows of a session flipped).
    """
    path = sessions["level", 2]
    noisy = with_laser_noise(read_log(path), np.random.default_rng(22), SMALL_NOISE, SEED_LASER_STEPS)
    flagged = []
    for k in range(4):
        scale = 0.0 if k == 0 else 1e-13
        lasers = noisy.lasers * (1.0 + scale * np.random.default_rng(k).uniform(-1.0, 1.0, noisy.lasers.shape))
        out = process(path, dataclasses.replace(noisy, lasers=lasers), on_inconsistent="flag")
        flagged.append(out.ambiguity > 0.1)  # a material ambiguity (mm), not one at the 1 um flag edge
    assert flagged[0].sum() > 0
    for other in flagged[1:]:
        assert np.array_equal(other, flagged[0])


SIZES = (0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0)


@pytest.mark.parametrize("arm", range(3))
@pytest.mark.parametrize("key", [("off", 1), ("level", 4)])
def test_fault_scan_accepted_faults_stay_within_the_bound(sessions, key, arm) -> None:
    """Single faults 0.05-5 mm on one arm of every fifth row (an odd step: stop rows and start rows alike): an
    accepted fault was below its MDB, and every point (its own row and the rows that carry its state) lies within
    U (k = 2) + R of the truth."""
    path = sessions[key]
    clean = read_log(path)
    _, truth = simulated_truth(path)
    refused = accepted = 0
    for row in range(1 + arm, len(clean), 5):
        for size in SIZES:
            faulty = with_reading_fault(clean, row, arm, size)
            try:
                out = process(path, faulty)
            except InconsistentMeasurementError:
                refused += 1
                continue
            accepted += 1
            assert size <= out.mdb[row, arm] * (1 + 1e-6), (row, arm, size, out.mdb[row, arm])
            error = np.linalg.norm(out.tips - truth, axis=1)
            assert np.all(error <= out.bound + 1e-9), (row, arm, size, np.max(error - out.bound))
    assert refused > 0 and accepted > 0
