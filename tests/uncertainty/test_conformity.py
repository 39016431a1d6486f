"""ISO 14253-1 decisions: the three zones, and their use in the ISO 10360-2 / -5 evaluations."""

from __future__ import annotations

import pytest

from pcmm_geo.artefacts.iso10360_2 import LengthMeasurement, LengthMpe, evaluate_length_test
from pcmm_geo.artefacts.iso10360_5 import evaluate_probing, sphere_probing_pattern
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.uncertainty.conformity import decide_conformity, overall_verdict


@pytest.mark.parametrize(
    ("value", "verdict"),
    [(1.0, "PASS"), (1.5, "PASS"), (1.51, "NOT PROVEN"), (2.0, "NOT PROVEN"), (2.5, "NOT PROVEN"), (2.51, "FAIL"),
     (-1.5, "PASS"), (-2.2, "NOT PROVEN"), (-2.6, "FAIL")],
)
def test_two_sided_zones(value: float, verdict: str) -> None:
    decision = decide_conformity(value, 0.5, upper_limit=2.0, lower_limit=-2.0)
    assert decision.verdict == verdict
    assert decision.acceptance_zone == (-1.5, 1.5)


def test_one_sided_and_zero_uncertainty() -> None:
    assert decide_conformity(-100.0, 0.5, upper_limit=2.0).verdict == "PASS"
    assert decide_conformity(0.2, 0.5, lower_limit=0.0).verdict == "NOT PROVEN"
    # U = 0: simple acceptance, the limit itself conforms
    assert [decide_conformity(v, 0.0, upper_limit=2.0).verdict for v in (2.0, 2.0000001)] == ["PASS", "FAIL"]
    assert decide_conformity(1.0, 0.5, upper_limit=2.0).state == "conformity proved"
    assert overall_verdict(["PASS", "PASS"]) == "PASS"
    with pytest.raises(InvalidInputError, match="limits"):
        decide_conformity(1.0, 0.5)
    with pytest.raises(InvalidInputError, match="expanded_uncertainty"):
        decide_conformity(1.0, -0.5, upper_limit=2.0)


def _lengths(errors_um: list[float]) -> list[LengthMeasurement]:
    """The given errors (length L{i}, position p1, repetition 1) first, completed by error-free values to the
    standard's 5 lengths x 7 positions x 3 repetitions (a partial set gets no verdict)."""
    given = [LengthMeasurement(f"L{i}", "p1", 1, 100.0, 100.0 + e / 1000.0) for i, e in enumerate(errors_um)]
    rest = [LengthMeasurement(f"L{i}", f"p{p}", r, 100.0, 100.0) for i in range(5) for p in range(1, 8)
            for r in (1, 2, 3) if not (p == 1 and r == 1 and i < len(errors_um))]
    return given + rest


def test_iso10360_2_with_the_iso14253_rule() -> None:
    mpe = LengthMpe(2.0, 1e9)  # 2 um at every length
    passed = evaluate_length_test(_lengths([0.5, -1.0]), mpe, decision_rule="iso14253", test_uncertainty=0.0005)
    assert passed.verdict == "PASS" and passed.passed
    ambiguous = evaluate_length_test(_lengths([0.5, 1.8]), mpe, decision_rule="iso14253", test_uncertainty=0.0005)
    assert [e.verdict for e in ambiguous.errors[:2]] == ["PASS", "NOT PROVEN"]
    assert ambiguous.verdict == "NOT PROVEN" and not ambiguous.passed
    failed = evaluate_length_test(_lengths([1.8, -2.7]), mpe, decision_rule="iso14253", test_uncertainty=0.0005)
    assert failed.verdict == "FAIL"
    simple = evaluate_length_test(_lengths([0.5, 1.8]), mpe)
    assert simple.verdict == "PASS" and simple.errors[1].verdict == ""


def test_iso10360_5_with_test_uncertainty() -> None:
    points = sphere_probing_pattern((0.0, 0.0, 0.0), 12.5)
    exact = evaluate_probing(points, 25.0, mpe_form=0.002, mpe_size=0.002, test_uncertainty=(0.0005, 0.0005))
    assert (exact.form_verdict, exact.size_verdict) == ("PASS", "PASS") and exact.passed
    # points on a sphere 1.8 um too large in diameter: size within MPE but within U of it
    big = evaluate_probing(points * (12.5009 / 12.5), 25.0, mpe_size=0.002, test_uncertainty=(0.0005, 0.0005))
    assert big.size_error == pytest.approx(0.0018, abs=1e-9)
    assert big.size_verdict == "NOT PROVEN" and big.passed is False
    assert "ISO 14253-1" in big.decision_rule
