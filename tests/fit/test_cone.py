"""Tests of the Gaussian cone fit against independent truth.

Truth: points sampled exactly on known cones; null-space data (points moved along the
cone normals by amounts orthogonal to the range of the residual Jacobian, which is
computed here by complex-step differentiation of an independent residual expression and
re-evaluated at the moved points until J^T e vanishes to rounding); the NIST pairs.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError, TooFewPointsError
from pcmm_geo.fit import ConeFit, fit_cone

ATOL = 1e-9


def random_frame(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return (q * np.sign(np.diag(r))).T


def sample_cone(rng, *, offset, half_angle_deg, heights, sector_deg, n):
    """Exact points at axial distances ``heights`` (from the apex) on a cone in a random pose.

    Returns points, apex, axis, outward unit normals.
    """
    across_1, across_2, axis = random_frame(rng)
    apex = offset * np.array([0.36, 0.48, -0.8])
    alpha = np.radians(half_angle_deg)
    h = heights[0] + (heights[1] - heights[0]) * rng.random(n)
    theta = np.radians(sector_deg) * rng.random(n) + 2 * np.pi * rng.random()
    radial = np.outer(np.cos(theta), across_1) + np.outer(np.sin(theta), across_2)
    points = apex + np.outer(h, axis) + (h * np.tan(alpha))[:, None] * radial
    normals = np.cos(alpha) * radial - np.sin(alpha) * axis
    return points, apex, axis, normals


def complex_step_jacobian(residual_fn, params):
    step = 1e-30
    columns = []
    for k in range(params.size):
        shifted = params.astype(complex)
        shifted[k] += 1j * step
        columns.append(residual_fn(shifted).imag / step)
    return np.column_stack(columns)


def cone_residuals_independent(points):
    """(rho - r - h tan(alpha)) cos(alpha) as a function of (c, w, r, alpha); w need not be unit."""

    def residuals(params):
        centre, direction, radius, alpha = params[0:3], params[3:6], params[6], params[7]
        offset = points - centre
        height = offset @ direction / np.sqrt(direction @ direction)
        rho = np.sqrt((offset * offset).sum(axis=1) - height**2)
        return (rho - radius - height * np.tan(alpha)) * np.cos(alpha)

    return residuals


def truth_parameters(points, apex, axis, half_angle):
    centroid = points.mean(axis=0)
    point = apex + ((centroid - apex) @ axis) * axis
    radius = ((point - apex) @ axis) * np.tan(half_angle)
    return point, radius


def null_space_cone(points, apex, axis, normals, half_angle, rng, form):
    """Iterate: project the deviation onto null(J(moved)^T), move the exact points along their normals."""
    deviation = rng.normal(size=len(points))
    deviation *= form / np.ptp(deviation)
    moved = points
    for _ in range(8):
        point, radius = truth_parameters(moved, apex, axis, half_angle)
        params = np.r_[point, axis, radius, half_angle]
        jac = complex_step_jacobian(cone_residuals_independent(moved), params)
        u, sing, _ = np.linalg.svd(jac, full_matrices=False)
        basis = u[:, sing > 1e-10 * sing[0]]
        deviation = deviation - basis @ (basis.T @ deviation)
        moved = points + deviation[:, None] * normals
    point, radius = truth_parameters(moved, apex, axis, half_angle)
    jac = complex_step_jacobian(cone_residuals_independent(moved), np.r_[point, axis, radius, half_angle])
    assert np.abs(jac.T @ deviation).max() < 1e-13 * form * len(points) * np.abs(jac).max()
    np.testing.assert_allclose(
        cone_residuals_independent(moved)(np.r_[point, axis, radius, half_angle]), deviation, atol=1e-12
    )
    return moved, deviation


def assert_same_cone(fit: ConeFit, points, apex, axis, half_angle):
    point, radius = truth_parameters(points, apex, axis, half_angle)
    assert abs(fit.half_angle - half_angle) < ATOL
    np.testing.assert_allclose(fit.axis, axis, rtol=0, atol=ATOL)
    np.testing.assert_allclose(fit.point, point, rtol=0, atol=ATOL)
    assert abs(fit.radius_at_point - radius) < ATOL
    if half_angle > np.radians(5):  # the apex is well determined only for a clearly conical cone
        np.testing.assert_allclose(fit.apex, apex, rtol=0, atol=1e-8)


CASES = [
    # offset, half angle (deg), heights from apex (mm), sector (deg), n
    (0.0, 30.0, (5.0, 25.0), 360.0, 50),
    (500.0, 10.0, (50.0, 120.0), 360.0, 60),
    (1000.0, 0.625, (100.0, 400.0), 360.0, 60),  # nearly cylindrical (like NIST con2)
    (1000.0, 58.7, (1.0, 3.0), 360.0, 40),  # wide (like NIST con24)
    (1000.0, 20.0, (30.0, 45.0), 90.0, 60),  # quarter sector, short
    (500.0, 45.0, (10.0, 11.0), 360.0, 30),  # very short section
    (0.0, 68.0, (180.0, 700.0), 60.0, 77),  # wide, long, 60 degree sector
    (500.0, 52.0, (250.0, 390.0), 60.0, 50),
]


@pytest.mark.parametrize(("offset", "half_angle_deg", "heights", "sector_deg", "n"), CASES)
def test_exact_points_recover_cone(offset, half_angle_deg, heights, sector_deg, n):
    rng = np.random.default_rng(int(offset + 10 * half_angle_deg + sector_deg))
    points, apex, axis, _ = sample_cone(
        rng, offset=offset, half_angle_deg=half_angle_deg, heights=heights, sector_deg=sector_deg, n=n
    )
    fit = fit_cone(points)
    assert_same_cone(fit, points, apex, axis, np.radians(half_angle_deg))
    assert np.abs(fit.residuals).max() < ATOL
    assert fit.converged and fit.dof == n - 6


@pytest.mark.parametrize(("offset", "half_angle_deg", "heights", "sector_deg", "n"), CASES)
def test_null_space_data_recover_cone(offset, half_angle_deg, heights, sector_deg, n):
    rng = np.random.default_rng(1 + int(offset + 10 * half_angle_deg + sector_deg))
    points, apex, axis, normals = sample_cone(
        rng, offset=offset, half_angle_deg=half_angle_deg, heights=heights, sector_deg=sector_deg, n=n
    )
    alpha = np.radians(half_angle_deg)
    form = 0.1 if heights[0] * np.tan(alpha) > 1.0 else 0.01  # keep the deviation small against the radius
    moved, deviation = null_space_cone(points, apex, axis, normals, alpha, rng, form)
    fit = fit_cone(moved)
    assert_same_cone(fit, moved, apex, axis, alpha)
    np.testing.assert_allclose(fit.residuals, deviation, rtol=0, atol=ATOL)
    assert fit.form == pytest.approx(np.ptp(deviation), abs=ATOL)


def test_hand_built_cone_and_nist_numbers():
    # apex at the origin, axis +z, 45 degrees: radius = height; rings at z = 2 and z = 4
    angle = np.radians(np.arange(0, 360, 60))
    rings = [np.c_[z * np.cos(angle), z * np.sin(angle), np.full(6, z)] for z in (2.0, 4.0)]
    fit = fit_cone(np.vstack(rings))
    np.testing.assert_allclose(fit.apex, [0, 0, 0], atol=ATOL)
    np.testing.assert_allclose(fit.point, [0, 0, 3], atol=ATOL)
    assert fit.radius_at_point == pytest.approx(3.0, abs=ATOL)
    assert fit.apex_angle_deg == pytest.approx(90.0, abs=1e-9)
    assert fit.surface_distance == pytest.approx(3.0 / np.sqrt(2), abs=ATOL)
    names = fit.parameter_names
    assert names[-2:] == ("radius_at_point", "half_angle")
    assert fit.parameters[7] == fit.half_angle
    # the same cone upside down: axis reported from apex to opening (-z)
    flipped = fit_cone(np.vstack(rings) * [1, 1, -1])
    np.testing.assert_allclose(flipped.axis, [0, 0, -1], atol=ATOL)
    # a point 1 mm outside along the normal has residual +1
    outside = np.array([[3.0 + np.sqrt(0.5), 0.0, 3.0 - np.sqrt(0.5)]])
    fit_plus = fit_cone(np.vstack([*rings, outside]), weights=np.r_[np.ones(12), 0.0])
    assert fit_plus.residuals[-1] == pytest.approx(1.0, abs=ATOL)


def test_covariance_half_angle_matches_independent_jacobian():
    rng = np.random.default_rng(21)
    alpha = np.radians(15.0)
    points, apex, axis, normals = sample_cone(
        rng, offset=200.0, half_angle_deg=15.0, heights=(20, 60), sector_deg=270, n=60
    )
    moved, deviation = null_space_cone(points, apex, axis, normals, alpha, rng, 0.05)
    fit = fit_cone(moved)
    point, radius = truth_parameters(moved, apex, axis, alpha)
    jac = complex_step_jacobian(cone_residuals_independent(moved), np.r_[point, axis, radius, alpha])
    variance = deviation @ deviation / (len(moved) - 6)
    expected = np.sqrt(variance * np.linalg.pinv(jac.T @ jac)[7, 7])
    assert fit.std_errors[fit.parameter_names.index("half_angle")] == pytest.approx(expected, rel=1e-6)
    # all 8 reported parameters are functions of the geometry: propagate the independent covariance
    centroid = moved.mean(axis=0)

    def machine_parameters(params):
        centre, direction, rad, half = params[0:3], params[3:6], params[6], params[7]
        unit_axis = direction / np.sqrt(direction @ direction)
        along = (centroid - centre) @ unit_axis
        return np.r_[centre + along * unit_axis, unit_axis, rad + along * np.tan(half), half]

    truth = np.r_[point, axis, radius, alpha]
    gradient = complex_step_jacobian(machine_parameters, truth)
    expected_cov = variance * gradient @ np.linalg.pinv(jac.T @ jac) @ gradient.T
    np.testing.assert_allclose(fit.covariance, expected_cov, rtol=0, atol=1e-6 * np.abs(expected_cov).max())
    np.testing.assert_allclose(fit.parameters, machine_parameters(truth), rtol=0, atol=ATOL)


def test_axis_hint_and_weights():
    rng = np.random.default_rng(8)
    points, apex, axis, _ = sample_cone(rng, offset=700.0, half_angle_deg=25.0, heights=(10, 30), sector_deg=120, n=40)
    fit = fit_cone(points, axis_hint=axis + 0.1)
    assert_same_cone(fit, points, apex, axis, np.radians(25.0))
    noisy = points + rng.normal(scale=0.01, size=points.shape)
    weights = np.r_[np.zeros(5), np.ones(35)]
    weighted = fit_cone(noisy, weights=weights)
    removed = fit_cone(noisy[5:])
    assert weighted.half_angle == pytest.approx(removed.half_angle, abs=ATOL)
    np.testing.assert_allclose(weighted.axis, removed.axis, atol=ATOL)


def _load_nist(path: Path) -> np.ndarray:
    values = path.read_text().split()
    count = int(values[0])
    return np.array(values[1 : 1 + 3 * count], dtype=float).reshape(count, 3)


NIST_DIR = Path(__file__).parent.parent / "data" / "nist"
NIST_CONES = sorted(NIST_DIR.glob("Cone/*.ds")) + sorted(NIST_DIR.glob("extra-from-points-txt/Cone/*.txt"))


def test_nist_files_present():
    assert len(NIST_CONES) == 5


@pytest.mark.parametrize("data_file", NIST_CONES, ids=lambda p: p.stem)
def test_nist_cones(data_file: Path):
    reference = np.loadtxt(data_file.with_suffix(".fit"))
    fit = fit_cone(_load_nist(data_file))
    np.testing.assert_allclose(fit.point, reference[0:3], rtol=0, atol=ATOL)
    np.testing.assert_allclose(fit.axis, reference[3:6], rtol=0, atol=ATOL)
    assert fit.surface_distance == pytest.approx(reference[6], abs=ATOL)
    assert np.radians(fit.apex_angle_deg) == pytest.approx(np.radians(reference[7]), abs=ATOL)


@pytest.mark.parametrize(
    ("points", "error"),
    [
        (np.zeros((7, 4)), InvalidInputError),
        (np.r_[np.ones((6, 3)), [[0, np.nan, 0]]], InvalidInputError),
        (np.random.default_rng(1).normal(size=(5, 3)), TooFewPointsError),
        (np.outer(np.arange(9.0), [0, 1, 1]), DegenerateGeometryError),
        (
            np.c_[np.random.default_rng(2).normal(size=(9, 2)), np.zeros(9)] @ random_frame(np.random.default_rng(3)),
            DegenerateGeometryError,
        ),
    ],
)
def test_bad_input_raises_typed_error(points, error):
    with pytest.raises(error):
        fit_cone(points)
