"""Variable DPKM parameters (thesis 8.2, Table 8.2): laws fitted from calibration positions, applied per log row."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.errors import InvalidInputError, NoRealSolutionError
from pcmm_geo.machine.analysis.logproc import process_log_dpkm
from pcmm_geo.machine.analysis.parameter_laws import (
    BOTH_ARMS_BETA_DRIVERS,
    TABLE_8_1,
    TABLE_8_2,
    THESIS_BETA_DRIVERS,
    DpkmParameterLaws,
    LinearLaw,
    fit_parameter_laws,
    parameter_samples,
    synthesise_log_dpkm,
    table_8_errors,
)
from pcmm_geo.machine.calibration.seed import APPENDIX_C, reconstruct_appendix_cd
from pcmm_geo.machine.kinematics import dpkm
from pcmm_geo.machine.kinematics.model import RigidBodyMachine

COLUMNS = dpkm.APPENDIX_D_COLUMN_POINTS
H0 = np.array([400.0, 460.0, 350.0])
PAIRS = ("ab", "bc", "ca")
#: the slopes of Appendix C (lines 93-144), mm/mm and degrees/mm
DEAD_SLOPE = dict(zip("abc", APPENDIX_C["dead_slope"], strict=True))
BETA_SLOPE = dict(zip(PAIRS, APPENDIX_C["beta_slope"], strict=True))
#: calibration readings of Appendix C (positions 1 and 2)
CALIBRATION_LASERS = APPENDIX_C["lasers"]


def moves(seed: int = 5, count: int = 30) -> list[tuple[int, float, bool]]:
    rng = np.random.default_rng(seed)
    return [(int(rng.integers(1, 4)), float(rng.uniform(-10, 10)), bool(rng.random() < 0.5)) for _ in range(count)]


def thesis_like_laws(pivot: np.ndarray) -> DpkmParameterLaws:
    """Table 3.1 values at the readings ``pivot`` (3,), varying with Appendix C's slopes."""
    drivers = {p: THESIS_BETA_DRIVERS[p][0] for p in PAIRS}
    return DpkmParameterLaws(
        {a: LinearLaw(dpkm.TABLE_3_1_DEAD_DISTANCE[a] - DEAD_SLOPE[a] * pivot[k], {a: DEAD_SLOPE[a]})
         for k, a in enumerate("abc")},
        {p: LinearLaw(dpkm.TABLE_3_1_BETA_DEG[p] - BETA_SLOPE[p] * pivot["abc".index(drivers[p])],
                      {drivers[p]: BETA_SLOPE[p]}) for p in PAIRS},
    )


def calibration_joints(laws: DpkmParameterLaws, lasers: np.ndarray) -> np.ndarray:
    """Joint centers (K, 3, 3) of a tetrahedron whose d and beta follow ``laws`` (tip at the origin)."""
    dead, beta = laws.evaluate(lasers)
    return np.array([
        dpkm.tetrahedron_directions(dict(zip(PAIRS, beta[k], strict=True))) * (lasers[k] + 60.0 + dead[k])[:, None]
        for k in range(len(lasers))
    ])


def process(log, laws: DpkmParameterLaws):
    return process_log_dpkm(log, column_points=COLUMNS, initial_heights=H0, parameter_laws=laws)


@pytest.fixture(scope="module")
def log_lasers_mid() -> np.ndarray:
    """Mid readings of the test log on the constant (Table 3.1) machine: where the variable laws pivot."""
    hint = RigidBodyMachine.from_dpkm().forward(heights=H0).lasers
    constant = DpkmParameterLaws.constant(dpkm.TABLE_3_1_DEAD_DISTANCE, dpkm.TABLE_3_1_BETA_DEG)
    log, _, _ = synthesise_log_dpkm(constant, COLUMNS, H0, moves(), lasers_hint=hint)
    return log.lasers.mean(axis=0)


