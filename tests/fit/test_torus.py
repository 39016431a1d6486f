"""Tests of the Gaussian torus fit against independent truth.

Truth: points sampled exactly on known tori, and null-space data (points moved along the
torus normals by amounts orthogonal to the range of the residual Jacobian, computed here
by complex-step differentiation of an independent residual expression and re-evaluated at
the moved points until J^T e vanishes to rounding).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pcmm_geo.errors import ConvergenceError, DegenerateGeometryError, InvalidInputError, TooFewPointsError
from pcmm_geo.fit import TorusFit, fit_torus

ATOL = 1e-9


def random_frame(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return (q * np.sign(np.diag(r))).T


def sample_torus(rng, *, offset, major, minor, around_deg, tube_deg, n):
    """Exact torus points: ``around_deg`` of the sweep, tube angles in [-tube_deg/2, tube_deg/2] (0 = outer equator).

    Returns points, centre, axis, outward unit normals.
    """
    across_1, across_2, axis = random_frame(rng)
    centre = offset * np.array([-0.64, 0.6, 0.48])
    sweep = np.radians(around_deg) * rng.random(n) + 2 * np.pi * rng.random()
    tube = np.radians(tube_deg) * (rng.random(n) - 0.5)
    radial = np.outer(np.cos(sweep), across_1) + np.outer(np.sin(sweep), across_2)
    normals = np.cos(tube)[:, None] * radial + np.outer(np.sin(tube), axis)
    points = centre + major * radial + minor * normals
    return points, centre, axis, normals


def complex_step_jacobian(residual_fn, params):
    step = 1e-30
    columns = []
    for k in range(params.size):
        shifted = params.astype(complex)
        shifted[k] += 1j * step
        columns.append(residual_fn(shifted).imag / step)
    return np.column_stack(columns)


def torus_residuals_independent(points):
    """sqrt((rho - R)^2 + h^2) - r as a function of (c, w, R, r); w need not be unit."""

    def residuals(params):
        centre, direction, major, minor = params[0:3], params[3:6], params[6], params[7]
        offset = points - centre
        height = offset @ direction / np.sqrt(direction @ direction)
        rho = np.sqrt((offset * offset).sum(axis=1) - height**2)
        return np.sqrt((rho - major) ** 2 + height**2) - minor

    return residuals


def null_space_torus(points, params, normals, rng, form):
    deviation = rng.normal(size=len(points))
    deviation *= form / np.ptp(deviation)
    moved = points
    for _ in range(8):
        jac = complex_step_jacobian(torus_residuals_independent(moved), params)
        u, sing, _ = np.linalg.svd(jac, full_matrices=False)
        basis = u[:, sing > 1e-10 * sing[0]]
        deviation = deviation - basis @ (basis.T @ deviation)
        moved = points + deviation[:, None] * normals
    jac = complex_step_jacobian(torus_residuals_independent(moved), params)
    assert np.abs(jac.T @ deviation).max() < 1e-13 * form * len(points) * np.abs(jac).max()
    np.testing.assert_allclose(torus_residuals_independent(moved)(params), deviation, atol=1e-12)
    return moved, deviation


def assert_same_torus(fit: TorusFit, centre, axis, major, minor):
    expected_axis = axis if axis[np.argmax(np.abs(axis))] > 0 else -axis
    np.testing.assert_allclose(fit.center, centre, rtol=0, atol=ATOL)
    np.testing.assert_allclose(fit.axis, expected_axis, rtol=0, atol=ATOL)
    assert abs(fit.major_radius - major) < ATOL
    assert abs(fit.minor_radius - minor) < ATOL


CASES = [
    # offset, major, minor, sweep (deg), tube span (deg), n
    (0.0, 20.0, 5.0, 360.0, 360.0, 80),
    (500.0, 50.0, 3.0, 360.0, 180.0, 80),  # outer half of the tube only
    (1000.0, 30.0, 10.0, 180.0, 360.0, 80),  # half the sweep
    (1000.0, 100.0, 8.0, 120.0, 120.0, 100),  # a patch
    (1000.0, 8.0, 6.0, 360.0, 300.0, 60),  # fat torus
    (0.0, 10.0, 6.5, 90.0, 360.0, 100),  # fat quarter elbow: no principal axis near the torus axis
    (500.0, 70.0, 48.0, 90.0, 360.0, 120),
]


@pytest.mark.parametrize(("offset", "major", "minor", "around_deg", "tube_deg", "n"), CASES)
def test_exact_points_recover_torus(offset, major, minor, around_deg, tube_deg, n):
    rng = np.random.default_rng(int(offset + major + around_deg + tube_deg))
    points, centre, axis, _ = sample_torus(
        rng, offset=offset, major=major, minor=minor, around_deg=around_deg, tube_deg=tube_deg, n=n
    )
    fit = fit_torus(points)
    assert_same_torus(fit, centre, axis, major, minor)
    assert np.abs(fit.residuals).max() < ATOL
    assert fit.converged and fit.dof == n - 7


@pytest.mark.parametrize(("offset", "major", "minor", "around_deg", "tube_deg", "n"), CASES)
def test_null_space_data_recover_torus(offset, major, minor, around_deg, tube_deg, n):
    rng = np.random.default_rng(2 + int(offset + major + around_deg + tube_deg))
    points, centre, axis, normals = sample_torus(
        rng, offset=offset, major=major, minor=minor, around_deg=around_deg, tube_deg=tube_deg, n=n
    )
    moved, deviation = null_space_torus(points, np.r_[centre, axis, major, minor], normals, rng, 0.1)
    fit = fit_torus(moved)
    assert_same_torus(fit, centre, axis, major, minor)
    np.testing.assert_allclose(fit.residuals, deviation, rtol=0, atol=ATOL)
    assert fit.form == pytest.approx(np.ptp(deviation), abs=ATOL)


def test_hand_built_torus_residual_sign():
    # R = 10, r = 2 about z; the point (13, 0, 0) is 1 outside the tube, (10, 0, 1) is 1 inside
    sweep = np.radians(np.arange(0, 360, 45))
    tube = np.radians(np.arange(0, 360, 72))
    ring = np.array(
        [
            [(10 + 2 * np.cos(v)) * np.cos(u), (10 + 2 * np.cos(v)) * np.sin(u), 2 * np.sin(v)]
            for u in sweep
            for v in tube
        ]
    )
    probes = np.array([[13.0, 0, 0], [10.0, 0, 1.0]])
    points = np.vstack([ring, probes]) + np.array([5.0, -5.0, 100.0])
    fit = fit_torus(points, weights=np.r_[np.ones(len(ring)), 0.0, 0.0])
    np.testing.assert_allclose(fit.center, [5, -5, 100], atol=ATOL)
    np.testing.assert_allclose(fit.axis, [0, 0, 1], atol=ATOL)
    assert fit.major_radius == pytest.approx(10.0, abs=ATOL)
    assert fit.minor_radius == pytest.approx(2.0, abs=ATOL)
    np.testing.assert_allclose(fit.residuals[-2:], [1.0, -1.0], atol=ATOL)
    assert fit.parameter_names[-2:] == ("major_radius", "minor_radius")
    with pytest.raises(dataclasses.FrozenInstanceError):
        fit.center = np.zeros(3)  # type: ignore[misc]


def test_covariance_minor_radius_matches_independent_jacobian():
    rng = np.random.default_rng(31)
    points, centre, axis, normals = sample_torus(
        rng, offset=100.0, major=25.0, minor=4.0, around_deg=360, tube_deg=200, n=90
    )
    params = np.r_[centre, axis, 25.0, 4.0]
    moved, deviation = null_space_torus(points, params, normals, rng, 0.05)
    fit = fit_torus(moved)
    jac = complex_step_jacobian(torus_residuals_independent(moved), params)
    inverse = np.linalg.pinv(jac.T @ jac)
    variance = deviation @ deviation / (len(moved) - 7)
    u = dict(zip(fit.parameter_names, fit.std_errors, strict=True))
    assert u["minor_radius"] == pytest.approx(np.sqrt(variance * inverse[7, 7]), rel=1e-6)
    assert u["major_radius"] == pytest.approx(np.sqrt(variance * inverse[6, 6]), rel=1e-6)
    sign = np.sign(fit.axis @ axis)

    def machine_parameters(p):
        return np.r_[p[0:3], sign * p[3:6] / np.sqrt(p[3:6] @ p[3:6]), p[6], p[7]]

    gradient = complex_step_jacobian(machine_parameters, params)
    expected_cov = variance * gradient @ inverse @ gradient.T
    np.testing.assert_allclose(fit.covariance, expected_cov, rtol=0, atol=1e-6 * np.abs(expected_cov).max())
    np.testing.assert_allclose(fit.parameters, machine_parameters(params), rtol=0, atol=ATOL)


def test_axis_hint_for_a_patch():
    rng = np.random.default_rng(12)
    points, centre, axis, _ = sample_torus(rng, offset=900.0, major=60.0, minor=12.0, around_deg=90, tube_deg=90, n=60)
    fit = fit_torus(points, axis_hint=-axis)
    assert_same_torus(fit, centre, axis, 60.0, 12.0)


@pytest.mark.parametrize(
    ("points", "error"),
    [
        (np.zeros((8, 2)), InvalidInputError),
        (np.r_[np.ones((7, 3)), [[0, 0, np.inf]]], InvalidInputError),
        (np.random.default_rng(1).normal(size=(6, 3)), TooFewPointsError),
        (np.outer(np.arange(10.0), [1, 0, 1]), DegenerateGeometryError),
        (np.c_[np.random.default_rng(2).normal(size=(10, 2)), np.ones(10)], DegenerateGeometryError),
    ],
)
def test_bad_input_raises_typed_error(points, error):
    with pytest.raises(error):
        fit_torus(points)


def test_no_convergence_raises(monkeypatch):
    import pcmm_geo.fit._kernels._core as core

    rng = np.random.default_rng(4)
    points, *_ = sample_torus(rng, offset=0.0, major=20.0, minor=5.0, around_deg=360, tube_deg=360, n=40)
    monkeypatch.setattr(core, "TOL", core.Tolerances(max_iterations=1))
    with pytest.raises(ConvergenceError):
        fit_torus(points + rng.normal(scale=0.01, size=points.shape))


def test_sparse_torus_with_a_nominal_axis_two_degrees_off():
    # eight exact points round a whole torus; the nominal axis is 2 degrees from the true one
    rng = np.random.default_rng(31)
    points, centre, axis, _ = sample_torus(rng, offset=500.0, major=30.0, minor=6.0, around_deg=360, tube_deg=360, n=8)
    sideways = np.cross(axis, [0.3, -0.5, 0.8])
    sideways /= np.linalg.norm(sideways)
    nominal = np.cos(np.radians(2.0)) * axis + np.sin(np.radians(2.0)) * sideways
    fit = fit_torus(points, axis_hint=nominal)
    assert_same_torus(fit, centre, axis, 30.0, 6.0)


def test_projected_torus_cost_vanishes_at_the_true_axis_position():
    from pcmm_geo.fit._kernels._axial import rotation_to_z
    from pcmm_geo.fit._kernels._torus_search import best_axis_position, varpro_costs

    rng = np.random.default_rng(5)
    points, centre, axis, _ = sample_torus(rng, offset=0.0, major=25.0, minor=5.0, around_deg=360, tube_deg=360, n=9)
    centroid = points.mean(axis=0)
    frame = rotation_to_z(axis)
    local = (points - centroid) @ frame.T
    true_position = (frame @ (centre - centroid))[:2]
    costs, params = varpro_costs(local, true_position[None, :])
    assert costs[0] < 1e-18
    np.testing.assert_allclose(params[0, 5:], [25.0, 5.0], atol=1e-9)
    # a starting-value search: its last grid is some 10 um fine
    cost, found = best_axis_position(local)
    assert cost < 1e-4
    np.testing.assert_allclose(found[:2], true_position, atol=0.02)
