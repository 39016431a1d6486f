"""Plots of the verification tests: ISO 10360-2 lengths, -5 probing, -6 software, micrometer stage.

Every plot shows the measured values against their limits, so that a nonconforming value is
seen at a glance: length errors against the MPE curve (and the guarded acceptance limits),
probing residuals where they lie on the sphere, software deviations as fractions of the MPE,
stage-test errors against the stage distance.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pcmm_geo.plots._figure import check_plot_path, length_unit, new_figure, save_figure, three_digits

if TYPE_CHECKING:
    from pcmm_geo.artefacts.iso10360_2 import LengthTestResult
    from pcmm_geo.artefacts.iso10360_5 import ProbingResult
    from pcmm_geo.artefacts.iso10360_6 import HarnessMpe, HarnessReport
    from pcmm_geo.artefacts.micrometer import StageTestResult

__all__ = ["plot_length_test", "plot_probing_test", "plot_software_test", "plot_stage_test"]

_MARKERS = "osD^v<>pP*Xh"


def plot_length_test(result: LengthTestResult, path: str | Path, *, overwrite: bool = False) -> Path:
    """ISO 10360-2: every E0 value (µm) against its calibrated length, with ±MPE and R0 per length.

    Parameters
    ----------
    result : LengthTestResult
        Result of :func:`pcmm_geo.artefacts.iso10360_2.evaluate_length_test`.
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
    >>> from pcmm_geo.artefacts.iso10360_2 import LengthMeasurement, LengthMpe, evaluate_length_test
    >>> runs = [LengthMeasurement("L1", "x", r, 100.0, 100.0 + 0.0005 * r) for r in (1, 2, 3)]
    >>> result = evaluate_length_test(runs, LengthMpe(2.0, 300.0), allow_incomplete=True)  # 3 of the 105 values
    >>> plot_length_test(result, os.path.join(tempfile.mkdtemp(), "e0.png")).suffix
    '.png'
    """
    check_plot_path(path, overwrite=overwrite)
    figure = new_figure(12.0, 5.6)
    left, right = figure.subplots(1, 2, width_ratios=(1.6, 1.0))
    lengths = np.array([e.calibrated_length for e in result.errors])
    span = np.linspace(0.0, 1.05 * float(lengths.max()), 200)
    mpe_um = np.array([result.mpe.mpe_mm(length) for length in span]) * 1000.0
    left.fill_between(span, -mpe_um, mpe_um, color="0.92", label="±MPE_E0")
    left.plot(span, mpe_um, color="0.4", linewidth=1.0)
    left.plot(span, -mpe_um, color="0.4", linewidth=1.0)
    rule = ("simple acceptance" if result.decision_rule.startswith("simple") or result.test_uncertainty <= 0 else
            "guarded acceptance" if result.decision_rule.startswith("guarded") else "ISO 14253-1 rule")
    u_um = 1000.0 * result.test_uncertainty
    if rule != "simple acceptance":
        guard = np.clip(mpe_um - u_um, 0.0, None)
        left.plot(span, guard, color="tab:green", linestyle="--", linewidth=1.0,
                  label="conformity proven inside (MPE - U)")
        left.plot(span, -guard, color="tab:green", linestyle="--", linewidth=1.0)
    if rule == "ISO 14253-1 rule":
        left.plot(span, mpe_um + u_um, color="tab:red", linestyle=":", linewidth=1.0,
                  label="nonconformity proven outside (MPE + U)")
        left.plot(span, -(mpe_um + u_um), color="tab:red", linestyle=":", linewidth=1.0)
    positions = sorted({e.position for e in result.errors})
    # positions side by side at each length (shifted by up to ±1.5 % of the axis) so that none hides another
    shift = {p: (k - 0.5 * (len(positions) - 1)) * 0.03 * span[-1] / max(len(positions), 1)
             for k, p in enumerate(positions)}
    for k, position in enumerate(positions):
        chosen = [e for e in result.errors if e.position == position]
        left.scatter([e.calibrated_length + shift[position] for e in chosen], [1000.0 * e.error for e in chosen],
                     s=22, marker=_MARKERS[k % len(_MARKERS)], label=f"position {position}", zorder=3)
    for state, colour in (("NOT PROVEN", "tab:orange"), ("FAIL", "red")):
        marked = [e for e in result.errors if (e.verdict or ("PASS" if e.conforms else "FAIL")) == state]
        if marked:
            left.scatter([e.calibrated_length + shift[e.position] for e in marked], [1000.0 * e.error for e in marked],
                         s=120, facecolors="none", edgecolors=colour, linewidths=1.5,
                         label=f"{state.lower()} ({len(marked)})", zorder=4)
    left.axhline(0.0, color="black", linewidth=0.6)
    left.set_xlim(0.0, span[-1])
    left.set_xlabel("calibrated length L / mm")
    left.set_ylabel("length error E0 / µm")
    left.legend(fontsize=7, ncol=4, loc="upper center", bbox_to_anchor=(0.5, -0.14))
    left.grid(alpha=0.3)
    ranges = result.repeatability
    labels = [f"{r.length_id}/{r.position}" for r in ranges]
    values = [1000.0 * r.range for r in ranges]
    colours = ["tab:blue" if r.conforms else "red" for r in ranges]
    rows = np.arange(len(ranges))[::-1]
    right.barh(rows, values, color=colours)
    right.set_yticks(rows, labels, fontsize=6 if len(rows) > 20 else 8)
    right.set_xlabel("repeatability range R0 / µm")
    right.set_title("R0 per length and position (red: above its limit)", fontsize=9)
    figure.suptitle(f"ISO 10360-2 length test: {result.verdict}, {len(result.errors)} values, max |E0| "
                    f"{1000.0 * result.max_abs_error:.3g} µm ({result.max_error_ratio:.2f} of MPE); {rule}"
                    + (f", U = {u_um:.3g} µm" if rule != "simple acceptance" else ""))
    return save_figure(figure, path, overwrite=overwrite)


def plot_probing_test(
    result: ProbingResult, points: Any, path: str | Path, *, overwrite: bool = False
) -> Path:
    """ISO 10360-5: the probed points' residuals on the test sphere (azimuth x elevation) and their spread.

    Parameters
    ----------
    result : ProbingResult
        Result of :func:`pcmm_geo.artefacts.iso10360_5.evaluate_probing`.
    points : array_like, shape (N, 3)
        The probed points (mm), in the order of ``result.residuals``.
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
    >>> from pcmm_geo.artefacts.iso10360_5 import evaluate_probing, sphere_probing_pattern
    >>> points = sphere_probing_pattern(radius=12.5)
    >>> points[:, 2] += 0.001 * points[:, 0] ** 2 / 156.25
    >>> result = evaluate_probing(points, 25.0)
    >>> plot_probing_test(result, points, os.path.join(tempfile.mkdtemp(), "p.png")).suffix
    '.png'
    """
    from pcmm_geo.plots.fit_residuals import draw_sphere_map

    check_plot_path(path, overwrite=overwrite)
    residuals = np.asarray(result.residuals, dtype=float)
    limits = [value for value in (result.mpe_form, result.mpe_size) if value is not None]
    factor, unit = length_unit(np.r_[residuals, result.form_error, result.size_error, limits])
    figure = new_figure(11.0, 4.6)
    left, right = figure.subplots(1, 2, width_ratios=(2.0, 1.0))
    draw_sphere_map(figure, left, np.asarray(points, dtype=float), np.asarray(result.center, dtype=float),
                    factor * residuals, unit)
    order = np.argsort(residuals)
    right.barh(np.arange(len(order)), factor * residuals[order], color="tab:blue", height=0.8)
    right.axvline(0.0, color="black", linewidth=0.6)
    if result.mpe_form is not None:
        # P_FTU is the range of the residuals: the band of width MPE centred on their mid-range
        middle = 0.5 * factor * (residuals.max() + residuals.min())
        for side in (-0.5, 0.5):
            right.axvline(middle + side * factor * result.mpe_form, color="tab:red", linestyle="--", linewidth=1.0)
        right.plot([], [], color="tab:red", linestyle="--", label="band of width MPE_PFTU")
        right.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.13))
    right.set_yticks([])
    right.set_xlabel(f"residual / {unit} (sorted)")
    right.set_title(f"P_FTU = {three_digits(factor * result.form_error)} {unit}, "
                    f"P_STU = {three_digits(factor * result.size_error, sign=True)} {unit}", fontsize=9)
    verdict = "no MPE stated" if result.passed is None else ("PASS" if result.passed else "FAIL")
    figure.suptitle(f"ISO 10360-5 probing test on a {result.reference_diameter:g} mm sphere: {result.n} points, "
                    f"{verdict}")
    return save_figure(figure, path, overwrite=overwrite)


def plot_software_test(
    report: HarnessReport, mpe: HarnessMpe, path: str | Path, *, overwrite: bool = False
) -> Path:
    """ISO 10360-6: each case's deviations (position, orientation, size, angle) as fractions of their MPE.

    A value above 1 (the red line) fails.  Logarithmic scale; an exactly zero deviation has no
    bar, a quantity that does not apply to the element (NaN) neither.

    Raises
    ------
    OutputExistsError, InvalidInputError, OSError
        As :func:`pcmm_geo.plots._figure.save_figure`.

    Examples
    --------
    >>> import os, tempfile
    >>> from pcmm_geo.artefacts.iso10360_6 import CaseDeviation, HarnessMpe, HarnessReport
    >>> cases = (CaseDeviation("s1", "sphere", 2e-10, float("nan"), 1e-10, float("nan"), True),)
    >>> report = HarnessReport(cases, HarnessMpe(), True, 0)
    >>> plot_software_test(report, HarnessMpe(), os.path.join(tempfile.mkdtemp(), "s.png")).suffix
    '.png'
    """
    check_plot_path(path, overwrite=overwrite)
    cases = list(report.cases)
    quantities = (("position", mpe.position, "tab:blue"), ("orientation", mpe.orientation, "tab:orange"),
                  ("size", mpe.size, "tab:green"), ("angle", mpe.angle, "tab:purple"))
    ratios = np.array([[getattr(c, name) / limit for name, limit, _ in quantities] for c in cases], dtype=float)
    finite = ratios[np.isfinite(ratios) & (ratios > 0)]
    floor = float(finite.min()) / 3.0 if finite.size else 1e-6
    floor = min(floor, 1e-3)
    height = min(max(3.5, 0.22 * len(cases) + 1.5), 40.0)
    figure = new_figure(9.0, height)
    axes = figure.add_subplot()
    rows = np.arange(len(cases))[::-1]
    width = 0.2
    for k, (name, limit, colour) in enumerate(quantities):
        values = ratios[:, k]
        shown = np.isfinite(values)
        axes.barh(rows[shown] + (1.5 - k) * width, np.maximum(values[shown], floor) - floor, left=floor,
                  height=width, color=colour, label=f"{name} (MPE {limit:g})")
    axes.axvline(1.0, color="red", linewidth=1.2, label="MPE")
    axes.set_xscale("log")
    axes.set_xlim(floor, max(10.0, 2.0 * float(np.nanmax(ratios)) if finite.size else 10.0))
    axes.set_yticks(rows, [f"{c.name} ({c.element})" + ("" if c.passed else " FAIL") for c in cases],
                    fontsize=6 if len(cases) > 30 else 8)
    axes.set_xlabel("deviation / MPE")
    axes.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=5)
    axes.grid(alpha=0.3, axis="x")
    verdict = "PASS" if report.passed else "FAIL"
    within = len(cases) - report.n_failed
    axes.set_title(f"ISO 10360-6 software test: {verdict}, {within}/{len(cases)} cases within MPE")
    return save_figure(figure, path, overwrite=overwrite)


def plot_stage_test(result: StageTestResult, path: str | Path, *, overwrite: bool = False) -> Path:
    """Micrometer-stage test: CMM-minus-stage distance error of each pair against the stage distance.

    Raises
    ------
    OutputExistsError, InvalidInputError, OSError
        As :func:`pcmm_geo.plots._figure.save_figure`.

    Examples
    --------
    >>> import os, tempfile
    >>> from pcmm_geo.artefacts.micrometer import evaluate_stage_test
    >>> stage = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0.0]])
    >>> result = evaluate_stage_test(stage, stage + [[0, 0, 0], [0.002, 0, 0], [0.001, 0, 0]], pairs="all")
    >>> plot_stage_test(result, os.path.join(tempfile.mkdtemp(), "m.png")).suffix
    '.png'
    """
    check_plot_path(path, overwrite=overwrite)
    stage = np.array([p.stage_distance for p in result.pairs])
    error = np.array([p.error for p in result.pairs])
    factor, unit = length_unit(error)
    figure = new_figure(8.0, 4.6)
    axes = figure.add_subplot()
    axes.axhline(0.0, color="black", linewidth=0.6)
    axes.scatter(stage, factor * error, color="tab:blue", zorder=3)
    for pair, x, y in zip(result.pairs, stage, factor * error, strict=True):
        axes.annotate(pair.label, (x, y), textcoords="offset points", xytext=(4, 4), fontsize=7)
    axes.set_xlabel("stage distance / mm")
    axes.set_ylabel(f"CMM - stage / {unit}")
    axes.grid(alpha=0.3)
    axes.set_title(f"Micrometer-stage test: {len(result.pairs)} pairs, max |error| "
                   f"{factor * result.max_abs_error:.3g} {unit}, rms {factor * result.rms_error:.3g} {unit}")
    return save_figure(figure, path, overwrite=overwrite)
