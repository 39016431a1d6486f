"""Plots of the thermal tools: sensor curves, 20 °C length correction budget, frame triangle, µm/K table."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pcmm_geo.plots._figure import check_plot_path, length_unit, new_figure, save_figure, three_digits

if TYPE_CHECKING:
    from pcmm_geo.thermal.correction import LengthCorrection
    from pcmm_geo.thermal.physical import ThermalSensitivityTable
    from pcmm_geo.thermal.triangle import FrameTriangle

__all__ = ["plot_frame_triangle", "plot_length_correction", "plot_sensor_curve", "plot_thermal_table"]


def plot_sensor_curve(
    temperature_of: Callable[[Any], Any],
    point: tuple[float, float] | None,
    path: str | Path,
    *,
    title: str,
    calibration: tuple[Sequence[float], Sequence[float]] | None = None,
    overwrite: bool = False,
) -> Path:
    """A sensor's temperature against resistance, the converted point and, if given, calibration residuals.

    Parameters
    ----------
    temperature_of : callable
        Resistance (ohm, array) -> temperature (°C, array).
    point : (resistance, temperature) or None
        The conversion to mark.
    path : str or Path
        Destination, ``.png``, ``.svg`` or ``.pdf``.
    title : str
    calibration : (temperatures, resistances), optional
        Calibration points (°C, ohm); their residuals (model - given, mK) go in a second panel.
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
    >>> from pcmm_geo.thermal.sensors import rtd_temperature
    >>> name = os.path.join(tempfile.mkdtemp(), "t.png")
    >>> plot_sensor_curve(rtd_temperature, (108.0, 20.5), name, title="Pt100").suffix
    '.png'
    """
    check_plot_path(path, overwrite=overwrite)
    known = [point[0]] if point is not None else []
    if calibration is not None:
        known += list(calibration[1])
    low, high = (min(known), max(known)) if known else (80.0, 120.0)
    # a few per cent beyond the known resistances (geometric: thermistors span decades)
    resistance = np.geomspace(low / 1.05, high * 1.05, 300)
    figure = new_figure(11.0 if calibration is not None else 7.0, 4.4)
    axes = figure.add_subplot(1, 2 if calibration is not None else 1, 1)
    axes.plot(resistance, temperature_of(resistance), color="tab:blue", label="sensor model")
    if calibration is not None:
        axes.scatter(calibration[1], calibration[0], color="black", s=20, zorder=3, label="calibration points")
    if point is not None:
        axes.scatter([point[0]], [point[1]], color="tab:red", marker="D", s=50, zorder=4,
                     label=f"{point[0]:.6g} ohm -> {point[1]:.6g} °C")
    axes.set_xlabel("resistance / ohm")
    axes.set_ylabel("temperature / °C")
    axes.legend(fontsize=8)
    axes.grid(alpha=0.3)
    if calibration is not None:
        temps, resistances = (np.asarray(v, dtype=float) for v in calibration)
        residual_mk = 1000.0 * (np.asarray(temperature_of(resistances), dtype=float) - temps)
        side = figure.add_subplot(1, 2, 2)
        side.axhline(0.0, color="black", linewidth=0.6)
        side.plot(temps, residual_mk, marker="o", color="tab:blue")
        side.set_xlabel("calibration temperature / °C")
        side.set_ylabel("model - given / mK")
        side.set_title(f"fit residuals, rms {three_digits(float(np.sqrt(np.mean(residual_mk**2))))} mK", fontsize=9)
        side.grid(alpha=0.3)
    figure.suptitle(title)
    return save_figure(figure, path, overwrite=overwrite)


def plot_length_correction(result: LengthCorrection, path: str | Path, *, overwrite: bool = False) -> Path:
    """The uncertainty budget of a length corrected to 20 °C: each |c| u and the combined u.

    Raises
    ------
    OutputExistsError, InvalidInputError, OSError
        As :func:`pcmm_geo.plots._figure.save_figure`.

    Examples
    --------
    >>> import os, tempfile
    >>> from pcmm_geo.thermal.correction import correct_length
    >>> corrected = correct_length(100.0, 21.0, 11.5e-6, u_temperature_workpiece=0.1, u_alpha_workpiece=1e-6)
    >>> plot_length_correction(corrected, os.path.join(tempfile.mkdtemp(), "c.png")).suffix
    '.png'
    """
    check_plot_path(path, overwrite=overwrite)
    names = [entry.quantity for entry in result.budget]
    contributions = np.array([abs(entry.contribution) for entry in result.budget], dtype=float)
    factor, unit = length_unit(np.r_[contributions, result.standard_uncertainty, result.correction])
    figure = new_figure(8.0, 1.6 + 0.35 * (len(names) + 1))
    axes = figure.add_subplot()
    rows = np.arange(len(names) + 1)[::-1]
    values = np.r_[factor * contributions, factor * result.standard_uncertainty]
    axes.barh(rows, values, color=["tab:blue"] * len(names) + ["black"])
    for row, value in zip(rows, values, strict=True):
        axes.text(value, row, f" {three_digits(value)}", va="center", fontsize=8)
    axes.set_yticks(rows, [*names, "combined u"], fontsize=8)
    axes.set_xlim(0.0, 1.25 * max(float(values.max()), 1e-12))
    axes.set_xlabel(f"|c| u / {unit}")
    correction = three_digits(factor * result.correction, sign=True)
    axes.set_title(f"L(20 °C) = {result.value:.6f} mm, correction {correction} {unit}, "
                   f"U(k = 2) = {three_digits(factor * result.expanded_uncertainty())} {unit}", fontsize=9)
    return save_figure(figure, path, overwrite=overwrite)


def plot_frame_triangle(
    nominal: FrameTriangle, expanded: FrameTriangle, path: str | Path, *, overwrite: bool = False
) -> Path:
    """The frame triangle at its nominal size and expanded, corner displacements magnified and labelled.

    Raises
    ------
    OutputExistsError, InvalidInputError, OSError
        As :func:`pcmm_geo.plots._figure.save_figure`.

    Examples
    --------
    >>> import os, tempfile
    >>> from pcmm_geo.thermal.triangle import expand_frame, frame_corners
    >>> nominal = frame_corners(650.0, 650.0, 650.0)
    >>> hot = expand_frame([21.0, 20.5, 20.0], nominal_sides=[650.0] * 3, alpha=23.1e-6)
    >>> plot_frame_triangle(nominal, hot, os.path.join(tempfile.mkdtemp(), "f.png")).suffix
    '.png'
    """
    check_plot_path(path, overwrite=overwrite)
    before = np.array([np.asarray(getattr(nominal, name), dtype=float)[:2] for name in "abc"])
    after = np.array([np.asarray(getattr(expanded, name), dtype=float)[:2] for name in "abc"])
    moved = after - before
    factor, unit = length_unit(moved)
    size = float(np.max(np.ptp(before, axis=0))) or 1.0
    largest = float(np.max(np.linalg.norm(moved, axis=1)))
    magnify = 0.08 * size / largest if largest > 0 else 1.0
    figure = new_figure(7.0, 6.0)
    axes = figure.add_subplot()
    axes.fill(*before.T, facecolor="0.93", edgecolor="0.4", label="nominal")
    shown = before + magnify * moved
    axes.fill(*shown.T, facecolor="none", edgecolor="tab:red", linewidth=1.5,
              label=f"expanded (displacements x {magnify:.3g})")
    for name, start, step in zip("ABC", before, moved, strict=True):
        axes.annotate("", xy=start + magnify * step, xytext=start,
                      arrowprops={"arrowstyle": "->", "color": "tab:red"})
        moved_x, moved_y = (three_digits(factor * value, sign=True) for value in step)
        axes.annotate(f"{name}: dx {moved_x}, dy {moved_y} {unit}", start,
                      textcoords="offset points", xytext=(6, -14), fontsize=8)
    axes.set_aspect("equal", adjustable="datalim")
    axes.margins(0.15)
    axes.set_xlabel("x / mm")
    axes.set_ylabel("y / mm")
    axes.legend(fontsize=8, loc="upper right")
    axes.set_title("Frame triangle (A pinned, B sliding in x)")
    return save_figure(figure, path, overwrite=overwrite)


def plot_thermal_table(table: ThermalSensitivityTable, path: str | Path, *, overwrite: bool = False) -> Path:
    """Tip displacement per kelvin of each member: largest and mean over the positions, and per axis.

    Raises
    ------
    OutputExistsError, InvalidInputError, OSError
        As :func:`pcmm_geo.plots._figure.save_figure`.

    Examples
    --------
    >>> import os, tempfile
    >>> from pcmm_geo.thermal.physical import thermal_sensitivity_table
    >>> table = thermal_sensitivity_table(points_per_axis=2)
    >>> plot_thermal_table(table, os.path.join(tempfile.mkdtemp(), "t.png")).suffix
    '.png'
    """
    check_plot_path(path, overwrite=overwrite)
    summary = table.summary()
    names = [str(row["member"]) for row in summary]
    rows = np.arange(len(names))[::-1]
    figure = new_figure(9.0, 2.3 + 0.4 * len(names))
    axes = figure.add_subplot()
    height = 0.18
    series = (("max_um_per_k", "largest |d|", "black"), ("max_dx_um_per_k", "largest |dx|", "tab:red"),
              ("max_dy_um_per_k", "largest |dy|", "tab:green"), ("max_dz_um_per_k", "largest |dz|", "tab:blue"))
    for k, (key, label, colour) in enumerate(series):
        axes.barh(rows + (1.5 - k) * height, [float(row[key]) for row in summary], height=height, color=colour,
                  label=label)
    axes.scatter([float(row["mean_um_per_k"]) for row in summary], rows + 1.5 * height, marker="D", s=22,
                 color="gold", edgecolors="black", linewidths=0.5, zorder=3, label="mean |d| over the positions")
    axes.set_yticks(rows, names, fontsize=8)
    axes.set_xlabel("tip displacement / (µm/K)")
    axes.legend(fontsize=7, ncol=5, loc="upper center", bbox_to_anchor=(0.5, -0.12))
    axes.grid(alpha=0.3, axis="x")
    axes.set_title(f"Tip displacement per K of each member over {len(table.positions)} positions")
    return save_figure(figure, path, overwrite=overwrite)
