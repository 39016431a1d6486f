"""Seeded scan: do sparse cylinder, cone and torus fits reach the least-squares minimum? (run on demand)

For each configuration, ``--sets`` random sparse data sets (``tests/fit/multistart_reference.py``:
cylinder R 5 x L 20, cones 8-35 degrees, torus 30 x 6, form 0.05 mm, random pose ~100 mm from
the origin) are fitted with ``pcmm_geo.fit`` and with the independent multi-start reference
(MINPACK LM from a 60-direction Fibonacci lattice, the principal axes and the generating
axis).  Each set is classed as

* ``global`` - the fit's sum of squares is within 1e-9 (relative) of the reference's,
* ``warned`` - it is not, but :class:`~pcmm_geo.errors.AmbiguousFitWarning` or
  :class:`~pcmm_geo.errors.UnassuredMinimumWarning` was emitted,
* ``silent`` - a wrong local minimum returned without a warning (the defect),
* ``better`` - the fit found a lower minimum than the reference (counted as global),
* ``error`` - the fit raised.

The ``screened`` column counts the cylinder fits that ran the direction screening (sparse
data, or dense data leaving a gap of more than 45 degrees about the axis: ``_screen.surrounds_axis``).

Usage::

    PYTHONPATH=. .venv/bin/python benchmarks/fit_robustness.py [--sets 1000] [--only cylinder-8] [--seed 0]

``docs/fit-robustness.md`` records a run.  Never part of the test suite.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "fit"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _environment import environment_line
from multistart_reference import reference_for, sparse_case

import pcmm_geo.fit.cylinder as cylinder_module
from pcmm_geo import fit
from pcmm_geo.errors import PcmmGeoError

_SCREENED: list[int] = []
_SCREEN = cylinder_module.screened_directions


def _counting_screen(*args: object) -> list:
    _SCREENED.append(1)
    return _SCREEN(*args)


cylinder_module.screened_directions = _counting_screen  # diagnostics of this scan only

#: name -> (kind, points per set (low, high inclusive), arc about the axis in degrees (low, high))
CONFIGS: dict[str, tuple[str, tuple[int, int], tuple[float, float]]] = {
    "cylinder-6": ("cylinder", (6, 6), (360, 360)),
    "cylinder-8": ("cylinder", (8, 8), (360, 360)),
    "cylinder-10": ("cylinder", (10, 10), (360, 360)),
    "cylinder-15-half": ("cylinder", (15, 15), (180, 180)),
    # dense: fitted from the principal axes alone where the points surround the axis (no gap over 45 degrees)
    "cylinder-300": ("cylinder", (300, 300), (360, 360)),
    "cylinder-300-partial": ("cylinder", (300, 300), (60, 300)),
    "cylinder-3000": ("cylinder", (3000, 3000), (360, 360)),
    "cylinder-3000-partial": ("cylinder", (3000, 3000), (60, 300)),
    "cone-7-10": ("cone", (7, 10), (360, 360)),
    "torus-8-10": ("torus", (8, 10), (360, 360)),
    "torus-8-10-partial": ("torus", (8, 10), (90, 180)),
}

_FIT = {"cylinder": fit.fit_cylinder, "cone": fit.fit_cone, "torus": fit.fit_torus}


def classify(kind: str, points: np.ndarray, reference_cost: float) -> tuple[str, float]:
    """Fit ``points`` and class the outcome against the reference cost; returns (class, seconds)."""
    start = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result = _FIT[kind](points)
        except PcmmGeoError:
            return "error", time.perf_counter() - start
    elapsed = time.perf_counter() - start
    ambiguous = any(type(w.message).__name__ in ("AmbiguousFitWarning", "UnassuredMinimumWarning") for w in caught)
    cost = result.sum_of_squares
    if cost <= reference_cost * (1 + 1e-9) + 1e-24:
        return ("better" if cost < reference_cost * (1 - 1e-6) else "global"), elapsed
    return ("warned" if ambiguous else "silent"), elapsed


def run(name: str, sets: int, seed: int) -> tuple[Counter, float]:
    kind, (n_low, n_high), (arc_low, arc_high) = CONFIGS[name]
    rng = np.random.default_rng([seed, sum(map(ord, name))])
    counts: Counter = Counter()
    seconds = 0.0
    for _ in range(sets):
        n = int(rng.integers(n_low, n_high + 1))
        arc = float(rng.uniform(arc_low, arc_high))
        case = sparse_case(kind, rng, n, arc_deg=arc)
        reference = reference_for(kind, case)
        _SCREENED.clear()
        label, elapsed = classify(kind, case.points, reference.cost)
        counts[label] += 1
        counts["screened"] += bool(_SCREENED)
        seconds += elapsed
    return counts, seconds / sets


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sets", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--only", action="append", choices=sorted(CONFIGS))
    args = parser.parse_args(argv)
    print(environment_line())
    print("| configuration | sets | global | warned | silent wrong | fit errors | screened | mean time per fit |")
    print("|---|---|---|---|---|---|---|---|")
    for name in args.only or CONFIGS:
        counts, mean_time = run(name, args.sets, args.seed)
        total = sum(value for key, value in counts.items() if key != "screened")
        good = counts["global"] + counts["better"]
        print(
            f"| {name} | {total} | {good} ({100 * good / total:.1f} %) | {counts['warned']} "
            f"| {counts['silent']} ({100 * counts['silent'] / total:.1f} %) | {counts['error']} "
            f"| {counts['screened'] if name.startswith('cylinder') else '-'} | {1e3 * mean_time:.0f} ms |",
            flush=True,
        )
    print(environment_line())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
