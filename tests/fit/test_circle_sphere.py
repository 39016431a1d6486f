"""Circles and spheres against closed-form truth and hand-built null-space perturbations."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from pcmm_geo.errors import (
    ConvergenceError,
    DegenerateGeometryError,
    InvalidInputError,
    PcmmGeoError,
    TooFewPointsError,
)
from pcmm_geo.fit import fit_circle, fit_sphere


def _null_space_radial(directions: np.ndarray, form: float, rng: np.random.Generator) -> np.ndarray:
    """Radial deviations orthogonal to the n-sphere Jacobian columns (unit direction, 1)."""
    jac = np.column_stack([directions, np.ones(len(directions))])
    q, _ = np.linalg.qr(jac, mode="complete")
    deviation = q[:, jac.shape[1] :] @ rng.normal(size=len(directions) - jac.shape[1])
    return deviation * (form / np.ptp(deviation)) if form else np.zeros(len(directions))


@pytest.mark.parametrize("offset", [0.0, 500.0, 1000.0])
@pytest.mark.parametrize("cap_deg", [30.0, 90.0, 180.0])
@pytest.mark.parametrize("form", [0.0, 0.1])
def test_sphere_null_space(offset: float, cap_deg: float, form: float) -> None:
    rng = np.random.default_rng(int(offset + cap_deg))
    n = 9
    polar = np.radians(cap_deg) * np.sqrt(rng.uniform(0.05, 1.0, n))
    azimuth = rng.uniform(0, 2 * np.pi, n)
    directions = np.column_stack([np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar)])
    directions = Rotation.random(random_state=rng).apply(directions)
    centre, radius = np.full(3, offset) + rng.normal(size=3), 12.5
    deviation = _null_space_radial(directions, form, rng)
    pts = centre + (radius + deviation)[:, None] * directions
    result = fit_sphere(pts)
    np.testing.assert_allclose(result.center, centre, atol=1e-9)
    assert result.radius == pytest.approx(radius, abs=1e-9)
    np.testing.assert_allclose(result.residuals, deviation, atol=1e-9)
    assert result.form == pytest.approx(form, abs=1e-9)
    assert result.converged and result.dof == n - 4


def test_sphere_fixed_radius_and_covariance() -> None:
    octahedron = np.vstack([np.eye(3), -np.eye(3)])
    pts = 5.0 * octahedron + [1.0, 2.0, 3.0]
    pts[0] += [0.01, 0, 0]  # one point outside: free fit moves centre and radius
    free = fit_sphere(pts)
    # closed form for the octahedron: x-centre shifts by 0.005, radius grows by 0.01 / 6 ...
    # verify optimality instead: residuals orthogonal to (unit directions, 1)
    directions = (pts - free.center) / np.linalg.norm(pts - free.center, axis=1)[:, None]
    assert np.abs(np.column_stack([directions, np.ones(6)]).T @ free.residuals).max() < 1e-14
    fixed = fit_sphere(pts, radius=5.0)
    assert fixed.radius == 5.0 and fixed.method == "gaussian-fixed-radius"
    assert fixed.std_errors[fixed.parameter_names.index("radius")] == 0.0
    assert fixed.dof == 3
    # with a fixed radius the residuals are orthogonal to the unit directions only
    directions = (pts - fixed.center) / np.linalg.norm(pts - fixed.center, axis=1)[:, None]
    assert np.abs(directions.T @ fixed.residuals).max() < 1e-14


def test_sphere_covariance_matches_closed_form_for_symmetric_data() -> None:
    octahedron = np.vstack([np.eye(3), -np.eye(3)])
    deviation = np.array([1.0, 1.0, -1.0, 1.0, 1.0, -1.0]) * 1e-3  # orthogonal to directions and 1
    deviation -= deviation.mean()
    pts = (10.0 + deviation)[:, None] * octahedron
    result = fit_sphere(pts)
    variance = np.sum(deviation**2) / (6 - 4)
    # J^T J = diag(2, 2, 2, 6) for the octahedron
    assert result.std_errors[result.parameter_names.index("center_x")] == pytest.approx(np.sqrt(variance / 2), rel=1e-9)
    assert result.std_errors[result.parameter_names.index("radius")] == pytest.approx(np.sqrt(variance / 6), rel=1e-9)


@pytest.mark.parametrize("arc_deg", [30.0, 120.0, 360.0])
@pytest.mark.parametrize("offset", [0.0, 1000.0])
def test_circle_2d_null_space(arc_deg: float, offset: float) -> None:
    rng = np.random.default_rng(7)
    angles = np.radians(arc_deg) * np.linspace(0, 1, 8, endpoint=arc_deg < 360)
    directions = np.column_stack([np.cos(angles), np.sin(angles)])
    deviation = _null_space_radial(directions, 0.05, rng)
    centre = np.array([offset, -offset]) + 0.3
    pts = centre + (4.0 + deviation)[:, None] * directions
    result = fit_circle(pts)
    np.testing.assert_allclose(result.center, centre, atol=1e-9)
    assert result.radius == pytest.approx(4.0, abs=1e-9)
    np.testing.assert_allclose(result.residuals, deviation, atol=1e-9)
    assert result.normal is None


def _circle_3d_null_space(
    arc_deg: float, offset: float, form: float, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray, float, np.ndarray, np.ndarray]:
    """Points whose exact 3-D (curve-distance) Gaussian circle is known."""
    n = 10
    angles = np.radians(arc_deg) * np.linspace(0, 1, n, endpoint=arc_deg < 360)
    radius = 7.0
    # local frame: circle in z = 0 centred at the origin; Jacobian of (radial, axial) components
    cos, sin = np.cos(angles), np.sin(angles)
    jac = np.zeros((2 * n, 6))
    jac[0::2, 0], jac[0::2, 1], jac[0::2, 5] = -cos, -sin, -1.0  # radial: centre x, y; radius
    jac[1::2, 2] = -1.0  # axial: centre z
    jac[1::2, 3], jac[1::2, 4] = radius * cos, radius * sin  # axial: tilts of the normal
    q, _ = np.linalg.qr(jac, mode="complete")
    stacked = q[:, 6:] @ rng.normal(size=2 * n - 6)
    stacked *= form / np.abs(stacked).max() if form else 0.0
    radial, axial = stacked[0::2], stacked[1::2]
    local = np.column_stack([(radius + radial) * cos, (radius + radial) * sin, axial])
    rotation = Rotation.random(random_state=rng)
    centre = np.full(3, offset) + rng.normal(size=3)
    return rotation.apply(local) + centre, centre, radius, rotation.apply([0.0, 0.0, 1.0]), np.hypot(radial, axial)


@pytest.mark.parametrize("arc_deg", [30.0, 90.0, 360.0])
@pytest.mark.parametrize("offset", [0.0, 500.0, 1000.0])
@pytest.mark.parametrize("form", [0.0, 0.05])
def test_circle_3d_curve_distance_null_space(arc_deg: float, offset: float, form: float) -> None:
    rng = np.random.default_rng(int(arc_deg + offset))
    pts, centre, radius, normal, distance = _circle_3d_null_space(arc_deg, offset, form, rng)
    result = fit_circle(pts)
    np.testing.assert_allclose(result.center, centre, atol=1e-9)
    assert result.radius == pytest.approx(radius, abs=1e-9)
    assert np.linalg.norm(np.cross(result.normal, normal)) < 1e-9
    np.testing.assert_allclose(np.abs(result.residuals), distance, atol=1e-9)
    assert result.dof == 2 * len(pts) - 6 and result.residual_components.shape == (len(pts), 2)


def test_circle_3d_projected_differs_from_curve_distance_when_tilted() -> None:
    rng = np.random.default_rng(2)
    pts, centre, _radius, _, _ = _circle_3d_null_space(90.0, 0.0, 0.2, rng)
    curve = fit_circle(pts)
    projected = fit_circle(pts, method="projected")
    assert np.linalg.norm(curve.center - centre) < 1e-9
    assert projected.method == "projected"
    assert np.linalg.norm(projected.center - centre) > 1e-6  # a different problem, a different answer
    # the projected fit solves a different problem: its normal is the plane's normal
    from pcmm_geo.fit import fit_plane

    assert np.linalg.norm(np.cross(projected.normal, fit_plane(pts).normal)) < 1e-14


def test_circle_errors() -> None:
    with pytest.raises(TooFewPointsError, match="at least 3"):
        fit_circle([[0.0, 0.0], [1.0, 1.0]])
    with pytest.raises(DegenerateGeometryError, match="collinear"):
        fit_circle([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [3.0, 3.0]])
    with pytest.raises(DegenerateGeometryError, match="collinear"):
        fit_circle([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [2.0, 2.0, 2.0]])
    with pytest.raises(InvalidInputError, match="'gaussian' or 'projected'"):
        fit_circle(np.eye(3), method="algebraic")  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="positive finite"):
        fit_circle(np.eye(3), radius=-1.0)


def test_sphere_errors() -> None:
    with pytest.raises(TooFewPointsError) as info:
        fit_sphere(np.zeros((3, 3)))
    assert (info.value.needed, info.value.got, info.value.element) == (4, 3, "sphere")
    with pytest.raises(DegenerateGeometryError, match="coplanar"):
        fit_sphere([[1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0], [0.5, 0.5, 0]])
    with pytest.raises(DegenerateGeometryError, match="identical"):
        fit_sphere(np.ones((5, 3)))
    with pytest.raises(InvalidInputError, match="finite"):
        fit_sphere([[1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, 0, np.inf]])
    with pytest.raises(InvalidInputError, match="weights"):
        fit_sphere(np.eye(4)[:, :3], weights=[1, 1, -1, 1])
    with pytest.raises(PcmmGeoError):
        fit_sphere("not points")  # type: ignore[arg-type]


def test_non_convergence_is_reported(monkeypatch: pytest.MonkeyPatch) -> None:
    from pcmm_geo.fit._kernels import _core

    monkeypatch.setattr(_core, "TOL", _core.Tolerances(max_iterations=1, step=0.0, rounding_floor=0.0))
    rng = np.random.default_rng(0)
    pts = rng.normal(size=(20, 3))
    pts = 10 * pts / np.linalg.norm(pts, axis=1)[:, None] + rng.normal(scale=0.5, size=(20, 3))
    with pytest.raises(ConvergenceError, match="no convergence after 1 iterations"):
        fit_sphere(pts)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), shift=st.floats(-1000, 1000))
def test_sphere_residuals_orthogonal_to_jacobian_and_motion_invariant(seed: int, shift: float) -> None:
    rng = np.random.default_rng(seed)
    directions = rng.normal(size=(12, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    pts = (20 + rng.normal(scale=0.05, size=12))[:, None] * directions
    base = fit_sphere(pts)
    unit = (pts - base.center) / np.linalg.norm(pts - base.center, axis=1)[:, None]
    assert np.abs(np.column_stack([unit, np.ones(12)]).T @ base.residuals).max() < 1e-12
    rotation = Rotation.random(random_state=rng)
    moved = fit_sphere(rotation.apply(pts) + shift)
    np.testing.assert_allclose(moved.center, rotation.apply(base.center) + shift, atol=1e-9)
    assert moved.radius == pytest.approx(base.radius, abs=1e-9)


@pytest.mark.parametrize("cap_deg", [180.0, 40.0])
def test_tall_sphere_uses_normal_equations_without_losing_accuracy(
    cap_deg: float, monkeypatch: pytest.MonkeyPatch
) -> None:
    # 30,000 points take the normal-equation path (pcmm_geo.fit._kernels._tall); the truth is the
    # generator's; the covariance must equal the one from the orthogonal routines
    from pcmm_geo.fit._kernels import _tall
    from pcmm_geo.fit.reference import make_reference_data

    data = make_reference_data(
        "sphere", n_points=30_000, radius=12.5, form=0.02, offset=1000.0, cap=np.radians(cap_deg), rng=7
    )
    assert data.n >= _tall.TALL_ROWS
    tall = fit_sphere(data.points)
    np.testing.assert_allclose(tall.center, data.parameters["center"], rtol=0, atol=1e-9)
    assert abs(tall.radius - 12.5) <= 1e-9
    monkeypatch.setattr(_tall, "TALL_ROWS", 10**9)
    orthogonal = fit_sphere(data.points)
    np.testing.assert_allclose(tall.covariance, orthogonal.covariance, rtol=1e-6, atol=0)
    assert tall.condition_number == pytest.approx(orthogonal.condition_number, rel=1e-6)
