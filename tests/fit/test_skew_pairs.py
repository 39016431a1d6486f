"""Pairwise closest points of several lines and the thesis' pairwise-midpoint probe point (fit.skew)."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError, TooFewPointsError
from pcmm_geo.fit.skew import mean_pairwise_midpoint, pairwise_closest_points


def _constructed_lines(rng: np.random.Generator, count: int, offset: float):
    """K lines through known points; for each pair the common perpendicular is built, not computed."""
    feet = rng.normal(size=(count, 3)) * 50.0 + offset
    directions = rng.normal(size=(count, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return feet, directions


def test_pair_with_a_constructed_common_perpendicular_far_from_the_origin() -> None:
    rng = np.random.default_rng(11)
    for offset in (0.0, 1e4):
        normal = rng.normal(size=3)
        normal /= np.linalg.norm(normal)
        in_plane = np.linalg.svd(normal[None])[2][1:]  # two unit vectors perpendicular to normal
        d_a, d_b = rng.normal(size=2) @ in_plane, rng.normal(size=2) @ in_plane
        foot_a = rng.normal(size=3) * 100 + offset
        height = 7.25
        foot_b = foot_a + height * normal
        points = np.array([foot_a + 3.0 * d_a, foot_b - 11.0 * d_b, foot_a - 40.0 * d_a])
        directions = np.array([d_a, 5.0 * d_b, -d_a + 0.3 * normal])
        pair = pairwise_closest_points(points, directions, pairs=[(0, 1)])
        assert pair.point_a.shape == (1, 3)
        np.testing.assert_allclose(pair.point_a[0], foot_a, atol=1e-9)
        np.testing.assert_allclose(pair.point_b[0], foot_b, atol=1e-9)
        assert pair.distance[0] == pytest.approx(height, abs=1e-9)
        np.testing.assert_allclose(pair.midpoint[0], foot_a + 0.5 * height * normal, atol=1e-9)


def test_default_pairs_are_every_pair_in_order_and_match_the_two_line_kernel() -> None:
    from pcmm_geo.fit.skew import closest_points

    points, directions = _constructed_lines(np.random.default_rng(3), 4, 0.0)
    pair = pairwise_closest_points(points, directions)
    order = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
    assert pair.distance.shape == (6,)
    for k, (i, j) in enumerate(order):
        single = closest_points(points[i], directions[i], points[j], directions[j])
        np.testing.assert_allclose(pair.point_a[k], single.point_a, atol=1e-12)
        np.testing.assert_allclose(pair.point_b[k], single.point_b, atol=1e-12)
        # independent check: the connecting segment is perpendicular to both lines
        gap = pair.point_b[k] - pair.point_a[k]
        assert abs(gap @ directions[i]) < 1e-9 and abs(gap @ directions[j]) < 1e-9


def test_mean_pairwise_midpoint_of_lines_through_one_point_is_that_point() -> None:
    rng = np.random.default_rng(5)
    centre = np.array([120.0, -35.0, 480.0])
    directions = rng.normal(size=(3, 3))
    points = centre + rng.normal(size=(3, 1)) * 30.0 * directions  # each point somewhere on its line
    found = mean_pairwise_midpoint(points, directions, pairs=[(0, 1), (1, 2), (2, 0)])
    np.testing.assert_allclose(found, centre, atol=1e-9)


def test_mean_pairwise_midpoint_by_hand() -> None:
    # x-axis at z=1, y-axis at z=-1, z-axis through (5, 0, 0): midpoints (0,0,0), (2.5,0,-1), (5,0,1)
    points = [[0, 0, 1], [0, 0, -1], [5, 0, 0]]
    directions = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
    found = mean_pairwise_midpoint(points, directions, pairs=[(0, 1), (1, 2), (2, 0)])
    np.testing.assert_allclose(found, [2.5, 0.0, 0.0], atol=1e-12)


def test_errors() -> None:
    with pytest.raises(DegenerateGeometryError, match=r"\[\[0, 1\]\]"):
        mean_pairwise_midpoint([[0, 0, 0], [0, 1, 0], [5, 5, 5]], [[1, 0, 0], [2, 0, 0], [0, 0, 1]])
    with pytest.raises(TooFewPointsError):
        pairwise_closest_points([[0, 0, 0]], [[1, 0, 0]])
    with pytest.raises(InvalidInputError, match="pairs"):
        pairwise_closest_points([[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [0, 0, 1]], pairs=[(0, 2)])
    with pytest.raises(InvalidInputError, match="pairs"):
        pairwise_closest_points([[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [0, 0, 1]], pairs=[(1, 1)])
    with pytest.raises(InvalidInputError, match="pairs"):
        pairwise_closest_points([[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [0, 0, 1]], pairs=[0, 1])
    with pytest.raises(InvalidInputError):
        pairwise_closest_points([[0, 0, 0], [0, 1, 0]], [[1, 0, 0]])
