"""Tests of the Gaussian cylinder fit against independent truth.

Truth comes from (1) points sampled exactly on known cylinders, (2) null-space data:
points pushed off a known cylinder along its normals by amounts orthogonal to the range
of the residual Jacobian (computed here by complex-step differentiation of an
independent residual expression), whose least-squares cylinder is therefore the known
one, and (3) the NIST reference pairs.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.errors import (
    ConvergenceError,
    DegenerateGeometryError,
    InvalidInputError,
    PcmmGeoError,
    TooFewPointsError,
)
from pcmm_geo.fit import CylinderFit, FitResult, fit_cylinder

ATOL = 1e-9


def random_frame(rng: np.random.Generator) -> np.ndarray:
    """Rows: two unit vectors across the axis and the axis itself (a random rotation)."""
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return (q * np.sign(np.diag(r))).T


def sample_cylinder(
    rng: np.random.Generator,
    *,
    offset: float,
    radius: float,
    length: float,
    arc_deg: float,
    n: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Exact points on a cylinder in a random pose; returns points, axis point, axis, radial normals."""
    frame = random_frame(rng)
    across_1, across_2, axis = frame
    base = offset * frame.T @ np.array([0.6, -0.48, 0.64])  # |base| = offset
    angles = np.radians(arc_deg) * rng.random(n) + rng.random() * 2 * np.pi
    heights = length * (rng.random(n) - 0.5)
    normals = np.outer(np.cos(angles), across_1) + np.outer(np.sin(angles), across_2)
    points = base + radius * normals + np.outer(heights, axis)
    return points, base, axis, normals


def complex_step_jacobian(residual_fn, params: np.ndarray) -> np.ndarray:
    """Jacobian of ``residual_fn`` by complex-step differentiation (exact to rounding)."""
    step = 1e-30
    columns = []
    for k in range(params.size):
        shifted = params.astype(complex)
        shifted[k] += 1j * step
        columns.append(residual_fn(shifted).imag / step)
    return np.column_stack(columns)


def cylinder_residuals_independent(points: np.ndarray):
    """Residual |(p - c) x w| / |w| - r as a function of (c, w, r), complex-step safe."""

    def residuals(params: np.ndarray) -> np.ndarray:
        centre, direction, radius = params[0:3], params[3:6], params[6]
        offset = points - centre
        cross = np.c_[
            offset[:, 1] * direction[2] - offset[:, 2] * direction[1],
            offset[:, 2] * direction[0] - offset[:, 0] * direction[2],
            offset[:, 0] * direction[1] - offset[:, 1] * direction[0],
        ]
        return np.sqrt((cross * cross).sum(axis=1)) / np.sqrt((direction * direction).sum()) - radius

    return residuals


def null_space_data(points, base, axis, normals, radius, rng, form):
    """Move the points along their normals by a null-space vector of J^T of peak-to-valley ``form``."""
    params = np.r_[base, axis, radius]
    jac = complex_step_jacobian(cylinder_residuals_independent(points), params)
    u, sing, _ = np.linalg.svd(jac, full_matrices=False)
    basis = u[:, sing > 1e-10 * sing[0]]
    deviation = rng.normal(size=len(points))
    deviation -= basis @ (basis.T @ deviation)
    deviation *= form / np.ptp(deviation)
    moved = points + deviation[:, None] * normals
    # the cylinder Jacobian is unchanged by radial moves; check the optimality condition
    jac_moved = complex_step_jacobian(cylinder_residuals_independent(moved), params)
    assert np.abs(jac_moved.T @ deviation).max() < 1e-12 * np.abs(jac_moved).max() * len(points)
    return moved, deviation


def assert_same_cylinder(fit: CylinderFit, base, axis, radius, centroid):
    expected_axis = axis if axis[np.argmax(np.abs(axis))] > 0 else -axis
    expected_point = base + ((centroid - base) @ axis) * axis
    assert abs(fit.radius - radius) < ATOL
    np.testing.assert_allclose(fit.axis, expected_axis, rtol=0, atol=ATOL)
    np.testing.assert_allclose(fit.point, expected_point, rtol=0, atol=ATOL)


