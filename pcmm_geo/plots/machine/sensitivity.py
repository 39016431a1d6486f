"""Sensitivity map of the micro-CMM over its working cube: every grid point, one panel per z level.

Each panel is one layer of the grid (x-y positions relative to the cube centre), coloured
by the laser-to-tip amplification ``laser_gain`` on one shared logarithmic scale; points
where the lasers are blind (singular ``dL/dh``, infinite gain) are drawn as red crosses and
counted in the figure title.  The last panel gives the probe-to-laser movement ratio of each
motor over all points, sorted, against the thesis' 20:1.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pcmm_geo._optional import require
from pcmm_geo.plots._figure import ARM_COLOURS, check_plot_path, new_figure, save_figure

if TYPE_CHECKING:
    from pcmm_geo.machine.analysis.sensitivity import Sensitivity

__all__ = ["plot_sensitivity", "z_levels"]


def z_levels(points: np.ndarray, decimals: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """Distinct z values of grid ``points`` (N, 3) and each point's level index (N,).

    Examples
    --------
    >>> levels, index = z_levels(np.array([[0, 0, 1.0], [1, 0, 0.0], [0, 1, 1.0]]))
    >>> levels.tolist(), index.tolist()
    ([0.0, 1.0], [1, 0, 1])
    """
    levels, index = np.unique(np.round(np.asarray(points, dtype=float)[:, 2], decimals), return_inverse=True)
    return levels, index.ravel()


def plot_sensitivity(sensitivity: Sensitivity, path: str | Path, *, overwrite: bool = False) -> Path:
    """Write the sensitivity map: laser gain per z level (all points) and the motor ratios.

    Parameters
    ----------
    sensitivity : Sensitivity
        Result of :func:`pcmm_geo.machine.analysis.sensitivity.sensitivity_over_cube` (mm).
    path : str or Path
        Destination, ``.png``, ``.svg`` or ``.pdf``.
    overwrite : bool
        Replace an existing file.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    OutputExistsError
        ``path`` exists and ``overwrite`` is False.
    InvalidInputError
        Unsupported suffix.
    OSError
        The folder does not exist or is not writable.

    Examples
    --------
    >>> import os, tempfile
    >>> from pcmm_geo.machine.analysis.sensitivity import sensitivity_over_cube
    >>> sens = sensitivity_over_cube(points_per_axis=2)
    >>> plot_sensitivity(sens, os.path.join(tempfile.mkdtemp(), "s.png")).suffix
    '.png'
    """
    LogNorm = require("matplotlib.colors").LogNorm
    ScalarFormatter = require("matplotlib.ticker").ScalarFormatter

    check_plot_path(path, overwrite=overwrite)
    rel = np.asarray(sensitivity.points, dtype=float) - np.asarray(sensitivity.center, dtype=float)
    gain = np.asarray(sensitivity.laser_gain, dtype=float)
    blind = ~np.isfinite(gain)
    levels, level_of = z_levels(rel)
    panels = len(levels) + 1
    columns = 3 if panels > 4 else panels
    rows = math.ceil(panels / columns)
    figure = new_figure(4.0 * columns + 1.0, 3.6 * rows + 0.4)
    finite = gain[~blind]
    norm = LogNorm(vmin=float(finite.min()), vmax=float(finite.max())) if finite.size else None
    half = 0.5 * float(sensitivity.size) * 1.12
    mappable = None
    level_axes = []
    for k, level in enumerate(levels):
        axes = figure.add_subplot(rows, columns, k + 1)
        level_axes.append(axes)
        here = level_of == k
        seen = here & ~blind
        if seen.any():
            mappable = axes.scatter(rel[seen, 0], rel[seen, 1], c=gain[seen], cmap="viridis", norm=norm, s=70,
                                    edgecolors="0.3", linewidths=0.4)
        singular = here & blind
        if singular.any():
            axes.scatter(rel[singular, 0], rel[singular, 1], marker="x", s=80, color="red", linewidths=2.0)
        axes.set_xlim(-half, half)
        axes.set_ylim(-half, half)
        axes.set_aspect("equal")
        axes.set_title(f"z - centre = {level + 0.0:+.1f} mm ({int(singular.sum())} singular)", fontsize=9)
        axes.set_xlabel("x - centre / mm", fontsize=8)
        axes.set_ylabel("y - centre / mm", fontsize=8)
        axes.tick_params(labelsize=7)
    if mappable is not None:
        bar = figure.colorbar(mappable, ax=level_axes, label="laser gain / (mm tip per mm laser), log scale",
                              shrink=0.8)
        bar.ax.yaxis.set_major_formatter(ScalarFormatter())
        bar.ax.yaxis.set_minor_formatter(ScalarFormatter())
    ratio_axes = figure.add_subplot(rows, columns, panels)
    ratios = np.where(np.isfinite(sensitivity.motor_ratio), sensitivity.motor_ratio, np.nan)
    for k, arm in enumerate("abc"):
        ratio_axes.plot(np.sort(ratios[:, k]), color=ARM_COLOURS[arm], label=f"motor {arm}")
    ratio_axes.axhline(20.0, color="grey", linestyle="--", label="thesis 20:1")
    ratio_axes.set_yscale("log")
    ratio_axes.yaxis.set_major_formatter(ScalarFormatter())
    ratio_axes.yaxis.set_minor_formatter(ScalarFormatter())
    ratio_axes.set_xlabel("grid point (sorted by ratio)", fontsize=8)
    ratio_axes.set_ylabel("probe / laser movement", fontsize=8)
    ratio_axes.set_title("Probe-to-laser ratio per motor (finite points)", fontsize=9)
    ratio_axes.legend(fontsize=7)
    ratio_axes.tick_params(labelsize=7)
    figure.suptitle(
        f"Laser-to-tip amplification over a {sensitivity.size:g} mm cube: {len(rel)} grid points, "
        f"{int(blind.sum())} singular (lasers blind, red x)")
    return save_figure(figure, path, overwrite=overwrite)
