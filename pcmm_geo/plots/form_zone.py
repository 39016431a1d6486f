"""Plot of a minimum-zone form evaluation: the deviations inside their zone, contacts marked."""

from __future__ import annotations

import textwrap
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pcmm_geo.plots._figure import check_plot_path, new_figure, polar_deviation_axes, save_figure

if TYPE_CHECKING:
    from pcmm_geo.fit.zone.form import FormEvaluation

__all__ = ["plot_form_zone"]


def plot_form_zone(evaluation: FormEvaluation, path: str | Path, *, overwrite: bool = False) -> Path:
    """Draw the zone and the deviations of a :class:`~pcmm_geo.fit.zone.form.FormEvaluation`.

    Roundness: a polar profile of the deviations from the mid-zone circle on rings that carry
    their values (µm), between the inner and outer zone circles.  Other characteristics: the
    deviation of every point from the mid-zone element (µm) against the point index, with the
    zone limits.  Contact (support) points are red.

    Parameters
    ----------
    evaluation : FormEvaluation
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
    InvalidInputError
        Unsupported suffix.

    Examples
    --------
    >>> import os, tempfile
    >>> from pcmm_geo.fit.zone import evaluate_form
    >>> angles = np.linspace(0, 2 * np.pi, 36, endpoint=False)
    >>> radii = 5 + 0.002 * np.cos(3 * angles)
    >>> evaluation = evaluate_form(np.c_[radii * np.cos(angles), radii * np.sin(angles)], "circle")
    >>> plot_form_zone(evaluation, os.path.join(tempfile.mkdtemp(), "zone.png")).name
    'zone.png'
    """
    check_plot_path(path, overwrite=overwrite)
    fit = evaluation.fit
    deviations_um = 1000.0 * np.asarray(fit.residuals, dtype=float)
    contacts = np.asarray(fit.contacts, dtype=int)
    width_um = 1000.0 * evaluation.deviation
    title = f"{evaluation.characteristic} {width_um:.4g} µm"
    if evaluation.tolerance is not None:
        title += f", tolerance {1000.0 * evaluation.tolerance:.4g} µm: {evaluation.verdict.upper()}"
    title += "\n" + textwrap.fill(_scope_words(evaluation), 110 if evaluation.element != "circle" else 80)
    is_circle = evaluation.element == "circle"
    figure = new_figure(6.5 if is_circle else 8.0, 7.0 if is_circle else 3.8)
    if is_circle:
        _polar(figure, evaluation, deviations_um, contacts, width_um)
    else:
        _band(figure, deviations_um, contacts, evaluation)
    figure.suptitle(title, fontsize=10)
    return save_figure(figure, path, overwrite=overwrite)


def _scope_words(evaluation) -> str:
    """What the width is proven to be: the global minimum, or a local one with its proven bound."""
    if evaluation.scope == "global":
        return f"global minimum zone over {evaluation.domain}" if evaluation.domain else "global minimum zone"
    if not evaluation.certified:
        return "zone about an unconverged fit, NOT a proven minimum"
    if np.isfinite(evaluation.bound):
        return f"local minimum zone; proven ≥ {1000.0 * evaluation.bound:.4g} µm"
    return "local minimum zone; no global bound"


def _polar(figure, evaluation, deviations_um, contacts, width_um) -> None:
    """Polar profile: deviations from the mid-zone circle on labelled rings, the zone between green circles."""
    fit = evaluation.fit
    rel = np.asarray(evaluation.points, dtype=float) - fit.center
    if rel.shape[1] == 3:  # angles in the circle's plane
        helper = np.zeros(3)
        helper[int(np.argmin(np.abs(fit.normal)))] = 1.0
        first = np.cross(helper, fit.normal)
        first /= np.linalg.norm(first)
        rel = np.column_stack([rel @ first, rel @ np.cross(fit.normal, first)])
    angles = np.arctan2(rel[:, 1], rel[:, 0])
    order = np.argsort(angles)
    axes = figure.add_subplot(projection="polar")
    half = 0.5 * width_um
    to_radius = polar_deviation_axes(axes, np.r_[deviations_um, -half, half], "µm", reference="mid-zone circle (0)")
    theta = np.linspace(0, 2 * np.pi, 361)
    for level, label in ((-half, f"zone: inner circle r_in = {fit.r_in:.6f} mm"),
                         (half, f"zone: outer circle r_out = {fit.r_out:.6f} mm")):
        axes.plot(theta, np.full_like(theta, float(to_radius(level))), color="tab:green", linewidth=1.2, label=label)
    closed = np.r_[order, order[:1]]
    axes.plot(angles[closed], to_radius(deviations_um[closed]), ".-", color="tab:blue", markersize=3, linewidth=0.6,
              label="measured")
    axes.plot(angles[contacts], to_radius(deviations_um[contacts]), "o", color="tab:red", markersize=7,
              label="contact points")
    step = np.diff(axes.get_yticks()[:2])[0]
    axes.set_title(f"deviation from the mid-zone circle, rings every {step:g} µm", fontsize=9)
    axes.legend(loc="upper center", bbox_to_anchor=(0.5, -0.06), ncol=2, fontsize=7)


def _band(figure, deviations_um, contacts, evaluation) -> None:
    axes = figure.add_subplot()
    index = np.arange(len(deviations_um))
    fit = evaluation.fit
    if evaluation.element == "line" and fit.parameters.size == 6:
        low, high = 0.0, 1000.0 * evaluation.deviation / 2
        label = "distance from the axis / µm"
    else:
        low, high = -500.0 * evaluation.deviation, 500.0 * evaluation.deviation
        label = "deviation from the mid-zone element / µm"
    axes.axhspan(low, high, color="tab:green", alpha=0.12, label="minimum zone")
    axes.axhline(low, color="tab:green", linewidth=1.0)
    axes.axhline(high, color="tab:green", linewidth=1.0)
    axes.plot(index, deviations_um, ".", color="tab:blue", markersize=3)
    axes.plot(index[contacts], deviations_um[contacts], "o", color="tab:red", markersize=7, label="contacts")
    margin = 0.3 * (high - low) if high > low else 1.0
    axes.set_ylim(low - margin, high + margin)
    axes.set_xlabel("point")
    axes.set_ylabel(label)
    axes.legend(loc="upper right", fontsize=8, ncol=2)
