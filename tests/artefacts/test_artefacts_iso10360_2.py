"""ISO 10360-2 length test evaluation."""

from __future__ import annotations

import csv
from importlib.resources import files
from pathlib import Path

import pytest

from pcmm_geo.artefacts import LengthMeasurement, LengthMpe, evaluate_length_test, read_length_test_csv
from pcmm_geo.errors import FileFormatError, InvalidInputError


def test_mpe_formula() -> None:
    assert LengthMpe(1.5, 333.0).mpe_mm(500.0) == pytest.approx((1.5 + 500 / 333) / 1000, abs=1e-15)
    assert LengthMpe(2.0, 100.0, b_um=4.0).mpe_mm(1000.0) == pytest.approx(0.004, abs=1e-15)
    assert LengthMpe(2.0, 100.0, b_um=4.0).mpe_mm(100.0) == pytest.approx(0.003, abs=1e-15)
    with pytest.raises(InvalidInputError, match="mpe K"):
        LengthMpe(2.0, 0.0)


def _data(errors_um: list[float], length: float = 100.0) -> list[LengthMeasurement]:
    return [
        LengthMeasurement("L5", "x", i + 1, length, length + e / 1000.0) for i, e in enumerate(errors_um)
    ]


def test_simple_rule() -> None:
    # MPE at 100 mm: 2 + 100/100 = 3 um
    result = evaluate_length_test(_data([1.0, -2.5, 2.9]), LengthMpe(2.0, 100.0))
    assert result.passed
    assert result.max_abs_error == pytest.approx(0.0029, abs=1e-12)
    assert result.max_error_ratio == pytest.approx(2.9 / 3.0, rel=1e-9)
    assert result.repeatability[0].range == pytest.approx(0.0054, abs=1e-12)  # 2.9 - (-2.5) um
    failing = evaluate_length_test(_data([1.0, -3.1, 2.0]), LengthMpe(2.0, 100.0))
    assert not failing.passed and failing.n_nonconforming == 1
    assert [e.conforms for e in failing.errors] == [True, False, True]


def test_guarded_rule() -> None:
    data = _data([1.0, -2.5, 2.9])
    guarded = evaluate_length_test(data, LengthMpe(2.0, 100.0), decision_rule="guarded", test_uncertainty=0.0005)
    # acceptance limit 3 - 0.5 = 2.5 um: -2.5 conforms (boundary), 2.9 does not
    assert [e.conforms for e in guarded.errors] == [True, True, False]
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
    bad = tmp_path / "bad.csv"
    bad.write_text("length_id,position,repetition,calibrated_length,measured_length\nL1,x,1,abc,10\n")
    with pytest.raises(FileFormatError, match=r"bad\.csv:2: column 'calibrated_length'"):
        read_length_test_csv(bad)
    missing = tmp_path / "missing.csv"
    missing.write_text("length_id,position,measured_length\nL1,x,10\n")
    with pytest.raises(FileFormatError, match="missing repetition, calibrated_length"):
        read_length_test_csv(missing)