def test_machine_with_linearly_varying_parameters(log_lasers_mid) -> None:
    """Constructed truth: d and beta truly linear in the lasers; the variable model recovers the tip, constants not."""
    truth = thesis_like_laws(log_lasers_mid)
    log, heights, tips = synthesise_log_dpkm(truth, COLUMNS, H0, moves(), lasers_hint=log_lasers_mid)
    variable = process(log, truth)
    assert np.abs(variable.tips - tips).max() < 1e-6 and np.abs(variable.heights - heights).max() < 1e-6
    constant = process(log, truth.at(log.lasers.mean(axis=0)))  # the best constants: the laws at mid-log readings
    assert np.abs(constant.tips - tips).max() > 0.5  # 1.8 mm

    # the laws come back from two calibration positions (Appendix C's procedure) to rounding
    fit = fit_parameter_laws(calibration_joints(truth, CALIBRATION_LASERS), np.zeros(3), CALIBRATION_LASERS)
    for arm in "abc":
        assert fit.laws.dead_distance[arm].slopes == pytest.approx({arm: DEAD_SLOPE[arm]}, abs=1e-12)
    for pair in PAIRS:
        assert fit.laws.beta_deg[pair].slopes == pytest.approx({THESIS_BETA_DRIVERS[pair][0]: BETA_SLOPE[pair]},
                                                               abs=1e-12)
    np.testing.assert_allclose(fit.dead_distance_nonlinearity, 0.0, atol=1e-12)
    assert np.abs(process(log, fit.laws).tips - tips).max() < 1e-6
    # the thesis' averages over the calibration positions (readings 1.8-139 mm) are far from this log's
    # readings (47-82 mm): the pair equations have no real root (the seed's "complex values", thesis 5.3)
    with pytest.raises(NoRealSolutionError):
        process(log, fit.constant)


def test_machine_with_constant_parameters(log_lasers_mid) -> None:
    """The other way round: constants recover the tip; Appendix C's slopes put it off."""
    constant = DpkmParameterLaws.constant(dpkm.TABLE_3_1_DEAD_DISTANCE, dpkm.TABLE_3_1_BETA_DEG)
    log, _, tips = synthesise_log_dpkm(constant, COLUMNS, H0, moves(), lasers_hint=log_lasers_mid)
    assert np.abs(process(log, constant).tips - tips).max() < 1e-6
    wrong = process(log, thesis_like_laws(log.lasers.mean(axis=0)))  # equal to the constants at mid-log readings
    assert np.abs(wrong.tips - tips).max() > 0.5  # 2.0 mm
    # fitted from exact calibration data, the slopes vanish and the laws are the constants
    fit = fit_parameter_laws(calibration_joints(constant, CALIBRATION_LASERS), np.zeros(3), CALIBRATION_LASERS)
    slopes = [v for law in (*fit.laws.dead_distance.values(), *fit.laws.beta_deg.values()) for v in law.slopes.values()]
    assert np.abs(slopes).max() < 1e-12
    assert np.abs(process(log, fit.laws).tips - tips).max() < 1e-6


