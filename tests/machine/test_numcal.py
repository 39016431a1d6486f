"""Numerical calibration (thesis ch. 6): model, solvers, identifiability and pose selection."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.errors import FileFormatError, InvalidInputError
from pcmm_geo.machine.calibration.numerical.identifiability import analyse_identifiability, condition_number, select_poses
from pcmm_geo.machine.calibration.numerical.numcal import (
    PARAMETER_NAMES,
    NumcalData,
    NumcalParameters,
    calibrate_numerically,
    height_errors,
    random_search,
    read_numcal_csv,
    residuals_and_jacobian,
    synthesise_numcal_data,
)

TRUTH = NumcalParameters.from_seed_table()


@pytest.fixture(scope="module")
def data():
    return synthesise_numcal_data(TRUTH, seed=1)


def test_synthetic_data_satisfy_the_cosine_rule_by_hand(data):
    # moving arm b uses the pair a-b: L_a, L_b, beta_ab, b_ab (eqs 2.5, 2.7), checked by hand
    row = data.moved.index("b") + 7
    length_a = data.lasers[row, 0] + 60.0 + 314.48
    length_b = data.lasers[row, 1] + 60.0 + 312.74
    distance = np.sqrt(length_a**2 + length_b**2 - 2 * length_a * length_b * np.cos(np.radians(68.25)))
    assert np.sqrt(distance**2 - 454.17**2) == pytest.approx(data.heights[row], abs=1e-9)
    residuals, _ = residuals_and_jacobian(data, TRUTH.vector())
    assert np.abs(residuals).max() < 1e-9
    # the seed's height error sqrt(L^2 - b^2) - h loses precision near the level start (h = 0):
    # L^2 - b^2 cancels there (and rounds negative -> NaN); elsewhere it is exact
    errors = height_errors(data, TRUTH.vector())
    assert np.abs(errors[data.heights > 1.0]).max() < 1e-9
    assert np.nanmax(np.abs(errors)) < 1e-4


def test_jacobian_matches_central_differences(data):
    vector = TRUTH.vector() + np.array([1.0, -2.0, 0.5, 0.01, -0.02, 0.015, 3.0, -1.0, 2.0])
    _, jac = residuals_and_jacobian(data, vector)
    for k in range(9):
        step = np.zeros(9)
        step[k] = 1e-6 if k in (3, 4, 5) else 1e-4
        plus, _ = residuals_and_jacobian(data, vector + step)
        minus, _ = residuals_and_jacobian(data, vector - step)
        np.testing.assert_allclose(jac[:, k], (plus - minus) / (2 * step[k]), rtol=1e-6, atol=1e-8)


def test_seed_height_error_is_nan_where_the_seed_went_complex(data):
    vector = TRUTH.vector()
    vector[6:] += 40.0  # b larger than the pivot distance: sqrt of a negative number in eq 2.5
    assert np.all(np.isnan(height_errors(data, vector)[:3]))


def test_local_refinement_recovers_truth_from_a_nearby_start(data):
    offset = np.array([0.3, -0.2, 0.25, 1e-3, -1e-3, 5e-4, 0.4, 0.2, -0.3])
    start = NumcalParameters.from_vector(TRUTH.vector() + offset)
    result = calibrate_numerically(data, method="simultaneous", global_search=None, start=start)
    assert result.rms < 1e-9
    # determined combinations are recovered; only the weakest (scale) direction may drift
    weak = np.array([result.identifiability.weak_combinations[0].coefficients[n] for n in PARAMETER_NAMES])
    _, jac = residuals_and_jacobian(data, TRUTH.vector())
    error = (result.parameters.vector() - TRUTH.vector()) * np.linalg.norm(jac, axis=0)
    determined_part = error - (error @ weak) * weak
    assert np.linalg.norm(determined_part) < 1e-6


@pytest.mark.parametrize("method", ["simultaneous", "sequential"])
def test_global_search_reaches_a_zero_residual_solution(data, method):
    result = calibrate_numerically(data, method=method, global_search="differential_evolution", seed=0)
    assert result.rms < 1e-4  # mm; noise-free data
    lower, upper = np.array([300, 300, 300, 60, 60, 60, 400, 400, 400.0]), np.array([400] * 3 + [80] * 3 + [500] * 3)
    recovered = np.r_[list(result.parameters.d.values()), list(result.parameters.beta_deg.values()),
                      list(result.parameters.b.values())]
    assert np.all((recovered >= lower) & (recovered <= upper))
    assert result.to_dict()["method"] == method


def test_identifiability_names_the_scale_mode(data):
    _, jac = residuals_and_jacobian(data, TRUTH.vector())
    report = analyse_identifiability(jac, PARAMETER_NAMES)
    assert report.rank == 9
    assert report.condition_number > 1e5  # the seed's experiment is badly conditioned
    weakest = report.weak_combinations[0]
    coefficients = np.array([weakest.coefficients[n] for n in PARAMETER_NAMES])
    # all dead distances move together with all b, against all beta (a "size" of the tetrahedron)
    assert np.all(coefficients[:3] > 0.3) and np.all(coefficients[6:] > 0.2) and np.all(coefficients[3:6] < -0.2)
    # moving along that (column-scaled) direction changes the residuals by s_min per unit step
    norms = np.linalg.norm(jac, axis=0)
    step = 1e-3 * coefficients / norms
    moved, _ = residuals_and_jacobian(data, TRUTH.vector() + step)
    assert np.linalg.norm(moved) == pytest.approx(1e-3 * weakest.singular_value, rel=1e-2)


def test_identifiability_closed_form_null_space():
    # residuals depend on x + 2y only: the null direction is (2, -1)/sqrt(5); z is determined
    jac = np.array([[1.0, 2.0, 0.0], [3.0, 6.0, 1.0], [-1.0, -2.0, 2.0], [0.5, 1.0, 0.0]])
    report = analyse_identifiability(jac, ("x", "y", "z"))
    assert report.rank == 2
    assert np.isinf(report.condition_number)
    null = report.weak_combinations[0]
    np.testing.assert_allclose([null.parameter_direction["x"], null.parameter_direction["y"]],
                               [2 / np.sqrt(5), -1 / np.sqrt(5)], atol=1e-12)
    assert abs(null.parameter_direction["z"]) < 1e-12
    # equilibrated columns x and y are identical -> (1, -1)/sqrt(2) in scaled coordinates
    assert report.undetermined == ("+0.707 x -0.707 y",)
    assert condition_number(np.diag([1.0, 1e3, 1e-3])) == pytest.approx(1.0)
    with pytest.raises(InvalidInputError):
        analyse_identifiability(jac, ("x", "y"))


def test_pose_selection_prefers_well_conditioned_poses(data):
    toy = [np.array([[1.0, 0.0]]), np.array([[1.0, 0.01]]), np.array([[0.0, 1.0]]), np.array([[1.0, 1.0]])]
    assert set(select_poses(toy, 2).indices) == {0, 2}
    _, jac = residuals_and_jacobian(data, TRUTH.vector())
    rows = [jac[k : k + 1] for k in range(jac.shape[0])]
    chosen = select_poses(rows, 12)
    assert len(set(chosen.indices)) == 12
    picked = condition_number(jac[list(chosen.indices)])
    assert picked == pytest.approx(chosen.final_condition_number)
    # better than the first 12 samples taken in order (4 per arm would be a fair naive pick)
    naive = condition_number(jac[[0, 1, 2, 3, 15, 16, 17, 18, 30, 31, 32, 33]])
    assert picked < naive
    with pytest.raises(InvalidInputError):
        select_poses(rows, 0)


def test_random_search_returns_the_best_of_its_samples(data):
    best, cost = random_search(data, 5000, seed=4, chunk=1000)
    rng = np.random.default_rng(4)
    lower = np.array([300.0] * 3 + [np.radians(60.0)] * 3 + [400.0] * 3)
    upper = np.array([400.0] * 3 + [np.radians(80.0)] * 3 + [500.0] * 3)
    samples = np.vstack([rng.uniform(lower, upper, (1000, 9)) for _ in range(5)])
    costs = [float(np.sum(residuals_and_jacobian(data, s)[0] ** 2)) for s in samples]
    assert cost == pytest.approx(min(costs), rel=1e-9)
    np.testing.assert_allclose(best.vector(), samples[int(np.argmin(costs))], rtol=1e-12)


def test_numcal_csv_reader(tmp_path, data):
    path = tmp_path / "numcal.csv"
    rows = ["moved,laser_a,laser_b,laser_c,height"]
    rows += [f"{m},{a!r},{b!r},{c!r},{h!r}" for m, (a, b, c), h in
             zip(data.moved, data.lasers.tolist(), data.heights.tolist(), strict=True)]
    path.write_text("\n".join(rows) + "\n")
    back = read_numcal_csv(path)
    assert back.moved == data.moved
    np.testing.assert_array_equal(back.lasers, data.lasers)
    path.write_text("moved,laser_a,laser_b,laser_c,height\nd,1,2,3,4\n")
    with pytest.raises(FileFormatError, match=r":2: moved"):
        read_numcal_csv(path)
    path.write_text("moved,laser_a,laser_b,laser_c\n")
    with pytest.raises(FileFormatError, match="header"):
        read_numcal_csv(path)
    with pytest.raises(InvalidInputError):
        NumcalData(("a",), np.zeros((2, 3)), np.zeros(2))
    with pytest.raises(InvalidInputError):
        calibrate_numerically(data, method="genetic")


def test_rank_deficient_data_warn_and_name_the_missing_parameters(data):
    from pcmm_geo.errors import IllConditionedWarning

    only_a = data.subset(("a",))
    with pytest.warns(IllConditionedWarning, match="rank 4 of 9") as caught:
        result = calibrate_numerically(only_a, global_search=None, start=TRUTH)
    message = str(caught[0].message)
    assert "d_b" in message and "beta_bc" in message and "b_ab" in message
    assert result.identifiability.rank == 4
    assert result.parameters.d["b"] == pytest.approx(TRUTH.d["b"])  # untouched start value


def test_greedy_sample_selection_beats_random_selections_of_the_same_size(data):
    """Verl et al. 2008: the greedy choice is better conditioned than any of 200 seeded random choices."""
    from pcmm_geo.machine.calibration.numerical.numcal import select_samples

    _, jac = residuals_and_jacobian(data, TRUTH.vector())
    rng = np.random.default_rng(12)
    for count in (9, 12):
        subset, selection = select_samples(data, count, parameters=TRUTH)
        assert len(set(selection.indices)) == count
        # the subset holds exactly the chosen rows, and its condition number is the one reported
        np.testing.assert_array_equal(subset.lasers, data.lasers[list(selection.indices)])
        _, sub_jac = residuals_and_jacobian(subset, TRUTH.vector())
        assert condition_number(sub_jac) == pytest.approx(selection.final_condition_number, rel=1e-9)
        random_choices = [condition_number(jac[rng.choice(len(data.moved), count, replace=False)]) for _ in range(200)]
        assert selection.final_condition_number < min(random_choices)
    # with 12 well-chosen samples the conditioning is better than with all 45
    assert selection.final_condition_number < condition_number(jac)
    with pytest.raises(InvalidInputError):
        select_samples(data, len(data.moved) + 1)


@pytest.mark.parametrize(
    ("method", "search", "stage_units"),
    [("simultaneous", "differential_evolution", 1001), ("sequential", "differential_evolution", 1001),
     ("simultaneous", "multistart", 20), ("sequential", None, 1)],
)
def test_progress_is_reported_from_the_global_search(data, method, search, stage_units):
    calls = []
    calibrate_numerically(data, method=method, global_search=search, seed=0, start=None if search else TRUTH,
                          progress=lambda done, total: calls.append((done, total)))
    stages = 3 if method == "sequential" else 1
    totals = {total for _, total in calls}
    assert totals == {stages * stage_units}
    done = [d for d, _ in calls]
    assert done == sorted(done) and done[-1] == stages * stage_units and done[0] >= 1
    if search == "differential_evolution":
        assert len(calls) > 10 * stages  # one call per generation, not only at the end
