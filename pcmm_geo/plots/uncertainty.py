"""Plot of a Monte Carlo uncertainty evaluation: the trials' histogram, its coverage interval and the GUM result.

The histogram of the simulated values is drawn as a deviation from the nominal (or the
mean), with the Monte Carlo coverage interval; the GUM (linear) result, when given, is drawn
beside it as its normal density with its own interval, so the two can be compared as JCGM
101 clause 8 does in numbers.  The budget is a bar chart of what each input group
contributes to the standard uncertainty, labelled in words (``laser readings``, not
``laser_noise``), Monte Carlo and GUM side by side.  Legends sit below the axes and cover no
data.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from pcmm_geo.plots._figure import check_plot_path, new_figure, save_figure

__all__ = ["budget_label", "plot_monte_carlo"]


def budget_label(name: str) -> str:
    """The words for an input group of a budget (``"laser_noise"`` -> ``"laser readings"``).

    Examples
    --------
    >>> budget_label("thermal_workpiece"), budget_label("slider_a.laser_scale")
    ('workpiece temperature and expansion', 'slider a laser scale')
    """
    from pcmm_geo.uncertainty.virtual_cmm import GROUP_LABELS

    return GROUP_LABELS.get(name, name.replace("_", " ").replace(".", " "))


def plot_monte_carlo(result: Any, path: str | Path, *, nominal: float | None = None, title: str = "",
                     gum: Any = None, overwrite: bool = False) -> Path:
    """Histogram (µm from the nominal, or from the mean) of ``result.values``, its interval and the GUM result.

    Parameters
    ----------
    result : UncertaintyResult
        A Monte Carlo result with ``values`` kept (``keep_values=True``); its budget, if any,
        is drawn as a bar chart beside the histogram.
    path : str or Path
        ``.png``, ``.svg`` or ``.pdf``.
    nominal : float, optional
        Reference value the deviations are drawn from (default: the Monte Carlo mean).
    title : str
    gum : UncertaintyResult, optional
        The GUM (linear) result of the same task: drawn as its normal density with its
        coverage interval, and its budget beside the Monte Carlo one.
    overwrite : bool

    Returns
    -------
    Path

    Raises
    ------
    InvalidInputError
        No values kept, or an unsupported suffix.
    OutputExistsError
        ``path`` exists and ``overwrite`` is False.

    Examples
    --------
    >>> import os, tempfile
    >>> from pcmm_geo.uncertainty import adaptive_monte_carlo
    >>> r = adaptive_monte_carlo(lambda rng, n: rng.normal(100.0, 3e-4, n), trials=5000, keep_values=True)
    >>> plot_monte_carlo(r, os.path.join(tempfile.mkdtemp(), "mc.png")).name
    'mc.png'
    """
    from pcmm_geo.errors import InvalidInputError

    if result.values is None:
        raise InvalidInputError("result", "a Monte Carlo result with values (keep_values=True)", "no values")
    check_plot_path(path, overwrite=overwrite)
    reference = result.value if nominal is None else nominal
    values_um = 1000.0 * (np.asarray(result.values) - reference)
    low, high = (1000.0 * (v - reference) for v in result.coverage_interval)
    budget = [entry for entry in result.budget if entry.contribution > 0]
    figure = new_figure(12.5 if budget else 7.5, 5.2)
    grid = figure.add_gridspec(1, 2, width_ratios=(1.5, 1.0)) if budget else None
    axes = figure.add_subplot(grid[0, 0]) if grid is not None else figure.add_subplot()
    axes.hist(values_um, bins=80, density=True, color="#4c72b0", alpha=0.75,
              label=f"Monte Carlo, {result.n_trials} trials")
    axes.axvspan(low, high, color="#dd8452", alpha=0.15,
                 label=f"Monte Carlo {100 * result.coverage_probability:.0f} % {result.interval_kind} interval, "
                       f"U = {1000 * result.expanded_uncertainty:.3f} µm")
    for edge in (low, high):
        axes.axvline(edge, color="#dd8452", linewidth=1.5)
    axes.axvline(1000.0 * (result.value - reference), color="black", linewidth=1.0, label="Monte Carlo mean")
    if gum is not None:
        centre = 1000.0 * (gum.value - reference)
        spread = 1000.0 * gum.standard_uncertainty
        span = np.linspace(min(values_um.min(), centre - 4 * spread), max(values_um.max(), centre + 4 * spread), 400)
        if spread > 0:
            density = np.exp(-0.5 * ((span - centre) / spread) ** 2) / (spread * np.sqrt(2 * np.pi))
            axes.plot(span, density, color="#c44e52", linewidth=1.8,
                      label=f"GUM: normal, u = {spread:.3f} µm")
        gum_low, gum_high = (1000.0 * (v - reference) for v in gum.coverage_interval)
        for k, edge in enumerate((gum_low, gum_high)):
            axes.axvline(edge, color="#c44e52", linewidth=1.2, linestyle="--",
                         label=f"GUM {100 * gum.coverage_probability:.0f} % interval, U = "
                               f"{1000 * gum.expanded_uncertainty:.3f} µm (k = {gum.coverage_factor:.2f})"
                         if k == 0 else None)
    axes.set_xlabel(f"deviation from {'nominal' if nominal is not None else 'mean'} / µm")
    axes.set_ylabel("probability density / (1/µm)")
    axes.set_title(title or f"{result.quantity}: U = {1000 * result.expanded_uncertainty:.3f} µm "
                   f"(k = {result.coverage_factor:.2f}), {result.n_trials} trials", fontsize=10)
    axes.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2, fontsize=7)
    if budget:
        _budget(figure.add_subplot(grid[0, 1]), budget, gum)
    return save_figure(figure, path, overwrite=overwrite)


def _budget(axes: Any, budget: list[Any], gum: Any) -> None:
    """Contribution of each input group to u (µm), Monte Carlo and GUM side by side, largest first."""
    gum_parts = {entry.name: entry.contribution for entry in getattr(gum, "budget", ()) or ()}
    budget = sorted(budget, key=lambda entry: entry.contribution, reverse=True)
    positions = np.arange(len(budget))
    height = 0.38 if gum_parts else 0.7
    axes.barh(positions - (height / 2 if gum_parts else 0.0), [1000.0 * e.contribution for e in budget],
              height=height, color="#55a868", label="Monte Carlo")
    if gum_parts:
        axes.barh(positions + height / 2, [1000.0 * gum_parts.get(e.name, np.nan) for e in budget], height=height,
                  color="#c44e52", alpha=0.8, label="GUM")
    axes.set_yticks(positions, [budget_label(entry.name) for entry in budget])
    axes.invert_yaxis()
    axes.set_xlabel("contribution to the standard uncertainty / µm\n(one input group varied at a time)")
    axes.set_title("Uncertainty budget", fontsize=10)
    axes.grid(axis="x", alpha=0.3)
    if gum_parts:
        axes.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=2, fontsize=7)