CASES = [
    # offset, radius, length, arc (deg), n
    (0.0, 10.0, 40.0, 360.0, 60),
    (500.0, 25.0, 10.0, 360.0, 40),  # short section
    (1000.0, 5.0, 100.0, 360.0, 80),  # long thin
    (1000.0, 50.0, 60.0, 30.0, 60),  # 30 degree arc
    (500.0, 2.0, 3.0, 90.0, 30),
    (1000.0, 200.0, 15.0, 45.0, 100),  # partial and short
]


@pytest.mark.parametrize(("offset", "radius", "length", "arc_deg", "n"), CASES)
def test_exact_points_recover_cylinder(offset, radius, length, arc_deg, n):
    rng = np.random.default_rng(int(offset + radius + arc_deg))
    points, base, axis, _ = sample_cylinder(rng, offset=offset, radius=radius, length=length, arc_deg=arc_deg, n=n)
    fit = fit_cylinder(points)
    assert isinstance(fit, FitResult)
    assert_same_cylinder(fit, base, axis, radius, points.mean(axis=0))
    assert np.abs(fit.residuals).max() < ATOL
    assert fit.converged and fit.n == n and fit.dof == n - 5


@pytest.mark.parametrize(("offset", "radius", "length", "arc_deg", "n"), CASES)
@pytest.mark.parametrize("form", [1e-3, 0.1])
def test_null_space_data_recover_cylinder(offset, radius, length, arc_deg, n, form):
    rng = np.random.default_rng(7 + int(offset + 3 * radius + arc_deg))
    points, base, axis, normals = sample_cylinder(
        rng, offset=offset, radius=radius, length=length, arc_deg=arc_deg, n=n
    )
    moved, deviation = null_space_data(points, base, axis, normals, radius, rng, form)
    fit = fit_cylinder(moved)
    assert_same_cylinder(fit, base, axis, radius, moved.mean(axis=0))
    np.testing.assert_allclose(fit.residuals, deviation, rtol=0, atol=ATOL)
    assert fit.form == pytest.approx(form, abs=ATOL)
    assert fit.rms == pytest.approx(np.sqrt(np.mean(deviation**2)), abs=ATOL)


def test_covariance_radius_matches_independent_jacobian():
    rng = np.random.default_rng(11)
    radius = 12.0
    points, base, axis, normals = sample_cylinder(rng, offset=300.0, radius=radius, length=30.0, arc_deg=200.0, n=50)
    moved, deviation = null_space_data(points, base, axis, normals, radius, rng, 0.05)
    fit = fit_cylinder(moved)
    jac = complex_step_jacobian(cylinder_residuals_independent(moved), np.r_[base, axis, radius])
    variance = deviation @ deviation / (len(moved) - 5)
    # the radius is estimable, so any generalised inverse of J^T J gives its variance
    expected = np.sqrt(variance * np.linalg.pinv(jac.T @ jac)[6, 6])
    assert fit.std_errors[fit.parameter_names.index("radius")] == pytest.approx(expected, rel=1e-6)
    assert fit.parameter_names[-1] == "radius"
    assert fit.parameters[6] == fit.radius
    # the axis direction is a unit vector: its covariance has no component along itself
    axis_cov = fit.covariance[3:6, 3:6]
    assert abs(fit.axis @ axis_cov @ fit.axis) < 1e-12 * np.trace(axis_cov)
    # full 7 x 7 covariance: point (foot of the centroid), axis and radius are functions of the
    # geometry only, so propagating the independent (c, w, r) covariance must give the same matrix
    centroid = moved.mean(axis=0)
    sign = np.sign(fit.axis @ axis)

    def machine_parameters(params):
        centre, direction, rad = params[0:3], params[3:6], params[6]
        unit_axis = direction / np.sqrt(direction @ direction)
        foot = centre + ((centroid - centre) @ unit_axis) * unit_axis
        return np.r_[foot, sign * unit_axis, rad]

    truth = np.r_[base, axis, radius]
    gradient = complex_step_jacobian(machine_parameters, truth)
    expected_cov = variance * gradient @ np.linalg.pinv(jac.T @ jac) @ gradient.T
    np.testing.assert_allclose(fit.covariance, expected_cov, rtol=0, atol=1e-6 * np.abs(expected_cov).max())
    np.testing.assert_allclose(fit.parameters, machine_parameters(truth), rtol=0, atol=ATOL)


