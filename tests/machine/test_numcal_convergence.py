"""Numerical calibration (thesis ch. 6) runs to a real convergence test, reports uncertainty, never fails silently.

Truth: physical data of a rigid-body machine built from known parameters (Table 7.1's values).
"""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.errors import CalibrationNotConvergedWarning, InvalidInputError
from pcmm_geo.machine.calibration.numerical.numcal import calibrate_numerically, residuals_and_jacobian
from pcmm_geo.machine.calibration.numerical.numcal_data import (
    PARAMETER_NAMES,
    NumcalData,
    NumcalParameters,
    synthesise_design_data,
    synthesise_numcal_data,
)
from pcmm_geo.machine.calibration.numerical.numcal_single_arm import (
    APPENDIX_B_HEIGHTS,
    TABLE_6_2,
    calibrate_single_arm,
    seed_sigma_err,
    single_arm_parameters,
)
from pcmm_geo.machine.calibration.numerical.numcal_solver import MAX_CONDITION, refine

TRUTH = NumcalParameters.from_seed_table()
LENGTHS = [0, 1, 2, 6, 7, 8]  # d and b (mm); 3, 4, 5 are beta (rad)


@pytest.fixture(scope="module")
def determined():
    """Pivots moved together over 0-200 mm, all three pair equations: all nine parameters determined."""
    return synthesise_design_data(TRUTH, np.random.default_rng(1).uniform(0.0, 200.0, (30, 3)))


def assert_recovered(vector, truth, tolerance=1e-6):
    error = np.abs(np.asarray(vector) - truth)
    assert error[LENGTHS].max() < tolerance, error  # mm
    assert error[3:6].max() < tolerance, error  # rad


@pytest.mark.parametrize("search", ["multistart", "differential_evolution"])
def test_noise_free_parameters_are_recovered_from_the_bounds(determined, search):
    result = calibrate_numerically(determined, pairs="all", global_search=search, seed=3)
    assert result.converged and "Gauss-Newton step below tolerance" in result.message
    assert_recovered(result.parameters.vector(), TRUTH.vector())
    assert result.rms < 1e-9 and result.rank == 9 and result.condition_number < 1e4
    assert result.dof == 3 * 30 - 9 and result.names == PARAMETER_NAMES
    assert np.all(np.sqrt(np.diag(result.covariance)) < 1e-8)  # noise-free: residual scale ~ 0


def test_seed_design_reports_that_it_is_not_determined():
    """The seed's experiment (one pivot at a time, 50 mm, one pair per sample): condition ~6e8 > MAX_CONDITION."""
    data = synthesise_numcal_data(TRUTH)
    with pytest.warns(CalibrationNotConvergedWarning, match="ill-determined: condition number"):
        result = calibrate_numerically(data, global_search=None, start=TRUTH)
    assert not result.converged and result.condition_number > MAX_CONDITION
    assert result.message.startswith("ill-determined")
    # even started at the truth, noise-free: the weak combination is named
    assert "weakest combination" in result.message and "d_a" in result.message


def test_evaluation_limit_is_reported_not_hidden(determined):
    start = NumcalParameters.from_vector(TRUTH.vector() + np.array([20, -15, 10, 0.03, -0.02, 0.02, 15, -10, 12.0]))
    with pytest.warns(CalibrationNotConvergedWarning, match="no convergence after"):
        result = calibrate_numerically(determined, pairs="all", global_search=None, start=start, max_evaluations=3)
    assert not result.converged and "limit 3" in result.message
    # the same start, without the limit, converges (continuation from where it stopped)
    result = calibrate_numerically(determined, pairs="all", global_search=None, start=start)
    assert result.converged
    assert_recovered(result.parameters.vector(), TRUTH.vector())


