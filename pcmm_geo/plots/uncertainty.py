"""Plot of a Monte Carlo uncertainty evaluation: histogram of the trials with the coverage interval."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from pcmm_geo.plots._figure import check_plot_path, new_figure, save_figure

__all__ = ["plot_monte_carlo"]


def plot_monte_carlo(result: Any, path: str | Path, *, nominal: float | None = None, title: str = "",
                     overwrite: bool = False) -> Path:
    """Histogram (µm from the nominal, or from the mean) of ``result.values`` with the coverage interval.

    Parameters
    ----------
    result : UncertaintyResult
        A Monte Carlo result with ``values`` kept (``keep_values=True``); its budget, if any,
        is drawn as a bar chart beside the histogram.
    path : str or Path
        ``.png``, ``.svg`` or ``.pdf``.
    nominal : float, optional
        Reference value the deviations are drawn from (default: the mean).
    title : str
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
    figure = new_figure(11.0 if budget else 7.0, 4.2)
    axes = figure.add_subplot(1, 2, 1) if budget else figure.add_subplot()
    axes.hist(values_um, bins=80, density=True, color="#4c72b0", alpha=0.8)
    axes.axvspan(low, high, color="#dd8452", alpha=0.15,
                 label=f"{100 * result.coverage_probability:.0f} % {result.interval_kind} interval")
    for edge in (low, high):
        axes.axvline(edge, color="#dd8452", linewidth=1.5)
    axes.axvline(1000.0 * (result.value - reference), color="black", linewidth=1.0, label="mean")
    axes.set_xlabel(f"deviation from {'nominal' if nominal is not None else 'mean'} / µm")
    axes.set_ylabel("probability density / 1/µm")
    axes.set_title(title or f"{result.quantity}: U = {1000 * result.expanded_uncertainty:.3f} µm "
                   f"(k = {result.coverage_factor:.2f}), {result.n_trials} trials")
    axes.legend(loc="upper right", fontsize="small")
    if budget:
        bars = figure.add_subplot(1, 2, 2)
        names = [entry.name for entry in budget]
        bars.barh(names, [1000.0 * entry.contribution for entry in budget], color="#55a868")
        bars.invert_yaxis()
        bars.set_xlabel("u_i(y) / µm (one input group varied)")
        bars.set_title("Budget")
    return save_figure(figure, path, overwrite=overwrite)