def test_residual_sign_and_point_convention():
    # hand-built: axis along z through (3, 4, .), radius 2; a point at distance 2.5 is 0.5 outside
    angles = np.radians([0, 72, 144, 216, 288])
    ring = np.c_[3 + 2 * np.cos(angles), 4 + 2 * np.sin(angles), np.zeros(5)]
    points = np.vstack([ring, ring + np.array([0.0, 0.0, 10.0])])
    fit = fit_cylinder(points)
    np.testing.assert_allclose(fit.point, [3, 4, 5], atol=ATOL)
    np.testing.assert_allclose(fit.axis, [0, 0, 1], atol=ATOL)
    assert fit.diameter == pytest.approx(4.0, abs=ATOL)
    with pytest.raises(dataclasses.FrozenInstanceError):
        fit.radius = 1.0  # type: ignore[misc]
    # the same cylinder with the axis pointing to -z is reported with +z
    fit_flipped = fit_cylinder(points[::-1] * [1, 1, -1])
    np.testing.assert_allclose(fit_flipped.axis, [0, 0, 1], atol=ATOL)


def test_residuals_outside_positive():
    rng = np.random.default_rng(3)
    points, base, axis, normals = sample_cylinder(rng, offset=0.0, radius=5.0, length=20.0, arc_deg=360.0, n=40)
    moved, _ = null_space_data(points, base, axis, normals, 5.0, rng, 0.02)
    fit = fit_cylinder(moved)
    outside = np.linalg.norm(np.cross(moved - base, axis), axis=1) > 5.0
    assert np.all((fit.residuals > 0) == outside)


def test_fixed_radius_fits_axis_only():
    rng = np.random.default_rng(5)
    points, base, axis, _ = sample_cylinder(rng, offset=800.0, radius=8.0, length=25.0, arc_deg=120.0, n=30)
    # with the radius fixed 0.1 mm too large, the axis of exact data on a 120 deg arc moves away
    # from the points; with the true radius the fit is exact
    fit = fit_cylinder(points, radius=8.0)
    assert_same_cylinder(fit, base, axis, 8.0, points.mean(axis=0))
    assert fit.dof == 30 - 4 and fit.method == "gaussian-fixed-radius"
    fit_big = fit_cylinder(points, radius=8.1)
    assert fit_big.radius == 8.1 and fit_big.rms > 1e-4
    assert fit_cylinder(points[:4], radius=8.0).radius == 8.0


def test_weights_zero_weight_equals_removal_and_integer_weights_equal_duplication():
    rng = np.random.default_rng(9)
    points, *_ = sample_cylinder(rng, offset=100.0, radius=6.0, length=20.0, arc_deg=300.0, n=30)
    noisy = points + rng.normal(scale=0.01, size=points.shape)
    weights = np.ones(30)
    weights[:5] = 0.0
    weighted = fit_cylinder(noisy, weights=weights)
    removed = fit_cylinder(noisy[5:])
    assert weighted.radius == pytest.approx(removed.radius, abs=ATOL)
    assert abs(abs(weighted.axis @ removed.axis) - 1) < 1e-12
    doubled = np.ones(30)
    doubled[:10] = 2.0
    weighted = fit_cylinder(noisy, weights=doubled)
    duplicated = fit_cylinder(np.vstack([noisy, noisy[:10]]))
    assert weighted.radius == pytest.approx(duplicated.radius, abs=ATOL)
    np.testing.assert_allclose(weighted.axis, duplicated.axis, atol=ATOL)


