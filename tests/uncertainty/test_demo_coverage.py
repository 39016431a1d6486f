"""Honest coverage of the demo's stated uncertainty over 40 seeds (issue 13 "Must show").

For a correct U (95 % coverage) the number of covered runs out of 40 is Binomial(40, 0.95):
P(X <= 33) = 0.014, so "at least 34" fails an honest U rarely.  An inflated U would pass that
easily, so the mean of |error| / U is checked as well: for a Gaussian error and U = 1.96 u it
is E|z| / 1.96 = 0.407 with a standard error of 0.60 / 1.96 / sqrt(40) = 0.048 over 40 runs;
[0.29, 0.53] is +-2.5 standard errors.  U 1.5x too large would give 0.27, 1.5x too small 0.61.
"""

from __future__ import annotations

import numpy as np

from pcmm_geo.demo import DemoSettings, run_demo


def test_demo_uncertainty_covers_the_true_error_in_about_95_percent_of_runs() -> None:
    ratios = []
    for seed in range(1000, 1040):
        result = run_demo(DemoSettings(seed=seed, uncertainty_trials=2000, uncertainty_budget=False))
        ratios.append(abs(result.length_error_calibrated) / result.expanded_uncertainty_calibrated)
    ratios = np.array(ratios)
    covered = int(np.sum(ratios <= 1.0))
    assert covered >= 34, f"{covered} of 40 runs covered"
    assert 0.29 <= float(ratios.mean()) <= 0.53, f"mean |error|/U = {ratios.mean():.3f}"
