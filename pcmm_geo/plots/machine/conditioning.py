"""Maps of the predicted tip uncertainty: over the workspace and over the start poses of a session.

Left: :func:`~pcmm_geo.machine.analysis.conditioning_maps.workspace_map`, the worst single-move tip u
(``PoseConditioning.tip_u``) of the tips on a horizontal plane through the level start's tip, on a
logarithmic scale; grey where the machine cannot reach, hatched where a mirror branch is within the
noise.  Right: :func:`~pcmm_geo.machine.analysis.conditioning_maps.start_map`, the worst of it over
each start's session box (each motor +-20 mm), by the offsets of pivots b and c from level (pivot a:
minus their sum); the thesis' level start, the off-level ``0 60 -60`` and the chosen start are marked,
and the starts the choice may take (reachable, unambiguous, pivots 20 mm apart) are outlined.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pcmm_geo._optional import require
from pcmm_geo.plots._figure import check_plot_path, new_figure, save_figure

if TYPE_CHECKING:
    from pcmm_geo.machine.analysis.conditioning_maps import StartMap, WorkspaceMap

__all__ = ["plot_conditioning_maps"]


def plot_conditioning_maps(workspace: WorkspaceMap, starts: StartMap, chosen: np.ndarray, path: str | Path, *,
                           overwrite: bool = False) -> Path:
    """Write the two maps (module notes) to ``path``.

    Parameters
    ----------
    workspace : WorkspaceMap
    starts : StartMap
    chosen : ndarray, shape (3,)
        The chosen start's offsets from level (mm), marked on the start map.
    path : str or Path
        ``.png``, ``.svg`` or ``.pdf``.
    overwrite : bool
        Replace an existing file.

    Returns
    -------
    Path

    Raises
    ------
    OutputExistsError
        ``path`` exists and ``overwrite`` is False.

    Examples
    --------
    >>> import os, tempfile
    >>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
    >>> from pcmm_geo.machine.analysis.conditioning_maps import choose_start, start_map, workspace_map
    >>> m = RigidBodyMachine.from_dpkm()
    >>> found = start_map(m, axis=np.arange(-80.0, 81.0, 40.0))
    >>> out = plot_conditioning_maps(workspace_map(m, points=5), found, choose_start(found),
    ...                              os.path.join(tempfile.mkdtemp(), "c.png"))
    >>> out.suffix
    '.png'
    """
    colors = require("matplotlib.colors")
    ticker = require("matplotlib.ticker")
    check_plot_path(path, overwrite=overwrite)
    norm = colors.LogNorm(vmin=0.03, vmax=10.0)
    cmap = require("matplotlib").colormaps["viridis"].with_extremes(over="#fde725", bad="0.85")
    figure = new_figure(13.5, 6.0)
    left, right = figure.add_subplot(1, 2, 1), figure.add_subplot(1, 2, 2)

    u = np.ma.masked_invalid(workspace.tip_u)
    x0, y0 = float(np.mean(workspace.x)), float(np.mean(workspace.y))
    extent = _extent(workspace.x - x0, workspace.y - y0)
    image = left.imshow(u.T, origin="lower", extent=extent, cmap=cmap, norm=norm, interpolation="nearest")
    ambiguous = np.nan_to_num(workspace.ambiguity_ratio, nan=np.inf) < 1.0
    if ambiguous.any():
        left.contourf(workspace.x - x0, workspace.y - y0, ambiguous.T.astype(float), levels=[0.5, 1.5], colors="none",
                      hatches=["////"])
    left.contour(workspace.x - x0, workspace.y - y0, u.T, levels=[0.1, 1.0], colors=["white", "red"],
                 linewidths=1.0)
    left.plot([0.0], [0.0], marker="x", color="red", markersize=10, mew=2, label="level start's tip")
    left.set_title(f"Worst single-move tip u over the workspace\n(plane z = {workspace.z:.1f} mm through the level "
                   "start's tip; contours 0.1 mm white, 1 mm red)", fontsize=9)
    left.set_xlabel(f"x - ({x0:.1f}) / mm", fontsize=8)
    left.set_ylabel(f"y - ({y0:.1f}) / mm", fontsize=8)
    left.legend(fontsize=7, loc="upper right")

    box = np.ma.masked_invalid(np.where(np.isfinite(starts.box_tip_u), starts.box_tip_u, np.nan))
    start_extent = _extent(starts.axis, starts.axis)
    right.imshow(box.T, origin="lower", extent=start_extent, cmap=cmap, norm=norm, interpolation="nearest")
    right.contour(starts.axis, starts.axis, starts.eligible.T.astype(float), levels=[0.5], colors="white",
                  linewidths=1.2)
    right.contour(starts.axis, starts.axis, box.T, levels=[0.1], colors="black", linewidths=0.8,
                  linestyles="--")  # masked where unreachable: no contour along the edge of the reachable starts
    right.plot([0.0], [0.0], marker="x", color="red", markersize=10, mew=2, label="level (thesis): unbounded")
    right.plot([60.0], [-60.0], marker="s", color="orange", markersize=7, linestyle="none",
               label="offsets 0 60 -60")
    right.plot([chosen[1]], [chosen[2]], marker="*", color="white", markeredgecolor="black", markersize=15,
               linestyle="none", label=f"chosen: {chosen[0]:g}, {chosen[1]:g}, {chosen[2]:g} mm")
    right.set_title(f"Worst single-move tip u over a session from each start (each motor +-{starts.span:.0f} mm)\n"
                    "white outline: reachable, unambiguous, pivots 20 mm apart; dashed: 0.1 mm", fontsize=9)
    right.set_xlabel("pivot b from level / mm (pivot a: -(b + c))", fontsize=8)
    right.set_ylabel("pivot c from level / mm", fontsize=8)
    right.legend(fontsize=7, loc="lower left")
    for axes in (left, right):
        axes.set_aspect("equal")
        axes.tick_params(labelsize=7)
    bar = figure.colorbar(image, ax=[left, right], extend="max", shrink=0.85,
                          label="predicted tip u / mm (log scale; grey: not reachable)")
    bar.ax.yaxis.set_major_formatter(ticker.ScalarFormatter())
    figure.suptitle("Predicted tip uncertainty (laser sigma 28.9 um and the sensors' steps, as process-log states it)")
    return save_figure(figure, path, overwrite=overwrite)


def _extent(x: np.ndarray, y: np.ndarray) -> list[float]:
    """Image extent whose pixels are centred on the grid points."""
    dx = float(x[1] - x[0]) if len(x) > 1 else 1.0
    dy = float(y[1] - y[0]) if len(y) > 1 else 1.0
    return [float(x[0]) - dx / 2, float(x[-1]) + dx / 2, float(y[0]) - dy / 2, float(y[-1]) + dy / 2]
