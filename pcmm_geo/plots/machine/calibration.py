"""Plot of a tetrahedron calibration: slider lines, joint centres, tip and probe points (thesis fig 7.2).

The left panel is the 3-D view of thesis fig 7.2: each arm's fitted slider line over the
range its joint travelled, the probed joint-ball centres at every slider position, the
probe-tip centre, the least-squares point nearest to the three lines (eq 7.2) and the
thesis' pairwise variant, with the common perpendicular of each pair of lines.  At the
scale of the machine the few millimetres by which the lines miss each other and the tip
are hard to see, so the right panel gives them as numbers: each line's distance from the
tip centre, the skew distance of each pair and how far the two theoretical probe points
lie from the tip centre.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pcmm_geo.plots._figure import ARM_COLOURS, check_plot_path, equal_3d_limits, new_figure, save_figure

if TYPE_CHECKING:
    from pcmm_geo.machine.calibration.result import TetrahedronCalibration

__all__ = ["draw_calibration_3d", "draw_miss_distances", "plot_calibration"]

ARMS = ("a", "b", "c")
PAIRS = ("ab", "bc", "ca")


def _line_extent(calibration: TetrahedronCalibration, arm: str) -> np.ndarray:
    """End points (2, 3) of arm's slider line from the tip's foot to beyond the farthest joint (mm)."""
    line = calibration.slider_lines[arm]
    centres = np.array([sphere.center for sphere in calibration.joint_spheres[arm]])
    along = (np.vstack([centres, calibration.tip_center]) - line.point) @ line.direction
    span = float(along.max() - along.min())
    reach = np.array([along.min() - 0.03 * span, along.max() + 0.03 * span])
    return line.point + reach[:, None] * line.direction


def draw_calibration_3d(axes: Any, calibration: TetrahedronCalibration) -> None:
    """Draw the fig 7.2 view into 3-D ``axes`` (a matplotlib ``Axes3D``).

    Parameters
    ----------
    axes : mpl_toolkits.mplot3d.Axes3D
    calibration : TetrahedronCalibration
        Result of :func:`pcmm_geo.machine.calibrate_tetrahedron`.

    Raises
    ------
    AttributeError
        ``calibration`` is not a :class:`TetrahedronCalibration`.

    Examples
    --------
    See :func:`plot_calibration`.
    """
    from pcmm_geo.fit import closest_points

    plotted = [np.asarray(calibration.tip_center, dtype=float)[None]]
    for arm in ARMS:
        colour = ARM_COLOURS[arm]
        segment = _line_extent(calibration, arm)
        centres = np.array([sphere.center for sphere in calibration.joint_spheres[arm]])
        axes.plot(*segment.T, color=colour, linewidth=1.5, label=f"arm {arm}: slider line, joint centres")
        axes.scatter(*centres.T, color=colour, s=28, depthshade=False)
        plotted += [segment, centres]
    tip = np.asarray(calibration.tip_center, dtype=float)
    probe = np.asarray(calibration.probe_point, dtype=float)
    pairwise = np.asarray(calibration.probe_point_pairwise, dtype=float)
    cloud = np.vstack([*plotted, probe, pairwise])
    # what is shorter than 4 % of the plotted span cannot be told apart in the 3-D view: it is not
    # drawn nor listed in the legend (the right panel gives those distances as numbers)
    visible = 0.04 * float(np.max(np.ptp(cloud, axis=0)))
    perpendiculars = []
    for pair in PAIRS:
        first, second = (calibration.slider_lines[arm] for arm in pair)
        closest = closest_points(first.point, first.direction, second.point, second.direction)
        perpendiculars.append(np.vstack([closest.point_a, closest.point_b]))
    if max(float(np.linalg.norm(ends[1] - ends[0])) for ends in perpendiculars) >= visible:
        for ends in perpendiculars:
            axes.plot(*ends.T, color="grey", linestyle=":", linewidth=1.0)
        axes.plot([], [], color="grey", linestyle=":", label="common perpendiculars")
    axes.scatter(*tip, marker="*", s=140, color="black", depthshade=False, label="tip centre")
    if float(np.linalg.norm(probe - pairwise)) >= visible:
        axes.scatter(*probe, marker="x", s=70, color="red", depthshade=False, label="probe point eq 7.2")
        axes.scatter(*pairwise, marker="+", s=90, color="purple", depthshade=False,
                     label="probe point (thesis pairwise)")
    else:
        axes.scatter(*probe, marker="x", s=70, color="red", depthshade=False,
                     label="probe point: eq 7.2 = thesis pairwise at this scale")
    equal_3d_limits(axes, cloud)
    axes.set_xlabel("x / mm")
    axes.set_ylabel("y / mm")
    axes.set_zlabel("z / mm", labelpad=8)
    axes.set_title("Slider paths, joint centres and probe point (fig 7.2; equal scale on x, y, z)")
    axes.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2, fontsize=7)


def draw_miss_distances(axes: Any, calibration: TetrahedronCalibration) -> None:
    """Horizontal bars of how far the slider lines miss the tip and each other (mm).

    Raises
    ------
    AttributeError
        ``calibration`` is not a :class:`TetrahedronCalibration`.

    Examples
    --------
    See :func:`plot_calibration`.
    """
    tip = np.asarray(calibration.tip_center, dtype=float)
    labels, values, colours = [], [], []
    for arm in ARMS:
        labels.append(f"line {arm} to tip centre")
        values.append(float(calibration.slider_lines[arm].tip_offset))
        colours.append(ARM_COLOURS[arm])
    for pair in PAIRS:
        labels.append(f"skew distance {pair[0]}-{pair[1]}")
        values.append(float(calibration.skew_distances[pair]))
        colours.append("grey")
    labels += ["eq 7.2 point to tip centre", "pairwise point to tip centre"]
    values += [float(np.linalg.norm(np.asarray(calibration.probe_point) - tip)),
               float(np.linalg.norm(np.asarray(calibration.probe_point_pairwise) - tip))]
    colours += ["red", "purple"]
    rows = np.arange(len(values))[::-1]
    axes.barh(rows, values, color=colours)
    for row, value in zip(rows, values, strict=True):
        axes.text(value, row, f" {value:.4f}", va="center", fontsize=8)
    axes.set_yticks(rows, labels, fontsize=8)
    axes.set_xlabel("distance / mm")
    axes.set_xlim(0.0, 1.25 * max(max(values), 1e-6))
    axes.set_title("How far the lines miss")


def plot_calibration(
    calibration: TetrahedronCalibration, path: str | Path, *, overwrite: bool = False
) -> Path:
    """Write the calibration plot: fig 7.2 in 3-D and the miss distances.

    Parameters
    ----------
    calibration : TetrahedronCalibration
        Result of :func:`pcmm_geo.machine.calibrate_tetrahedron` (lengths in mm).
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
    >>> from pcmm_geo.machine.calibration import calibrate_tetrahedron
    >>> from pcmm_geo.machine.calibration.seed import appendix_cd_files
    >>> calibration = calibrate_tetrahedron(*appendix_cd_files())
    >>> plot_calibration(calibration, os.path.join(tempfile.mkdtemp(), "cal.png")).suffix
    '.png'
    """
    check_plot_path(path, overwrite=overwrite)
    figure = new_figure(12.0, 6.5)
    grid = figure.add_gridspec(1, 2, width_ratios=(1.6, 1.0))
    draw_calibration_3d(figure.add_subplot(grid[0, 0], projection="3d"), calibration)
    draw_miss_distances(figure.add_subplot(grid[0, 1]), calibration)
    return save_figure(figure, path, overwrite=overwrite)
