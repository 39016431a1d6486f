"""Sparse cylinders, cones and tori reach the least-squares minimum, or say they cannot be sure.

A seeded scan (the small sibling of ``benchmarks/fit_robustness.py``): every data set is
fitted by pcmm_geo and by the independent multi-start reference of
``multistart_reference.py`` (MINPACK LM from a lattice of axes, the principal axes and the
generating axis).  A fit passes when its sum of squares is within 1e-9 (relative) of the
reference's, or when it said it could not be sure: :class:`~pcmm_geo.errors.AmbiguousFitWarning`
(competing minima) or :class:`~pcmm_geo.errors.UnassuredMinimumWarning` (sparse torus without a
hint).  Zero silent wrong answers are allowed (before the direction screening: 18 % of 6-point
cylinders, 3 % of cones, 12-24 % of sparse tori).  The screening alone still leaves 8.7 % (whole)
and 10 % (partial) of 8-10-point tori in a wrong minimum in the 150-set benchmark scan, which is
why every torus fit of fewer than 20 points without ``axis_hint`` warns.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from multistart_reference import reference_for, sparse_case

from pcmm_geo.errors import AmbiguousFitWarning, UnassuredMinimumWarning
from pcmm_geo.fit import fit_cone, fit_cylinder, fit_torus
from pcmm_geo.fit.torus import ASSURED_POINTS

FITS = {"cylinder": fit_cylinder, "cone": fit_cone, "torus": fit_torus}

SCANS = [
    # kind, points per set, arc about the axis (deg), number of sets, silent failures allowed
    ("cylinder", (6, 8), (360, 360), 30, 0),
    ("cylinder", (15, 15), (180, 180), 10, 0),
    # dense: fitted from the principal axes, screened only where the points leave a gap about the axis
    ("cylinder", (300, 300), (360, 360), 4, 0),
    ("cylinder", (300, 300), (60, 300), 6, 0),
    ("cylinder", (2500, 2500), (60, 360), 3, 0),  # through the subsample start
    ("cone", (7, 10), (360, 360), 14, 0),
    # sparse tori: the screening alone leaves about 1 set in 10 in a wrong minimum (set 1 of the
    # partial scan with this seed); every such fit warns UnassuredMinimumWarning, so none is silent
    ("torus", (8, 10), (360, 360), 8, 0),
    ("torus", (8, 10), (90, 180), 8, 0),
]


def _silent_failures(kind: str, points_range, arc_range, sets: int, seed: int) -> list[str]:
    rng = np.random.default_rng([seed, len(kind), sets])
    silent = []
    for index in range(sets):
        n = int(rng.integers(points_range[0], points_range[1] + 1))
        case = sparse_case(kind, rng, n, arc_deg=float(rng.uniform(*arc_range)))
        reference = reference_for(kind, case, count=24)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            result = FITS[kind](case.points)
        ambiguous = [w.message for w in caught if isinstance(w.message, AmbiguousFitWarning)]
        unassured = [w.message for w in caught if isinstance(w.message, UnassuredMinimumWarning)]
        if kind == "torus":  # below ASSURED_POINTS without a hint a torus fit always says so
            assert unassured and unassured[0].n_points == n and unassured[0].assured_from == ASSURED_POINTS
        for warning in ambiguous:  # structured: the competing minima, best first, within the margin
            costs = [minimum["sum_of_squares"] for minimum in warning.minima]
            assert costs[0] == pytest.approx(result.sum_of_squares, rel=1e-9)
            assert max(costs) <= costs[0] * (1 + warning.margin) + 1e-20
        if result.sum_of_squares > reference.cost * (1 + 1e-9) + 1e-24 and not (ambiguous or unassured):
            silent.append(f"set {index}: {n} points, sum of squares {result.sum_of_squares:.6g} > {reference.cost:.6g}")
    return silent


@pytest.mark.parametrize(("kind", "points_range", "arc_range", "sets", "allowed"), SCANS)
def test_sparse_axial_fits_never_return_a_wrong_minimum_silently(kind, points_range, arc_range, sets, allowed) -> None:
    silent = _silent_failures(kind, points_range, arc_range, sets, seed=11)
    assert len(silent) <= allowed, silent


def test_dense_cylinders_are_screened_only_where_they_leave_a_gap_about_the_axis(monkeypatch) -> None:
    """The criterion of ``_screen.surrounds_axis``: sparse or partial data are screened, dense full ones not."""
    import pcmm_geo.fit.cylinder as cylinder_module
    from pcmm_geo.fit._kernels._screen import DENSE_POINTS, FULL_COVERAGE_GAP, largest_azimuth_gap

    screened = []
    original = cylinder_module.screened_directions
    monkeypatch.setattr(cylinder_module, "screened_directions", lambda *args: screened.append(1) or original(*args))
    rng = np.random.default_rng(21)
    for count, arc_deg, expected in [(DENSE_POINTS, 360.0, True), (DENSE_POINTS + 1, 360.0, False),
                                     (400, 300.0, True), (3000, 360.0, False), (3000, 200.0, True)]:
        case = sparse_case("cylinder", rng, count, arc_deg=arc_deg)
        screened.clear()
        result = fit_cylinder(case.points)
        assert bool(screened) == expected, (count, arc_deg)
        across = (case.points - result.point) @ np.linalg.svd(result.axis[None])[2][1:].T
        assert (largest_azimuth_gap(across) > FULL_COVERAGE_GAP) == (arc_deg < 315.0)
        assert result.sum_of_squares <= reference_for("cylinder", case, count=12).cost * (1 + 1e-9) + 1e-24
    # points of zero weight count neither as density nor as coverage: 150 weighted points are sparse
    case = sparse_case("cylinder", rng, 400, arc_deg=360.0)
    weights = np.zeros(400)
    weights[:150] = 1.0
    screened.clear()
    fit_cylinder(case.points, weights=weights)
    assert screened


def test_ambiguity_warning_carries_the_competing_minima() -> None:
    # points near the intersection of the cylinders x^2 + y^2 = 25 and y^2 + z^2 = 25, made
    # symmetric under the swap x <-> z: the two mirror-image cylinders fit exactly equally well
    rng = np.random.default_rng(3)
    angle = rng.uniform(0, 2 * np.pi, 5)
    side = np.array([1.0, -1.0, 1.0, -1.0, 1.0])
    half = np.c_[5 * np.cos(angle), 5 * np.sin(angle), side * 5 * np.cos(angle)] + rng.normal(scale=0.02, size=(5, 3))
    points = np.vstack([half, half[:, ::-1]])
    with pytest.warns(AmbiguousFitWarning) as record:
        result = fit_cylinder(points)
    warning = record[0].message
    assert warning.element == "cylinder" and len(warning.minima) == 2
    first, second = warning.minima
    assert first["sum_of_squares"] == pytest.approx(second["sum_of_squares"], rel=1e-9)
    assert first["sum_of_squares"] == pytest.approx(result.sum_of_squares, rel=1e-9)
    # the competitors are each other's mirror image under x <-> z
    assert np.allclose(np.abs(first["axis"][::-1]), np.abs(second["axis"]), atol=1e-7)
    assert first["radius"] == pytest.approx(second["radius"], abs=1e-9)


def test_sparse_torus_warns_without_a_hint_and_not_with_one_or_with_enough_points() -> None:
    rng = np.random.default_rng(5)
    case = sparse_case("torus", rng, 9, arc_deg=360.0)
    with pytest.warns(UnassuredMinimumWarning, match="9 points and no axis_hint"):
        fit_torus(case.points)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        hinted = fit_torus(case.points, axis_hint=case.axis)
    reference = reference_for("torus", case, count=24)
    assert hinted.sum_of_squares <= reference.cost * (1 + 1e-9) + 1e-24
    dense = sparse_case("torus", rng, ASSURED_POINTS, arc_deg=360.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fit_torus(dense.points)
