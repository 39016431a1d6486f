"""Simulated sessions through ``process-log`` against the simulator's truth: the numbers of issue 22.

Four scans, all seeded, all against the simulator's own heights and tips
(:func:`pcmm_geo.acquisition.simulators.cmm.simulated_truth`), never against processed output:

``sessions``
    default sessions (``pcmm acquire --simulate --moves M --settle 0``) from the level start and
    from ``--start-offsets-mm 0 60 -60``, seeds 1..S: how many process (exit 0), how many tips lie
    within U (k = 2) of the truth, how many rows carry each flag; noise-free (count steps only),
    with 2 um Gaussian noise processed with the default laser uncertainty, and (off-level) with
    20 um processed with that as its standard deviation.
``faults``
    noise-free sessions, one reading at a time made wrong by 0.05-5 mm, every arm, every k-th
    row (stop rows and start rows alternately): refused or accepted; an accepted fault must lie
    below its MDB, and every point within U (k = 2) + R (+ ambiguity) of the truth.
``power``
    sessions with Gaussian noise at the stated sigma, a fault of the MDB (or a multiple of it) on one
    reading: the fraction refused (Baarda: the power, 80 % at one MDB) beside the theory's
    ``P(|N(delta, 1)| > k)``, with a binomial interval, split by whether the fault changed the
    log's segments (read as a further move of the motor).
``mdb``
    ranges of the redundancy numbers, MDBs and external reliabilities.

Usage (about 10-30 min for the defaults on one core; ``--quick`` for a few minutes)::

    OPENBLAS_NUM_THREADS=1 python tools/process_log_scan.py [--seeds 20] [--moves 60] [--quick] [--out out/scan.json]
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from pcmm_geo.acquisition.acqlog import read_log as read_acquisition_log  # noqa: E402
from pcmm_geo.acquisition.simulators.cmm import OFF_LEVEL_START_OFFSETS, simulated_truth  # noqa: E402
from pcmm_geo.cli import main  # noqa: E402
from pcmm_geo.errors import ConvergenceError, InconsistentMeasurementError, OutOfRangeError  # noqa: E402
from pcmm_geo.machine.analysis.logproc import SEED_LASER_STEPS, process_log, read_log  # noqa: E402
from pcmm_geo.machine.analysis.logproc.gate import DEFAULT_ALPHA, DEFAULT_POWER, gate_limits, w_test_power  # noqa: E402
from pcmm_geo.machine.analysis.logproc.synthesis import with_laser_noise, with_reading_fault  # noqa: E402
from pcmm_geo.machine.kinematics.model import RigidBodyMachine  # noqa: E402

MACHINE = RigidBodyMachine.from_dpkm()
SIZES = (0.05, 0.1, 0.2, 0.3, 0.5, 1.0, 2.0, 5.0)
REFUSED = (InconsistentMeasurementError, ConvergenceError, OutOfRangeError)


def acquire(folder: Path, seed: int, start: str, moves: int) -> Path:
    path = folder / f"{start}_{seed}.csv"
    args = ["acquire", "--simulate", "--seed", str(seed), "--moves", str(moves), "--settle", "0", "--out", str(path)]
    if start == "off":
        args += ["--start-offsets-mm", *map(str, OFF_LEVEL_START_OFFSETS)]
    elif start == "level":
        args += ["--start", "level"]  # the thesis' start, by name (pcmm acquire's default is a conditioned start)
    with contextlib.redirect_stdout(io.StringIO()):
        if main(args) != 0:
            raise RuntimeError(f"acquire failed: {args}")
    return path


def process(path: Path, log=None, **options):
    start = [float(v) for v in read_acquisition_log(path).metadata["start_heights_mm"].split()]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return process_log(MACHINE, read_log(path) if log is None else log, initial_heights=start, **options)


def binomial_interval(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """Clopper-Pearson interval of a proportion."""
    from scipy.stats import beta

    low = 0.0 if k == 0 else float(beta.ppf((1 - level) / 2, k, n - k + 1))
    high = 1.0 if k == n else float(beta.ppf(1 - (1 - level) / 2, k + 1, n - k))
    return low, high


def tally(path: Path, out, tally_: dict) -> None:
    _, truth = simulated_truth(path)
    error = np.linalg.norm(out.tips - truth, axis=1)
    consistent = ~out.inconsistent
    stated = consistent & ~out.ambiguous & np.isfinite(out.bound)
    for key, value in (("rows", len(error)), ("consistent", int(consistent.sum())), ("stated", int(stated.sum())),
                       ("stated_within_U", int(np.sum(error[stated] <= 2 * out.tip_uncertainty[stated] + 1e-9))),
                       ("consistent_within_U", int(np.sum(error[consistent] <= 2 * out.tip_uncertainty[consistent]
                                                          + 1e-9))),
                       ("consistent_within_bound", int(np.sum(error[consistent] <= out.bound[consistent] + 1e-9))),
                       ("ambiguous", int(np.sum(out.ambiguous & consistent))),
                       ("unbounded", int(np.sum(out.unbounded))), ("uncertain", int(np.sum(out.uncertain))),
                       ("refused_rows", int(out.inconsistent.sum()))):
        tally_[key] = tally_.get(key, 0) + value
    tally_.setdefault("largest_error_stated_mm", 0.0)
    if stated.any():
        tally_["largest_error_stated_mm"] = max(tally_["largest_error_stated_mm"], float(error[stated].max()))


def scan_sessions(paths: dict, rng: np.random.Generator) -> dict:
    results: dict = {}
    for (start, seed), path in paths.items():
        for case, kwargs, noise in (("noise-free", {}, None), ("2 um noise, default sigma", {}, 0.002),
                                    ("20 um noise, sigma 20 um", {"laser_sigma": 0.02}, 0.02)):
            if noise == 0.02 and start == "level":
                continue
            key = f"{start} / {case}"
            entry = results.setdefault(key, {"sessions": 0, "processed": 0})
            entry["sessions"] += 1
            log = None if noise is None else with_laser_noise(read_log(path), rng, noise, SEED_LASER_STEPS)
            try:
                out = process(path, log, **kwargs) if noise is None else process(path, log, on_inconsistent="flag",
                                                                                   **kwargs)
            except REFUSED as exc:
                entry.setdefault("refusals", []).append(f"seed {seed}: {exc}")
                continue
            entry["processed"] += 1
            tally(path, out, entry)
    for entry in results.values():
        if entry.get("stated"):
            entry["stated_within_U_fraction"] = entry["stated_within_U"] / entry["stated"]
            entry["stated_within_U_interval"] = binomial_interval(entry["stated_within_U"], entry["stated"])
    return results


def scan_faults(paths: dict, every: int) -> dict:
    results: dict = {}
    for (start, seed), path in paths.items():
        clean = read_log(path)
        _, truth = simulated_truth(path)
        entry = results.setdefault(start, {"cases": 0, "refused": 0, "accepted": 0, "accepted_above_mdb": 0,
                                           "accepted_outside_bound": 0, "refused_by_size": {}})
        for index, row in enumerate(range(1, len(clean), every)):
            row += index % 2 if every % 2 == 0 else 0  # stop rows (odd) and start rows (even) alike
            for arm in range(3):
                for size in SIZES:
                    entry["cases"] += 1
                    by_size = entry["refused_by_size"].setdefault(str(size), [0, 0])
                    by_size[1] += 1
                    try:
                        out = process(path, with_reading_fault(clean, row, arm, size))
                    except REFUSED:
                        entry["refused"] += 1
                        by_size[0] += 1
                        continue
                    entry["accepted"] += 1
                    entry["accepted_above_mdb"] += int(size > out.mdb[row, arm] * (1 + 1e-6))
                    error = np.linalg.norm(out.tips - truth, axis=1)
                    outside = error > out.bound + 1e-9
                    if outside.any():
                        entry["accepted_outside_bound"] += 1
                        entry.setdefault("outside_examples", []).append(
                            {"seed": seed, "row": row, "arm": arm, "size": size,
                             "excess_mm": float(np.max(error - out.bound))})
    return results


def scan_power(paths: dict, rng: np.random.Generator, trials: int, sigma: float,
               multiples: tuple[float, ...] = (1.0,)) -> dict:
    """Faults of ``multiple`` times the MDB (from the processing of the noisy log without the fault) on one reading.

    A trial draws fresh Gaussian noise, processes the log without a fault (a log refused then is a false alarm,
    not a power trial), puts a fault of the stated multiple of that reading's MDB with a random sign on a random
    reading of a row that begins a height, and processes again.  Trials are split by whether the faulty log kept
    the segments of the clean one: a fault that makes the next start row look like a further move of the motor
    (thesis 3.5: the tetrahedron settling) changes the model the w-test works in, and the MDB of the clean model
    no longer applies to it.
    """
    limits = gate_limits(DEFAULT_ALPHA, DEFAULT_POWER)
    entries = {m: {"trials": 0, "refused": 0, "same_segments": [0, 0], "other_segments": [0, 0]} for m in multiples}
    false_alarms = clean_trials = 0
    for (start, _), path in paths.items():
        if start != "off":
            continue
        clean = read_log(path)
        for _trial in range(trials):
            noisy = with_laser_noise(clean, rng, sigma, SEED_LASER_STEPS)
            clean_trials += 1
            try:
                reference = process(path, noisy, laser_sigma=sigma)
            except REFUSED:
                false_alarms += 1
                continue
            observed = np.flatnonzero(np.isfinite(reference.mdb).all(axis=1) & (reference.moved_arm >= 0))
            row = int(rng.choice(observed))
            arm = int(rng.integers(3))
            sign = float(rng.choice((-1.0, 1.0)))
            for multiple in multiples:
                entry = entries[multiple]
                size = float(reference.mdb[row, arm]) * sign * multiple
                out = process(path, with_reading_fault(noisy, row, arm, size), laser_sigma=sigma,
                              on_inconsistent="flag")
                refused = bool(out.inconsistent.any())
                kind = "same_segments" if np.array_equal(out.moved_arm, reference.moved_arm) else "other_segments"
                entry["trials"] += 1
                entry["refused"] += int(refused)
                entry[kind][0] += int(refused)
                entry[kind][1] += 1
    result: dict = {"sigma_mm": sigma, "stated_power": DEFAULT_POWER, "clean_logs": clean_trials,
                    "clean_logs_refused": false_alarms,
                    "clean_logs_refused_interval": binomial_interval(false_alarms, max(clean_trials, 1))}
    for multiple, entry in entries.items():
        same, other = entry["same_segments"], entry["other_segments"]
        result[f"{multiple:g} MDB"] = {
            "theory": w_test_power(multiple * limits.noncentrality, limits.critical),
            "trials": entry["trials"], "refused": entry["refused"],
            "fraction": entry["refused"] / max(entry["trials"], 1),
            "interval": binomial_interval(entry["refused"], entry["trials"]),
            "same_segments": {"trials": same[1], "refused": same[0], "fraction": same[0] / max(same[1], 1),
                              "interval": binomial_interval(same[0], same[1])},
            "read_as_further_move": {"trials": other[1], "refused": other[0]},
        }
    return result


def reliability_ranges(paths: dict) -> dict:
    ranges: dict = {}
    for (start, _), path in paths.items():
        out = process(path)
        entry = ranges.setdefault(start, {"redundancy": [], "mdb_mm": [], "R_mm": []})
        observed = ~np.isnan(out.w_test).any(axis=1)
        entry["redundancy"] += out.redundancy[observed].ravel().tolist()
        entry["mdb_mm"] += out.mdb[observed].ravel().tolist()
        entry["R_mm"] += out.tip_reliability.tolist()
    summary = {}
    for start, entry in ranges.items():
        summary[start] = {}
        for name, values in entry.items():
            array = np.asarray(values, dtype=float)
            finite = array[np.isfinite(array)]
            summary[start][name] = {"min": float(finite.min()), "median": float(np.median(finite)),
                                    "p95": float(np.percentile(finite, 95)), "max": float(finite.max()),
                                    "infinite": int(np.sum(~np.isfinite(array)))}
    return summary


def run(arguments: argparse.Namespace) -> dict:
    rng = np.random.default_rng(arguments.rng_seed)
    started = time.perf_counter()
    only = set(arguments.only or ("sessions", "faults", "power", "reliability"))
    seeds = max(arguments.seeds if only & {"sessions", "reliability"} else 0,
                arguments.fault_seeds if "faults" in only else 0, arguments.power_seeds if "power" in only else 0)
    report: dict = {"seeds": arguments.seeds, "moves": arguments.moves}
    with tempfile.TemporaryDirectory() as folder:
        paths = {(start, seed): acquire(Path(folder), seed, start, arguments.moves)
                 for start in ("level", "off") for seed in range(1, seeds + 1)}
        session_paths = {key: path for key, path in paths.items() if key[1] <= arguments.seeds}
        if "sessions" in only:
            report["sessions"] = scan_sessions(session_paths, rng)
        if "faults" in only:
            fault_paths = {key: path for key, path in paths.items() if key[1] <= arguments.fault_seeds}
            report["faults"] = scan_faults(fault_paths, arguments.every)
        if "power" in only:
            power_paths = {key: path for key, path in paths.items() if key[1] <= arguments.power_seeds}
            report["power"] = scan_power(power_paths, rng, arguments.trials, arguments.power_sigma,
                                         tuple(arguments.power_multiples))
        if "reliability" in only:
            report["reliability"] = reliability_ranges(session_paths)
    report["seconds"] = round(time.perf_counter() - started, 1)
    return report


def main_(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20, help="sessions per start (default 20)")
    parser.add_argument("--moves", type=int, default=60, help="moves per session (default 60)")
    parser.add_argument("--fault-seeds", type=int, default=4, help="sessions per start in the fault scan (default 4)")
    parser.add_argument("--every", type=int, default=3, help="fault on every k-th row (default 3)")
    parser.add_argument("--trials", type=int, default=100, help="power trials per session (default 100)")
    parser.add_argument("--power-seeds", type=int, default=4, help="off-level sessions in the power scan (default 4)")
    parser.add_argument("--power-multiples", type=float, nargs="+", default=[1.0],
                        help="fault sizes of the power scan in MDBs (default 1)")
    parser.add_argument("--only", choices=("sessions", "faults", "power", "reliability"), nargs="+",
                        help="run only these scans")
    parser.add_argument("--power-sigma", type=float, default=0.02, help="Gaussian noise of the power scan, mm")
    parser.add_argument("--rng-seed", type=int, default=22)
    parser.add_argument("--quick", action="store_true", help="4 seeds, 2 fault sessions, every 8th row, 30 trials")
    parser.add_argument("--out", help="write the numbers as JSON")
    arguments = parser.parse_args(argv)
    if arguments.quick:
        arguments.seeds, arguments.fault_seeds, arguments.every, arguments.trials = 4, 2, 8, 30
        arguments.power_seeds = 2
    report = run(arguments)
    text = json.dumps(report, indent=1)
    if arguments.out:
        Path(arguments.out).parent.mkdir(parents=True, exist_ok=True)
        Path(arguments.out).write_text(text + "\n", encoding="utf-8")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main_())
