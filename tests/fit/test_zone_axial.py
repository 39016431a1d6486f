"""Global axial minimax fits (3-D line, cylinder zone / MCC / MIC) against independent references.

The references (``axial_reference.py``, no pcmm_geo code) solve a dense grid of axis
directions exactly in 2-D and polish the best ones: their value is that of an axis of the
region, so a fit that claims ``scope == "global"`` must be at least as good (to 1e-9 mm), and
its proven bound may never be better than the reference (a bound above a feasible value
would be false).  The audit's cylinder cases (``tests/data/zone_audit``) must give the
audit's value or better within the default region.
"""

from __future__ import annotations

import csv
import warnings
from pathlib import Path

import numpy as np
import pytest
from axial_reference import Region, best_axis, best_line

from pcmm_geo.errors import AmbiguousFitWarning, DegenerateGeometryError, InvalidInputError
from pcmm_geo.fit import AxisRegion, SearchBudget, fit_cone, fit_cylinder, fit_line

AUDIT = Path(__file__).resolve().parents[1] / "data" / "zone_audit"
GAP = 1e-9  # mm
#: deterministic budget (no wall-clock limit): the tests do not depend on the machine's speed
BUDGET = SearchBudget(max_cells=1_500_000, max_seconds=None)


def _value(fit, criterion: str) -> float:
    return fit.form if criterion == "chebyshev" else fit.radius


def _rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def _sparse_cylinder(rng: np.random.Generator, n: int, arc: float) -> np.ndarray:
    radius = 10 ** rng.uniform(0, 1.7)
    length = radius * rng.uniform(0.3, 3.0)
    angles = rng.uniform(0, arc, n)
    noise = radius * 10 ** rng.uniform(-4, -1.5)
    rho = radius + rng.normal(0, noise, n)
    local = np.c_[rho * np.cos(angles), rho * np.sin(angles), rng.uniform(0, length, n)]
    return local @ _rotation(rng).T + rng.uniform(-500, 500, 3)


def _unambiguous(rng: np.random.Generator, smallest: int, largest: int, arc: float) -> tuple[np.ndarray, object]:
    """A sparse set whose least-squares cylinder (the default region's reference) is unambiguous, and that cylinder."""
    while True:
        points = _sparse_cylinder(rng, int(rng.integers(smallest, largest)), arc)
        with warnings.catch_warnings():
            warnings.simplefilter("error", AmbiguousFitWarning)
            try:
                return points, fit_cylinder(points)
            except AmbiguousFitWarning:
                continue


def _check_against(fit, reference: float, criterion: str, region: Region) -> None:
    """A global claim is never worse than the reference; the proven bound never beyond it; the axis is in the region."""
    certificate = fit.certificate
    value = _value(fit, criterion)
    if criterion == "mic":
        assert certificate.bound_mm >= reference - GAP, (certificate.bound_mm, reference)
        if certificate.scope == "global":
            assert value >= reference - GAP, (value, reference, fit.message)
        assert certificate.bound_mm >= value - 1e-12
    else:
        assert certificate.bound_mm <= reference + GAP, (certificate.bound_mm, reference)
        if certificate.scope == "global":
            assert value <= reference + GAP, (value, reference, fit.message)
        assert certificate.bound_mm <= value + 1e-12
    assert certificate.gap_mm == pytest.approx(abs(value - certificate.bound_mm), abs=1e-12)
    assert (certificate.scope == "global") == (certificate.gap_mm <= GAP)
    # the reported element holds every point as its criterion says
    if criterion == "mcc":
        assert np.max(fit.residuals) <= 1e-12
    elif criterion == "mic":
        assert np.min(fit.residuals) >= -1e-12
    else:
        assert np.ptp(fit.residuals) == pytest.approx(fit.form, abs=1e-12)
    # the axis lies in the region
    tilt = np.degrees(np.arccos(min(1.0, abs(float(fit.axis @ region.axis)))))
    assert tilt <= region.cone_deg + 1e-7
    height = (fit.point - region.origin) @ region.axis
    crossing = fit.point - height / float(fit.axis @ region.axis) * fit.axis - region.origin
    assert np.linalg.norm(crossing) <= region.offset * (1 + 1e-9)


