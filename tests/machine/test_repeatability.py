"""Start-position repeatability (thesis 6.3, Tables 6.6 and 6.7) against the printed tables,
an independent statistics implementation and the simulator with a known settling scatter."""

from __future__ import annotations

import statistics
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.acquisition.acqlog import AcquisitionLog, LogRow
from pcmm_geo.acquisition.simulators.cmm import START_POSITION, SimulatedMicroCMM
from pcmm_geo.errors import FileFormatError, InvalidInputError, TooFewPointsError
from pcmm_geo.machine.analysis.logproc.rows import MeasurementLog, write_log
from pcmm_geo.machine.analysis.repeatability import (
    arm_statistics,
    read_start_readings_csv,
    start_readings_from_logs,
    start_repeatability,
)

EXAMPLES = Path(__file__).resolve().parents[2] / "pcmm_geo" / "data" / "examples"
#: thesis Table 6.6 (tests 1-3, no pre-sequence) and Table 6.7 (tests 1-6 after the pre-sequence), mm
TABLE_6_6 = np.array([[33.70, 33.51, 37.14], [33.41, 33.56, 37.08], [33.70, 33.51, 37.14]])
TABLE_6_7 = np.array([[34.11, 32.41, 37.65], [34.21, 32.17, 37.82], [34.11, 32.46, 37.67],
                      [34.26, 32.22, 37.78], [33.86, 32.17, 37.53], [33.86, 32.17, 37.50]])
TABLE_6_7_PRINTED_RANGE = (0.45, 0.29, 0.32)
PRINT_STEP = 0.01  # the tables print to 0.01 mm


def test_table_6_7_ranges_of_l_b_and_l_c_are_reproduced_l_a_is_not() -> None:
    result = start_repeatability(TABLE_6_7)
    ranges = [arm.range for arm in result.arms]
    # l_b and l_c: the printed range is max - min of the printed column (to rounding)
    assert ranges[1] == pytest.approx(TABLE_6_7_PRINTED_RANGE[1], abs=1e-9)
    assert ranges[2] == pytest.approx(TABLE_6_7_PRINTED_RANGE[2], abs=1e-9)
    # l_a: the printed column spans 33.86 .. 34.26 = 0.40 mm; the printed 0.45 is not max - min, and no
    # rounding of the printed values (+- 0.005 mm each) can widen 0.40 to 0.45
    assert ranges[0] == pytest.approx(0.40, abs=1e-9)
    assert ranges[0] + PRINT_STEP < TABLE_6_7_PRINTED_RANGE[0] - 1e-9


def test_table_6_7_sigma_conventions_match_an_independent_implementation() -> None:
    result = start_repeatability(TABLE_6_7)
    for k, arm in enumerate(result.arms):
        column = [float(v) for v in TABLE_6_7[:, k]]
        assert arm.sigma_sample == pytest.approx(statistics.stdev(column), rel=1e-12)
        assert arm.sigma_population == pytest.approx(statistics.pstdev(column), rel=1e-12)
        assert arm.mean == pytest.approx(statistics.fmean(column), rel=1e-14)
        assert arm.median == pytest.approx(statistics.median(column), rel=1e-14)
        assert arm.unit == "mm" and arm.count == 6
    # sample / population = sqrt(n / (n - 1))
    assert result.arms[0].sigma_sample / result.arms[0].sigma_population == pytest.approx(np.sqrt(6 / 5), rel=1e-12)


def test_table_6_6_flags_exactly_the_reading_the_thesis_names() -> None:
    result = start_repeatability(TABLE_6_6)
    assert result.outlier_limit == pytest.approx(0.10)
    assert [(f.test, f.arm, f.value) for f in result.flagged] == [("test 2", "a", 33.41)]
    assert result.flagged[0].deviation == pytest.approx(0.29, abs=1e-9)
    assert result.flagged[0].median == pytest.approx(33.70)
    # l_b 33.56 (0.05 from the median) and l_c 37.08 (0.06) are within what two readings of +-0.05 mm allow
    assert result.arms[1].largest_deviation == pytest.approx(0.05, abs=1e-9)
    assert result.arms[2].largest_deviation == pytest.approx(0.06, abs=1e-9)
    assert not result.within_accuracy
    # a tighter stated accuracy (+-0.02 mm, limit 0.04) flags l_b and l_c of test 2 too
    strict = start_repeatability(TABLE_6_6, laser_accuracy=0.02)
    assert [(f.test, f.arm) for f in strict.flagged] == [("test 2", "a"), ("test 2", "b"), ("test 2", "c")]


def test_table_6_7_scatter_exceeds_the_laser_accuracy() -> None:
    result = start_repeatability(TABLE_6_7)
    flagged = {(f.test, f.arm) for f in result.flagged}
    # l_a median 34.11: 34.26 (0.15) and the two 33.86 (0.25) are beyond 0.10 mm, 34.21 (0.10) is not
    assert {key for key in flagged if key[1] == "a"} == {("test 4", "a"), ("test 5", "a"), ("test 6", "a")}
    assert len(flagged) == 3 + 2 + 4


def test_the_bundled_tables_are_the_printed_values() -> None:
    six = read_start_readings_csv(EXAMPLES / "start_readings_table_6_6.csv")
    seven = read_start_readings_csv(EXAMPLES / "start_readings_table_6_7.csv")
    np.testing.assert_allclose(six.lasers, TABLE_6_6, atol=1e-12)
    np.testing.assert_allclose(seven.lasers, TABLE_6_7, atol=1e-12)
    assert seven.labels[0] == "test 1" and len(seven.labels) == 6


