"""ISO 10360-2 length test evaluation."""

from __future__ import annotations

import csv
from importlib.resources import files
from pathlib import Path

import pytest

from pcmm_geo.artefacts import LengthMeasurement, LengthMpe, evaluate_length_test, read_length_test_csv
from pcmm_geo.artefacts.iso10360_2 import completeness
from pcmm_geo.errors import FileFormatError, IncompleteTestError, InvalidInputError


def test_mpe_formula() -> None:
    assert LengthMpe(1.5, 333.0).mpe_mm(500.0) == pytest.approx((1.5 + 500 / 333) / 1000, abs=1e-15)
    assert LengthMpe(2.0, 100.0, b_um=4.0).mpe_mm(1000.0) == pytest.approx(0.004, abs=1e-15)
    assert LengthMpe(2.0, 100.0, b_um=4.0).mpe_mm(100.0) == pytest.approx(0.003, abs=1e-15)
    with pytest.raises(InvalidInputError, match="mpe K"):
        LengthMpe(2.0, 0.0)


POSITIONS = ("x", "y", "z", "diag_1", "diag_2", "diag_3", "diag_4")


def _data(errors_um: list[float], length: float = 100.0) -> list[LengthMeasurement]:
    """The given errors for L5 in position x (repetitions 1..), then error-free values completing the 5 x 7 x 3 set."""
    given = [LengthMeasurement("L5", "x", i + 1, length, length + e / 1000.0) for i, e in enumerate(errors_um)]
    rest = [
        LengthMeasurement(f"L{k}", position, rep, cal, cal)
        for k, cal in zip(range(1, 6), (10.0, 20.0, 50.0, 70.0, length), strict=True)
        for position in POSITIONS
        for rep in (1, 2, 3)
        if not (k == 5 and position == "x" and rep <= len(errors_um))
    ]
    return given + rest


def test_simple_rule() -> None:
    # MPE at 100 mm: 2 + 100/100 = 3 um
    result = evaluate_length_test(_data([1.0, -2.5, 2.9]), LengthMpe(2.0, 100.0))
    assert result.passed
    assert result.max_abs_error == pytest.approx(0.0029, abs=1e-12)
    assert result.max_error_ratio == pytest.approx(2.9 / 3.0, rel=1e-9)
    assert result.repeatability[0].range == pytest.approx(0.0054, abs=1e-12)  # 2.9 - (-2.5) um
    failing = evaluate_length_test(_data([1.0, -3.1, 2.0]), LengthMpe(2.0, 100.0))
    assert not failing.passed and failing.n_nonconforming == 1
    assert [e.conforms for e in failing.errors[:3]] == [True, False, True]


def test_guarded_rule() -> None:
    data = _data([1.0, -2.5, 2.9])
    guarded = evaluate_length_test(data, LengthMpe(2.0, 100.0), decision_rule="guarded", test_uncertainty=0.0005)
    # acceptance limit 3 - 0.5 = 2.5 um: -2.5 conforms (boundary), 2.9 does not
    assert [e.conforms for e in guarded.errors[:3]] == [True, True, False]
    assert guarded.errors[0].acceptance_limit == pytest.approx(0.0025, abs=1e-15)
    assert "guarded" in guarded.decision_rule
    assert not guarded.passed


def test_r0_limit() -> None:
    data = _data([1.0, -2.5, 2.9])
    result = evaluate_length_test(data, LengthMpe(2.0, 100.0), mpl_r0=0.005)
    assert not result.passed and not result.repeatability[0].conforms


def test_example_file_against_independent_recomputation() -> None:
    path = files("pcmm_geo") / "data/examples/iso10360_2_lengths.csv"
    result = evaluate_length_test(read_length_test_csv(path), LengthMpe(2.0, 100.0))
    with open(str(path), newline="") as handle:
        rows = list(csv.DictReader(line for line in handle if not line.startswith("#")))
    assert len(rows) == 105
    errors = [float(r["measured_length"]) - float(r["calibrated_length"]) for r in rows]
    mpes = [(2.0 + float(r["calibrated_length"]) / 100.0) / 1000.0 for r in rows]
    assert result.max_abs_error == pytest.approx(max(abs(e) for e in errors), abs=1e-12)
    assert result.passed == all(abs(e) <= m for e, m in zip(errors, mpes, strict=True))
    assert len(result.repeatability) == 35


def test_inconsistent_and_bad_input(tmp_path: Path) -> None:
    data = [LengthMeasurement("L1", "x", 1, 10.0, 10.0), LengthMeasurement("L1", "y", 1, 10.1, 10.1)]
    with pytest.raises(InvalidInputError, match="calibrated_length"):
        evaluate_length_test(data, LengthMpe(2.0, 100.0))
    with pytest.raises(InvalidInputError, match="decision_rule"):
        evaluate_length_test(_data([1.0]), LengthMpe(2.0, 100.0), decision_rule="lenient")
    with pytest.raises(InvalidInputError, match="at least one"):
        evaluate_length_test([], LengthMpe(2.0, 100.0))
    with pytest.raises(InvalidInputError, match="twice"):
        evaluate_length_test(_data([1.0, 2.0, 3.0]) + _data([1.0])[:1], LengthMpe(2.0, 100.0))
    bad = tmp_path / "bad.csv"
    bad.write_text("length_id,position,repetition,calibrated_length,measured_length\nL1,x,1,abc,10\n")
    with pytest.raises(FileFormatError, match=r"bad\.csv:2: column 'calibrated_length'"):
        read_length_test_csv(bad)
    missing = tmp_path / "missing.csv"
    missing.write_text("length_id,position,measured_length\nL1,x,10\n")
    with pytest.raises(FileFormatError, match="missing repetition, calibrated_length"):
        read_length_test_csv(missing)


def test_the_standards_105_values_or_an_explicit_incomplete_verdict() -> None:
    mpe = LengthMpe(2.0, 100.0)
    full = _data([1.0, -2.5, 2.9])
    assert len(full) == 105 and completeness(full) == ""
    partial = full[:3]  # 3 of the 105 values: no verdict without asking
    with pytest.raises(IncompleteTestError, match=r"ISO 10360-2: the standard uses 105 values, got 3") as info:
        evaluate_length_test(partial, mpe)
    assert info.value.needed == 105 and info.value.got == 3 and "1 of 5 lengths" in info.value.detail
    result = evaluate_length_test(partial, mpe, allow_incomplete=True)
    assert result.passed is None and not result.complete
    assert result.verdict.startswith("INCOMPLETE (3 of 105 values: 1 of 5 lengths, 1 of 7 positions)")
    assert "PASS" not in result.verdict
    failing = evaluate_length_test(_data([1.0, -3.1, 2.0])[:3], mpe, allow_incomplete=True)
    assert failing.passed is False and failing.verdict.startswith("INCOMPLETE") and failing.verdict.endswith("FAIL")
    # one repetition short in one place: 104 values
    short = full[1:]
    assert completeness(short) == "104 of 105 values: 1 length/position pairs without 3 repetitions"
    with pytest.raises(IncompleteTestError):
        evaluate_length_test(short, mpe)
    assert evaluate_length_test(full, mpe).verdict == "PASS"
