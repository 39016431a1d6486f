"""Benchmark of the numerical calibration (thesis ch. 6) on synthetic data of known truth.

Compares, on the seed's experiment (15 height-gauge samples per arm, Table 7.1 values as
truth), least squares after differential evolution or a seeded multi-start, simultaneous
and sequential, against the seed's brute force: a numpy random search of the seed's size
(8e6 samples by default; the thesis quotes 80e6 as MATLAB's memory limit).

Reported per method: wall time, rms distance residual, largest error of d and b (mm) and
beta (degrees), the error left after removing the component along the weakest direction,
and whether the result says it converged (a calibration that is not determined says no).

``--design seed`` is the seed's experiment (one pivot at a time to 50 mm, physical rigid-body
data); ``--design combined`` moves the three pivots together over 0-200 mm (30 poses), which
determines all nine parameters.  ``--pairs`` chooses one or three equations per sample.

Run: ``.venv/bin/python benchmarks/bench_numcal.py [--samples 8000000] [--noise 0.0]
[--design seed|combined] [--pairs moved|all]``.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _environment import environment_line

from pcmm_geo.errors import CalibrationNotConvergedWarning
from pcmm_geo.machine.calibration.numerical.numcal import (
    NumcalParameters,
    calibrate_numerically,
    random_search,
    residuals_and_jacobian,
    synthesise_design_data,
    synthesise_numcal_data,
)


def errors(found: NumcalParameters, truth: NumcalParameters, weak: np.ndarray, norms: np.ndarray) -> tuple:
    delta = found.vector() - truth.vector()
    scaled = delta * norms
    determined = scaled - (scaled @ weak) * weak
    return (
        float(np.abs(delta[[0, 1, 2, 6, 7, 8]]).max()),
        float(np.degrees(np.abs(delta[3:6]).max())),
        float(np.linalg.norm(determined)),
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=8_000_000, help="random-search size (seed: 8e6 / 80e6)")
    parser.add_argument("--noise", type=float, default=0.0, help="laser and height-gauge sigma in mm")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--design", choices=("seed", "combined"), default="seed")
    parser.add_argument("--pairs", choices=("moved", "all"), default="moved")
    args = parser.parse_args()

    truth = NumcalParameters.from_seed_table()
    if args.design == "seed":
        data = synthesise_numcal_data(truth, laser_sigma=args.noise, height_sigma=args.noise, seed=args.seed)
    else:
        design = np.random.default_rng(args.seed).uniform(0.0, 200.0, (30, 3))
        data = synthesise_design_data(truth, design, laser_sigma=args.noise, height_sigma=args.noise, seed=args.seed)
    _, jac = residuals_and_jacobian(data, truth.vector(), pairs=args.pairs)
    norms = np.linalg.norm(jac, axis=0)
    from pcmm_geo.machine.calibration.numerical.identifiability import analyse_identifiability

    report = analyse_identifiability(jac, [f"p{k}" for k in range(9)])
    weak = np.array(list(report.weak_combinations[0].coefficients.values()))
    print(environment_line())
    print(f"data: {len(data.moved)} samples, noise {args.noise} mm; condition number {report.condition_number:.3g}")
    print(f"{'method':53s} {'time s':>8s} {'rms mm':>10s} {'|dd|,|db| mm':>13s} {'|dbeta| deg':>12s} "
          f"{'determined':>11s} {'evals':>9s} converged")
    runs = [
        ("least squares + differential evolution, simultaneous", "simultaneous", "differential_evolution"),
        ("least squares + differential evolution, sequential", "sequential", "differential_evolution"),
        ("least squares + 20-start multistart, simultaneous", "simultaneous", "multistart"),
        ("least squares + 20-start multistart, sequential", "sequential", "multistart"),
    ]
    if args.pairs == "all":
        runs = [run for run in runs if run[1] == "simultaneous"]  # the sequential stages use the moved pair only
    for label, method, search in runs:
        start = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", CalibrationNotConvergedWarning)  # reported in the last column
            result = calibrate_numerically(data, method=method, pairs=args.pairs, global_search=search,
                                           seed=args.seed)
        elapsed = time.perf_counter() - start
        length_error, angle_error, determined = errors(result.parameters, truth, weak, norms)
        print(f"{label:53s} {elapsed:8.2f} {result.rms:10.3g} {length_error:13.4g} {angle_error:12.4g} "
              f"{determined:11.3g} {result.evaluations:9d} {result.converged}")
    start = time.perf_counter()
    found, _ = random_search(data, args.samples, seed=args.seed, pairs=args.pairs)
    elapsed = time.perf_counter() - start
    residuals, _ = residuals_and_jacobian(data, found.vector(), pairs=args.pairs)
    length_error, angle_error, determined = errors(found, truth, weak, norms)
    print(f"{'numpy random search (' + format(args.samples, '.0e') + ' samples)':53s} {elapsed:8.2f} "
          f"{np.sqrt(np.mean(residuals**2)):10.3g} {length_error:13.4g} {angle_error:12.4g} {determined:11.3g} "
          f"{args.samples:9d}")


if __name__ == "__main__":
    main()
