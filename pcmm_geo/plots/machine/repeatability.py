"""Plots of the thesis' error investigation (6.3): start-position repeatability and height per laser.

- :func:`plot_start_repeatability` -- each laser's start reading per test, relative to its median,
  with the band laser error alone explains (Tables 6.6, 6.7) and the flagged readings marked.
- :func:`plot_laser_ratio` -- ``delta_h / delta_l`` per run and arm against the rigid-body
  prediction, and the predicted ratio as a function of the rise (Table 6.8).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pcmm_geo.plots._figure import ARM_COLOURS, check_plot_path, new_figure, save_figure

if TYPE_CHECKING:
    from pcmm_geo.machine.analysis.laser_ratio import LaserHeightRatio
    from pcmm_geo.machine.analysis.laser_ratio_model import RatioTableSummary
    from pcmm_geo.machine.analysis.repeatability import StartRepeatability
    from pcmm_geo.machine.kinematics.model import RigidBodyMachine

__all__ = ["plot_laser_ratio", "plot_start_repeatability"]

ARMS = ("a", "b", "c")


def plot_start_repeatability(result: StartRepeatability, path: str | Path, *, overwrite: bool = False) -> Path:
    """Start readings minus each laser's median per test, the +-2 accuracy band, flagged readings circled.

    Parameters
    ----------
    result : StartRepeatability
    path : str or Path
        Destination, ``.png``, ``.svg`` or ``.pdf``.
    overwrite : bool
        Replace an existing file.

    Returns
    -------
    Path

    Raises
    ------
    OutputExistsError, InvalidInputError, OSError
        As :func:`pcmm_geo.plots._figure.save_figure`.

    Examples
    --------
    >>> import os, tempfile
    >>> from pcmm_geo.machine.analysis.repeatability import start_repeatability
    >>> result = start_repeatability([[33.70, 33.51, 37.14], [33.41, 33.56, 37.08], [33.70, 33.51, 37.14]])
    >>> plot_start_repeatability(result, os.path.join(tempfile.mkdtemp(), "r.png")).suffix
    '.png'
    """
    check_plot_path(path, overwrite=overwrite)
    figure = new_figure(9.0, 4.6)
    axes = figure.subplots(1, 1)
    tests = np.arange(1, len(result.labels) + 1)
    axes.axhspan(-result.outlier_limit, result.outlier_limit, color="0.9", zorder=0,
                 label=f"laser error alone (+-2 x {result.laser_accuracy:g} mm)")
    axes.axhline(0.0, color="black", linewidth=0.6)
    for k, stats in enumerate(result.arms):
        relative = result.readings[:, k] - stats.median
        axes.plot(tests + (k - 1) * 0.06, relative, marker="o", linewidth=0.8, color=ARM_COLOURS[stats.arm],
                  label=f"laser {stats.arm}: range {stats.range:.3f} mm, s {stats.sigma_sample:.3f} mm")
        if stats.flagged:
            chosen = np.array(stats.flagged)
            axes.scatter(tests[chosen] + (k - 1) * 0.06, relative[chosen], s=160, facecolors="none",
                         edgecolors="red", linewidths=1.4, zorder=5)
    axes.scatter([], [], s=160, facecolors="none", edgecolors="red", label="flagged: beyond laser error")
    axes.set_xticks(tests, [label[:14] for label in result.labels], rotation=30 if len(tests) > 6 else 0, fontsize=8)
    axes.set_xlabel("test")
    axes.set_ylabel("start reading - median of its laser / mm")
    axes.grid(alpha=0.3)
    axes.legend(fontsize=8, loc="best")
    figure.suptitle(f"Start-position repeatability over {len(tests)} tests (thesis 6.3, Tables 6.6/6.7)")
    return save_figure(figure, path, overwrite=overwrite)


def _points(result: LaserHeightRatio | RatioTableSummary) -> list[tuple[str, int, float, float, float]]:
    """(arm, test, ratio, rise mm, standard uncertainty or 0) for every run."""
    runs = getattr(result, "runs", None)
    if runs is not None:
        return [(r.arm, r.test, r.height_per_laser, abs(r.height_change), r.u_accuracy) for r in runs]
    table: Any = result
    return [(arm, t + 1, float(table.ratios[t, k]), table.travel, 0.0)
            for k, arm in enumerate(ARMS) for t in range(table.ratios.shape[0])]


def plot_laser_ratio(result: LaserHeightRatio | RatioTableSummary, path: str | Path, *,
                     machine: RigidBodyMachine | None = None, overwrite: bool = False) -> Path:
    """Measured ``delta_h / delta_l`` per run and arm against the rigid-body prediction.

    Left: the ratio of each run (with its accuracy-based standard uncertainty where known) and the
    predicted ratio of each arm (dashed).  Right: the predicted ratio against the rise from level
    pivots, with the measured runs at their rise.

    Parameters
    ----------
    result : LaserHeightRatio or RatioTableSummary
    path : str or Path
        Destination, ``.png``, ``.svg`` or ``.pdf``.
    machine : RigidBodyMachine, optional
        Geometry of the prediction curve (default: the thesis geometry).
    overwrite : bool

    Returns
    -------
    Path

    Examples
    --------
    >>> import os, tempfile
    >>> from pcmm_geo.machine.analysis.laser_ratio_model import ratio_table_summary
    >>> summary = ratio_table_summary([[5.03, 6.20, 5.53], [5.12, 6.31, 5.58]])
    >>> plot_laser_ratio(summary, os.path.join(tempfile.mkdtemp(), "q.png")).suffix
    '.png'
    """
    from pcmm_geo.machine.analysis.laser_ratio_model import predicted_height_per_laser
    from pcmm_geo.machine.kinematics.model import RigidBodyMachine

    check_plot_path(path, overwrite=overwrite)
    machine = machine or RigidBodyMachine.from_dpkm()
    points = _points(result)
    figure = new_figure(12.0, 4.8)
    left, right = figure.subplots(1, 2)
    rises = [p[3] for p in points]
    curve = np.linspace(min(20.0, 0.5 * min(rises)), 1.1 * max(rises), 80)
    for k, arm in enumerate(ARMS):
        mine = [p for p in points if p[0] == arm]
        if not mine:
            continue
        colour = ARM_COLOURS[arm]
        tests = np.array([p[1] for p in mine], dtype=float) + (k - 1) * 0.08
        left.errorbar(tests, [p[2] for p in mine], yerr=[p[4] for p in mine], marker="o", linestyle="none",
                      color=colour, capsize=3, label=f"arm {arm} measured")
        prediction = next((p for p in result.predictions if p.arm == arm), None)
        if prediction is not None:
            left.axhline(prediction.height_per_laser, color=colour, linestyle="--", linewidth=1.0,
                         label=f"arm {arm} model {prediction.height_per_laser:.2f}")
        right.plot(curve, predicted_height_per_laser(machine, arm, 0.0, curve), color=colour,
                   label=f"arm {arm} model")
        right.scatter([p[3] for p in mine], [p[2] for p in mine], color=colour, s=18, zorder=5)
    left.set_xlabel("run (test)")
    left.set_ylabel("delta_h / delta_l  (eq 6.3) / (mm/mm)")
    left.grid(alpha=0.3)
    left.legend(fontsize=7, ncol=2)
    right.set_xlabel("rise of the moved pivot from level / mm")
    right.set_ylabel("delta_h / delta_l / (mm/mm)")
    right.set_yscale("log")
    from matplotlib.ticker import NullFormatter, ScalarFormatter

    right.yaxis.set_major_formatter(ScalarFormatter())
    right.yaxis.set_minor_formatter(NullFormatter())
    right.set_yticks([4, 5, 6, 8, 10, 15, 20, 30])
    right.grid(alpha=0.3, which="both")
    right.legend(fontsize=8)
    right.set_title("the model's ratio falls with the rise: the laser moves with its square at first", fontsize=9)
    figure.suptitle("Height per laser displacement (thesis 6.3, eqs 6.1-6.3, Table 6.8)")
    return save_figure(figure, path, overwrite=overwrite)
