"""Table 3.2 log processing: synthesised logs back to their probe points, CSV format checks."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.errors import FileFormatError, IllConditionedWarning, InvalidInputError, OutputExistsError
from pcmm_geo.machine.analysis.logproc import (
    LOG_COLUMNS,
    MeasurementLog,
    process_log,
    process_log_dpkm,
    read_log,
    synthesise_log,
    write_log,
)
from pcmm_geo.machine.kinematics.model import RigidBodyMachine

APPENDIX_E_SLOPES = {"a": (0.0075, 0.0201), "b": (0.0082, 0.0192), "c": (0.0069, 0.0153)}


def moves_and_truth(h0: np.ndarray, seed: int = 0, count: int = 40):
    rng = np.random.default_rng(seed)
    moves = [(int(rng.integers(1, 4)), float(rng.uniform(-10, 10)), bool(rng.random() < 0.3)) for _ in range(count)]
    states = []
    current = h0.copy()
    for motor, change, _ in moves:
        states.append(current.copy())  # start row: before the move
        current = current.copy()
        current[motor - 1] += change
        states.append(current.copy())  # stop row
    return moves, np.array(states)


@pytest.mark.parametrize("slopes", [None, APPENDIX_E_SLOPES])
def test_round_trip_synthesised_log(slopes) -> None:
    machine = RigidBodyMachine.from_dpkm(column_slopes=slopes)
    h0 = machine.reference_heights + np.array([0.0, 60.0, -50.0])  # away from the level (singular) pose
    moves, heights = moves_and_truth(h0)
    log = synthesise_log(machine, h0, moves)
    assert len(log) == 2 * len(moves)
    np.testing.assert_array_equal(log.start_stop[:4], [1, 0, 1, 0])
    # slanted columns too: the datum holds all three start heights
    out = process_log(machine, log, initial_heights=h0)
    truth_tips = machine.forward(heights=heights).tip
    assert np.abs(out.heights - heights).max() < 1e-6
    assert np.abs(out.tips - truth_tips).max() < 1e-6
    expected_probe_rows = [2 * k + 1 for k, move in enumerate(moves) if move[2]]
    np.testing.assert_array_equal(out.probe_rows, expected_probe_rows)
    np.testing.assert_allclose(out.probe_points, truth_tips[expected_probe_rows], atol=1e-6)
    assert out.direction_consistent.all() and out.converged.all()
    # start rows repeat the previous stop row's lasers exactly: heights are copied
    assert np.all(out.moved_arm[2::2] == -1)
    np.testing.assert_array_equal(out.moved_arm[1::2], [m[0] - 1 for m in moves])


def test_unsettled_stop_row_is_completed_by_the_next_start_row() -> None:
    machine = RigidBodyMachine.from_dpkm()
    h0 = machine.reference_heights + np.array([0.0, 60.0, -50.0])
    moves = [(2, 8.0, False), (3, -6.0, True)]
    log = synthesise_log(machine, h0, moves)
    # the stop row of move 1 was saved before the machine settled: lasers of 75 % of the move
    partial = h0 + np.array([0.0, 6.0, 0.0])
    lasers = log.lasers.copy()
    lasers[1] = machine.forward(heights=partial).lasers
    unsettled = MeasurementLog(log.start_stop, log.probe, log.motor, log.direction, lasers)
    out = process_log(machine, unsettled, initial_heights=h0)
    np.testing.assert_allclose(out.heights[1], partial, atol=1e-6)
    # the start row (lasers differ from the stop row) re-solves motor 2 (the previous row's motor)
    assert out.moved_arm[2] == 1
    np.testing.assert_allclose(out.heights[2], h0 + np.array([0.0, 8.0, 0.0]), atol=1e-6)
    np.testing.assert_allclose(out.heights[3], h0 + np.array([0.0, 8.0, -6.0]), atol=1e-6)


def test_direction_flag_is_checked() -> None:
    machine = RigidBodyMachine.from_dpkm()
    h0 = machine.reference_heights + np.array([0.0, 60.0, -50.0])
    log = synthesise_log(machine, h0, [(1, 5.0, False), (2, -5.0, False)])
    wrong = log.direction.copy()
    wrong[3] = 1  # motor 2 went down but the row says up
    flipped = MeasurementLog(log.start_stop, log.probe, log.motor, wrong, log.lasers)
    with pytest.warns(IllConditionedWarning, match="1 of 4 log rows stand on a height that moved against"):
        out = process_log(machine, flipped, initial_heights=h0)
    np.testing.assert_array_equal(out.direction_consistent, [True, True, True, False])
    # issue 22: a contradicted direction means a wrong branch or a wrong flag: no bound is stated
    assert np.isinf(out.bound[3]) and np.all(np.isfinite(out.bound[:3]))


def test_csv_round_trip(tmp_path: Path) -> None:
    machine = RigidBodyMachine.from_dpkm()
    h0 = machine.reference_heights + np.array([0.0, 60.0, -50.0])
    moves, heights = moves_and_truth(h0, seed=3, count=10)
    log = synthesise_log(machine, h0, moves)
    path = write_log(tmp_path / "log.csv", log)
    assert path.read_text().splitlines()[0] == ",".join(LOG_COLUMNS)
    again = read_log(path)
    np.testing.assert_array_equal(again.motor, log.motor)
    np.testing.assert_allclose(again.lasers, log.lasers, atol=1e-9)
    out = process_log(machine, again, initial_heights=h0)
    assert np.abs(out.tips - machine.forward(heights=heights).tip).max() < 1e-6
    with pytest.raises(OutputExistsError, match="exists"):
        write_log(path, log)
    write_log(path, log, overwrite=True)


@pytest.mark.parametrize(
    ("text", "line", "match"),
    [
        ("1,0,1,1,50,51\n", 1, "header"),  # 7 numbers would be a headerless seed log
        ("start_stop,probe,motor,direction,laser_a,laser_b,laser_c\n1,0,1,1,50,51\n", 2, "7 fields"),
        ("start_stop,probe,motor,direction,laser_a,laser_b,laser_c\n1,0,1,1,50,51,52\n0,0,4,1,50,51,52\n", 3, "motor"),
        ("start_stop,probe,motor,direction,laser_a,laser_b,laser_c\n1,0,1,1,5x,51,52\n", 2, "laser_a: expected a"),
        ("start_stop,probe,motor,direction,laser_a,laser_b,laser_c\n1,0,1,2,50,51,52\n", 2, "direction"),
        ("start_stop,probe,motor,direction,laser_a,laser_b,laser_c\n1,0,1,1,nan,51,52\n", 2, "finite"),
    ],
)
def test_malformed_logs(tmp_path: Path, text: str, line: int, match: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(FileFormatError, match=match) as info:
        read_log(path)
    assert info.value.line == line


def test_empty_log_and_bad_arrays(tmp_path: Path) -> None:
    path = tmp_path / "empty.csv"
    path.write_text(",".join(LOG_COLUMNS) + "\n")
    with pytest.raises(FileFormatError, match="none"):
        read_log(path)
    with pytest.raises(InvalidInputError, match="motor"):
        MeasurementLog([1], [0], [5], [1], [[1.0, 2.0, 3.0]])
    with pytest.raises(InvalidInputError, match="motor"):
        synthesise_log(RigidBodyMachine.from_dpkm(), [400.0] * 3, [(0, 1.0, False)])


def seed_processing(log, h0, sign_rule="continuity"):
    from pcmm_geo.machine.kinematics import dpkm

    return process_log_dpkm(
        log, dead_distance=dpkm.TABLE_3_1_DEAD_DISTANCE, beta_deg=dpkm.TABLE_3_1_BETA_DEG,
        column_points=dpkm.APPENDIX_D_COLUMN_POINTS, initial_heights=h0, sign_rule=sign_rule,
    )


def test_seed_pair_formula_processing_agrees_with_rigid_body() -> None:
    machine = RigidBodyMachine.from_dpkm()  # seed geometry: lines meet at the tip, vertical columns
    h0 = machine.reference_heights + np.array([0.0, 60.0, -50.0])
    moves, heights = moves_and_truth(h0, seed=5, count=30)
    log = synthesise_log(machine, h0, moves)
    seed = seed_processing(log, h0)
    rigid = process_log(machine, log, initial_heights=h0)
    assert np.abs(seed.heights - heights).max() < 1e-9
    assert np.abs(seed.tips - rigid.tips).max() < 1e-9
    assert np.abs(seed.residuals).max() < 1e-9  # redundant laser pairs close


def test_seed_direction_rule_fails_when_pivot_stays_above_its_neighbour() -> None:
    machine = RigidBodyMachine.from_dpkm()
    h0 = machine.reference_heights + np.array([0.0, 60.0, -50.0])  # pivot b 60 mm above pivot a
    log = synthesise_log(machine, h0, [(2, -5.0, True)])  # b moves down but stays 55 mm above a
    truth = h0 + np.array([0.0, -5.0, 0.0])
    np.testing.assert_allclose(seed_processing(log, h0).heights[-1], truth, atol=1e-9)
    wrong = seed_processing(log, h0, sign_rule="seed_direction").heights[-1]
    # the seed's rule puts b 55 mm *below* a: a 110 mm error
    assert wrong[1] == pytest.approx(h0[0] - 55.0, abs=1e-6)
    with pytest.raises(InvalidInputError, match="sign_rule"):
        seed_processing(log, h0, sign_rule="other")


def test_read_log_accepts_acquisition_logs_with_metadata_and_extra_columns(tmp_path: Path) -> None:
    """A durable acquisition log (``# key: value`` header, raw-count columns) reads as Table 3.2."""
    from pcmm_runner import run_pcmm

    out = tmp_path / "run.csv"
    run_pcmm("acquire", "--simulate", "--moves", "4", "--settle", "0", "--seed", "3", "--out", out).check_returncode()
    text = out.read_text()
    data_lines = [line for line in text.splitlines()[1:] if line and not line.startswith("#")]
    log = read_log(out)
    assert text.startswith("#")
    assert len(log.lasers) == len(data_lines) - 1  # minus the header row
    first = data_lines[1].split(",")
    np.testing.assert_array_equal(log.lasers[0], [float(v) for v in first[4:7]])
    assert int(log.motor[0]) == int(first[2])
