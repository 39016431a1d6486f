"""Numerical calibration (thesis ch. 6): model, solvers, identifiability and pose selection."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.errors import CalibrationNotConvergedWarning, FileFormatError, InvalidInputError
from pcmm_geo.machine.calibration.numerical.identifiability import (
    analyse_identifiability,
    condition_number,
    select_poses,
)
from pcmm_geo.machine.calibration.numerical.numcal import (
    PARAMETER_NAMES,
    NumcalData,
    NumcalParameters,
    calibrate_numerically,
    height_errors,
    random_search,
    read_numcal_csv,
    residuals_and_jacobian,
    synthesise_design_data,
    synthesise_numcal_data,
)
from pcmm_geo.machine.calibration.numerical.numcal_data import SEED_BOUNDS, numcal_machine

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


def test_synthetic_data_come_from_the_rigid_body_machine(data):
    """Lasers of a rigid tetrahedron: angles between arms = beta, pivots on vertical columns b apart."""
    machine = numcal_machine(TRUTH)
    heights = 100.0 + np.asarray(data.pivot_heights)
    pivots = machine.pivots(heights)
    tips = machine.forward(heights=heights).tip
    arms = pivots - tips[:, None, :]
    lengths = np.linalg.norm(arms, axis=2)
    np.testing.assert_allclose(lengths, data.lasers + 60.0 + TRUTH.vector()[:3], atol=1e-9)
    for k, (i, n) in enumerate(((0, 1), (1, 2), (2, 0))):
        cosine = np.sum(arms[:, i] * arms[:, n], axis=1) / (lengths[:, i] * lengths[:, n])
        np.testing.assert_allclose(np.arccos(cosine), TRUTH.vector()[3 + k], atol=1e-9)
        np.testing.assert_allclose(np.linalg.norm(pivots[:, i, :2] - pivots[:, n, :2], axis=1),
                                   TRUTH.vector()[6 + k], atol=1e-9)
    assert np.all(tips[:, 2] < pivots[:, :, 2].min(axis=1) - 250.0)  # the tip hangs below the pivots
    # raising pivot a by 50 mm: its laser changes by 4.8 mm, the two others by about 1.6 um only
    change = data.lasers[14] - data.lasers[0]
    assert 4.5 < change[0] < 5.0 and np.all(np.abs(change[1:]) < 2e-3) and np.all(np.abs(change[1:]) > 1e-3)
    # all three pair equations hold, not only the moved pair's
    residuals, _ = residuals_and_jacobian(data, TRUTH.vector(), pairs="all")
    assert residuals.shape == (135,) and np.abs(residuals).max() < 1e-9


def test_d_bounds_exclude_the_start_of_range():
    # Appendix B adds its dead distance to the raw laser reading: its 300-400 mm include the 60 mm
    np.testing.assert_allclose(SEED_BOUNDS[0][:3], 240.0)
    np.testing.assert_allclose(SEED_BOUNDS[1][:3], 340.0)
    assert np.all(SEED_BOUNDS[0] < TRUTH.vector()) and np.all(TRUTH.vector() < SEED_BOUNDS[1])


@pytest.mark.parametrize("pairs", ["moved", "all"])
def test_jacobian_matches_central_differences(data, pairs):
    vector = TRUTH.vector() + np.array([1.0, -2.0, 0.5, 0.01, -0.02, 0.015, 3.0, -1.0, 2.0])
    _, jac = residuals_and_jacobian(data, vector, pairs=pairs)
    for k in range(9):
        step = np.zeros(9)
        step[k] = 1e-6 if k in (3, 4, 5) else 1e-4
        plus, _ = residuals_and_jacobian(data, vector + step, pairs=pairs)
        minus, _ = residuals_and_jacobian(data, vector - step, pairs=pairs)
        np.testing.assert_allclose(jac[:, k], (plus - minus) / (2 * step[k]), rtol=1e-6, atol=1e-8)


def test_seed_height_error_is_nan_where_the_seed_went_complex(data):
    vector = TRUTH.vector()
    vector[6:] += 40.0  # b larger than the pivot distance: sqrt of a negative number in eq 2.5
    assert np.all(np.isnan(height_errors(data, vector)[:3]))


def test_identifiability_of_the_seed_experiment_on_physical_data(data):
    # one equation per sample (the seed's): each pair fixes only two of its combinations -> three weak directions
    _, jac = residuals_and_jacobian(data, TRUTH.vector())
    report = analyse_identifiability(jac, PARAMETER_NAMES)
    relative = report.singular_values / report.singular_values[0]
    assert np.all(relative[6:] < 1e-7) and np.all(relative[:6] > 1e-3)
    assert report.condition_number > 1e8
    # all three pair equations: one weak "size" direction is left
    _, jac_all = residuals_and_jacobian(data, TRUTH.vector(), pairs="all")
    report = analyse_identifiability(jac_all, PARAMETER_NAMES)
    relative = report.singular_values / report.singular_values[0]
    assert relative[-1] < 1e-6 and relative[-2] > 1e-4
    weakest = report.weak_combinations[0]
    coefficients = np.array([weakest.coefficients[n] for n in PARAMETER_NAMES])
    # all dead distances move together with all b, against all beta (a "size" of the tetrahedron)
    assert np.all(coefficients[:3] > 0.3) and np.all(coefficients[6:] > 0.2) and np.all(coefficients[3:6] < -0.2)
    # moving along that (column-scaled) direction changes the residuals by s_min per unit step
    norms = np.linalg.norm(jac_all, axis=0)
    step = 1e-3 * coefficients / norms
    plus, _ = residuals_and_jacobian(data, TRUTH.vector() + step, pairs="all")
    minus, _ = residuals_and_jacobian(data, TRUTH.vector() - step, pairs="all")
    # central difference: the second-order part (the valley is curved) cancels
    assert np.linalg.norm(plus - minus) / 2 == pytest.approx(1e-3 * weakest.singular_value, rel=2e-2)


def test_design_identifiability_names_a_design_that_determines_everything():
    from pcmm_geo.machine.calibration.numerical.numcal import design_identifiability

    rng = np.random.default_rng(4)
    together = design_identifiability(rng.uniform(0.0, 200.0, (30, 3)))
    assert together.rank == 9 and together.condition_number < 1e4
    seed_design = np.zeros((45, 3))
    for k in range(3):
        seed_design[15 * k : 15 * (k + 1), k] = np.linspace(0.0, 50.0, 15)
    assert design_identifiability(seed_design, pairs="moved").condition_number > 1e8
    assert 1e6 < design_identifiability(seed_design).condition_number < 1e8


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
    lower, upper = SEED_BOUNDS
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
    with pytest.raises(InvalidInputError):
        calibrate_numerically(data, method="sequential", pairs="all")
    with pytest.raises(InvalidInputError):
        NumcalData(("a",), np.zeros((1, 3)), np.ones(1), np.zeros((1, 3)))  # heights differ from pivot_heights


def test_numcal_csv_with_three_heights_round_trips(tmp_path):
    from pcmm_geo.errors import OutputExistsError
    from pcmm_geo.machine.calibration.numerical.numcal_data import write_numcal_csv

    design = np.array([[10.0, 0.0, 5.0], [0.0, 20.0, 1.0], [3.0, 4.0, 30.0]])
    data = synthesise_design_data(TRUTH, design)
    path = write_numcal_csv(data, tmp_path / "wide.csv")
    assert path.read_text().splitlines()[0] == "moved,laser_a,laser_b,laser_c,height_a,height_b,height_c"
    back = read_numcal_csv(path)
    assert back.moved == ("a", "b", "c")
    np.testing.assert_array_equal(back.pivot_heights, design)
    np.testing.assert_array_equal(back.lasers, data.lasers)
    with pytest.raises(OutputExistsError):
        write_numcal_csv(data, path)


def test_rank_deficient_data_warn_and_name_the_missing_parameters(data):
    only_a = data.subset(("a",))
    with pytest.warns(CalibrationNotConvergedWarning, match="rank 3 of 9") as caught:
        result = calibrate_numerically(only_a, global_search=None, start=TRUTH)
    message = str(caught[0].message)
    assert "d_b" in message and "beta_bc" in message and "b_ab" in message
    assert result.rank == 3 and not result.converged and "rank 3 of 9" in result.message
    # the fourth combination of the moved pair is the one seen only through the 1.6 um stationary laser
    assert "d_a" in result.message and "d_c" in result.message and "b_ca" in result.message
    assert np.all(np.isnan(result.covariance))  # no uncertainty can be stated
    assert result.parameters.d["b"] == pytest.approx(TRUTH.d["b"])  # untouched start value


def test_greedy_sample_selection_beats_random_selections_of_the_same_size(data):
    """Verl et al. 2008: the greedy choice is better conditioned than any of 200 seeded random choices."""
    from pcmm_geo.machine.calibration.numerical.numcal import select_samples

    _, jac = residuals_and_jacobian(data, TRUTH.vector(), pairs="all")
    rng = np.random.default_rng(12)
    for count in (9, 12):
        subset, selection = select_samples(data, count, parameters=TRUTH, pairs="all")
        assert len(set(selection.indices)) == count
        # the subset holds exactly the chosen rows, and its condition number is the one reported
        np.testing.assert_array_equal(subset.lasers, data.lasers[list(selection.indices)])
        _, sub_jac = residuals_and_jacobian(subset, TRUTH.vector(), pairs="all")
        assert condition_number(sub_jac) == pytest.approx(selection.final_condition_number, rel=1e-9)
        choices = [rng.choice(len(data.moved), count, replace=False) for _ in range(200)]
        random_choices = [condition_number(jac[np.ravel([[3 * k, 3 * k + 1, 3 * k + 2] for k in c])])
                          for c in choices]
        assert selection.final_condition_number < min(random_choices)
    with pytest.raises(InvalidInputError):
        select_samples(data, len(data.moved) + 1)


@pytest.mark.parametrize(
    ("method", "search", "stage_units"),
    [("simultaneous", "differential_evolution", 1001), ("sequential", "differential_evolution", 1001),
     ("simultaneous", "multistart", 20), ("sequential", None, 1)],
)
@pytest.mark.filterwarnings("ignore::pcmm_geo.errors.CalibrationNotConvergedWarning")  # the seed's design
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