def test_simulated_settling_scatter_is_recovered() -> None:
    """SimulatedMicroCMM draws each laser's offset uniform in +-scatter/2 after every move: the
    population sigma tends to scatter / sqrt(12), the range to the scatter, the mean to the truth."""
    scatter, tests = 0.45, 300
    cmm = SimulatedMicroCMM(settle_scatter=scatter, seed=7)
    truth = cmm.true_lasers
    high, low = START_POSITION + 40_320, START_POSITION - 40_320
    readings = []
    for _ in range(tests):
        for motor in (1, 2, 3):  # the session's pre-sequence: start + span, start - span, start
            for start, target in ((START_POSITION, high), (high, low), (low, START_POSITION)):
                cmm.move(motor, start, target)
        readings.append([cmm.laser(k) for k in range(3)])
    np.testing.assert_allclose(cmm.true_lasers, truth, atol=1e-9)  # the rigid body returns to the same pose
    result = start_repeatability(readings)
    expected_sigma = scatter / np.sqrt(12.0)
    # relative standard error of a sigma estimate from n uniform values: 0.5 sqrt(0.8 / n) = 2.6 %; allow 4 of them
    for k, arm in enumerate(result.arms):
        assert arm.sigma_population == pytest.approx(expected_sigma, rel=0.105)
        assert scatter * 0.97 < arm.range <= scatter + 1e-12
        assert abs(arm.mean - truth[k]) < 4 * expected_sigma / np.sqrt(tests)
    assert result.flagged  # +-0.225 mm of scatter cannot hide under the 0.10 mm limit
    # a scatter below 2 x accuracy can never be flagged: every reading is within scatter of the median
    small = SimulatedMicroCMM(settle_scatter=0.08, seed=3)
    quiet = []
    for _ in range(40):
        small.move(1, START_POSITION, START_POSITION + 2000)
        small.move(1, START_POSITION + 2000, START_POSITION)
        quiet.append([small.laser(k) for k in range(3)])
    assert start_repeatability(quiet).flagged == ()


def _acquisition_log(path: Path, lasers: list[float], *, presequence: bool = True,
                     positions: tuple[int, int, int] = (START_POSITION,) * 3, start_stop: int = 1) -> Path:
    metadata = {"presequence": presequence, "start_position_usteps": START_POSITION}
    with AcquisitionLog.create(path, metadata) as log:
        log.append(LogRow(start_stop, 0, 2, 1, *lasers, pos_usteps=positions))
        log.append(LogRow(0, 0, 2, 1, lasers[0] + 1.0, lasers[1] - 1.0, lasers[2], pos_usteps=positions))
    return path


def test_start_rows_come_from_the_first_row_of_each_log(tmp_path: Path) -> None:
    paths = [_acquisition_log(tmp_path / f"run{k}.csv", list(TABLE_6_7[k])) for k in range(6)]
    found = start_readings_from_logs(paths)
    np.testing.assert_allclose(found.lasers, TABLE_6_7, atol=1e-12)
    assert found.presequence == (True,) * 6 and found.labels[0] == "run0.csv"
    # a Table 3.2 log (no positions, no metadata) gives its first row
    rows = MeasurementLog([1, 0], [0, 0], [1, 1], [1, 1], [TABLE_6_6[1], TABLE_6_6[0]])
    table = write_log(tmp_path / "t32.csv", rows)
    mixed = start_readings_from_logs([paths[0], table])
    np.testing.assert_allclose(mixed.lasers[1], TABLE_6_6[1], atol=1e-9)
    assert mixed.presequence == (True, None)


def test_logs_that_do_not_start_at_the_start_are_refused(tmp_path: Path) -> None:
    good = _acquisition_log(tmp_path / "good.csv", [34.0, 32.0, 37.0])
    moved = _acquisition_log(tmp_path / "moved.csv", [34.0, 32.0, 37.0], positions=(START_POSITION, 250_000,
                                                                                    START_POSITION))
    with pytest.raises(FileFormatError, match="not at the start position"):
        start_readings_from_logs([good, moved])
    stop = _acquisition_log(tmp_path / "stop.csv", [34.0, 32.0, 37.0], start_stop=0)
    with pytest.raises(FileFormatError, match="not a start reading"):
        start_readings_from_logs([good, stop])
    without = _acquisition_log(tmp_path / "without.csv", [34.0, 32.0, 37.0], presequence=False)
    with pytest.raises(InvalidInputError, match="pre-sequence"):
        start_readings_from_logs([good, without])
    with pytest.raises(TooFewPointsError):
        start_readings_from_logs([good])


def test_bad_inputs_are_typed_errors(tmp_path: Path) -> None:
    with pytest.raises(InvalidInputError, match=r"\(K, 3\)"):
        start_repeatability([[1.0, 2.0], [3.0, 4.0]])
    with pytest.raises(TooFewPointsError):
        start_repeatability([[1.0, 2.0, 3.0]])
    with pytest.raises(InvalidInputError, match="finite"):
        start_repeatability([[1.0, 2.0, 3.0], [1.0, np.nan, 3.0]])
    with pytest.raises(InvalidInputError, match="laser_accuracy"):
        start_repeatability(TABLE_6_7, laser_accuracy=0.0)
    with pytest.raises(InvalidInputError, match="labels"):
        start_repeatability(TABLE_6_7, labels=["x"])
    with pytest.raises(TooFewPointsError):
        arm_statistics([1.0], "a")
    bad = tmp_path / "bad.csv"
    bad.write_text("test,laser_a,laser_b,laser_c\n1,33.7,x,37.1\n")
    with pytest.raises(FileFormatError) as caught:
        read_start_readings_csv(bad)
    assert caught.value.line == 2
    bad.write_text("test,a,b\n")
    with pytest.raises(FileFormatError, match="expected header"):
        read_start_readings_csv(bad)
