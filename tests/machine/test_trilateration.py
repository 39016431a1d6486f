"""Three-sphere intersection against constructed points and the Appendix E inputs."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError, NoRealSolutionError
from pcmm_geo.machine.kinematics.dpkm import APPENDIX_E
from pcmm_geo.machine.kinematics.trilateration import trilaterate


def test_random_configurations_recover_both_roots() -> None:
    rng = np.random.default_rng(7)
    centres = rng.uniform(-300, 300, (500, 3, 3)) + np.array([0, 0, 400.0])
    tips = rng.uniform(-60, 60, (500, 3))
    radii = np.linalg.norm(centres - tips[:, None, :], axis=-1)
    result = trilaterate(centres, radii)
    # the true tip is one of the roots; the other is its mirror image in the plane of the centres
    normal = np.cross(centres[:, 1] - centres[:, 0], centres[:, 2] - centres[:, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    mirror = tips - 2 * np.einsum("ki,ki->k", tips - centres[:, 0], normal)[:, None] * normal
    lower_true = np.where((tips[:, 2] <= mirror[:, 2])[:, None], tips, mirror)
    upper_true = np.where((tips[:, 2] <= mirror[:, 2])[:, None], mirror, tips)
    np.testing.assert_allclose(result.lower, lower_true, atol=1e-8)
    np.testing.assert_allclose(result.upper, upper_true, atol=1e-8)
    np.testing.assert_array_equal(result.point, result.lower)
    np.testing.assert_allclose(trilaterate(centres, radii, root="upper").point, upper_true, atol=1e-8)


def test_probe_below_pivots_is_the_lower_root() -> None:
    centres = np.array([[-265.0, 0.0, 400.0], [132.0, 230.0, 395.0], [133.0, -229.0, 405.0]])
    tip = np.array([12.0, -7.0, 80.0])
    result = trilaterate(centres, np.linalg.norm(centres - tip, axis=1))
    np.testing.assert_allclose(result.point, tip, atol=1e-10)
    assert result.upper[2] > 600.0


def test_tangent_spheres_have_one_root() -> None:
    centres = np.array([[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [0.0, 4.0, 0.0]])
    radius = np.sqrt(8.0)  # all three pass through (2, 2, 0) only
    result = trilaterate(centres, [radius, radius, radius])
    np.testing.assert_allclose(result.lower, [2.0, 2.0, 0.0], atol=1e-7)
    np.testing.assert_allclose(result.upper, [2.0, 2.0, 0.0], atol=1e-7)
    assert abs(result.height_squared) < 1e-12


def test_appendix_e_pivots_give_the_corrected_probe_point() -> None:
    result = trilaterate(APPENDIX_E["pivots"], APPENDIX_E["lengths"])
    np.testing.assert_allclose(result.point, [15.035, -206.091, 79.681], atol=5e-4)


def test_spheres_that_do_not_meet_raise_with_discriminant() -> None:
    centres = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0]])
    with pytest.raises(NoRealSolutionError) as info:
        trilaterate(centres, [3.0, 3.0, 3.0])
    assert info.value.discriminant < 0
    # (5, 5) is the circumcentre at distance sqrt(50) > 3 from each centre: height^2 = 9 - 50
    assert info.value.discriminant == pytest.approx(9.0 - 50.0)


def test_degenerate_and_bad_input() -> None:
    with pytest.raises(DegenerateGeometryError, match="collinear"):
        trilaterate([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [1.0, 1.0, 1.0])
    with pytest.raises(DegenerateGeometryError, match="coincide"):
        trilaterate([[0, 0, 0], [0, 0, 0], [2, 0, 0]], [1.0, 1.0, 1.0])
    with pytest.raises(InvalidInputError, match="shape"):
        trilaterate(np.zeros((3, 2)), [1.0, 1.0, 1.0])
    with pytest.raises(InvalidInputError, match="root"):
        trilaterate(np.eye(3), [1.0, 1.0, 1.0], root="middle")  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="non-negative"):
        trilaterate(np.eye(3), [1.0, -1.0, 1.0])
