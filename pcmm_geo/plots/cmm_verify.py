"""The second opinion on a CMM's results (``pcmm qif verify --plot``): each difference against its tolerance.

Top panel: one horizontal bar per feature and compared quantity (diameter, location,
direction, half-angle): the difference between the CMM's value and pcmm_geo's refit divided
by the agreement tolerance of that quantity, on a logarithmic axis with the tolerance (1)
marked.  Second panel: one bar per recomputed characteristic, ``|reported - recomputed|``
over its agreement bound, green where it agrees (including another accepted convention or a
datum shift's range) and red where it disagrees.  A bar right of the line disagrees (a green
bar right of it agrees by an accepted alternative).  Features that could not be refitted and
characteristics that are not computable are counted in the titles, not drawn.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from pcmm_geo.plots._figure import check_plot_path, new_figure, save_figure

__all__ = ["characteristic_ratios", "plot_verification", "verification_ratios"]

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


def characteristic_ratios(verification: Any) -> list[tuple[str, str, float]]:
    """``(characteristic label, status, |reported - recomputed| / bound)`` of every recomputed characteristic.

    Characteristics that are not computable are left out (the figure's title counts them).

    Examples
    --------
    >>> from pcmm_geo.gdt.qif.characteristics import CharacteristicCheck, CharacteristicVerification
    >>> check = CharacteristicCheck(id=7, name="POS1", type="position", unit="mm", reported=0.3, recomputed=0.28,
    ...                             status="disagrees", reason="", bound=0.01)
    >>> [(label, status, round(r, 6)) for label, status, r in
    ...  characteristic_ratios(CharacteristicVerification("f.qif", (check,), ""))]
    [('7 POS1 (position)', 'disagrees', 2.0)]
    """
    out = []
    for check in verification.checks:
        if check.reported is None or check.recomputed is None or not check.bound or check.status == "not computable":
            continue
        label = f"{check.id} {check.name or '-'} ({check.type.replace('_', ' ')})"
        out.append((label, check.status, abs(float(check.reported) - float(check.recomputed)) / float(check.bound)))
    return out


def _bars(axes: Any, rows: list[tuple[str, str, float]], colours: dict[str, str], xlabel: str) -> None:
    """Horizontal bars of ``rows`` (label, group, ratio) on a log axis with the bound (1) marked."""
    ratios = np.array([ratio for _, _, ratio in rows])
    positive = ratios[ratios > 0]
    floor = min(float(positive.min()) / 3.0 if positive.size else 1e-3, 1e-2)
    y = np.arange(len(rows))[::-1]
    seen: set[str] = set()
    for position, (_, name, ratio) in zip(y, rows, strict=True):
        axes.barh(position, max(ratio, floor) - floor, left=floor, height=0.7, color=colours[name],
                  label=None if name in seen else name)
        seen.add(name)
    axes.axvline(1.0, color="red", linewidth=1.2, label="agreement bound")
    axes.set_xscale("log")
    axes.set_xlim(floor, max(10.0, 2.0 * float(ratios.max())))
    axes.set_yticks(y, [f"{label}: {name}" for label, name, _ in rows], fontsize=7 if len(rows) > 25 else 8)
    axes.set_xlabel(xlabel)
    axes.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=5)
    axes.grid(alpha=0.3, axis="x")


def plot_verification(result: Any, path: str | Path, *, overwrite: bool = False,
                      characteristics: Any = None) -> Path:
    """Every compared difference of a second opinion as a fraction of its agreement tolerance.

    Parameters
    ----------
    result : pcmm_geo.cmm.verify.Verification
        The features refitted from their points (top panel).
    path : str or Path
        ``.png``, ``.svg`` or ``.pdf``.
    overwrite : bool
    characteristics : pcmm_geo.gdt.qif.characteristics.CharacteristicVerification, optional
        The characteristics recomputed (a second panel: ``|reported - recomputed| / bound`` per
        characteristic, coloured by status; those not computable are counted in its title).

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
    chars = [] if characteristics is None else characteristic_ratios(characteristics)
    panels = [("features", rows)] + ([("characteristics", chars)] if characteristics is not None else [])
    sizes = [max(3, len(panel_rows)) for _, panel_rows in panels]
    height = min(max(3.0, 0.25 * sum(sizes) + 1.9 * len(panels)), 60.0)
    figure = new_figure(8.5, height)
    grid = figure.add_gridspec(len(panels), 1, height_ratios=sizes)
    summary = result.summary()
    for index, (kind, panel_rows) in enumerate(panels):
        axes = figure.add_subplot(grid[index])
        if kind == "features":
            title = (f"Features refitted: {summary['agree']} agree, {summary['disagree']} disagree, "
                     f"{summary['not_checked']} not checked")
            empty = "no feature could be refitted and compared"
        else:
            counts = characteristics.summary()
            title = (f"Characteristics recomputed: {counts['agrees']} agree, {counts['disagrees']} disagree, "
                     f"{counts['not_computable']} not computable (not drawn)")
            empty = "no characteristic could be recomputed"
        if not panel_rows:
            axes.text(0.5, 0.5, empty, ha="center", va="center", transform=axes.transAxes)
            axes.set_axis_off()
        elif kind == "features":
            _bars(axes, panel_rows, {name: colour for _, name, colour in _QUANTITIES},
                  "|reported − refitted| / agreement tolerance")
        else:
            _bars(axes, panel_rows, {"agrees": "tab:green", "disagrees": "tab:red"},
                  "|reported − recomputed| / agreement bound")
        axes.set_title(title, fontsize=10)
    return save_figure(figure, path, overwrite=overwrite)
