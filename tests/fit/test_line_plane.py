"""Lines and planes against closed-form truth and hand-built null-space perturbations."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError, TooFewPointsError
from pcmm_geo.fit import fit_line, fit_plane


def _perpendicular_basis(direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.eye(3)[int(np.argmin(np.abs(direction)))]
    e1 = np.cross(direction, helper)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(direction, e1)


@pytest.mark.parametrize("offset", [0.0, 500.0, 1000.0])
@pytest.mark.parametrize("form", [0.0, 0.01, 0.1])
def test_plane_null_space_data(offset: float, form: float) -> None:
    rng = np.random.default_rng(11)
    normal = Rotation.random(random_state=rng).apply([0.0, 0.0, 1.0])
    e1, e2 = _perpendicular_basis(normal)
    point = np.full(3, offset) + rng.normal(size=3)
    u, v = rng.uniform(-20, 20, size=(2, 12))
    # residual vector orthogonal to the Jacobian columns (1, u, v): the plane stays optimal
    design = np.column_stack([np.ones(12), u, v])
    q, _ = np.linalg.qr(design, mode="complete")
    deviation = q[:, 3:] @ rng.normal(size=9)
    deviation *= form / np.ptp(deviation) if form else 0.0
    centre = point - (u.mean() * e1 + v.mean() * e2)  # so that the centroid of the feet is `point`
    pts = centre + np.outer(u, e1) + np.outer(v, e2) + np.outer(deviation, normal)
    result = fit_plane(pts)
    assert np.linalg.norm(np.cross(result.normal, normal)) < 1e-12
    assert abs((result.point - point) @ normal) < 1e-10
    np.testing.assert_allclose(np.sign(result.normal @ normal) * result.residuals, deviation, atol=1e-10)
    assert result.form == pytest.approx(form, abs=1e-10)
    assert result.dof == 9
    assert result.normal[np.argmax(np.abs(result.normal))] > 0


def test_plane_exact_and_covariance_against_closed_form() -> None:
    # points z = 0.1 * (+-1) pattern on a grid: s^2 and (J^T J)^-1 known in closed form
    x, y = np.meshgrid([-1.0, 0.0, 1.0], [-1.0, 0.0, 1.0])
    z = 0.1 * np.array([[1, -1, 1], [-1, 1, -1], [1, -1, 1]], dtype=float)
    z -= z.mean()
    pts = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    result = fit_plane(pts)
    np.testing.assert_allclose(result.normal, [0, 0, 1], atol=1e-15)
    variance = np.sum(z**2) / (9 - 3)
    # offset variance = s^2 / N, tilt variance = s^2 / sum(x^2) = s^2 / 6
    u = dict(zip(result.parameter_names, result.std_errors, strict=True))
    assert u["point_z"] == pytest.approx(np.sqrt(variance / 9), rel=1e-12)
    assert u["normal_x"] == pytest.approx(np.sqrt(variance / 6), rel=1e-12)
    assert u["point_x"] == pytest.approx(0.0, abs=1e-15)


def test_plane_weights_equal_duplicated_points() -> None:
    rng = np.random.default_rng(3)
    pts = rng.normal(size=(10, 3)) * [10, 5, 0.1]
    weights = np.ones(10)
    weights[0] = 2.0
    weighted = fit_plane(pts, weights=weights)
    duplicated = fit_plane(np.vstack([pts, pts[:1]]))
    np.testing.assert_allclose(weighted.normal, duplicated.normal, atol=1e-14)
    np.testing.assert_allclose(weighted.point, duplicated.point, atol=1e-14)


def test_plane_errors() -> None:
    with pytest.raises(TooFewPointsError, match="at least 3 points, got 2"):
        fit_plane([[0, 0, 0], [1, 0, 0]])
    with pytest.raises(DegenerateGeometryError, match="collinear"):
        fit_plane([[0, 0, 0], [1, 1, 1], [2, 2, 2], [3, 3, 3]])
    with pytest.raises(DegenerateGeometryError, match="identical"):
        fit_plane([[1, 2, 3]] * 4)
    with pytest.raises(InvalidInputError, match="finite"):
        fit_plane([[0, 0, 0], [1, 0, 0], [0, np.nan, 0]])
    with pytest.raises(InvalidInputError, match=r"expected shape \(N, 3\)"):
        fit_plane(np.zeros((4, 2)))
    with pytest.raises(ValueError):  # builtin base class
        fit_plane(np.zeros((4, 4)))


@pytest.mark.parametrize("offset", [0.0, 1000.0])
def test_line_3d_null_space(offset: float) -> None:
    rng = np.random.default_rng(5)
    direction = Rotation.random(random_state=rng).apply([1.0, 0.0, 0.0])
    e1, e2 = _perpendicular_basis(direction)
    t = np.linspace(-30, 30, 9)
    # components orthogonal to (1, t): the line through the centroid along `direction` stays optimal
    design = np.column_stack([np.ones(9), t])
    q, _ = np.linalg.qr(design, mode="complete")
    a, b = (q[:, 2:] @ rng.normal(size=(7, 2)) * 0.02).T
    point = np.full(3, offset)
    pts = point + np.outer(t, direction) + np.outer(a, e1) + np.outer(b, e2)
    result = fit_line(pts)
    assert np.linalg.norm(np.cross(result.direction, direction)) < 1e-13
    np.testing.assert_allclose(result.point, point, atol=1e-10)
    np.testing.assert_allclose(result.residuals, np.hypot(a, b), atol=1e-12)
    assert result.dof == 2 * 9 - 4


def test_line_2d_signed_residuals_and_sign_convention() -> None:
    pts = np.array([[0.0, 1.0], [1.0, -1.0], [2.0, 1.0], [3.0, -1.0]])
    pts[:, 1] *= 0.5
    result = fit_line(pts)
    # first-order optimality: residuals orthogonal to the Jacobian columns (1, along-line position)
    along = (pts - result.point) @ result.direction
    assert np.linalg.norm(result.residuals @ np.column_stack([np.ones(4), along])) < 1e-12
    # closed form: the direction is the principal axis of the 2x2 scatter matrix
    centred = pts - pts.mean(axis=0)
    scatter = centred.T @ centred
    angle = 0.5 * np.arctan2(2 * scatter[0, 1], scatter[0, 0] - scatter[1, 1])
    cross = result.direction[0] * np.sin(angle) - result.direction[1] * np.cos(angle)
    assert abs(cross) < 1e-14
    assert result.direction[0] > 0  # sign convention: largest component positive
    left_normal = np.array([-result.direction[1], result.direction[0]])
    assert result.distance(result.point + 2.0 * left_normal) == pytest.approx(2.0, abs=1e-12)


def test_line_errors() -> None:
    with pytest.raises(TooFewPointsError):
        fit_line([[0.0, 0.0, 0.0]])
    with pytest.raises(DegenerateGeometryError, match="identical"):
        fit_line([[1.0, 1.0]] * 3)
    with pytest.raises(InvalidInputError, match="got shape"):
        fit_line(np.zeros((3, 4)))


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    shift=st.floats(-1000, 1000),
)
def test_plane_fit_is_invariant_under_rigid_motion(seed: int, shift: float) -> None:
    rng = np.random.default_rng(seed)
    pts = rng.normal(size=(15, 3)) * [20, 10, 0.05]
    rotation = Rotation.random(random_state=rng)
    moved = rotation.apply(pts) + shift
    base, after = fit_plane(pts), fit_plane(moved)
    assert np.linalg.norm(np.cross(rotation.apply(base.normal), after.normal)) < 1e-10
    np.testing.assert_allclose(np.abs(after.residuals), np.abs(base.residuals), atol=1e-10)
