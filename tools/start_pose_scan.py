"""Default acquisition sessions by start pose against the simulator's truth: the table of issue 36.

For each start (``conditioned``, ``pcmm acquire``'s default; ``level``, the thesis'; ``offsets``,
``--start-offsets-mm 0 60 -60``) and seeds 1..S: ``pcmm acquire --simulate --seed S --moves M
--settle 0``, processed as ``pcmm process-log`` does (the log's start heights as the datum), the tips
compared with the simulator's own (:func:`pcmm_geo.acquisition.simulators.cmm.simulated_truth`).
Printed per start: sessions processed, probe points, the largest probe-point error, the median
probe-point u and R, the largest stated bound, flags, how many probe points lie within U (k = 2) and
within their bound, and the predicted u of the planned path (median over sessions of its median).

Usage (about 1 min for 20 seeds on one core)::

    OPENBLAS_NUM_THREADS=1 python tools/start_pose_scan.py [--seeds 20] [--moves 40] [--json]
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from pcmm_geo.acquisition.acqlog import read_log as read_acquisition_log  # noqa: E402
from pcmm_geo.acquisition.simulators.cmm import OFF_LEVEL_START_OFFSETS, simulated_truth  # noqa: E402
from pcmm_geo.cli import main  # noqa: E402
from pcmm_geo.machine.analysis.logproc import process_log, read_log  # noqa: E402
from pcmm_geo.machine.kinematics.model import RigidBodyMachine  # noqa: E402

STARTS = {"conditioned": [], "level": ["--start", "level"],
          "offsets 0 60 -60": ["--start-offsets-mm", *map(str, OFF_LEVEL_START_OFFSETS)]}


def scan(start: str, seeds: int, moves: int, folder: Path) -> dict[str, object]:
    machine = RigidBodyMachine.from_dpkm()
    errors, u, reliability, bound, predicted = [], [], [], [], []
    processed = within_u = within_bound = points = uncertain = ambiguous = unbounded = 0
    for seed in range(1, seeds + 1):
        path = folder / f"{start.split()[0]}_{seed}.csv"
        out = io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
            code = main(["acquire", "--simulate", "--seed", str(seed), "--moves", str(moves), "--settle", "0",
                         "--out", str(path), "--json", *STARTS[start]])
        if code != 0:
            continue
        predicted.append(json.loads(out.getvalue())["plan"]["predicted_median_tip_u_mm"])
        heights = [float(v) for v in read_acquisition_log(path).metadata["start_heights_mm"].split()]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = process_log(machine, read_log(path), initial_heights=heights)
        processed += 1
        _, truth = simulated_truth(path)
        rows = result.probe_rows
        error = np.linalg.norm(result.tips - truth, axis=1)[rows]
        errors += error.tolist()
        u += result.tip_uncertainty[rows].tolist()
        reliability += result.tip_reliability[rows].tolist()
        bound += result.bound[rows].tolist()
        points += rows.size
        within_u += int(np.sum(error <= 2.0 * result.tip_uncertainty[rows]))
        within_bound += int(np.sum(error <= result.bound[rows]))
        uncertain += int(result.uncertain.sum())
        ambiguous += int(result.ambiguous.sum())
        unbounded += int(result.unbounded.sum())
    return {
        "start": start, "sessions": f"{processed} / {seeds}", "probe_points": points,
        "max_error_mm": float(np.max(errors)), "median_u_mm": float(np.median(u)),
        "median_R_mm": float(np.median(reliability)), "largest_bound_mm": float(np.max(bound)),
        "within_U": within_u, "within_bound": within_bound,
        "flags": f"{uncertain} uncertain, {ambiguous} ambiguous, {unbounded} unbounded rows",
        "predicted_median_u_mm": float(np.median(predicted)),
    }


def main_scan() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--moves", type=int, default=40)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        results = [scan(start, args.seeds, args.moves, Path(folder)) for start in STARTS]
    if args.json:
        print(json.dumps(results, indent=2))
        return
    print("| start | sessions | probe points | max abs(tip - truth) | median tip u | median R | largest bound | "
          "within U (k = 2) | within bound | predicted median u | flags |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in results:
        print(f"| {r['start']} | {r['sessions']} | {r['probe_points']} | {r['max_error_mm']:.3g} mm | "
              f"{r['median_u_mm']:.3g} mm | {r['median_R_mm']:.3g} mm | {r['largest_bound_mm']:.3g} mm | "
              f"{r['within_U']} of {r['probe_points']} | {r['within_bound']} of {r['probe_points']} | "
              f"{r['predicted_median_u_mm']:.3g} mm | {r['flags']} |")


if __name__ == "__main__":
    main_scan()
