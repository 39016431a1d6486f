"""Seeded study of calibration error growth with probing noise (the table of docs/machine.md)."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.machine.calibration import calibrate_tetrahedron
from pcmm_geo.machine.calibration.noise import (
    CALIBRATION_LASERS,
    SIGMAS,
    calibration_errors,
    noise_growth_study,
    skewed_tetrahedron,
    synthesise_probings,
)

FIELDS = ("tip_centre", "slider_direction", "slider_point", "laser_scale", "laser_offset", "dead_distance", "beta_deg")


@pytest.fixture(scope="module")
def study():
    return noise_growth_study(SIGMAS, seeds=20)


def test_synthetic_machine_really_has_skewed_lines_and_scaled_lasers():
    truth = skewed_tetrahedron()
    lines = [truth.sliders[arm] for arm in "abc"]
    for k in range(3):
        first, second = lines[k], lines[(k + 1) % 3]
        normal = np.cross(first.direction, second.direction)
        skew = abs((second.point - first.point) @ normal) / np.linalg.norm(normal)
        assert skew > 5.0  # mm: the lines do not meet
        assert np.linalg.norm(first.point - truth.tip_centre) > 9.0  # nor pass through the tip
    assert [line.laser_scale for line in lines] == [1.02, 0.97, 1.01]


def test_noise_free_row_recovers_the_true_geometry(study):
    row = study.rows[0]
    assert row.sigma == 0.0
    for field in FIELDS:
        assert getattr(row, field) < 1e-6, field


def test_errors_grow_monotonically_and_linearly_with_noise(study):
    for field in FIELDS:
        values = np.array([getattr(row, field) for row in study.rows])
        assert np.all(np.diff(values) > 0), field
        # same seeds at every level: the noise only scales, and to first order so do the errors
        one, two = values[SIGMAS.index(1e-3)], values[SIGMAS.index(2e-3)]
        assert two / one == pytest.approx(2.0, rel=0.02), field


def test_tip_centre_error_matches_first_order_sphere_fit_propagation(study):
    """Median |centre error| of a least-squares sphere fit: sigma^2 (A^T A)^-1 with rows A = [u_i, 1]."""
    golden = np.pi * (3.0 - np.sqrt(5.0))
    k = np.arange(study.points_per_ball)
    z = 1.0 - 1.5 * (k + 0.5) / k.size
    ring = np.sqrt(1.0 - z**2)
    normals = np.c_[ring * np.cos(golden * k), ring * np.sin(golden * k), z]
    design = np.c_[normals, np.ones(k.size)]
    covariance = np.linalg.inv(design.T @ design)[:3, :3]  # per unit sigma
    draws = np.random.default_rng(0).multivariate_normal(np.zeros(3), covariance, 200_000)
    expected = np.median(np.linalg.norm(draws, axis=1))  # 0.83 sigma for 12 points on 3/4 of a ball
    row = study.rows[SIGMAS.index(1e-3)]
    assert row.tip_centre / 1e-3 == pytest.approx(expected, rel=0.25)  # median of 20 seeds


def test_markdown_table_and_errors_of_a_single_run():
    truth = skewed_tetrahedron()
    cal = calibrate_tetrahedron(synthesise_probings(truth, sigma=1e-3, seed=3), CALIBRATION_LASERS)
    errors = calibration_errors(cal, truth)
    assert set(errors) == set(FIELDS)
    assert 1e-5 < errors["tip_centre"] < 5e-3
    table = noise_growth_study([0.0, 1e-3], seeds=2).to_markdown().splitlines()
    assert len(table) == 4 and table[0].startswith("| probe noise σ / µm |") and table[3].startswith("| 1 |")
    with pytest.raises(InvalidInputError):
        noise_growth_study([1e-3], seeds=0)
    with pytest.raises(InvalidInputError):
        synthesise_probings(truth, sigma=-1.0)
    with pytest.raises(InvalidInputError):
        synthesise_probings(truth, CALIBRATION_LASERS[:, :2])
