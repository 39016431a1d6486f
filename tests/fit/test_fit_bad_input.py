"""Bad input gets a typed error with the true reason; batch fits check what single fits check;
centroids are exact far from the origin."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest

from pcmm_geo.errors import (
    AmbiguousFitError,
    DegenerateGeometryError,
    InvalidInputError,
    PcmmGeoError,
    TooFewPointsError,
)
from pcmm_geo.fit import (
    fit_circle,
    fit_circles,
    fit_cone,
    fit_cylinder,
    fit_line,
    fit_lines,
    fit_plane,
    fit_planes,
    fit_sphere,
    fit_spheres,
    fit_torus,
)
from pcmm_geo.fit._kernels._inputs import weighted_centroid


def _ring(n: int = 7, radius: float = 10.0, offset: float = 1000.0) -> np.ndarray:
    angle = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.c_[radius * np.cos(angle), radius * np.sin(angle), np.zeros(n)] + offset


def _sphere_points() -> np.ndarray:
    return np.array([[11, 0, 0], [-9, 0, 0], [1, 10, 0], [1, -10, 0], [1, 0, 10], [1, 0, -10]], dtype=float)


def test_fixed_radius_sphere_on_coplanar_points_refuses_the_mirror_ambiguity() -> None:
    with pytest.raises(AmbiguousFitError, match="mirror") as caught:
        fit_sphere(_ring(), radius=12.0)
    first, second = caught.value.candidates
    height = math.sqrt(12.0**2 - 10.0**2)  # both centres sqrt(R^2 - 10^2) off the plane
    assert sorted([first[2], second[2]]) == pytest.approx([1000.0 - height, 1000.0 + height], abs=1e-9)
    assert isinstance(caught.value, DegenerateGeometryError) and isinstance(caught.value, ValueError)
    # a radius below the ring's: the in-plane centre is the unique minimum (residuals 10 - 8)
    unique = fit_sphere(_ring(), radius=8.0)
    assert np.allclose(unique.center, 1000.0, atol=1e-9)
    assert unique.residuals == pytest.approx(np.full(7, 2.0), abs=1e-9)


def test_fixed_radius_circle_needs_three_points_and_refuses_collinear_mirror_pairs() -> None:
    with pytest.raises(TooFewPointsError, match="at least 3"):
        fit_circle([[0.0, 0.0], [1.0, 1.0]], radius=5.0)
    with pytest.raises(AmbiguousFitError, match="mirror"):
        fit_circle([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]], radius=5.0)


@pytest.mark.parametrize("radius", ["10", [10], np.array([10.0]), True, 1j, float("nan"), -1.0, 0])
def test_radius_must_be_one_positive_number(radius: object) -> None:
    cylinder = np.r_[_ring(), _ring() + np.array([0.0, 0.0, 5.0])]
    for fit, points in ((fit_sphere, _sphere_points()), (fit_cylinder, cylinder)):
        with pytest.raises(InvalidInputError, match="radius: expected one positive finite number") as caught:
            fit(points, radius=radius)
        assert caught.value.what == "radius"


def test_numpy_scalar_radius_is_accepted() -> None:
    result = fit_sphere(_sphere_points(), radius=np.float32(10.0))
    assert result.radius == 10.0
    assert np.allclose(result.center, [1, 0, 0], atol=1e-12)


@pytest.mark.parametrize("fit", [fit_line, fit_plane, fit_circle, fit_sphere, fit_cylinder, fit_cone, fit_torus])
def test_complex_string_and_overflowing_points_are_refused(fit) -> None:
    points = np.random.default_rng(1).normal(size=(12, 3))
    with pytest.raises(InvalidInputError, match="complex") as caught:
        fit(points + 1e-3j)
    assert caught.value.what == "points"
    with pytest.raises(InvalidInputError, match="real numbers"):
        fit(points.astype(str))
    with pytest.raises(InvalidInputError, match="magnitude at most") as caught:
        fit(points * 1e200)  # finite, but squares overflow: not "coplanar" or "collinear"
    assert "1e+200" in caught.value.got or "e+20" in caught.value.got


def test_weights_strings_and_all_zero_are_refused_with_the_reason() -> None:
    with pytest.raises(InvalidInputError, match="weights: expected real numbers, got strings"):
        fit_sphere(_sphere_points(), weights=["a"] * 6)
    with pytest.raises(InvalidInputError, match="at least one positive weight"):
        fit_sphere(_sphere_points(), weights=np.zeros(6))
    with pytest.raises(InvalidInputError, match="non-negative"):
        fit_plane(_sphere_points(), weights=[1, 1, 1, 1, 1, -1])
    # exact rationals are numbers
    result = fit_sphere(_sphere_points(), weights=[Fraction(1, 2)] * 6)
    assert result.radius == pytest.approx(10.0, abs=1e-12)


def test_batch_fits_check_degeneracy_per_set_and_name_it() -> None:
    rng = np.random.default_rng(3)
    planes = rng.normal(size=(4, 6, 3))
    planes[2] = np.outer(np.linspace(0, 1, 6), [1.0, 2.0, 3.0]) + 50.0  # collinear
    with pytest.raises(DegenerateGeometryError, match="set 2 of 4: points are collinear") as caught:
        fit_planes(planes)
    assert caught.value.set_index == 2
    with pytest.raises(DegenerateGeometryError, match="collinear"):  # the single fit agrees
        fit_plane(planes[2])
    lines = rng.normal(size=(3, 5, 3))
    lines[1] = 7.0  # identical points
    with pytest.raises(DegenerateGeometryError, match="set 1 of 3: all 5 points are identical") as caught:
        fit_lines(lines)
    assert caught.value.set_index == 1
    with pytest.raises(DegenerateGeometryError, match="identical"):
        fit_line(lines[1])
    circles = rng.normal(size=(2, 5, 3))
    circles[0] = np.outer(np.arange(5.0), [1.0, 0.0, 0.0])
    with pytest.raises(DegenerateGeometryError, match="set 0 of 2"):
        fit_circles(circles)
    spheres = rng.normal(size=(2, 6, 3))
    spheres[1, :, 2] = 3.0
    with pytest.raises(DegenerateGeometryError, match="set 1 of 2: points are coplanar"):
        fit_spheres(spheres)
    with pytest.raises(InvalidInputError, match="complex"):
        fit_spheres(spheres + 0j)
    with pytest.raises(TooFewPointsError):
        fit_planes(rng.normal(size=(2, 2, 3)))


def test_every_error_is_a_pcmm_geo_error_and_a_value_error() -> None:
    for call in (
        lambda: fit_sphere(_ring(), radius=12.0),
        lambda: fit_sphere(_sphere_points(), radius="10"),
        lambda: fit_sphere(_sphere_points() * 1e200),
        lambda: fit_planes(np.zeros((2, 4, 3))),
    ):
        with pytest.raises(PcmmGeoError) as caught:
            call()
        assert isinstance(caught.value, ValueError)


def test_centroid_of_a_million_points_far_from_the_origin_is_exact() -> None:
    rng = np.random.default_rng(7)
    counts = rng.integers(-10_000_000, 10_000_000, size=(1_000_000, 3))
    points = 1e5 + counts / 2.0**20  # exactly representable, so the exact mean is a known fraction
    assert np.array_equal((points - 1e5) * 2.0**20, counts)
    exact = [Fraction(10**5) + Fraction(int(counts[:, k].sum()), len(counts) * 2**20) for k in range(3)]

    def error(centroid: np.ndarray) -> float:
        return max(abs(float(Fraction(float(c)) - e)) for c, e in zip(centroid, exact, strict=True))

    assert error(points.mean(axis=0)) > 1e-10  # the plain mean is off by about 1.5e-9 mm
    assert error(weighted_centroid(points)) <= 1e-11  # within an ulp of 1e5 (1.5e-11)
    assert error(weighted_centroid(points, np.full(len(points), 0.25))) <= 1e-11
    # the fits centre on it: a plane through the cloud far from the origin sits at the exact mean
    plane = fit_plane(points[:200_000] * [1.0, 1.0, 0.0] + [0.0, 0.0, 3.0])
    assert abs(plane.point[2] - 3.0) <= 1e-12