def test_a_minimum_outside_the_bounds_is_reported(determined):
    lower = np.array([240.0, 240.0, 240.0, 1.0, 1.0, 1.0, 400.0, 400.0, 400.0])
    upper = np.array([310.0, 340.0, 340.0, 1.4, 1.4, 1.4, 500.0, 500.0, 500.0])  # d_a = 314.48 is outside
    with pytest.warns(CalibrationNotConvergedWarning, match="outside the bounds: .*d_a"):
        result = calibrate_numerically(determined, pairs="all", global_search=None, start=TRUTH,
                                       bounds=(lower, upper))
    assert not result.converged


def test_refine_continues_a_run_that_stopped_early():
    # Rosenbrock as residuals: scipy's trust region needs more than the first round's budget from (-1.2, 1)
    def fun(x):
        return np.array([10.0 * (x[1] - x[0] ** 2), 1.0 - x[0]])

    def jac(x):
        return np.array([[-20.0 * x[0], 10.0], [-1.0, 0.0]])

    solution = refine(fun, jac, np.array([-1.2, 1.0]), np.full(2, -5.0), np.full(2, 5.0))
    assert solution.converged
    np.testing.assert_allclose(solution.x, [1.0, 1.0], atol=1e-12)


def test_uncertainty_agrees_with_a_seeded_monte_carlo_of_recalibrations():
    """Reported u (weighted fit, s² (J̃ᵀJ̃)⁻¹ from one data set) vs the spread of 150 recalibrations.

    Tolerance: the spread of 150 samples estimates sigma to about 6 % (1 sd), and the reported
    u of one data set (63 degrees of freedom) varies by about 9 %; the median reported u of
    each parameter must lie within 15 % of the spread, their mean ratio within 10 %, and the
    bias within 4 standard errors.
    """
    design = np.random.default_rng(5).uniform(0.0, 200.0, (24, 3))
    sigma = 1e-3  # mm, lasers and height gauge
    estimates, reported = [], []
    for seed in range(150):
        data = synthesise_design_data(TRUTH, design, laser_sigma=sigma, height_sigma=sigma, seed=100 + seed)
        result = calibrate_numerically(data, pairs="all", global_search=None, start=TRUTH, laser_sigma=sigma,
                                       height_sigma=sigma)
        assert result.converged and result.reading_sigma == (sigma, sigma)
        estimates.append(result.parameters.vector())
        reported.append(np.sqrt(np.diag(result.covariance)))
    estimates, reported = np.array(estimates), np.array(reported)
    spread = estimates.std(axis=0, ddof=1)
    ratio = np.median(reported, axis=0) / spread
    assert np.all(np.abs(ratio - 1.0) < 0.15), ratio
    assert abs(ratio.mean() - 1.0) < 0.10, ratio
    bias = np.abs(estimates.mean(axis=0) - TRUTH.vector())
    assert np.all(bias < 4.0 * spread / np.sqrt(len(estimates))), bias / spread
    # the seed's geometry amplifies reading noise strongly: 1 um gives about 0.2 mm in d
    assert 0.05 < spread[0] < 1.0


def test_weighted_and_unweighted_fits_agree_on_noise_free_data(determined):
    plain = calibrate_numerically(determined, pairs="all", global_search=None, start=TRUTH)
    weighted = calibrate_numerically(determined, pairs="all", global_search=None, start=TRUTH, laser_sigma=1e-3,
                                     height_sigma=1e-3)
    assert plain.converged and weighted.converged
    assert_recovered(weighted.parameters.vector(), TRUTH.vector())
    assert weighted.to_dict()["reading_sigma"] == [1e-3, 1e-3] and plain.to_dict()["reading_sigma"] is None
    with pytest.raises(InvalidInputError):
        calibrate_numerically(determined, pairs="all", global_search=None, start=TRUTH, laser_sigma=-1.0)


# ---------------------------------------------------------------------------------------------
# single-arm four-parameter calibration (thesis 6.2.1, Table 6.2)


def test_single_arm_parameters_follow_the_moved_pair():
    assert single_arm_parameters("a") == ("d_a", "d_c", "beta_ca", "b_ca")
    assert single_arm_parameters("c") == ("d_b", "d_c", "beta_bc", "b_bc")
    with pytest.raises(InvalidInputError):
        single_arm_parameters("d")


