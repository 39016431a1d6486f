"""Plots a metrologist reads without the code: labelled scale rings, words not code names, the GUM beside
the Monte Carlo, legends that cover no data (one spelling of "centre": ``tests/test_user_text.py``).

Each figure is captured as it is saved (``Figure.savefig`` wrapped) and read back: ring labels
against the radii they sit at, the profile's radius against the fit's residuals (independent
of the plotting code), legend boxes against the data in display coordinates.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from pcmm_geo.plots._figure import data_under_legends

ROOT = Path(__file__).resolve().parents[2]
RING = ROOT / "pcmm_geo" / "data" / "examples" / "roundness_ring.csv"
_LABEL = re.compile(r"^([+-]?\d+(?:\.\d+)?)(?: (µm|nm|mm))?$")


@pytest.fixture
def figures(monkeypatch: pytest.MonkeyPatch) -> list[Figure]:
    """Every figure saved while the test runs."""
    saved: list[Figure] = []
    original = Figure.savefig

    def keep(self: Figure, *args: object, **kwargs: object) -> None:
        original(self, *args, **kwargs)
        saved.append(self)

    monkeypatch.setattr(Figure, "savefig", keep)
    return saved


def _ring_scale(axes: object) -> tuple[np.ndarray, np.ndarray, str]:
    """(ring radii, ring values, unit) read from the polar axes' tick labels."""
    radii = np.asarray(axes.get_yticks(), dtype=float)
    values, units = [], set()
    for label in axes.get_yticklabels():
        match = _LABEL.match(label.get_text())
        assert match, f"ring label {label.get_text()!r} is not a value"
        values.append(float(match.group(1)))
        units.discard(None)
        if match.group(2):
            units.add(match.group(2))
    assert len(units) == 1, "the unit is written on a ring"
    return radii, np.asarray(values), units.pop()


def _polar(figure: Figure) -> object:
    return next(a for a in figure.axes if a.name == "polar")


def test_the_fit_circle_polar_plot_is_read_off_its_rings(tmp_path: Path, figures: list[Figure]) -> None:
    from pcmm_geo.fit import fit_circle
    from pcmm_geo.io.points import read_points
    from pcmm_geo.plots import plot_fit_residuals

    points = read_points(RING)[:, :2]
    fit = fit_circle(points)
    plot_fit_residuals(fit, tmp_path / "circle.png", points=points)
    polar = _polar(figures[-1])
    radii, values, unit = _ring_scale(polar)
    assert unit == "µm" and len(values) >= 4
    np.testing.assert_allclose(np.diff(radii), np.diff(values), rtol=1e-12)  # rings equally spaced, to scale
    zero = radii[np.argmin(np.abs(values))]
    measured = next(line for line in polar.lines if line.get_label() == "measured")
    read_off = np.asarray(measured.get_ydata(), dtype=float) - zero  # deviation read against the 0 ring
    np.testing.assert_allclose(np.sort(read_off)[[0, -1]], 1000 * np.sort(fit.residuals)[[0, -1]], atol=1e-9)
    assert values.min() <= 1000 * fit.residuals.min() and values.max() >= 1000 * fit.residuals.max()
    step = values[1] - values[0]
    assert f"rings every {step:g} µm" in polar.get_title()
    assert data_under_legends(figures[-1]) == []


def test_the_roundness_plot_rings_carry_values_and_the_zone(tmp_path: Path, figures: list[Figure]) -> None:
    from pcmm_geo.fit.zone import evaluate_form
    from pcmm_geo.io.points import read_points
    from pcmm_geo.plots.form_zone import plot_form_zone

    evaluation = evaluate_form(read_points(RING)[:, :2], "circle", tolerance=0.010)
    plot_form_zone(evaluation, tmp_path / "zone.png")
    polar = _polar(figures[-1])
    radii, values, unit = _ring_scale(polar)
    zero = radii[np.argmin(np.abs(values))]
    half = 500.0 * evaluation.deviation  # µm
    zone = [line for line in polar.lines if line.get_label().startswith("zone:")]
    assert sorted(float(np.mean(line.get_ydata())) - zero for line in zone) == pytest.approx([-half, half])
    contacts = next(line for line in polar.lines if line.get_label() == "contact points")
    on_zone = np.abs(np.abs(np.asarray(contacts.get_ydata()) - zero) - half)
    assert np.all(on_zone < 1e-6)  # the support points lie on the zone circles, as read off the rings
    assert unit == "µm" and data_under_legends(figures[-1]) == []


def test_the_monte_carlo_plot_speaks_words_and_draws_the_gum(tmp_path: Path, figures: list[Figure]) -> None:
    from pcmm_geo.plots.uncertainty import plot_monte_carlo
    from pcmm_geo.uncertainty.result import BudgetEntry, UncertaintyResult

    rng = np.random.default_rng(7)
    values = 100.0 + rng.normal(0.0, 3e-4, 20_000)
    budget = (BudgetEntry("laser_noise", 1e-4, 0.1), BudgetEntry("thermal_workpiece", 2.8e-4, 0.9))
    common = {"quantity": "length", "unit": "mm", "coverage_probability": 0.95, "budget": budget}
    monte_carlo = UncertaintyResult(value=float(values.mean()), standard_uncertainty=float(values.std()),
                                    expanded_uncertainty=0.00059, coverage_factor=1.96,
                                    coverage_interval=(99.99941, 100.00059), method="Monte Carlo",
                                    interval_kind="shortest", n_trials=20_000, values=values, **common)
    gum = UncertaintyResult(value=100.0, standard_uncertainty=3e-4, expanded_uncertainty=0.000588,
                            coverage_factor=1.96, coverage_interval=(99.999412, 100.000588), method="GUM",
                            interval_kind="symmetric", n_trials=0, **common)
    plot_monte_carlo(monte_carlo, tmp_path / "mc.png", nominal=100.0, gum=gum)
    figure = figures[-1]
    texts = [t.get_text() for t in figure.findobj(match=lambda artist: hasattr(artist, "get_text"))]
    assert not [t for t in texts if re.search(r"\w_\w", t)], "code names in the figure"
    assert "laser readings" in texts and "workpiece temperature and expansion" in texts
    histogram = figure.axes[0]
    gum_lines = [line for line in histogram.lines if line.get_label().startswith("GUM")]
    density = next(line for line in gum_lines if "normal" in line.get_label())
    x, y = (np.asarray(v, dtype=float) for v in density.get_data())
    assert x[np.argmax(y)] == pytest.approx(0.0, abs=0.02)  # the GUM density is centred on its value (µm)
    assert float(np.max(y)) == pytest.approx(1 / (0.3 * np.sqrt(2 * np.pi)), rel=1e-3)  # u = 0.3 µm
    edges = sorted(float(line.get_xdata()[0]) for line in histogram.lines if line.get_linestyle() == "--")
    assert edges == pytest.approx([-0.588, 0.588], abs=1e-9)
    assert data_under_legends(figure) == []