def _audit_cases() -> list[tuple[str, float]]:
    with open(AUDIT / "truths.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    return [(row["file"], float(row["truth_mm"])) for row in rows if row["element"] == "cylinder"]


@pytest.mark.parametrize(("name", "audit_value"), _audit_cases())
def test_audit_cylinder_cases(name: str, audit_value: float) -> None:
    """The audit's enclosing cylinders (45 deg from the LS axis) are matched or beaten, globally."""
    points = np.loadtxt(AUDIT / name, delimiter=",", skiprows=1)
    gauss = fit_cylinder(points)
    fit = fit_cylinder(points, criterion="mcc", search_budget=BUDGET)
    assert fit.converged, fit.message
    assert fit.certificate.scope == "global", fit.message
    assert fit.radius <= audit_value + 1e-6  # the audit printed 6-7 digits
    # every one of them lies on the 45 deg edge of the default region, and says so
    assert fit.certificate.on_region_boundary
    assert "edge of the searched axis region" in fit.message
    assert np.degrees(np.arccos(abs(float(fit.axis @ gauss.axis)))) == pytest.approx(45.0, abs=1e-7)
    assert "45 deg of the least-squares axis" in fit.certificate.domain
    region = Region.around(points, gauss.axis, gauss.point, 45.0, 2 * gauss.radius)
    _check_against(fit, best_axis(points, "mcc", region, count=600).value, "mcc", region)


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("criterion", ["chebyshev", "mcc"])
def test_random_sparse_cylinders(seed: int, criterion: str) -> None:
    rng = np.random.default_rng(500 + seed + (100 if criterion == "mcc" else 0))
    for _ in range(1):
        arc = rng.uniform(np.pi / 2, 2 * np.pi)
        points, gauss = _unambiguous(rng, 7, 13, arc)
        axis = gauss.axis + rng.normal(0, 0.05, 3)  # a nominal axis near the LS one
        cone, offset = float(rng.uniform(10, 45)), float(gauss.radius * rng.uniform(0.2, 2.0))
        region_spec = AxisRegion(cone_deg=cone, offset_mm=offset, axis=axis, point=gauss.point)
        fit = fit_cylinder(points, criterion=criterion, axis_region=region_spec, search_budget=BUDGET)
        region = Region.around(points, axis, gauss.point, cone, offset)
        _check_against(fit, best_axis(points, criterion, region, count=300, polish=2).value, criterion, region)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("criterion", ["chebyshev", "mcc", "mic"])
def test_many_random_sparse_cylinders(seed: int, criterion: str) -> None:
    rng = np.random.default_rng(9000 + seed + {"chebyshev": 0, "mcc": 100, "mic": 200}[criterion])
    for _ in range(3):
        arc = 2 * np.pi if criterion == "mic" else rng.uniform(np.pi / 3, 2 * np.pi)
        points, gauss = _unambiguous(rng, 6, 13, arc)
        region = Region.around(points, gauss.axis, gauss.point, 45.0, 2 * gauss.radius)
        try:
            fit = fit_cylinder(points, criterion=criterion, search_budget=BUDGET)
        except DegenerateGeometryError:
            assert criterion == "mic"  # sparse rings may surround no empty cylinder
            continue
        _check_against(fit, best_axis(points, criterion, region, count=800, polish=2).value, criterion, region)


@pytest.mark.parametrize("seed", range(3))
def test_random_sparse_lines(seed: int) -> None:
    rng = np.random.default_rng(700 + seed)
    for _ in range(1):
        n = int(rng.integers(4, 12))
        local = np.c_[rng.normal(0, 10 ** rng.uniform(-3, 0), (n, 2)), rng.uniform(0, 50, n)]
        points = local @ _rotation(rng).T + rng.uniform(-500, 500, 3)
        fit = fit_line(points, criterion="chebyshev", search_budget=BUDGET)
        reference = best_line(points, count=800, polish=2)
        assert fit.certificate.bound_mm <= reference.value + GAP
        assert fit.certificate.scope == "global", fit.message
        assert fit.form <= reference.value + GAP
        assert fit.certificate.domain.startswith("all straight lines")
        assert 2.0 * np.max(fit.residuals) == pytest.approx(fit.form, abs=1e-12)


def test_exact_line_converges_with_form_zero() -> None:
    """Collinear points: form 0 to rounding, converged, global (the KKT system is degenerate there)."""
    direction = np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5])
    points = np.array([100.0, -20.0, 5.0]) + np.outer([0.0, 3.0, 7.5, 11.0, 40.0], direction)
    fit = fit_line(points, criterion="chebyshev")
    assert fit.converged, fit.message
    assert fit.certificate.scope == "global"
    assert fit.form <= 1e-12
    assert abs(abs(float(fit.direction @ direction)) - 1.0) <= 1e-15


def test_line_zone_without_a_least_squares_line_is_not_refused() -> None:
    """The corners of a cube have no preferred direction, yet a smallest enclosing cylinder."""
    corners = [[x, y, z] for x in (0.0, 2.0) for y in (0.0, 2.0) for z in (0.0, 2.0)]
    cube = np.array(corners) + np.array([10.0, -3.0, 7.0])
    with pytest.raises(DegenerateGeometryError, match="no preferred direction"):
        fit_line(cube)
    fit = fit_line(cube, criterion="chebyshev", search_budget=SearchBudget(max_cells=300_000, max_seconds=None))
    reference = best_line(cube, count=800, polish=2).value
    assert fit.certificate.bound_mm <= reference + GAP
    assert fit.form <= 2.0 * np.sqrt(2.0) + 1e-12  # no worse than along an edge (the face diagonal)
    if fit.certificate.scope == "global":
        assert fit.form <= reference + GAP


