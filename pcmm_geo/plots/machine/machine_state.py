"""Plots of the machine's state: numerical calibration (thesis ch. 6) and a kinematic pose.

- :func:`plot_numerical_calibration` -- distance residual of every height-gauge sample, grouped by
  the arm that was moved, and the singular values of the column-scaled Jacobian (what the data
  determine, what they do not).
- :func:`plot_pose` -- the machine in one pose in 3-D (columns, pivots, arms to the tip, equal
  scale on x, y and z) with, for a forward solution, the loop-closure residual of each arm.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pcmm_geo.plots._figure import (
    ARM_COLOURS,
    check_plot_path,
    equal_3d_limits,
    length_unit,
    new_figure,
    save_figure,
    three_digits,
)

if TYPE_CHECKING:
    from pcmm_geo.machine.calibration.numerical.numcal import NumericalCalibration
    from pcmm_geo.machine.calibration.numerical.numcal_data import NumcalData
    from pcmm_geo.machine.kinematics.model import RigidBodyMachine

__all__ = ["plot_numerical_calibration", "plot_pose", "plot_trilateration"]

ARMS = ("a", "b", "c")


def plot_numerical_calibration(
    result: NumericalCalibration, data: NumcalData, path: str | Path, *, overwrite: bool = False
) -> Path:
    """Residual per sample (by moved arm) and the singular values of the identification.

    Parameters
    ----------
    result : NumericalCalibration
        Result of :func:`pcmm_geo.machine.calibration.numerical.numcal.calibrate_numerically`.
    data : NumcalData
        The samples it was computed from (``result.residuals`` follows their order: one per
        sample, or three per sample -- pairs ab, bc, ca -- with ``pairs="all"``).
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
    >>> from pcmm_geo.machine.calibration.numerical.numcal import calibrate_numerically
    >>> from pcmm_geo.machine.calibration.numerical.numcal_data import NumcalParameters, synthesise_design_data
    >>> truth = NumcalParameters.from_seed_table()
    >>> design = np.random.default_rng(1).uniform(0.0, 200.0, (18, 3))
    >>> data = synthesise_design_data(truth, design, laser_sigma=1e-3, seed=1)
    >>> result = calibrate_numerically(data, pairs="all", global_search=None, start=truth)
    >>> plot_numerical_calibration(result, data, os.path.join(tempfile.mkdtemp(), "n.png")).suffix
    '.png'
    """
    check_plot_path(path, overwrite=overwrite)
    residuals = np.asarray(result.residuals, dtype=float)
    factor, unit = length_unit(residuals)
    figure = new_figure(12.0, 4.6)
    left, right = figure.subplots(1, 2, width_ratios=(1.7, 1.0))
    left.axhline(0.0, color="black", linewidth=0.6)
    if residuals.size == len(data.moved):  # the seed's one equation per sample: by moved arm
        moved = np.asarray(data.moved)
        for arm in ARMS:
            chosen = moved == arm
            if chosen.any():
                left.plot(np.asarray(data.heights)[chosen], factor * residuals[chosen], marker="o", markersize=4,
                          linewidth=0.8, color=ARM_COLOURS[arm],
                          label=f"arm {arm} moved ({int(chosen.sum())} samples)")
        left.set_xlabel("height-gauge reading of the moved pivot / mm")
    else:  # all three pair equations per sample (order ab, bc, ca): by pair, against the pair's height difference
        pivots = np.asarray(data.pivot_heights)
        for k, (pair, (first, second)) in enumerate(zip(("ab", "bc", "ca"), ((0, 1), (1, 2), (2, 0)), strict=True)):
            rise = pivots[:, second] - pivots[:, first]
            left.plot(rise, factor * residuals[k::3], marker="o", markersize=4, linestyle="none",
                      color=ARM_COLOURS[pair[1]], label=f"pair {pair} ({len(rise)} samples)")
        left.set_xlabel("height difference of the pair's pivots / mm")
    left.set_ylabel(f"distance residual / {unit}")
    left.legend(fontsize=8)
    left.grid(alpha=0.3)
    ident = result.identifiability
    values = np.asarray(ident.singular_values, dtype=float)
    relative = values / values[0] if values.size and values[0] > 0 else values
    right.bar(np.arange(1, len(values) + 1), np.where(relative > 0, relative, np.nan), color="tab:blue")
    right.set_yscale("log")
    right.set_xticks(np.arange(1, len(values) + 1))
    right.set_xlabel("singular value index")
    right.set_ylabel("s / s_max")
    right.set_title(f"Identifiability: rank {ident.rank} of {len(values)}, "
                    f"condition number {ident.condition_number:.3g}", fontsize=9)
    right.grid(alpha=0.3, axis="y")
    equations = "all pairs" if result.pairs == "all" else "moved pair"
    figure.suptitle(f"Numerical calibration ({result.method}, {equations}): {len(data.moved)} samples, "
                    f"rms {three_digits(factor * result.rms)} {unit}")
    return save_figure(figure, path, overwrite=overwrite)


def plot_pose(
    machine: RigidBodyMachine,
    heights: Any,
    tip: Any,
    path: str | Path,
    *,
    residuals: Any = None,
    title: str = "Machine pose",
    overwrite: bool = False,
) -> Path:
    """The machine in one pose: column lines, pivots, arms from pivot to tip, the tip (equal scale).

    Parameters
    ----------
    machine : RigidBodyMachine
    heights : array_like, shape (3,)
        Pivot height readings of arms a, b, c (mm).
    tip : array_like, shape (3,)
        Probe-tip centre (mm).
    path : str or Path
        Destination, ``.png``, ``.svg`` or ``.pdf``.
    residuals : array_like, shape (9,), optional
        Loop-closure residuals (x, y, z per arm, mm) of a forward solution; drawn in a second panel.
    title : str
        Figure title.
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
    >>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
    >>> machine = RigidBodyMachine.from_dpkm()
    >>> pose = machine.forward(heights=machine.reference_heights)
    >>> plot_pose(machine, pose.heights, pose.tip, os.path.join(tempfile.mkdtemp(), "k.png")).suffix
    '.png'
    """
    check_plot_path(path, overwrite=overwrite)
    heights = np.asarray(heights, dtype=float).reshape(3)
    tip = np.asarray(tip, dtype=float).reshape(3)
    pivots = np.asarray(machine.pivots(heights), dtype=float).reshape(3, 3)
    figure = new_figure(12.0 if residuals is not None else 8.0, 6.0)
    if residuals is not None:
        grid = figure.add_gridspec(1, 2, width_ratios=(1.6, 1.0))
        axes = figure.add_subplot(grid[0, 0], projection="3d")
    else:
        axes = figure.add_subplot(projection="3d")
    cloud = [tip[None], pivots]
    for k, arm in enumerate(ARMS):
        column = machine.columns[arm]
        direction = np.asarray(column.direction, dtype=float)
        along = float((pivots[k] - np.asarray(column.point, dtype=float)) @ direction)
        reach = np.array([min(along, 0.0) - 50.0, max(along, 0.0) + 50.0])
        line = np.asarray(column.point, dtype=float) + reach[:, None] * direction
        axes.plot(*line.T, color="0.6", linewidth=2.5, label="column lines" if k == 0 else None)
        axes.plot(*np.vstack([pivots[k], tip]).T, color=ARM_COLOURS[arm], linewidth=1.8,
                  label=f"arm {arm}: pivot at height {heights[k]:.3f} mm")
        axes.scatter(*pivots[k], color=ARM_COLOURS[arm], s=40, depthshade=False)
        cloud.append(line)
    axes.scatter(*tip, marker="*", s=160, color="black", depthshade=False,
                 label=f"tip ({tip[0]:.3f}, {tip[1]:.3f}, {tip[2]:.3f}) mm")
    equal_3d_limits(axes, np.vstack(cloud))
    axes.set_xlabel("x / mm")
    axes.set_ylabel("y / mm")
    axes.set_zlabel("z / mm", labelpad=8)
    axes.legend(loc="upper center", bbox_to_anchor=(0.5, -0.02), ncol=2, fontsize=7)
    if residuals is not None:
        closure = np.asarray(residuals, dtype=float).reshape(3, 3)
        factor, unit = length_unit(closure)
        side = figure.add_subplot(grid[0, 1])
        width = 0.25
        for j, axis in enumerate("xyz"):
            side.bar(np.arange(3) + (j - 1) * width, factor * closure[:, j], width=width, label=axis,
                     color=("tab:red", "tab:green", "tab:blue")[j])
        side.axhline(0.0, color="black", linewidth=0.6)
        side.set_xticks(np.arange(3), [f"arm {arm}" for arm in ARMS])
        side.set_ylabel(f"loop-closure residual / {unit}")
        side.set_title("Measured readings against the solved pose", fontsize=9)
        side.legend(fontsize=8, title="component", title_fontsize=8)
        side.grid(alpha=0.3, axis="y")
    figure.suptitle(title)
    return save_figure(figure, path, overwrite=overwrite)


def plot_trilateration(
    pivots: Any, lengths: Any, lower: Any, upper: Any, path: str | Path, *, overwrite: bool = False
) -> Path:
    """Three pivots, the arms of the given lengths to both intersection points (equal scale on x, y, z).

    Parameters
    ----------
    pivots : array_like, shape (3, 3)
        Pivot centres a, b, c (mm).
    lengths : array_like, shape (3,)
        Pivot-to-tip lengths (mm).
    lower, upper : array_like, shape (3,)
        The two intersections of the three spheres (mm); the probe hangs at the lower one.
    path : str or Path
        Destination, ``.png``, ``.svg`` or ``.pdf``.
    overwrite : bool

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
    >>> pivots = np.array([[0, 0, 0], [100, 0, 0], [0, 100, 0.0]])
    >>> tip = np.array([30.0, 30.0, -80.0])
    >>> lengths = np.linalg.norm(pivots - tip, axis=1)
    >>> upper = tip * [1, 1, -1]
    >>> plot_trilateration(pivots, lengths, tip, upper, os.path.join(tempfile.mkdtemp(), "t.png")).suffix
    '.png'
    """
    check_plot_path(path, overwrite=overwrite)
    pivots = np.asarray(pivots, dtype=float).reshape(3, 3)
    lengths = np.asarray(lengths, dtype=float).reshape(3)
    lower = np.asarray(lower, dtype=float).reshape(3)
    upper = np.asarray(upper, dtype=float).reshape(3)
    figure = new_figure(8.0, 6.5)
    axes = figure.add_subplot(projection="3d")
    for k, arm in enumerate(ARMS):
        colour = ARM_COLOURS[arm]
        axes.plot(*np.vstack([pivots[k], lower]).T, color=colour, linewidth=1.8,
                  label=f"arm {arm}: {lengths[k]:.3f} mm")
        axes.plot(*np.vstack([pivots[k], upper]).T, color=colour, linewidth=0.8, linestyle=":")
        axes.scatter(*pivots[k], color=colour, s=40, depthshade=False)
    axes.scatter(*lower, marker="*", s=160, color="black", depthshade=False, label="lower root (probe)")
    axes.scatter(*upper, marker="o", s=50, facecolors="none", edgecolors="black", depthshade=False,
                 label="upper root (mirror image, dotted arms)")
    equal_3d_limits(axes, np.vstack([pivots, lower, upper]))
    axes.set_xlabel("x / mm")
    axes.set_ylabel("y / mm")
    axes.set_zlabel("z / mm", labelpad=8)
    axes.legend(loc="upper center", bbox_to_anchor=(0.5, -0.02), ncol=2, fontsize=7)
    axes.set_title("Trilateration: three spheres about the pivots")
    return save_figure(figure, path, overwrite=overwrite)
