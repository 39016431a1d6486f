"""Height per laser displacement (thesis 6.3, eqs 6.1-6.3, Table 6.8): the printed table's statistics,
the model's prediction against an independent law-of-cosines solution, model-generated records of
known ratio read through the height-gauge reader, and the reading-uncertainty model."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import fsolve, minimize

from pcmm_geo.errors import FileFormatError, InvalidInputError
from pcmm_geo.machine.analysis.laser_ratio import ReadingLimits, laser_height_ratio, split_runs
from pcmm_geo.machine.analysis.laser_ratio_model import (
    SimpleRecord,
    predict_arm,
    predicted_height_per_laser,
    ratio_table_summary,
    read_ratio_table_csv,
    synthesise_ratio_record,
)
from pcmm_geo.machine.calibration.numerical.numcal_data import read_numcal_csv
from pcmm_geo.machine.kinematics.model import RigidBodyMachine

EXAMPLES = Path(__file__).resolve().parents[2] / "pcmm_geo" / "data" / "examples"
#: thesis Table 6.8: delta_h / delta_l of five runs (rows) per arm a, b, c; printed sigma row
TABLE_6_8 = np.array([[5.03, 6.20, 5.53], [5.12, 6.31, 5.58], [5.39, 6.34, 5.61], [5.39, 6.30, 5.58],
                      [5.56, 6.41, 5.65]])
TABLE_6_8_SIGMA = (0.20, 0.07, 0.04)
HALF_STEP = 0.005  # the table prints to 0.01


def _sigma_interval(values: np.ndarray, ddof: int) -> tuple[float, float]:
    """Smallest and largest sigma of values each anywhere within +-HALF_STEP of the printed ones.

    The variance is convex in the values: its maximum over the box is at a vertex, its minimum
    is found by a bounded local minimisation (any local minimum of a convex function is global)."""
    largest = max(np.std(values + np.array(signs) * HALF_STEP, ddof=ddof)
                  for signs in itertools.product((-1.0, 1.0), repeat=len(values)))
    found = minimize(lambda x: np.var(x, ddof=ddof), values, bounds=[(v - HALF_STEP, v + HALF_STEP) for v in values],
                     method="L-BFGS-B", options={"ftol": 1e-15, "gtol": 1e-12})
    return float(np.sqrt(found.fun)), float(largest)


def test_table_6_8_sigma_row_is_the_population_sigma() -> None:
    summary = ratio_table_summary(TABLE_6_8)
    population = [round(arm.sigma_population, 2) for arm in summary.arms]
    sample = [round(arm.sigma_sample, 2) for arm in summary.arms]
    # from the printed (rounded) ratios neither convention gives the printed row digit for digit
    assert population == [0.19, 0.07, 0.04]  # 0.1945 for arm a
    assert sample == [0.22, 0.08, 0.04]
    # allowing every printed ratio its +-0.005 of rounding, only the population sigma can print as 0.20 0.07 0.04
    for k, printed in enumerate(TABLE_6_8_SIGMA):
        low, high = _sigma_interval(TABLE_6_8[:, k], ddof=0)
        assert low <= printed + HALF_STEP and high >= printed - HALF_STEP, (k, low, high)
    low, high = _sigma_interval(TABLE_6_8[:, 0], ddof=1)
    assert low > TABLE_6_8_SIGMA[0] + HALF_STEP  # sample sigma of arm a is at least 0.212: cannot print as 0.20
    assert summary.arms[0].mean == pytest.approx(5.298, abs=1e-12)
    assert summary.arms[1].mean == pytest.approx(6.312, abs=1e-12)


def test_bundled_table_6_8_is_the_printed_table() -> None:
    labels, ratios = read_ratio_table_csv(EXAMPLES / "laser_ratio_table_6_8.csv")
    np.testing.assert_allclose(ratios, TABLE_6_8, atol=1e-12)
    assert labels == ("1", "2", "3", "4", "5")


def _law_of_cosines_lasers(machine: RigidBodyMachine, heights: np.ndarray) -> np.ndarray:
    """Laser readings of the seed geometry (arms from the tip, vertical columns) from the three
    pivot distances: |P_i - P_j|^2 = L_i^2 + L_j^2 - 2 L_i L_j cos(beta_ij), solved with fsolve."""
    sliders = [machine.tetrahedron.sliders[arm] for arm in "abc"]
    offsets = np.array([s.laser_offset for s in sliders])
    directions = np.array([s.direction for s in sliders])
    pivots = np.array([machine.columns[arm].point for arm in "abc"], dtype=float)
    pivots[:, 2] = heights
    pairs = ((0, 1), (1, 2), (2, 0))

    def closure(lengths: np.ndarray) -> list[float]:
        return [lengths[i] ** 2 + lengths[j] ** 2 - 2 * lengths[i] * lengths[j] * directions[i] @ directions[j]
                - np.sum((pivots[i] - pivots[j]) ** 2) for i, j in pairs]

    lengths, _, status, message = fsolve(closure, machine.reference_lasers + offsets, xtol=1e-13, full_output=True)
    assert status == 1, message
    return lengths - offsets


def test_model_prediction_matches_an_independent_law_of_cosines_solution() -> None:
    machine = RigidBodyMachine.from_dpkm()
    level = machine.reference_heights
    start = _law_of_cosines_lasers(machine, level)
    for k, arm in enumerate("abc"):
        for rise in (25.0, 60.0, 100.0):
            raised = level.copy()
            raised[k] += rise
            finish = _law_of_cosines_lasers(machine, raised)
            expected = (0.0 - rise) / (start[k] - finish[k])
            got = float(predicted_height_per_laser(machine, arm, 0.0, rise))
            assert got == pytest.approx(expected, rel=1e-8), (arm, rise)
    # the geometry alone makes the arms differ by about 6 % for a 100 mm rise from level
    ratios = [float(predicted_height_per_laser(machine, arm, 0.0, 100.0)) for arm in "abc"]
    assert ratios == pytest.approx([5.2389, 5.2872, 5.5531], abs=5e-4)


def _write_numcal_csv(path: Path, record: SimpleRecord) -> Path:
    lines = ["moved,laser_a,laser_b,laser_c,height"]
    lines += [f"{arm},{row[0]!r},{row[1]!r},{row[2]!r},{height!r}"
              for arm, row, height in zip(record.moved, record.lasers.tolist(), record.heights.tolist(), strict=True)]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_exact_model_record_read_through_the_height_gauge_reader(tmp_path: Path) -> None:
    travels = [100.0, 98.5, 101.2, 99.0, 100.7]
    record = synthesise_ratio_record(travel=travels)
    data = read_numcal_csv(_write_numcal_csv(tmp_path / "ratio.csv", record))
    result = laser_height_ratio(data)
    assert [(r.arm, r.test) for r in result.runs] == [(arm, t) for arm in "abc" for t in range(1, 6)]
    machine = RigidBodyMachine.from_dpkm()
    for run in result.runs:
        assert run.height_change == pytest.approx(-travels[run.test - 1], abs=1e-12)  # eq 6.2: h_s - h_f
        assert run.laser_change == pytest.approx(run.laser_start - run.laser_finish, abs=1e-15)  # eq 6.1
        assert run.height_per_laser == pytest.approx(run.predicted, rel=1e-9)
        expected = _law_of_cosines_ratio(machine, run.arm, travels[run.test - 1])
        assert run.height_per_laser == pytest.approx(expected, rel=1e-8)
    # five different travels give five different ratios: about -0.05 per mm of extra travel
    arm_a = result.arms[0]
    assert arm_a.count == 5 and arm_a.unit == "1"
    assert arm_a.range == pytest.approx(abs(result.predictions[0].per_mm_travel) * (101.2 - 98.5), rel=0.05)
    assert result.predicted_spread == pytest.approx(5.5531 - 5.2389, abs=0.02)


def _law_of_cosines_ratio(machine: RigidBodyMachine, arm: str, rise: float) -> float:
    k = "abc".index(arm)
    raised = machine.reference_heights.copy()
    raised[k] += rise
    start = _law_of_cosines_lasers(machine, machine.reference_heights)
    return -rise / (start[k] - _law_of_cosines_lasers(machine, raised)[k])


def test_laser_quantisation_stays_within_its_bound_and_matches_its_uncertainty() -> None:
    """Heights on the 0.01 mm grid (no height error), lasers rounded to their output step: the
    ratio error is bounded by |dh| q_l / dl^2 and its spread matches the resolution model."""
    rng = np.random.default_rng(11)
    runs = 120
    travels = np.round(rng.uniform(95.0, 105.0, runs), 2)
    offsets = rng.uniform(0.0, 0.05, (runs, 3))  # shifts both rows of a run: delta_l unchanged, rounding randomised
    limits = ReadingLimits()
    record = synthesise_ratio_record(travel=travels, runs_per_arm=runs, start_offsets=offsets,
                                     laser_resolution=limits.laser_resolution)
    result = laser_height_ratio(record)
    assert len(result.runs) == 3 * runs
    for arm_index, arm in enumerate("abc"):
        chosen = [r for r in result.runs if r.arm == arm]
        q_l = limits.laser_resolution[arm_index]
        errors = np.array([r.height_per_laser - r.predicted for r in chosen])
        bounds = np.array([abs(r.height_change) * q_l / (abs(r.laser_change) - q_l) ** 2 for r in chosen])
        assert np.all(np.abs(errors) <= bounds)
        laser_part = np.array([abs(r.height_change) * np.sqrt(2) * q_l / np.sqrt(12) / r.laser_change**2
                               for r in chosen])
        assert np.std(errors / laser_part) == pytest.approx(1.0, abs=0.2)
        assert all(r.u_resolution >= lp for r, lp in zip(chosen, laser_part, strict=True))


def test_ratio_uncertainty_closed_form() -> None:
    limits = ReadingLimits(height_resolution=0.01, height_accuracy=0.01, laser_resolution=(0.02, 0.02, 0.02),
                           laser_accuracy=0.05)
    record = SimpleRecord(("a", "a"), np.array([[30.0, 40.0, 50.0], [50.0, 40.0, 50.0]]), np.array([0.0, 100.0]))
    (run,) = laser_height_ratio(record, limits=limits).runs
    assert run.height_per_laser == pytest.approx(5.0)  # (0 - 100) / (30 - 50)
    u_h, u_l = np.sqrt(2) * 0.01 / np.sqrt(12), np.sqrt(2) * 0.02 / np.sqrt(12)
    assert run.u_resolution == pytest.approx(np.hypot(u_h / 20, 100 * u_l / 400), rel=1e-12)
    a_h, a_l = np.sqrt(2) * 0.01 / np.sqrt(3), np.sqrt(2) * 0.05 / np.sqrt(3)
    assert run.u_accuracy == pytest.approx(np.hypot(a_h / 20, 100 * a_l / 400), rel=1e-12)
    assert run.u_accuracy == pytest.approx(0.0102, abs=1e-4)


def test_a_start_laser_offset_moves_the_ratio_as_predicted() -> None:
    record = synthesise_ratio_record(travel=100.0, runs_per_arm=1)
    lasers = record.lasers.copy()
    epsilon = 0.02
    lasers[0, 0] += epsilon  # the start reading of arm a's run settles 0.02 mm off
    shifted = laser_height_ratio(SimpleRecord(record.moved, lasers, record.heights))
    exact = laser_height_ratio(record)
    change = shifted.runs[0].height_per_laser - exact.runs[0].height_per_laser
    assert change == pytest.approx(exact.predictions[0].per_mm_start_laser * epsilon, rel=0.01)
    # Table 6.7's 0.45 mm start scatter is worth about 0.12 in the ratio of a 100 mm run
    assert exact.predictions[0].per_mm_start_laser * 0.45 == pytest.approx(0.12, abs=0.01)


def test_prediction_per_mm_travel_is_a_derivative() -> None:
    machine = RigidBodyMachine.from_dpkm()
    prediction = predict_arm(machine, "b", 0.0, 100.0)
    fine = (predicted_height_per_laser(machine, "b", 0.0, 100.01) - predicted_height_per_laser(machine, "b", 0.0,
                                                                                                99.99)) / 0.02
    assert prediction.per_mm_travel == pytest.approx(float(fine), rel=1e-4)
    shifted = (predicted_height_per_laser(machine, "b", 0.01, 100.01)
               - predicted_height_per_laser(machine, "b", -0.01, 99.99)) / 0.02
    assert prediction.per_mm_start_height == pytest.approx(float(shifted), rel=1e-3)
    # level is not the extreme of the ratio: a start 1 mm below level raises the ratio by about 0.1
    assert prediction.per_mm_start_height == pytest.approx(-0.1, abs=0.02)


def test_runs_are_split_at_direction_reversals_and_arm_changes() -> None:
    assert split_runs(["a"] * 4 + ["b"] * 2, [0, 100, 0.01, 99.99, 0, 100]) == [("a", 0, 1), ("a", 2, 3),
                                                                               ("b", 4, 5)]
    assert split_runs(["c"] * 4, [0, 0, 50, 100]) == [("c", 0, 3)]  # a zero step continues the run
    with pytest.raises(InvalidInputError, match="single row"):
        split_runs(["a", "a", "a", "b"], [0, 50, 100, 0])
    with pytest.raises(InvalidInputError, match="height change"):
        split_runs(["a", "a"], [5.0, 5.0])


def test_bad_records_are_refused(tmp_path: Path) -> None:
    flat = SimpleRecord(("a", "a"), np.array([[30.0, 40.0, 50.0], [30.005, 40.0, 50.0]]), np.array([0.0, 3.0]))
    with pytest.raises(InvalidInputError, match="resolution"):  # inside the dead spot: eq 6.3 undefined
        laser_height_ratio(flat)
    with pytest.raises(InvalidInputError):
        laser_height_ratio(SimpleRecord(("a", "a"), np.zeros((2, 2)), np.array([0.0, 1.0])))
    with pytest.raises(InvalidInputError, match="mirrored"):  # -50 and +50 mm give the same laser reading
        predicted_height_per_laser(RigidBodyMachine.from_dpkm(), "a", -50.0, 50.0)
    with pytest.raises(InvalidInputError, match="travel"):
        ratio_table_summary(TABLE_6_8, travel=-1.0)
    bad = tmp_path / "ratios.csv"
    bad.write_text("test,ratio_a,ratio_b\n1,5,6\n")
    with pytest.raises(FileFormatError, match="expected header"):
        read_ratio_table_csv(bad)