def test_single_arm_recovers_its_four_parameters_when_both_pivots_move():
    rng = np.random.default_rng(0)
    pivots = np.zeros((20, 3))
    pivots[:, 0], pivots[:, 2] = rng.uniform(0.0, 200.0, 20), rng.uniform(0.0, 200.0, 20)  # a and c, b still
    raw = synthesise_design_data(TRUTH, pivots)
    data = NumcalData(("a",) * 20, raw.lasers, pivots[:, 0], pivots)
    result = calibrate_single_arm(data, "a", global_search="multistart", seed=1)
    assert result.converged and result.method == "single-arm" and result.covariance.shape == (4, 4)
    free = [PARAMETER_NAMES.index(name) for name in result.names]
    error = np.abs(result.values - TRUTH.vector()[free])
    assert error[[0, 1, 3]].max() < 1e-6 and error[2] < 1e-6  # d_a, d_c, b_ca in mm; beta_ca in rad


def test_single_arm_seed_experiment_is_reported_not_determined():
    """Table 6.2's experiment: one pivot raised to 30 mm (Appendix B's heights), the other still."""
    pivots = np.zeros((len(APPENDIX_B_HEIGHTS), 3))
    pivots[:, 0] = APPENDIX_B_HEIGHTS
    data = synthesise_design_data(TRUTH, pivots)
    with pytest.warns(CalibrationNotConvergedWarning) as caught:
        result = calibrate_single_arm(data, "a", global_search=None, start=TRUTH)
    assert not result.converged and result.condition_number > MAX_CONDITION
    assert "d_a" in str(caught[0].message)
    # test 3 of Table 6.2: three points for four parameters
    with pytest.warns(CalibrationNotConvergedWarning, match=r"fewer equations \(3\) than parameters \(4\)"):
        result = calibrate_single_arm(data.take([0, 7, 10]), "a", global_search=None, start=TRUTH)
    assert result.dof == -1 and not result.converged


def test_table_6_2_mechanism_parameters_20_mm_apart_fit_to_the_gauge_resolution():
    """Why Table 6.2's parameters scatter: d_a 20 mm off still fits the 11 heights to within 0.01 mm."""
    pivots = np.zeros((len(APPENDIX_B_HEIGHTS), 3))
    pivots[:, 0] = APPENDIX_B_HEIGHTS
    data = synthesise_design_data(TRUTH, pivots)
    names = single_arm_parameters("a")
    free = np.array([PARAMETER_NAMES.index(name) for name in names[1:]])  # d_c, beta_ca, b_ca; d_a held
    shifted = TRUTH.vector()
    shifted[0] += 20.0

    def fun(x):
        vector = shifted.copy()
        vector[free] = x
        return residuals_and_jacobian(data, vector)[0]

    def jac(x):
        vector = shifted.copy()
        vector[free] = x
        return residuals_and_jacobian(data, vector)[1][:, free]

    profile = refine(fun, jac, shifted[free], shifted[free] - [50.0, 0.2, 50.0], shifted[free] + [50.0, 0.2, 50.0])
    rms = float(np.sqrt(np.mean(fun(profile.x) ** 2)))
    assert rms < 0.005  # mm: below the height gauge's 0.01 mm resolution
    assert np.abs(profile.x - TRUTH.vector()[free])[[0, 2]].max() > 5.0  # the others move by millimetres too
    # the seed's sigma_err amplifies distance errors near the level start (infinite slope of sqrt(L² - b²))
    noisy = synthesise_design_data(TRUTH, pivots, laser_sigma=0.005, seed=3)
    with pytest.warns(CalibrationNotConvergedWarning):
        result = calibrate_single_arm(noisy, "a", global_search=None, start=TRUTH)
    assert result.rms < 0.01 and seed_sigma_err(result) > 10 * result.rms
    assert TABLE_6_2["test 2"][5] == len(APPENDIX_B_HEIGHTS)
