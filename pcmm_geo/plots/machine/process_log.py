"""Plot of a processed measurement log: tip path with probe points, pivot heights, closure residuals, u and R."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pcmm_geo.plots._figure import ARM_COLOURS, check_plot_path, equal_3d_limits, new_figure, save_figure

if TYPE_CHECKING:
    from pcmm_geo.machine.analysis.logproc import ProcessedLog

__all__ = ["plot_processed_log"]


def plot_processed_log(processed: ProcessedLog, path: str | Path, *, overwrite: bool = False) -> Path:
    """Write the log plot: 3-D tip path and probe points; pivot heights, closure residual, u and R per row.

    The lower right panel shows each row's standard uncertainty ``u`` (the 3-D point's,
    ``sqrt(trace C)``), its external reliability ``R`` (largest tip shift of an undetected laser
    fault of minimal detectable size) and the stated bound ``U (k = 2) + R``; unbounded rows are
    marked at the top of the axis.

    Parameters
    ----------
    processed : ProcessedLog
        Result of :func:`pcmm_geo.machine.analysis.logproc.process_log` (mm).
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
    >>> from pcmm_geo.machine.analysis.logproc import process_log, synthesise_log
    >>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
    >>> machine = RigidBodyMachine.from_dpkm()
    >>> start = machine.reference_heights + [0.0, 60.0, -50.0]
    >>> log = synthesise_log(machine, start, [(1, 5.0, True), (2, -4.0, True), (3, 3.0, False)])
    >>> processed = process_log(machine, log, initial_heights=start)
    >>> plot_processed_log(processed, os.path.join(tempfile.mkdtemp(), "log.png")).name
    'log.png'
    """
    check_plot_path(path, overwrite=overwrite)
    tips = np.asarray(processed.tips, dtype=float)
    rows = np.arange(1, len(tips) + 1)
    figure = new_figure(12.0, 8.0)
    grid = figure.add_gridspec(3, 2, width_ratios=(1.2, 1.0))

    path_axes = figure.add_subplot(grid[:, 0], projection="3d")
    path_axes.plot(*tips.T, color="tab:grey", linewidth=0.8, label="tip path")
    if len(processed.probe_rows):
        path_axes.scatter(*np.asarray(processed.probe_points).T, color="red", s=22, depthshade=False,
                          label=f"probe points ({len(processed.probe_rows)})")
    failed = ~np.asarray(processed.converged, dtype=bool)
    if failed.any():
        path_axes.scatter(*tips[failed].T, color="black", marker="x", s=30, depthshade=False,
                          label=f"not converged ({int(failed.sum())})")
    equal_3d_limits(path_axes, tips)
    path_axes.set_xlabel("x / mm")
    path_axes.set_ylabel("y / mm")
    path_axes.set_zlabel("z / mm")
    path_axes.set_title(f"Probe-tip path over {len(tips)} rows")
    path_axes.legend(loc="upper left", fontsize=8)

    height_axes = figure.add_subplot(grid[0, 1])
    heights = np.asarray(processed.heights, dtype=float)
    for k, arm in enumerate(ARM_COLOURS):
        height_axes.plot(rows, heights[:, k] - heights[0, k], color=ARM_COLOURS[arm], label=f"pivot {arm}")
    height_axes.set_ylabel("height change / mm")
    height_axes.set_title("Pivot heights relative to row 1", fontsize=10)
    height_axes.legend(fontsize=8)

    residual_axes = figure.add_subplot(grid[1, 1], sharex=height_axes)
    closure_um = 1000.0 * np.asarray(processed.closure_residual, dtype=float)
    residual_axes.plot(rows, np.where(closure_um > 0, closure_um, np.nan), color="tab:purple", linewidth=0.8,
                       label="closure")
    if processed.closure_tolerance is not None:
        residual_axes.axhline(1000.0 * processed.closure_tolerance, color="tab:grey", linewidth=0.8, linestyle="--",
                              label="refused above")
    refused = np.asarray(processed.inconsistent, dtype=bool)
    if refused.any():
        residual_axes.scatter(rows[refused], np.maximum(closure_um[refused], 1e-9), color="red", marker="x", s=24,
                              label=f"refused ({int(refused.sum())})")
        path_axes.scatter(*tips[refused].T, color="red", marker="x", s=30, depthshade=False,
                          label=f"refused rows ({int(refused.sum())})")
        path_axes.legend(loc="upper left", fontsize=8)
    residual_axes.set_yscale("log")
    _plain_log_labels(residual_axes)
    residual_axes.set_ylabel("closure residual / µm")
    residual_axes.set_title("Laser misfit per row (w-test per reading)", fontsize=10)
    residual_axes.legend(fontsize=8)

    _plot_uncertainty(figure.add_subplot(grid[2, 1], sharex=height_axes), processed, rows)
    return save_figure(figure, path, overwrite=overwrite)


def _plot_uncertainty(axes: object, processed: ProcessedLog, rows: np.ndarray) -> None:
    """u, R and U + R per row on a log scale; unbounded rows as triangles at the top."""
    u = np.asarray(processed.tip_uncertainty, dtype=float)
    reliability = np.asarray(processed.tip_reliability, dtype=float)
    bound = np.asarray(processed.bound, dtype=float)
    finite = np.isfinite(bound)
    shown = np.isfinite(u) & (u > 0)  # the datum row (held) has u = 0: nothing to draw on a log scale
    axes.plot(rows, np.where(shown, u, np.nan), color="tab:blue", linewidth=0.9, label="u")  # type: ignore
    axes.plot(rows, np.where(np.isfinite(reliability) & (reliability > 0), reliability, np.nan),  # type: ignore
              color="tab:orange", linewidth=0.9, label="R (external reliability)")
    axes.plot(rows, np.where(finite & (bound > 0), bound, np.nan), color="black", linewidth=0.7,  # type: ignore
              linestyle="--", label="bound U (k = 2) + R")
    if np.isfinite(processed.max_bound):
        axes.axhline(processed.max_bound, color="red", linewidth=0.8, linestyle=":", label="--max-bound-mm")  # type: ignore
    top = float(np.nanmax(np.where(finite, bound, np.nan))) if finite.any() else 1.0
    if (~finite).any():
        axes.scatter(rows[~finite], np.full(int((~finite).sum()), 2.0 * top), marker="^", color="red", s=16,  # type: ignore
                     label=f"unbounded ({int((~finite).sum())})")
    ambiguous = np.asarray(processed.ambiguous, dtype=bool)
    if ambiguous.any():
        axes.scatter(rows[ambiguous], np.where(finite, bound, 2.0 * top)[ambiguous], marker="o",  # type: ignore
                     facecolors="none", edgecolors="tab:red", s=20, label=f"ambiguous ({int(ambiguous.sum())})")
    axes.set_yscale("log")  # type: ignore
    _plain_log_labels(axes)
    values = np.concatenate([u, reliability])
    values = values[np.isfinite(values) & (values > 0)]
    low = float(values.min()) if values.size else top / 10.0
    axes.set_ylim(low / 1.5, 12.0 * top)  # type: ignore  # room for the legend above the curves
    axes.set_xlabel("log row")  # type: ignore
    axes.set_ylabel("mm")  # type: ignore
    axes.set_title("Tip uncertainty u, external reliability R and stated bound per row", fontsize=10)  # type: ignore
    axes.legend(fontsize=7, ncol=3, loc="upper center")  # type: ignore


def _plain_log_labels(axes: object) -> None:
    """Tick labels of a log axis as plain numbers (0.2, 0.4), not powers of ten (2 x 10^-1)."""
    from matplotlib.ticker import LogFormatter

    axes.yaxis.set_major_formatter(LogFormatter())  # type: ignore
    axes.yaxis.set_minor_formatter(LogFormatter(labelOnlyBase=False, minor_thresholds=(1.5, 0.6)))  # type: ignore