@pytest.mark.parametrize("criterion", ["chebyshev", "mcc", "mic"])
def test_exact_cylinder_converges(criterion: str) -> None:
    """Points exactly on a cylinder: zone 0, MCC = MIC = R, all global, in the default region."""
    rng = np.random.default_rng(3)
    angles = rng.uniform(0, 2 * np.pi, 40)
    local = np.c_[7.5 * np.cos(angles), 7.5 * np.sin(angles), rng.uniform(-10, 10, 40)]
    rotation = _rotation(rng)
    points = local @ rotation.T + [300.0, -200.0, 50.0]
    fit = fit_cylinder(points, criterion=criterion, search_budget=BUDGET)
    assert fit.converged, fit.message
    assert fit.certificate.scope == "global"
    assert fit.form <= 1e-11
    if criterion != "chebyshev":
        assert fit.radius == pytest.approx(7.5, abs=1e-11)
    assert abs(abs(float(fit.axis @ rotation[:, 2])) - 1.0) <= 1e-13


def test_region_options_and_edge_flag() -> None:
    rng = np.random.default_rng(11)
    points = _sparse_cylinder(rng, 40, 2 * np.pi)
    gauss = fit_cylinder(points)
    free = fit_cylinder(points, criterion="mcc", search_budget=BUDGET)
    assert not free.certificate.on_region_boundary
    # a nominal axis 20 deg off, searched within 5 deg: the best cylinder lies on the cone
    tilted = np.cross(gauss.axis, [1.0, 0.0, 0.0])
    nominal = np.cos(np.radians(20)) * gauss.axis + np.sin(np.radians(20)) * tilted / np.linalg.norm(tilted)
    narrow = AxisRegion(cone_deg=5.0, axis=nominal)
    fit = fit_cylinder(points, criterion="mcc", axis_region=narrow, search_budget=BUDGET)
    assert fit.certificate.on_region_boundary and fit.certificate.scope == "global"
    assert np.degrees(np.arccos(abs(float(fit.axis @ nominal)))) == pytest.approx(5.0, abs=1e-7)
    assert fit.radius >= free.radius - GAP  # a smaller region cannot do better
    assert "5 deg of the nominal axis" in fit.certificate.domain
    assert fit.certificate.bound_mm <= fit.radius


def test_budget_exhausted_is_local_with_a_bound() -> None:
    rng = np.random.default_rng(5)
    points = _sparse_cylinder(rng, 60, 2 * np.pi)
    fit = fit_cylinder(points, criterion="chebyshev", search_budget=SearchBudget(max_cells=200, max_seconds=None))
    certificate = fit.certificate
    assert certificate.scope == "local"
    assert "cell budget of 200 cells" in fit.message
    assert 0.0 <= certificate.bound_mm <= fit.form
    assert certificate.gap_mm == pytest.approx(fit.form - certificate.bound_mm, abs=1e-15)
    assert certificate.gap_mm > GAP


def test_cone_is_local_and_says_why() -> None:
    rng = np.random.default_rng(2)
    angles = rng.uniform(0, 2 * np.pi, 60)
    heights = rng.uniform(0, 20, 60)
    radii = 5 + heights * np.tan(np.radians(15)) + rng.normal(0, 1e-3, 60)
    points = np.c_[radii * np.cos(angles), radii * np.sin(angles), heights]
    fit = fit_cone(points, criterion="chebyshev")
    assert fit.converged, fit.message
    assert fit.certificate.scope == "local"
    assert np.isnan(fit.certificate.bound_mm)
    assert "local" in fit.certificate.domain


def test_bad_region_and_budget_are_refused() -> None:
    with pytest.raises(InvalidInputError, match="cone_deg"):
        AxisRegion(cone_deg=90.0)
    with pytest.raises(InvalidInputError, match="offset_mm"):
        AxisRegion(offset_mm=-1.0)
    with pytest.raises(InvalidInputError, match=r"axis_region\.point"):
        AxisRegion(point=[0.0, 0.0, 0.0])
    with pytest.raises(InvalidInputError, match="axis"):
        AxisRegion(axis=[0.0, 0.0, 0.0])
    with pytest.raises(InvalidInputError, match="max_cells"):
        SearchBudget(max_cells=0)
    points = _sparse_cylinder(np.random.default_rng(1), 20, 2 * np.pi)
    with pytest.raises(InvalidInputError, match="minimax criteria only"):
        fit_cylinder(points, axis_region=AxisRegion())
    with pytest.raises(InvalidInputError, match="axis_region"):
        fit_cylinder(points, criterion="mcc", axis_region=45.0)
    with pytest.raises(InvalidInputError, match="search_budget"):
        fit_line(points[:, :2], criterion="chebyshev", search_budget=BUDGET)