def test_appendix_c_laws_are_reproduced_from_the_rebuilt_calibration() -> None:
    """Appendix C lines 93-144: the 15-digit line coefficients from the joint centers, tip and lasers."""
    rebuilt = reconstruct_appendix_cd()
    fit = fit_parameter_laws(rebuilt.centers, rebuilt.tip, rebuilt.lasers)
    np.testing.assert_allclose([fit.laws.dead_distance[a].slopes[a] for a in "abc"], APPENDIX_C["dead_slope"],
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose([fit.laws.dead_distance[a].intercept for a in "abc"], APPENDIX_C["dead_intercept"],
                               rtol=0, atol=1e-7)
    np.testing.assert_allclose([fit.laws.beta_deg[p].slopes[THESIS_BETA_DRIVERS[p][0]] for p in PAIRS],
                               APPENDIX_C["beta_slope"], rtol=0, atol=1e-9)
    np.testing.assert_allclose([fit.laws.beta_deg[p].intercept for p in PAIRS], APPENDIX_C["beta_intercept"],
                               rtol=0, atol=1e-7)
    # Table 7.1's d_i and beta_in are the averages of the two positions (Appendix D, D1 and Beta row 3)
    np.testing.assert_allclose([fit.constant.dead_distance[a].intercept for a in "abc"],
                               [314.48, 312.74, 309.42], atol=0.005)
    np.testing.assert_allclose([fit.constant.beta_deg[p].intercept for p in PAIRS], [68.25, 69.03, 68.70], atol=0.005)


def test_laws_from_a_tetrahedron_calibration_agree_with_the_fit() -> None:
    """Two implementations (calibration's Appendix C lines and fit_parameter_laws) on the bundled Appendix C/D data."""
    from pcmm_geo.machine.calibration import calibrate_tetrahedron
    from pcmm_geo.machine.calibration.seed import appendix_cd_files

    export, lasers = appendix_cd_files()
    calibration = calibrate_tetrahedron(export, lasers)
    laws = DpkmParameterLaws.from_calibration(calibration)
    fit = fit_parameter_laws(np.stack([[s.center for s in calibration.joint_spheres[a]] for a in "abc"], axis=1),
                             calibration.tip_center, calibration.lasers)
    readings = np.array([[10.0, 20.0, 30.0], [50.0, 140.0, 120.0]])
    np.testing.assert_allclose(laws.evaluate(readings)[0], fit.laws.evaluate(readings)[0], atol=1e-9)
    np.testing.assert_allclose(laws.evaluate(readings)[1], fit.laws.evaluate(readings)[1], atol=1e-9)
    constant = DpkmParameterLaws.from_calibration(calibration, variable=False)
    assert constant.is_constant
    np.testing.assert_allclose(constant.evaluate(readings)[0][0], [calibration.dead_distance[a] for a in "abc"])
    with pytest.raises(InvalidInputError, match="calibration"):
        DpkmParameterLaws.from_calibration(object())


def test_dead_distance_is_not_linear_along_a_slider_line_that_misses_the_tip() -> None:
    """Thesis 7.2: with the rebuilt joints moving on their slider lines, d(l) bends away from the two-point line."""
    rebuilt = reconstruct_appendix_cd()
    first, second = rebuilt.centers
    high, low = rebuilt.lasers
    share = np.linspace(0.0, 1.0, 8)[:, None]
    lasers = low + share * (high - low)
    joints = second[None] + share[..., None] * (first - second)[None]
    fit = fit_parameter_laws(joints, rebuilt.tip, lasers)
    assert fit.dead_distance_nonlinearity.max() > 1e-3  # 8.9 um RMS on arm b
    assert fit.dead_distance_nonlinearity.max() < 0.05
    # and each angle depends on both of its arms' readings, not only on the one Appendix C drives it by
    middle = (high + low) / 2

    def angles(readings: np.ndarray) -> np.ndarray:
        on_lines = second + ((readings - low) / (high - low))[:, None] * (first - second)
        return parameter_samples(on_lines[None], rebuilt.tip, readings[None])[1][0]

    beta_mid = angles(middle)[None]
    beta_moved = angles(middle + np.array([10.0, 0.0, 0.0]))[None]  # only laser a changes
    change_ab = float(beta_moved[0, 0] - beta_mid[0, 0])
    assert abs(change_ab) > 0.05  # 0.11 degrees, while the law of beta_ab (driven by l_b) stays put


@pytest.mark.parametrize("pair", list(TABLE_8_1))
def test_table_8_error_rows_are_calculated_minus_measured(pair: str) -> None:
    """What of Table 8.2 is reproducible: its Error row from its Calculated row and Table 8.1's Measured row."""
    error_8_1, error_8_2 = table_8_errors()[pair]
    assert error_8_1 == pytest.approx(TABLE_8_1[pair][2], abs=0.0101)  # printed values are rounded to 0.01
    assert error_8_2 == pytest.approx(TABLE_8_2[pair][1], abs=0.0101)
    assert error_8_2 > error_8_1  # "the error showing an increase for all measurement points"


def test_bad_input() -> None:
    with pytest.raises(InvalidInputError, match="slopes"):
        LinearLaw(1.0, {"d": 0.0})
    with pytest.raises(InvalidInputError, match="slopes"):
        LinearLaw(1.0, {"a": float("nan")})
    with pytest.raises(InvalidInputError, match="beta_deg"):
        DpkmParameterLaws({a: LinearLaw(300.0) for a in "abc"}, {"ab": LinearLaw(68.0, {"b": 0.0})})
    joints = calibration_joints(DpkmParameterLaws.constant(dpkm.TABLE_3_1_DEAD_DISTANCE, dpkm.TABLE_3_1_BETA_DEG),
                                CALIBRATION_LASERS)
    with pytest.raises(InvalidInputError, match="d_a"):
        fit_parameter_laws(joints[:1], np.zeros(3), CALIBRATION_LASERS[:1])
    with pytest.raises(InvalidInputError, match="d_a"):
        fit_parameter_laws(joints, np.zeros(3), np.array([[50.0, 1.0, 2.0], [50.0, 3.0, 4.0]]))
    with pytest.raises(InvalidInputError, match="beta_ab"):  # two positions cannot separate l_a from l_b
        fit_parameter_laws(joints, np.zeros(3), CALIBRATION_LASERS, beta_drivers=BOTH_ARMS_BETA_DRIVERS)
    with pytest.raises(InvalidInputError, match="shapes"):
        parameter_samples(joints[0], np.zeros(3), CALIBRATION_LASERS)
    with pytest.raises(InvalidInputError, match="dead_distance/beta_deg"):
        process_log_dpkm(synthesise_log_dpkm(
            DpkmParameterLaws.constant(dpkm.TABLE_3_1_DEAD_DISTANCE, dpkm.TABLE_3_1_BETA_DEG), COLUMNS, H0,
            [(1, 2.0, True)], lasers_hint=RigidBodyMachine.from_dpkm().forward(heights=H0).lasers)[0],
            column_points=COLUMNS, initial_heights=H0)


def offset_line_machine() -> RigidBodyMachine:
    """The seed geometry with its slider lines moved 3-6 mm off the tip (the calibrated tetrahedron's flaw, 7.2)."""
    from pcmm_geo.machine.kinematics.model import SliderLine, Tetrahedron

    seed = RigidBodyMachine.from_dpkm()
    sliders = {}
    for arm, line in seed.tetrahedron.sliders.items():
        side = np.cross(line.direction, [0.0, 0.0, 1.0])
        side /= np.linalg.norm(side)
        up = np.cross(line.direction, side)
        offset = {"a": 3.0 * side, "b": -6.0 * up + 2.0 * side, "c": 5.0 * up}[arm]
        sliders[arm] = SliderLine(line.point + offset, line.direction, line.laser_scale, line.laser_offset)
    return RigidBodyMachine(Tetrahedron(sliders, seed.tetrahedron.tip_center), seed.columns,
                            reference_lasers=seed.reference_lasers, reference_heights=seed.reference_heights)


def test_slider_lines_that_miss_the_tip() -> None:
    """Truth: a rigid tetrahedron whose slider lines miss the tip, processed by the DPKM with each parameter model.

    Single-driver laws (Appendix C) are worse than constants -- Table 8.2's finding -- because an
    angle between two arms changes with both readings; laws driven by both arms' readings and
    fitted over the log's range are 40x better than constants; the rigid-body model is exact.
    """
    from pcmm_geo.machine.analysis.logproc import process_log, synthesise_log

    machine = offset_line_machine()
    tip = machine.tetrahedron.tip_center
    log_moves = moves(seed=3)
    log = synthesise_log(machine, H0, log_moves)
    states = [H0]
    for motor, change, _ in log_moves:
        after = states[-1].copy()
        after[motor - 1] += change
        states += [states[-1], after]
    truth = machine.forward(heights=np.array(states[1:])).tip

    def dpkm_error(laws: DpkmParameterLaws) -> float:
        return float(np.abs(process(log, laws).tips - truth).max())

    assert np.abs(process_log(machine, log, initial_heights=H0).tips - truth).max() < 1e-6
    thesis = fit_parameter_laws(machine.joints(CALIBRATION_LASERS), tip, CALIBRATION_LASERS)
    assert dpkm_error(thesis.laws) > 2.0 * dpkm_error(thesis.constant) > 2.0  # 7.7 mm against 2.6 mm
    low, high = log.lasers.min(axis=0), log.lasers.max(axis=0)
    grid = np.stack(np.meshgrid(*[np.linspace(low[k], high[k], 3) for k in range(3)], indexing="ij"), -1).reshape(-1, 3)
    single = fit_parameter_laws(machine.joints(grid), tip, grid)
    both = fit_parameter_laws(machine.joints(grid), tip, grid, beta_drivers=BOTH_ARMS_BETA_DRIVERS)
    assert dpkm_error(single.laws) > dpkm_error(single.constant) > 0.1  # 0.49 mm against 0.28 mm
    assert dpkm_error(both.laws) < dpkm_error(both.constant) / 10.0  # 0.007 mm against 0.28 mm
    assert both.beta_nonlinearity.max() < 1e-4 < single.beta_nonlinearity.max()  # degrees
