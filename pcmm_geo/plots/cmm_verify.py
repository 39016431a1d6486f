"""The second opinion on a CMM's results (``pcmm qif verify --plot``): each difference against its tolerance.

One horizontal bar per feature and compared quantity (diameter, location, direction,
half-angle): the difference between the CMM's value and pcmm_geo's refit divided by the
agreement tolerance of that quantity, on a logarithmic axis with the tolerance (1) marked.
A bar right of the line disagrees.  Features that could not be refitted are listed in the
title's count, not drawn.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from pcmm_geo.plots._figure import check_plot_path, new_figure, save_figure

__all__ = ["plot_verification"]

_QUANTITIES = (("diameter_mm", "diameter", "tab:blue"), ("location_distance_mm", "location", "tab:orange"),
               ("direction_angle_rad", "direction", "tab:green"), ("half_angle_rad", "half-angle", "tab:purple"))


def verification_ratios(result: Any) -> list[tuple[str, str, float]]:
    """``(feature label, quantity, |difference| / tolerance)`` of every compared quantity, in file order.

    Examples
    --------
    >>> from pcmm_geo.cmm.verify import FeatureCheck, Verification
    >>> check = FeatureCheck(id=5, type="sphere", name="S1", n_points=25, agrees=False, reason="",
    ...                      difference={"diameter_mm": -3e-4, "location_distance_mm": 5e-5},
    ...                      compared=("diameter_mm", "location_distance_mm"), tolerance_mm=1e-4)
    >>> [(label, name, round(r, 6)) for label, name, r in verification_ratios(Verification("f.qif", (check,), 1e-4))]
    [('5 S1', 'diameter', 3.0), ('5 S1', 'location', 0.5)]
    """
    out = []
    for check in result.features:
        label = f"{check.id} {check.name or check.type}"
        for key, name, _ in _QUANTITIES:
            if key not in check.compared:
                continue
            limit = check.angle_tolerance_rad if key.endswith("_rad") else check.tolerance_mm
            if limit is None or not limit > 0:
                continue
            out.append((label, name, abs(float(check.difference[key])) / float(limit)))
    return out


def plot_verification(result: Any, path: str | Path, *, overwrite: bool = False) -> Path:
    """Every compared difference of a second opinion as a fraction of its agreement tolerance.

    Parameters
    ----------
    result : pcmm_geo.cmm.verify.Verification
    path : str or Path
        ``.png``, ``.svg`` or ``.pdf``.
    overwrite : bool

    Returns
    -------
    Path

    Raises
    ------
    OutputExistsError, InvalidInputError, OSError
        As :func:`pcmm_geo.plots._figure.save_figure`.
    """
    check_plot_path(path, overwrite=overwrite)
    rows = verification_ratios(result)
    colours = {name: colour for _, name, colour in _QUANTITIES}
    height = min(max(3.0, 0.25 * len(rows) + 1.6), 40.0)
    figure = new_figure(8.5, height)
    axes = figure.add_subplot()
    summary = result.summary()
    title = (f"Second opinion: {summary['agree']} agree, {summary['disagree']} disagree, "
             f"{summary['not_checked']} not checked")
    if not rows:
        axes.text(0.5, 0.5, "no feature could be refitted and compared", ha="center", va="center",
                  transform=axes.transAxes)
        axes.set_axis_off()
        axes.set_title(title)
        return save_figure(figure, path, overwrite=overwrite)
    ratios = np.array([ratio for _, _, ratio in rows])
    positive = ratios[ratios > 0]
    floor = min(float(positive.min()) / 3.0 if positive.size else 1e-3, 1e-2)
    y = np.arange(len(rows))[::-1]
    seen: set[str] = set()
    for position, (_, name, ratio) in zip(y, rows, strict=True):
        axes.barh(position, max(ratio, floor) - floor, left=floor, height=0.7, color=colours[name],
                  label=None if name in seen else name)
        seen.add(name)
    axes.axvline(1.0, color="red", linewidth=1.2, label="tolerance")
    axes.set_xscale("log")
    axes.set_xlim(floor, max(10.0, 2.0 * float(ratios.max())))
    axes.set_yticks(y, [f"{label}: {name}" for label, name, _ in rows], fontsize=7 if len(rows) > 25 else 8)
    axes.set_xlabel("|reported − refitted| / agreement tolerance")
    axes.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=5)
    axes.grid(alpha=0.3, axis="x")
    axes.set_title(title)
    return save_figure(figure, path, overwrite=overwrite)
