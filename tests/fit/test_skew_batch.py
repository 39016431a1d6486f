"""Skew-line geometry (closed forms) and batch fits (equal to the single fits)."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError, TooFewPointsError
from pcmm_geo.fit import (
    closest_points,
    fit_circle,
    fit_circles,
    fit_line,
    fit_lines,
    fit_plane,
    fit_planes,
    fit_sphere,
    fit_spheres,
    nearest_point_to_lines,
)


def test_perpendicular_skew_lines_at_known_distance() -> None:
    # line a: x axis; line b: parallel to y through (3, 0, 7) -> common perpendicular along z
    pair = closest_points([10.0, 0, 0], [2.0, 0, 0], [3.0, 5.0, 7.0], [0, -1.0, 0])
    np.testing.assert_allclose(pair.point_a, [3, 0, 0], atol=1e-15)
    np.testing.assert_allclose(pair.point_b, [3, 0, 7], atol=1e-15)
    assert float(pair.distance) == pytest.approx(7.0, abs=1e-15)
    assert float(pair.parameter_a) == pytest.approx(-7.0)  # along the unit direction from (10, 0, 0)
    assert float(pair.parameter_b) == pytest.approx(5.0)
    assert not bool(pair.parallel)


def test_skew_lines_general_case_against_closed_form_formula() -> None:
    rng = np.random.default_rng(1)
    pa, da, pb, db = rng.normal(size=(4, 3)) * [[100], [1], [100], [1]]
    pair = closest_points(pa, da, pb, db)
    normal = np.cross(da, db)
    expected = abs((pb - pa) @ normal) / np.linalg.norm(normal)
    assert float(pair.distance) == pytest.approx(expected, rel=1e-12)
    # the connecting segment is perpendicular to both lines
    segment = pair.point_b - pair.point_a
    assert abs(segment @ da) < 1e-10 and abs(segment @ db) < 1e-10


def test_intersecting_and_parallel_lines() -> None:
    pair = closest_points([0, 0, 0], [1, 1, 0], [2, 0, 0], [-1, 1, 0])
    np.testing.assert_allclose(pair.point_a, [1, 1, 0], atol=1e-15)
    assert float(pair.distance) == pytest.approx(0.0, abs=1e-15)
    parallel = closest_points([0, 0, 0], [0, 0, 1], [3, 4, 10], [0, 0, -2])
    assert bool(parallel.parallel)
    assert float(parallel.distance) == pytest.approx(5.0, abs=1e-15)
    np.testing.assert_allclose(parallel.point_b, [3, 4, 0], atol=1e-15)


def test_closest_points_vectorised_over_batches() -> None:
    rng = np.random.default_rng(2)
    pa, da, pb, db = rng.normal(size=(4, 6, 3))
    batch = closest_points(pa, da, pb, db)
    for i in range(6):
        single = closest_points(pa[i], da[i], pb[i], db[i])
        np.testing.assert_allclose(batch.point_a[i], single.point_a, atol=1e-14)
        assert batch.distance[i] == pytest.approx(float(single.distance))
    with pytest.raises(InvalidInputError, match="non-zero"):
        closest_points([0, 0, 0], [0, 0, 0], [1, 1, 1], [1, 0, 0])


def test_nearest_point_to_three_lines_known_answer() -> None:
    # three lines through (1, 2, 3) shifted perpendicular by +-d in symmetric pairs would cancel;
    # here: the three coordinate axes shifted to pass at distance 1 around the point (1, 1, 1)
    points = np.array([[0.0, 1.0, 2.0], [2.0, 0.0, 1.0], [1.0, 2.0, 0.0]])
    directions = np.eye(3)
    result = nearest_point_to_lines(points, directions)
    # sum of squared distances: (y-1)^2+(z-2)^2 + (x-2)^2+(z-1)^2 + (x-1)^2+(y-2)^2 -> minimum at 1.5
    np.testing.assert_allclose(result.point, [1.5, 1.5, 1.5], atol=1e-14)
    np.testing.assert_allclose(result.distances, np.full(3, np.sqrt(0.5)), atol=1e-14)
    # two lines: the midpoint of the common perpendicular
    two = nearest_point_to_lines(points[:2], directions[:2])
    pair = closest_points(points[0], directions[0], points[1], directions[1])
    np.testing.assert_allclose(two.point, pair.midpoint, atol=1e-14)


def test_nearest_point_errors() -> None:
    with pytest.raises(TooFewPointsError):
        nearest_point_to_lines([[0, 0, 0]], [[1, 0, 0]])
    with pytest.raises(DegenerateGeometryError, match="parallel"):
        nearest_point_to_lines([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 0, 1], [0, 0, 2], [0, 0, -1]])
    with pytest.raises(InvalidInputError, match=r"\(K, 3\)"):
        nearest_point_to_lines([[0, 0, 0], [1, 0, 0]], [[0, 0, 1]])


def _random_sets(k: int, n: int, dim: int, seed: int, offset: float = 500.0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    directions = rng.normal(size=(k, n, dim))
    directions /= np.linalg.norm(directions, axis=2, keepdims=True)
    radii = rng.uniform(1, 20, size=(k, 1, 1))
    centres = rng.uniform(-offset, offset, size=(k, 1, dim))
    return centres + radii * directions * (1 + rng.normal(scale=1e-3, size=(k, n, 1)))


def test_batch_spheres_equal_single_fits() -> None:
    stack = _random_sets(50, 5, 3, seed=4)
    batch = fit_spheres(stack)
    assert len(batch) == 50 and batch.converged.all()
    for i in range(50):
        single = fit_sphere(stack[i])
        np.testing.assert_allclose(batch.centers[i], single.center, atol=1e-10)
        assert batch.radii[i] == pytest.approx(single.radius, abs=1e-10)
        np.testing.assert_allclose(batch.residuals[i], single.residuals, atol=1e-10)
        assert batch.form[i] == pytest.approx(single.form, abs=1e-10)


def test_batch_circles_planes_lines_equal_single_fits() -> None:
    circles2 = _random_sets(20, 6, 2, seed=5)
    batch2 = fit_circles(circles2)
    assert batch2.normals is None
    for i in range(20):
        single = fit_circle(circles2[i])
        np.testing.assert_allclose(batch2.centers[i], single.center, atol=1e-10)
        assert batch2.radii[i] == pytest.approx(single.radius, abs=1e-10)
    rng = np.random.default_rng(6)
    flat = rng.normal(size=(20, 8, 3)) * [10, 10, 0.01] + 100
    circles3 = fit_circles(_random_sets(20, 8, 3, seed=7))
    for i, stack in enumerate(_random_sets(20, 8, 3, seed=7)):
        single = fit_circle(stack, method="projected")
        np.testing.assert_allclose(circles3.centers[i], single.center, atol=1e-10)
        np.testing.assert_allclose(circles3.normals[i], single.normal, atol=1e-12)
    planes = fit_planes(flat)
    lines = fit_lines(flat)
    for i in range(20):
        np.testing.assert_allclose(planes.normals[i], fit_plane(flat[i]).normal, atol=1e-12)
        np.testing.assert_allclose(planes.residuals[i], fit_plane(flat[i]).residuals, atol=1e-12)
        np.testing.assert_allclose(lines.directions[i], fit_line(flat[i]).direction, atol=1e-12)
        np.testing.assert_allclose(lines.residuals[i], fit_line(flat[i]).residuals, atol=1e-12)


def test_batch_errors_name_the_set() -> None:
    stack = _random_sets(3, 5, 3, seed=8)
    stack[1, 2, 0] = np.nan
    with pytest.raises(InvalidInputError, match="set 1"):
        fit_spheres(stack)
    coplanar = _random_sets(3, 6, 3, seed=9)
    coplanar[2, :, 2] = 0.0
    with pytest.raises(DegenerateGeometryError, match="set 2 of 3: points are coplanar"):
        fit_spheres(coplanar)
    with pytest.raises(TooFewPointsError):
        fit_spheres(np.zeros((4, 3, 3)))
    with pytest.raises(InvalidInputError, match=r"\(K, N, 3\)"):
        fit_spheres(np.zeros((5, 3)))
