"""Global minimum zone, MCC and MIC against exact truths computed without pcmm_geo code.

The truths (``zone_truths.py``): hull antipodal pairs for the plane slab and the 2-D strip,
all 4- / 5-point splits for circle / sphere zones, every spanned ball for the enclosing ball,
Voronoi vertices in the hull and hull crossings for the largest empty circle.  On many random
sparse sets per element (warped patches, strips, small radii, partial arcs, few points) every
answer must be the truth to 1e-9 mm *and* say ``scope == "global"``.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from zone_truths import (
    empty_circle_truth,
    enclosing_truth,
    rotation,
    round_profile,
    round_zone_truth,
    slab_truth,
    strip_truth,
    warped_patch,
)

from pcmm_geo.errors import DegenerateGeometryError
from pcmm_geo.fit import fit_circle, fit_line, fit_plane, fit_sphere

AUDIT = Path(__file__).resolve().parents[1] / "data" / "zone_audit"
GAP = 1e-9  # mm
SETS = 60  # random sets per element and family


def _assert_global(fit, value: float, truth: float) -> None:
    assert fit.converged, fit.message
    assert fit.certificate.scope == "global", fit.message
    assert abs(value - truth) <= GAP, (value, truth)
    assert fit.certificate.gap_mm <= GAP
    assert abs(value - fit.certificate.bound_mm) == pytest.approx(fit.certificate.gap_mm, abs=1e-15)


def _check_round_zone(points: np.ndarray, fit_function, straight_truth) -> None:
    """The zone is the exhaustive truth, or refused when a straight zone (centre at infinity) is narrower."""
    finite = round_zone_truth(points)
    if len(points) > points.shape[1] + 1 and straight_truth(points) < finite - GAP:
        with pytest.raises(DegenerateGeometryError, match="infinite radius"):
            fit_function(points, criterion="chebyshev")
        return
    fit = fit_function(points, criterion="chebyshev")
    _assert_global(fit, fit.form, finite)


@pytest.mark.parametrize("seed", range(3))
def test_plane_zone_is_the_hull_antipodal_truth(seed: int) -> None:
    rng = np.random.default_rng(1000 + seed)
    for _ in range(SETS):
        points = warped_patch(rng)
        fit = fit_plane(points, criterion="chebyshev")
        _assert_global(fit, fit.form, slab_truth(points))
        assert np.ptp(fit.residuals) == pytest.approx(fit.form, abs=1e-12)  # every point in the zone
        assert fit.certificate.domain == "all planes"


@pytest.mark.parametrize("seed", range(2))
def test_line_zone_is_the_hull_edge_truth(seed: int) -> None:
    rng = np.random.default_rng(2000 + seed)
    for _ in range(SETS):
        n = int(rng.integers(3, 30))
        x = rng.uniform(-20, 20, n)
        points = np.c_[x, rng.normal(0, 10 ** rng.uniform(-3, 0), n) + rng.normal(0, 3e-3) * x**2]
        turn = rng.uniform(0, 2 * np.pi)
        points = points @ np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]]).T
        points += rng.uniform(-500, 500, 2)
        fit = fit_line(points, criterion="chebyshev")
        _assert_global(fit, fit.form, strip_truth(points))


@pytest.mark.parametrize("seed", range(2))
def test_circle_zone_is_the_exhaustive_split_truth(seed: int) -> None:
    rng = np.random.default_rng(3000 + seed)
    for _ in range(SETS):
        points = round_profile(rng, 2, (3, 12), arcs=True)
        _check_round_zone(points, fit_circle, strip_truth)


@pytest.mark.parametrize("seed", range(2))
def test_sphere_zone_is_the_exhaustive_split_truth(seed: int) -> None:
    rng = np.random.default_rng(4000 + seed)
    for _ in range(SETS // 2):
        points = round_profile(rng, 3, (5, 10), arcs=True)
        _check_round_zone(points, fit_sphere, slab_truth)


@pytest.mark.parametrize(("dim", "seed"), [(2, 0), (2, 1), (3, 0)])
def test_mcc_is_the_smallest_enclosing_ball(dim: int, seed: int) -> None:
    rng = np.random.default_rng(5000 + 10 * dim + seed)
    fit_function = fit_circle if dim == 2 else fit_sphere
    for _ in range(SETS):
        points = round_profile(rng, dim, (3 if dim == 2 else 4, 12), arcs=True)
        fit = fit_function(points, criterion="mcc")
        _assert_global(fit, fit.radius, enclosing_truth(points))
        assert np.max(fit.residuals) <= 1e-12  # encloses every point


@pytest.mark.parametrize("seed", range(2))
def test_mic_circle_is_the_largest_empty_circle_in_the_hull(seed: int) -> None:
    rng = np.random.default_rng(6000 + seed)
    refused = 0
    for _ in range(SETS):
        points = round_profile(rng, 2, (4, 13), arcs=False)
        if rng.random() < 0.3:  # some arcs short enough that the points do not surround an empty circle
            angles = rng.uniform(0, rng.uniform(0.5, 1.5) * np.pi, len(points))
            points = np.c_[np.cos(angles), np.sin(angles)] * 20 + rng.normal(0, 0.05, points.shape)
        truth, on_boundary = empty_circle_truth(points)
        if on_boundary:
            with pytest.raises(DegenerateGeometryError, match="do not surround"):
                fit_circle(points, criterion="mic")
            refused += 1
            continue
        fit = fit_circle(points, criterion="mic")
        _assert_global(fit, fit.radius, truth)
        assert np.min(fit.residuals) >= -1e-12  # no point inside the circle
    assert 0 < refused < SETS


# ------------------------------------------------------------------ the audit's sets


def _audit_cases(element: str) -> list[tuple[str, str, float]]:
    with open(AUDIT / "truths.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    return [(r["file"], r["criterion"], float(r["truth_mm"])) for r in rows if r["element"] == element]


@pytest.mark.parametrize(("name", "criterion", "truth"), _audit_cases("plane") + _audit_cases("circle"))
def test_audit_cases_give_the_audit_truth(name: str, criterion: str, truth: float) -> None:
    points = np.loadtxt(AUDIT / name, delimiter=",", skiprows=1)
    if points.shape[1] == 3:
        fit = fit_plane(points, criterion=criterion)
        value = fit.form
        assert abs(slab_truth(points) - truth) <= 1e-9  # the audit's value, to its printed digits
    else:
        fit = fit_circle(points, criterion=criterion)
        value = fit.radius
        assert abs(empty_circle_truth(points)[0] - truth) <= 1e-9
    assert fit.certificate.scope == "global" and fit.converged
    assert abs(value - truth) <= 1e-9  # the audit printed 9 decimals


# ------------------------------------------------------------------ exact data


def test_exact_data_converge_with_zero_form() -> None:
    angles = np.radians([0.0, 100.0, 230.0])
    three = np.c_[5 * np.cos(angles), 5 * np.sin(angles)] + [120.0, -40.0]
    for criterion in ("chebyshev", "mcc", "mic"):
        fit = fit_circle(three, criterion=criterion)
        assert fit.converged and fit.certificate.scope == "global", fit.message
        assert fit.form <= 1e-12 and fit.radius == pytest.approx(5.0, abs=1e-12)
        assert np.linalg.norm(fit.center - [120.0, -40.0]) <= 1e-12
    tetrahedron = np.array([[1.0, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]]) * 4 / np.sqrt(3) + [7.0, 8, 9]
    for criterion in ("chebyshev", "mcc", "mic"):
        fit = fit_sphere(tetrahedron, criterion=criterion)
        assert fit.converged and fit.certificate.scope == "global", fit.message
        assert fit.form <= 1e-12 and fit.radius == pytest.approx(4.0, abs=1e-12)
    rng = np.random.default_rng(9)
    flat = np.c_[rng.uniform(-10, 10, (50, 2)), np.zeros(50)] @ rotation(rng).T + 300.0
    for points in (flat, flat[:3]):
        fit = fit_plane(points, criterion="chebyshev")
        assert fit.converged and fit.certificate.scope == "global" and fit.form <= 1e-12
    straight = np.outer(rng.uniform(-10, 10, 20), [0.6, 0.8]) + 50.0
    fit = fit_line(straight, criterion="chebyshev")
    assert fit.converged and fit.certificate.scope == "global" and fit.form <= 1e-12
    ring = np.c_[np.cos(rng.uniform(0, 2 * np.pi, 2000)), np.sin(rng.uniform(0, 2 * np.pi, 2000))]
    ring = 7.0 * ring / np.linalg.norm(ring, axis=1)[:, None] + [3.0, 4.0]
    for criterion in ("chebyshev", "mcc", "mic"):
        fit = fit_circle(ring, criterion=criterion)
        assert fit.converged and fit.certificate.scope == "global", fit.message
        assert fit.form <= 1e-12 and fit.radius == pytest.approx(7.0, abs=1e-12)


def test_three_d_circle_is_global_in_its_plane() -> None:
    rng = np.random.default_rng(12)
    flat = round_profile(rng, 2, (8, 9), arcs=False)
    frame = rotation(rng)
    points = np.c_[flat, rng.normal(0, 1e-3, len(flat))] @ frame.T
    fit = fit_circle(points, criterion="chebyshev")
    assert fit.certificate.scope == "global"
    assert fit.certificate.domain == "all circles in the least-squares plane of the points"
    # the in-plane problem (in the least-squares plane's coordinates) is solved exactly
    centred = points - points.mean(axis=0)
    basis = np.linalg.svd(centred)[2][:2]
    assert fit.form == pytest.approx(round_zone_truth(centred @ basis.T), abs=GAP)


def test_a_straight_zone_narrower_than_every_circle_is_refused() -> None:
    x = np.linspace(-10, 10, 9)
    points = np.c_[x, 0.01 * np.array([1, -1] * 4 + [1])]  # a zigzag along a line: no annulus is narrower
    with pytest.raises(DegenerateGeometryError, match="infinite radius"):
        fit_circle(points, criterion="chebyshev")
