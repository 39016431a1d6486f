"""Benchmark of the virtual micro-CMM (issue 13): 1e5 gauge-block Monte Carlo trials, and the demo's coverage.

1. Wall time of ``--trials`` (default 1e5) trials of the 100 mm gauge-block task with every
   input group active (calibration covariance, laser and encoder noise, probing scatter,
   machine and workpiece thermal state): batched chord-method kinematics
   (:mod:`pcmm_geo.uncertainty.kinematics`) and batched plane fits.  Target: < 10 s on a
   2-core machine.  The peer is the straightforward loop -- one perturbed
   ``RigidBodyMachine`` and one ``forward`` per trial -- timed on ``--loop-trials`` trials
   and extrapolated.
2. Honest coverage of the demo's stated U over ``--seeds`` seeds (the unit test runs 40):
   fraction of runs with ``|true error| <= U`` and the mean ``|error| / U`` (0.407 expected
   for a Gaussian error and U = 1.96 u).

Small matrix products run faster on one BLAS thread; this script sets
``OPENBLAS_NUM_THREADS=1`` unless the variable is already set (printed).

Run: ``.venv/bin/python benchmarks/bench_uncertainty.py [--trials 100000] [--seeds 200]``.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import dataclasses
import time

import numpy as np

from benchmarks import _environment
from benchmarks._timing import best_of


def _vcmm() -> tuple[object, object]:
    from pcmm_geo.demo import demo_calibrated_machine
    from pcmm_geo.uncertainty.tasks import gauge_block_task
    from pcmm_geo.uncertainty.virtual_cmm import ThermalInputs, VirtualCMM

    machine, radius, covariance, center = demo_calibrated_machine()
    thermal = ThermalInputs(arm_temperature_u=0.05, column_temperature_u=0.05, machine_temperature=20.5,
                            alpha_machine_u=1e-6, workpiece_temperature=20.3, workpiece_temperature_u=0.05,
                            alpha_workpiece_u=1e-6)
    vcmm = VirtualCMM(machine, radius, covariance.model_covariance()[1], laser_sigma=5e-4, encoder_sigma=2e-4,
                      probing_sigma=2e-4, thermal=thermal)
    return vcmm, gauge_block_task(100.0, center)


def loop_peer(vcmm: object, task: object, trials: int) -> float:
    """The unvectorised way: a perturbed machine and a forward solve per trial (calibration + reading noise)."""
    from pcmm_geo.machine.kinematics.model import RigidBodyMachine, SliderLine, Tetrahedron

    rng = np.random.default_rng(1)
    lasers0, heights0 = vcmm.nominal_readings(task)
    cov = np.asarray(vcmm.calibration_covariance)
    base = vcmm.machine
    start = time.perf_counter()
    for _ in range(trials):
        delta = rng.multivariate_normal(np.zeros(28), cov, method="eigh")
        sliders = {}
        for k, arm in enumerate("abc"):
            s = base.tetrahedron.sliders[arm]
            d = delta[8 * k:8 * k + 8]
            sliders[arm] = SliderLine(s.point + d[0:3], s.direction + d[3:6], s.laser_scale + d[6],
                                      s.laser_offset + d[7])
        machine = RigidBodyMachine(Tetrahedron(sliders, base.tetrahedron.tip_center + delta[24:27]), base.columns,
                                   base.reference_lasers, base.reference_heights)
        lasers = lasers0 + rng.normal(0.0, vcmm.laser_sigma, lasers0.shape)
        heights = heights0 + rng.normal(0.0, vcmm.encoder_sigma, heights0.shape)
        tips = machine.forward(lasers, heights, laser_sigma=vcmm.laser_sigma, height_sigma=vcmm.encoder_sigma).tip
        task.evaluate((tips - (vcmm.tip_radius + delta[27]) * task.normals)[None])
    return (time.perf_counter() - start) / trials


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=100_000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--loop-trials", type=int, default=200)
    parser.add_argument("--seeds", type=int, default=200, help="demo seeds for the coverage sweep (0: skip)")
    args = parser.parse_args()
    print(_environment.environment_line())

    vcmm, task = _vcmm()
    simulate = vcmm.simulation(task)
    timing = best_of(lambda: simulate(np.random.default_rng(0), args.trials), args.repeat)
    values = timing.value
    print(f"gauge block 100 mm, all input groups, {args.trials} trials: best {timing.best:.2f} s "
          f"(runs {', '.join(f'{t:.2f}' for t in timing.runs)}); u = {1000 * values.std(ddof=1):.4f} um")
    per_trial = loop_peer(vcmm, task, args.loop_trials)
    print(f"loop peer (RigidBodyMachine.forward per trial, {args.loop_trials} trials): {1e3 * per_trial:.2f} ms/trial "
          f"-> {per_trial * args.trials:.0f} s for {args.trials} trials ({per_trial * args.trials / timing.best:.0f}x)")
    start = time.perf_counter()
    gum = vcmm.gum(task)
    print(f"GUM linear (central differences, {2 * sum(vcmm.group_sizes(task).values()) + 1} evaluations): "
          f"{time.perf_counter() - start:.2f} s, U = {1000 * gum.expanded_uncertainty:.4f} um")

    if args.seeds:
        from pcmm_geo.demo import DemoSettings, run_demo

        start = time.perf_counter()
        ratios = []
        for seed in range(args.seeds):
            result = run_demo(dataclasses.replace(DemoSettings(seed=seed), uncertainty_trials=2000,
                                                  uncertainty_budget=False))
            ratios.append(abs(result.length_error_calibrated) / result.expanded_uncertainty_calibrated)
        ratios_arr = np.array(ratios)
        covered = float(np.mean(ratios_arr <= 1.0))
        half_width = 1.96 * np.sqrt(0.95 * 0.05 / args.seeds)
        print(f"demo coverage over {args.seeds} seeds: {100 * covered:.1f} % within U "
              f"(95 % +- {100 * half_width:.1f} % expected), mean |error|/U = {ratios_arr.mean():.3f} "
              f"(0.407 expected), {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
