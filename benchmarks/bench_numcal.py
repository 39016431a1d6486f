"""Benchmark of the numerical calibration (thesis ch. 6) on synthetic data of known truth.

Compares, on the seed's experiment (15 height-gauge samples per arm, Table 7.1 values as
truth), least squares after differential evolution or a seeded multi-start, simultaneous
and sequential, against the seed's brute force: a numpy random search of the seed's size
(8e6 samples by default; the thesis quotes 80e6 as MATLAB's memory limit).

Reported per method: wall time, rms distance residual, largest error of d and b (mm) and
beta (degrees), and the error left after removing the component along the weakest
(scale) direction, which the data cannot determine.

Run: ``.venv/bin/python benchmarks/bench_numcal.py [--samples 8000000] [--noise 0.0]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from pcmm_geo.machine.calibration.numerical.numcal import (
    NumcalParameters,
    calibrate_numerically,
    random_search,
    residuals_and_jacobian,
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
    args = parser.parse_args()

    truth = NumcalParameters.from_seed_table()
    data = synthesise_numcal_data(truth, laser_sigma=args.noise, height_sigma=args.noise, seed=args.seed)
    _, jac = residuals_and_jacobian(data, truth.vector())
    norms = np.linalg.norm(jac, axis=0)
    from pcmm_geo.machine.calibration.numerical.identifiability import analyse_identifiability

    report = analyse_identifiability(jac, [f"p{k}" for k in range(9)])
    weak = np.array(list(report.weak_combinations[0].coefficients.values()))
    print(f"data: {len(data.moved)} samples, noise {args.noise} mm; condition number {report.condition_number:.3g}")
    print(f"{'method':53s} {'time s':>8s} {'rms mm':>10s} {'|dd|,|db| mm':>13s} {'|dbeta| deg':>12s} "
          f"{'determined':>11s} {'evals':>9s}")
    runs = [
        ("least squares + differential evolution, simultaneous", "simultaneous", "differential_evolution"),
        ("least squares + differential evolution, sequential", "sequential", "differential_evolution"),
        ("least squares + 20-start multistart, simultaneous", "simultaneous", "multistart"),
        ("least squares + 20-start multistart, sequential", "sequential", "multistart"),
    ]
    for label, method, search in runs:
        start = time.perf_counter()
        result = calibrate_numerically(data, method=method, global_search=search, seed=args.seed)
        elapsed = time.perf_counter() - start
        length_error, angle_error, determined = errors(result.parameters, truth, weak, norms)
        print(f"{label:53s} {elapsed:8.2f} {result.rms:10.3g} {length_error:13.4g} {angle_error:12.4g} "
              f"{determined:11.3g} {result.evaluations:9d}")
    start = time.perf_counter()
    found, _ = random_search(data, args.samples, seed=args.seed)
    elapsed = time.perf_counter() - start
    residuals, _ = residuals_and_jacobian(data, found.vector())
    length_error, angle_error, determined = errors(found, truth, weak, norms)
    print(f"{'numpy random search (' + format(args.samples, '.0e') + ' samples)':53s} {elapsed:8.2f} "
          f"{np.sqrt(np.mean(residuals**2)):10.3g} {length_error:13.4g} {angle_error:12.4g} {determined:11.3g} "
          f"{args.samples:9d}")


if __name__ == "__main__":
    main()
