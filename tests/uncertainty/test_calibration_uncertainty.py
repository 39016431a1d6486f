"""Covariance of the tetrahedron calibration: linear (Jacobian of the whole calibration) vs Monte Carlo."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pcmm_geo.demo import CALIBRATION_LASERS, DemoSettings, simulate_probings, true_machine
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.uncertainty.calibration import (
    MODEL_PARAMETERS,
    PARAMETER_NAMES,
    CalibrationCovariance,
    calibration_covariance,
    calibration_covariance_monte_carlo,
    sphere_fit_covariance,
)


@pytest.fixture(scope="module")
def probings() -> dict:
    settings = DemoSettings(seed=21)
    return simulate_probings(true_machine(settings), settings, np.random.default_rng(21))


def test_sphere_fit_covariance_matches_monte_carlo() -> None:
    from pcmm_geo.fit.batch import fit_spheres

    rng = np.random.default_rng(0)
    unit = rng.normal(size=(15, 3))
    unit[:, 2] = np.abs(unit[:, 2])  # upper half: the vertical center coordinate is worse
    unit /= np.linalg.norm(unit, axis=1, keepdims=True)
    points = 6.35 * unit
    cov = sphere_fit_covariance(points, np.zeros(3), 0.001)
    fits = fit_spheres(points + rng.normal(0.0, 0.001, (20_000, 15, 3)))
    samples = np.column_stack([np.asarray(fits.centers), np.asarray(fits.radii)])
    np.testing.assert_allclose(np.sqrt(np.diag(np.cov(samples, rowvar=False))), np.sqrt(np.diag(cov)), rtol=0.03)


def test_linear_and_monte_carlo_covariances_agree(probings: dict) -> None:
    linear = calibration_covariance(probings, CALIBRATION_LASERS, probing_sigma=0.0005, laser_sigma=0.0005)
    mc = calibration_covariance_monte_carlo(
        probings, CALIBRATION_LASERS, probing_sigma=0.0005, laser_sigma=0.0005, trials=600, seed=2
    )
    assert linear.names == mc.names == PARAMETER_NAMES
    u_lin, u_mc = linear.standard_uncertainties, mc.standard_uncertainties
    # 600 trials: the relative standard error of a Monte Carlo u is 1/sqrt(1200) = 2.9 %; allow 5 of them
    for name in PARAMETER_NAMES:
        assert u_mc[name] == pytest.approx(u_lin[name], rel=0.15), name
    # the same correlations, too (dead distance a vs laser offset a)
    i, j = PARAMETER_NAMES.index("dead_distance_a"), PARAMETER_NAMES.index("slider_a.laser_offset")
    corr = [c.covariance[i, j] / np.sqrt(c.covariance[i, i] * c.covariance[j, j]) for c in (linear, mc)]
    assert corr[0] == pytest.approx(corr[1], abs=0.15)
    # physical sizes: sub-micrometre dead distances, microradian angles, ppm laser scales
    assert 1e-4 < u_lin["dead_distance_a"] < 2e-3
    assert 1e-7 < u_lin["beta_ab"] < 1e-5
    assert 1e-6 < u_lin["slider_b.laser_scale"] < 2e-5


def test_uncertainty_grows_linearly_with_the_inputs(probings: dict) -> None:
    small = calibration_covariance(probings, CALIBRATION_LASERS, probing_sigma=0.0005, laser_sigma=0.0005)
    large = calibration_covariance(probings, CALIBRATION_LASERS, probing_sigma=0.001, laser_sigma=0.001)
    u_small, u_large = small.standard_uncertainties, large.standard_uncertainties
    for name in PARAMETER_NAMES:  # the calibration is linear over its input uncertainties
        assert u_large[name] == pytest.approx(2.0 * u_small[name], rel=1e-3), name
    values, cov = small.model_covariance()
    assert values.shape == (len(MODEL_PARAMETERS),) and cov.shape == (28, 28)


def test_covariance_round_trips_through_the_calibration_file(probings: dict, tmp_path) -> None:
    from pcmm_geo.machine.calibration import calibrate_tetrahedron, load_calibration, save_calibration
    from pcmm_geo.machine.calibration.calfile import load_covariance

    cal = calibrate_tetrahedron(probings, CALIBRATION_LASERS)
    cov = calibration_covariance(probings, CALIBRATION_LASERS, probing_sigma=0.0005, laser_sigma=0.0005)
    path = save_calibration(cal, tmp_path / "cal.json", covariance=cov)
    back = CalibrationCovariance.from_dict(load_covariance(path))
    assert back.names == cov.names
    np.testing.assert_allclose(back.covariance, cov.covariance, rtol=1e-12, atol=0.0)
    assert load_calibration(path).dead_distance == pytest.approx(cal.dead_distance)
    # files without a covariance (written before issue 13) still load; the covariance is None
    document = json.loads(path.read_text())
    del document["covariance"]
    old = tmp_path / "old.json"
    old.write_text(json.dumps(document))
    assert load_covariance(old) is None
    assert load_calibration(old).beta_deg == pytest.approx(cal.beta_deg)


def test_bad_inputs(probings: dict) -> None:
    with pytest.raises(InvalidInputError, match="probing_sigma"):
        calibration_covariance(probings, CALIBRATION_LASERS, probing_sigma=-1.0, laser_sigma=0.0005)
    with pytest.raises(InvalidInputError, match="trials"):
        calibration_covariance_monte_carlo(probings, CALIBRATION_LASERS, probing_sigma=0.001, laser_sigma=0.0,
                                           trials=3)
    with pytest.raises(InvalidInputError, match="covariance"):
        CalibrationCovariance.from_dict({"names": ["a"], "values": [1.0, 2.0], "matrix": [[1.0]],
                                         "method": "x", "probing_sigma_mm": 0.0, "laser_sigma_mm": 0.0})
