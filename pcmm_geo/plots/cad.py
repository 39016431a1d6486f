"""Plots of CAD comparisons: deviations of a scan from its nominal mesh, and segmented scans."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._optional import require
from pcmm_geo.elements import SPECS, element_of
from pcmm_geo.plots._figure import check_plot_path, length_unit, new_figure, save_figure

if TYPE_CHECKING:
    from pcmm_geo.artefacts.cad_compare import MeshDeviations
    from pcmm_geo.artefacts.cad_segment import Segmentation
    from pcmm_geo.fit import FitResult

__all__ = ["plot_deviations", "plot_segments"]

FloatArray = NDArray[np.float64]


def plot_deviations(
    deviations: MeshDeviations, path: str | Path, *, title: str | None = None, overwrite: bool = False
) -> Path:
    """Write a 3-D scatter of the registered points coloured by their signed deviation (nm, µm or mm).

    The colour scale is symmetric about zero (blue inside the material, red outside); with
    a tolerance it spans the larger of the tolerance and the largest deviation, and points
    beyond the tolerance are drawn with a black edge.

    Parameters
    ----------
    deviations : MeshDeviations
        From :func:`pcmm_geo.artefacts.mesh_deviations` or ``compare_to_mesh(...).deviations``.
    path : str or Path
        Destination, ``.png``, ``.svg`` or ``.pdf``.
    title : str, optional
        First title line (default ``"deviations from nominal"``).
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
    >>> from pcmm_geo.artefacts.cad_compare import mesh_deviations
    >>> from pcmm_geo.io.meshes import box_mesh
    >>> found = mesh_deviations([[0, 0, 4.501], [10, 0, 4.499], [50.002, 0, 0]], box_mesh(100, 35, 9))
    >>> plot_deviations(found, os.path.join(tempfile.mkdtemp(), "dev.png")).name
    'dev.png'
    """
    TwoSlopeNorm = require("matplotlib.colors").TwoSlopeNorm

    check_plot_path(path, overwrite=overwrite)
    points = np.asarray(deviations.points, dtype=float)
    summary = deviations.summary
    signed = np.asarray(deviations.signed_distance, dtype=float)
    factor, unit = length_unit(np.r_[signed, [] if summary.tolerance is None else [summary.tolerance]])
    shown = factor * signed
    tolerance = None if summary.tolerance is None else factor * summary.tolerance
    limit = float(np.max(np.abs(shown))) if shown.size else 0.0
    if tolerance is not None:
        limit = max(limit, tolerance)
    limit = limit or 1.0
    figure = new_figure(7.5, 5.5)
    axes = figure.add_subplot(projection="3d")
    beyond = np.zeros(len(points), dtype=bool) if tolerance is None else np.abs(shown) > tolerance
    scatter = axes.scatter(points[:, 0], points[:, 1], points[:, 2], c=shown, cmap="RdBu_r",
                           norm=TwoSlopeNorm(vcenter=0.0, vmin=-limit, vmax=limit), s=6, depthshade=False,
                           edgecolors=np.where(beyond[:, None], [[0.0, 0.0, 0.0, 1.0]], [[0.0, 0.0, 0.0, 0.0]]),
                           linewidths=0.6)
    _true_proportions(axes, points)
    axes.set_xlabel("x / mm")
    axes.set_ylabel("y / mm")
    axes.set_zlabel("z / mm")
    colour_bar = figure.colorbar(scatter, ax=axes, shrink=0.7, pad=0.08)
    colour_bar.set_label(f"deviation / {unit} (+ outside)")
    statistics = (f"n {summary.count}, min {factor * summary.minimum:.3g} {unit}, "
                  f"max {factor * summary.maximum:.3g} {unit}, rms {factor * summary.rms:.3g} {unit}")
    if tolerance is not None:
        statistics += f", {summary.count_beyond} beyond ±{tolerance:.3g} {unit}"
    axes.set_title(f"{title or 'deviations from nominal'}\n{statistics}", fontsize=9)
    return save_figure(figure, path, overwrite=overwrite)


def plot_segments(
    points: ArrayLike, segmentation: Segmentation, path: str | Path, *, overwrite: bool = False
) -> Path:
    """Write a 3-D scatter of a scan with one colour per segment (grey: unassigned).

    Parameters
    ----------
    points : array_like, shape (N, 3)
        The points that were segmented (mm).
    segmentation : Segmentation
        From :func:`pcmm_geo.artefacts.segment_scan`.
    path : str or Path
        Destination, ``.png``, ``.svg`` or ``.pdf``.
    overwrite : bool
        Replace an existing file.

    Returns
    -------
    Path

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
    >>> from pcmm_geo.artefacts.cad_segment import segment_scan
    >>> rng = np.random.default_rng(0)
    >>> floor = np.c_[rng.uniform(0, 10, 200), rng.uniform(0, 10, 200), np.zeros(200)]
    >>> result = segment_scan(floor, distance_threshold=0.01)
    >>> plot_segments(floor, result, os.path.join(tempfile.mkdtemp(), "seg.png")).name
    'seg.png'
    """
    colormaps = require("matplotlib").colormaps

    check_plot_path(path, overwrite=overwrite)
    cloud = np.asarray(points, dtype=float)
    figure = new_figure(7.5, 5.5)
    axes = figure.add_subplot(projection="3d")
    palette = colormaps["tab10"]
    if segmentation.unassigned.size:
        rest = cloud[segmentation.unassigned]
        axes.scatter(rest[:, 0], rest[:, 1], rest[:, 2], color="0.6", s=3, depthshade=False,
                     label=f"unassigned ({segmentation.unassigned.size})")
    for number, segment in enumerate(segmentation.segments):
        member = cloud[segment.indices]
        size = _size_text(segment.fit)
        axes.scatter(member[:, 0], member[:, 1], member[:, 2], color=palette(number % 10), s=4, depthshade=False,
                     label=f"{number + 1} {segment.kind} ({size}n {len(segment.indices)}, "
                           f"rms {1000 * segment.fit.rms:.2g} µm)")
    _true_proportions(axes, cloud)
    axes.set_xlabel("x / mm")
    axes.set_ylabel("y / mm")
    axes.set_zlabel("z / mm")
    figure.legend(loc="outside lower center", fontsize=7, markerscale=2.5, ncols=2)
    axes.set_title(f"{len(segmentation.planes)} planes, {len(segmentation.cylinders)} cylinders "
                   f"(threshold {1000 * segmentation.distance_threshold:.3g} µm)", fontsize=9)
    return save_figure(figure, path, overwrite=overwrite)


def _size_text(fit: FitResult) -> str:
    """The legend's size of a segment's fit, its summary row of the spec's size (``"r 4.0000 mm, "``; "" for a plane).

    >>> from pcmm_geo.fit import fit_cylinder
    >>> theta = np.linspace(0.0, 2 * np.pi, 8, endpoint=False)
    >>> _size_text(fit_cylinder(np.c_[4 * np.tile(np.cos(theta), 2), 4 * np.tile(np.sin(theta), 2),
    ...                              np.repeat([0.0, 9.0], 8)]))
    'r 4.0000 mm, '
    """
    element = element_of(fit)
    size = None if element is None else SPECS[element].size
    rows = [row for row in fit.summary() if row.name == size]
    return "".join(f"r {row.value:.4f} {row.unit}, " for row in rows)


def _true_proportions(axes: Any, points: FloatArray, margin: float = 0.04) -> None:
    """Tight limits around ``points`` (N, 3) with one mm drawn the same length on every axis."""
    low, high = points.min(axis=0), points.max(axis=0)
    pad = margin * float(np.max(high - low)) or 1.0
    low, high = low - pad, high + pad
    axes.set_xlim(low[0], high[0])
    axes.set_ylim(low[1], high[1])
    axes.set_zlim(low[2], high[2])
    axes.set_box_aspect(tuple(float(v) for v in (high - low)))
    MaxNLocator = require("matplotlib.ticker").MaxNLocator

    for axis, extent in zip((axes.xaxis, axes.yaxis, axes.zaxis), high - low, strict=True):
        axis.set_major_locator(MaxNLocator(max(2, min(6, round(6 * extent / float(np.max(high - low)) + 1)))))