def test_axis_hint_is_accepted_and_does_not_change_the_optimum():
    rng = np.random.default_rng(13)
    points, base, axis, _ = sample_cylinder(rng, offset=1000.0, radius=40.0, length=8.0, arc_deg=30.0, n=40)
    fit = fit_cylinder(points, axis_hint=-axis + 0.05)
    assert_same_cylinder(fit, base, axis, 40.0, points.mean(axis=0))


def _load_nist(path: Path) -> np.ndarray:
    lines = path.read_text().split()
    count = int(lines[0])
    return np.array(lines[1 : 1 + 3 * count], dtype=float).reshape(count, 3)


NIST_DIR = Path(__file__).parent.parent / "data" / "nist"
NIST_CYLINDERS = sorted(NIST_DIR.glob("Cylinder/*.ds")) + sorted(NIST_DIR.glob("extra-from-points-txt/Cylinder/*.txt"))


def test_nist_files_present():
    assert len(NIST_CYLINDERS) == 7


@pytest.mark.parametrize("data_file", NIST_CYLINDERS, ids=lambda p: p.stem)
def test_nist_cylinders(data_file: Path):
    points = _load_nist(data_file)
    reference = np.loadtxt(data_file.with_suffix(".fit"))
    fit = fit_cylinder(points)
    ref_axis = reference[3:6]
    centroid = points.mean(axis=0)
    ref_point = reference[:3] + ((centroid - reference[:3]) @ ref_axis) * ref_axis
    assert fit.diameter == pytest.approx(reference[6], abs=ATOL)
    np.testing.assert_allclose(np.sign(fit.axis @ ref_axis) * fit.axis, ref_axis, rtol=0, atol=ATOL)
    np.testing.assert_allclose(fit.point, ref_point, rtol=0, atol=ATOL)


@pytest.mark.parametrize(
    ("points", "error"),
    [
        (np.zeros((6, 2)), InvalidInputError),
        (np.zeros(18), InvalidInputError),
        (np.r_[np.ones((5, 3)), [[np.nan, 0, 0]]], InvalidInputError),
        (np.r_[np.ones((5, 3)), [[np.inf, 0, 0]]], InvalidInputError),
        ([["a", "b", "c"]] * 6, InvalidInputError),
        (np.random.default_rng(1).normal(size=(4, 3)), TooFewPointsError),
        (np.outer(np.arange(8.0), [1, 2, 3]) + 1000, DegenerateGeometryError),  # collinear
        (np.c_[np.random.default_rng(2).normal(size=(8, 2)), np.full(8, 3.0)], DegenerateGeometryError),  # coplanar
    ],
)
def test_bad_input_raises_typed_error(points, error):
    with pytest.raises(error) as info:
        fit_cylinder(points)
    assert isinstance(info.value, PcmmGeoError)


def test_bad_options_raise():
    rng = np.random.default_rng(4)
    points, *_ = sample_cylinder(rng, offset=0.0, radius=3.0, length=10.0, arc_deg=360.0, n=12)
    with pytest.raises(InvalidInputError, match="radius"):
        fit_cylinder(points, radius=-1.0)
    with pytest.raises(InvalidInputError, match="axis_hint"):
        fit_cylinder(points, axis_hint=[0, 0, 0])
    with pytest.raises(InvalidInputError, match="axis_hint"):
        fit_cylinder(points, axis_hint=[1, 2])
    with pytest.raises(InvalidInputError, match="weights"):
        fit_cylinder(points, weights=np.ones(5))
    with pytest.raises(InvalidInputError, match="weights"):
        fit_cylinder(points, weights=-np.ones(12))
    with pytest.raises(TooFewPointsError, match="at least 4"):
        fit_cylinder(points[:3], radius=3.0)


def test_no_convergence_raises(monkeypatch):
    import pcmm_geo.fit._kernels._core as core

    rng = np.random.default_rng(6)
    points, *_ = sample_cylinder(rng, offset=0.0, radius=3.0, length=10.0, arc_deg=360.0, n=12)
    monkeypatch.setattr(core, "TOL", core.Tolerances(max_iterations=1))
    with pytest.raises(ConvergenceError) as info:
        fit_cylinder(points + rng.normal(scale=0.01, size=points.shape))
    assert isinstance(info.value, RuntimeError)
