"""Sizes for the position modifiers: only the modifier's envelope exactly, the other size limit by a bound.

Truths: points on an exact cylinder (MIC = MCC = its diameter) and a hole with a flat sector, whose
MIC over the tight region must equal the MIC of ``fit_cylinder`` over its default region.
"""

from __future__ import annotations

import numpy as np

from pcmm_geo.fit import SearchBudget, fit_cylinder
from pcmm_geo.gdt import FeatureData, _sizes, size_evaluation


def _rings(radius_of, n_angles: int = 24, heights=(0.0, 5.0, 10.0), seed: int = 3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    out = []
    for z in heights:
        t = np.sort(rng.uniform(0.0, 2 * np.pi, n_angles))
        r = radius_of(t)
        out.append(np.c_[r * np.cos(t), r * np.sin(t), np.full(n_angles, z)])
    points = np.vstack(out)
    # a rigid motion: the sizes do not depend on the frame
    c, s = np.cos(0.03), np.sin(0.03)
    rot = np.array([[1, 0, 0], [0, c, -s], [0, s, c]]) @ np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return points @ rot.T + [12.0, -3.0, 1.5]


def _hole(points: np.ndarray, tol=(0.0, 0.1)) -> FeatureData:
    return FeatureData("H", "cylinder", points, np.zeros(3), np.array([0.0, 0.0, 1.0]), "internal", 10.0, tol)


def test_an_exact_cylinder_oversize_fails_by_its_exact_mcc():
    points = _rings(lambda t: np.full_like(t, 5.025))  # diameter 10.05: MIC = MCC = 10.05
    ok = size_evaluation(_hole(points, (0.0, 0.1)), "MMC")
    assert ok["size_ok"] and abs(ok["mating_size_mm"] - 10.05) < 1e-9 and abs(ok["bonus_low_mm"] - 0.05) < 1e-9
    # the upper limit decided by the least-squares-axis bound: no exact MCC computed
    assert ok["minimum_material_size_mm"] is None and abs(ok["minimum_material_size_bound_mm"] - 10.05) < 1e-9
    over = size_evaluation(_hole(points, (0.0, 0.04)), "MMC")  # LMC size 10.04 < 10.05
    assert not over["size_ok"]
    assert abs(over["minimum_material_size_mm"] - 10.05) < 1e-9  # the bound did not decide: exact MCC
    lmc = size_evaluation(_hole(points, (0.0, 0.1)), "LMC")
    assert abs(lmc["bonus_low_mm"] - 0.05) < 1e-9 and lmc["mating_size_mm"] is None


def test_a_region_too_tight_is_widened_until_the_mic_is_inside(monkeypatch):
    # lobed sections sampled at random angles: the MIC axis lies off the least-squares axis
    def radius_of(t):
        return 5.0 + 0.004 * np.cos(3 * t + 0.3) + 0.002 * np.sin(5 * t)

    points = _rings(radius_of, seed=11)
    reference = fit_cylinder(points, criterion="mic")
    assert reference.certificate.scope == "global" and not reference.certificate.on_region_boundary
    calls = []
    original = fit_cylinder

    def spy(*args, **kwargs):
        if "axis_region" in kwargs:  # a search whose optimum is on the edge cannot close: cut it short
            kwargs["search_budget"] = SearchBudget(max_seconds=1.0)
        fit = original(*args, **kwargs)
        if "axis_region" in kwargs:
            calls.append(fit.certificate.on_region_boundary)
        return fit

    monkeypatch.setattr("pcmm_geo.fit.fit_cylinder", spy)
    monkeypatch.setattr(_sizes, "_OFFSET_SPREADS", 0.16)  # a first region too small
    monkeypatch.setattr(_sizes, "_TILT_SPREADS", 0.16)
    monkeypatch.setattr(_sizes, "_OFFSET_FLOOR_RADII", 1e-6)
    monkeypatch.setattr(_sizes, "_TILT_FLOOR", 1e-7)
    sizes = size_evaluation(_hole(points), "MMC")
    assert calls[0] is True and calls[-1] is False  # hit the edge first, widened until inside
    assert abs(sizes["mating_size_mm"] - 2 * reference.radius) < 1e-9


def test_the_tight_region_gives_the_default_regions_mic():
    def radius_of(t):
        return 5.0 + 0.004 * np.cos(3 * t + 0.3) + 0.002 * np.sin(5 * t)

    points = _rings(radius_of, seed=11)
    sizes = size_evaluation(_hole(points, (-0.1, 0.1)), "MMC")
    reference = fit_cylinder(points, criterion="mic")
    assert abs(sizes["mating_size_mm"] - 2 * reference.radius) < 1e-9
    assert "45 deg" in reference.certificate.domain and "45 deg" not in sizes["mating_region"]


def test_the_surround_check_of_the_least_squares_axis():
    full = _rings(lambda t: np.full_like(t, 5.0))
    assert _sizes._surrounds(full, fit_cylinder(full))
    # an arc of 2.5 rad (< pi): its centre lies outside the hull of its projection
    t = np.linspace(0.0, 2.5, 30)
    arc = np.vstack([np.c_[5 * np.cos(t), 5 * np.sin(t), np.full(30, z)] for z in (0.0, 4.0, 8.0)])
    assert not _sizes._surrounds(arc, fit_cylinder(arc))
