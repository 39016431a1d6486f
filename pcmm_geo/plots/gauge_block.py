"""Gauge-block report plot: per-face plane residuals and the lengths of the different methods.

Top row: one panel per probed face (``face_1``, ``face_2``, ``top``, ``side``), the points in
the coordinates of their own least-squares plane, coloured by their signed deviation from it
(µm, one colour scale for all faces).  Bottom: every length the evaluation gives -- the two
one-way ISO 3650 central lengths, the exact projection, the two-angle length (the thesis'
eqs 5.1-5.3) and the naive two-point distance -- as differences from the ISO 3650 central length (µm), with the lengths
themselves written next to the bars.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from pcmm_geo.plots._figure import check_plot_path, length_unit, new_figure, save_figure

if TYPE_CHECKING:
    from pcmm_geo.artefacts.gauge_block import GaugeBlockMeasurement

__all__ = ["face_deviations", "length_comparison", "plot_gauge_block"]

FACE_ORDER = ("face_1", "face_2", "top", "side")
FACE_TITLES = {"face_1": "measuring face 1", "face_2": "measuring face 2", "top": "top face", "side": "side face"}


def face_deviations(points: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """In-plane coordinates (N, 2) and signed deviations (N,) of points from their least-squares plane (mm).

    The in-plane axes are two orthonormal directions perpendicular to the fitted normal; the
    first is the one of x, y, z least aligned with the normal, made perpendicular to it.

    Raises
    ------
    TooFewPointsError, DegenerateGeometryError
        Fewer than 3 points, or collinear points.

    Examples
    --------
    >>> flat, deviation = face_deviations([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.002]])
    >>> flat.shape, [round(float(d), 4) for d in deviation]
    ((4, 2), [0.0005, -0.0005, -0.0005, 0.0005])
    """
    from pcmm_geo.fit import fit_plane

    cloud = np.asarray(points, dtype=float)
    plane = fit_plane(cloud)
    normal = np.asarray(plane.normal, dtype=float)
    seed_axis = np.eye(3)[int(np.argmin(np.abs(normal)))]
    first = seed_axis - (seed_axis @ normal) * normal
    first /= np.linalg.norm(first)
    second = np.cross(normal, first)
    relative = cloud - np.asarray(plane.point, dtype=float)
    return np.column_stack([relative @ first, relative @ second]), np.asarray(plane.residuals, dtype=float)


def length_comparison(measurement: GaugeBlockMeasurement) -> list[tuple[str, float]]:
    """``(method, length in mm)`` for every length ``measurement`` holds, ISO 3650 central length first.

    Examples
    --------
    >>> from pcmm_geo.artefacts.gauge_block import measure_gauge_block
    >>> ys, zs = np.meshgrid([-10.0, 0.0, 10.0], [-3.0, 0.0, 3.0])
    >>> lateral = np.c_[ys.ravel(), zs.ravel()]
    >>> faces = {"face_1": np.c_[np.zeros(9), lateral], "face_2": np.c_[np.full(9, 100.0), lateral]}
    >>> [name for name, _ in length_comparison(measure_gauge_block(faces))]
    ['ISO 3650 central length', 'face 1 centre to plane 2', 'face 2 centre to plane 1']
    """
    rows = [
        ("ISO 3650 central length", float(measurement.central_length)),
        ("face 1 centre to plane 2", float(measurement.length_face1_to_plane2)),
        ("face 2 centre to plane 1", float(measurement.length_face2_to_plane1)),
    ]
    if not math.isnan(measurement.projected_length):
        rows.append(("exact projection (top x side)", float(measurement.projected_length)))
    if measurement.seed is not None:
        rows.append(("two-angle length (3-point planes)", float(measurement.seed.length)))
        rows.append(("two-point distance", float(measurement.seed.vector_length)))
    return rows


def _draw_face(axes: Any, label: str, points: ArrayLike, limit: float, factor: float, unit: str) -> Any:
    flat, deviation = face_deviations(points)
    shown = factor * deviation
    mappable = axes.scatter(flat[:, 0], flat[:, 1], c=shown, cmap="coolwarm", vmin=-limit,
                            vmax=limit, s=46, edgecolors="black", linewidths=0.4)
    axes.set_aspect("equal", adjustable="datalim")
    axes.set_title(f"{FACE_TITLES[label]}: {len(flat)} points\nform {float(np.ptp(shown)):.3g} {unit}",
                   fontsize=9)
    axes.set_xlabel("in-plane u / mm", fontsize=8)
    axes.set_ylabel("in-plane v / mm", fontsize=8)
    axes.tick_params(labelsize=7)
    return mappable


def _draw_lengths(axes: Any, measurement: GaugeBlockMeasurement) -> None:
    rows = length_comparison(measurement)
    reference = rows[0][1]
    offsets_um = np.array([1000.0 * (length - reference) for _, length in rows])
    positions = np.arange(len(rows))[::-1]
    colours = ["black", "tab:blue", "tab:blue", "tab:green", "tab:red", "tab:grey"][: len(rows)]
    axes.barh(positions, offsets_um, color=colours, height=0.6)
    axes.axvline(0.0, color="black", linewidth=0.8)
    span = max(float(np.max(np.abs(offsets_um))), 1e-3)
    for position, offset, (_, length) in zip(positions, offsets_um, rows, strict=True):
        axes.text(span * 1.05, position, f"{length:.6f} mm ({offset:+.3f} µm)", va="center", fontsize=8)
    axes.set_xlim(-1.1 * span, 2.3 * span)
    axes.set_yticks(positions, [name for name, _ in rows], fontsize=8)
    axes.set_xlabel("length minus ISO 3650 central length / µm")
    axes.set_title(f"Central length {reference:.6f} mm (ISO 3650) against the other lengths", fontsize=10)


def plot_gauge_block(
    points_by_face: Mapping[str, ArrayLike],
    measurement: GaugeBlockMeasurement,
    path: str | Path,
    *,
    overwrite: bool = False,
) -> Path:
    """Write the gauge-block report plot (face residuals, lengths of every method).

    Parameters
    ----------
    points_by_face : mapping str -> array_like (N, 3)
        The points given to :func:`~pcmm_geo.artefacts.gauge_block.measure_gauge_block` (mm).
    measurement : GaugeBlockMeasurement
        Its result.
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
    TooFewPointsError, DegenerateGeometryError
        A face cannot be fitted with a plane (as in the measurement itself).
    OSError
        The folder does not exist or is not writable.

    Examples
    --------
    >>> import os, tempfile
    >>> from importlib.resources import files
    >>> from pcmm_geo.artefacts.gauge_block import measure_gauge_block, read_gauge_block_csv
    >>> faces = read_gauge_block_csv(files("pcmm_geo") / "data/examples/gauge_block.csv")
    >>> out = plot_gauge_block(faces, measure_gauge_block(faces), os.path.join(tempfile.mkdtemp(), "gb.png"))
    >>> out.name
    'gb.png'
    """
    check_plot_path(path, overwrite=overwrite)
    labels = [label for label in FACE_ORDER if label in points_by_face]
    largest = max(float(np.max(np.abs(face_deviations(points_by_face[label])[1]))) for label in labels)
    factor, unit = length_unit([largest])
    limit = factor * largest or 1.0
    figure = new_figure(3.0 * len(labels) + 1.5, 7.0)
    grid = figure.add_gridspec(2, len(labels), height_ratios=(1.25, 1.0))
    face_axes = [figure.add_subplot(grid[0, k]) for k in range(len(labels))]
    mappable = None
    for axes, label in zip(face_axes, labels, strict=True):
        mappable = _draw_face(axes, label, points_by_face[label], limit, factor, unit)
    figure.colorbar(mappable, ax=face_axes, label=f"deviation from face plane / {unit}", shrink=0.9)
    _draw_lengths(figure.add_subplot(grid[1, :]), measurement)
    return save_figure(figure, path, overwrite=overwrite)
