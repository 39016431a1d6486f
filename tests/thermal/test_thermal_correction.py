"""Correction of lengths to 20 C (ISO 1) with a first-order GUM budget."""

from __future__ import annotations

import math

import pytest

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.thermal import correct_length


def test_workpiece_only_hand_value() -> None:
    res = correct_length(100.0, 23.0, 11.5e-6)
    assert res.value == pytest.approx(100.0 / (1 + 3 * 11.5e-6), abs=1e-12)
    assert res.correction == pytest.approx(-0.00345, rel=1e-4)  # first order: -L alpha dT


def test_differential_expansion_cancels() -> None:
    # workpiece and scale of the same material at the same temperature: no correction
    res = correct_length(250.0, 24.0, 11.5e-6, temperature_scale=24.0, alpha_scale=11.5e-6)
    assert res.value == pytest.approx(250.0, abs=1e-12)
    # aluminium workpiece on a steel-scale machine, both at 22 C: L (1 - (a_w - a_s) dT) to first order
    res = correct_length(100.0, 22.0, 23.1e-6, temperature_scale=22.0, alpha_scale=11.5e-6)
    assert res.value == pytest.approx(100.0 * (1 + 2 * 11.5e-6) / (1 + 2 * 23.1e-6), abs=1e-12)
    assert res.correction == pytest.approx(-100.0 * 11.6e-6 * 2, rel=1e-3)


def test_budget_hand_values() -> None:
    res = correct_length(100.0, 22.0, 11.5e-6, u_alpha_workpiece=1e-6, u_temperature_workpiece=0.1)
    contributions = {e.quantity: e.contribution for e in res.budget}
    assert contributions["alpha_workpiece"] == pytest.approx(100 * 2 * 1e-6, rel=1e-4)
    assert contributions["temperature_workpiece"] == pytest.approx(100 * 11.5e-6 * 0.1, rel=1e-4)
    assert res.standard_uncertainty == pytest.approx(math.hypot(2e-4, 1.15e-4), rel=1e-4)
    assert res.budget[0].quantity == "alpha_workpiece"  # largest first
    assert res.expanded_uncertainty() == pytest.approx(2 * res.standard_uncertainty)


def test_alpha_irrelevant_at_20_degrees() -> None:
    res = correct_length(100.0, 20.0, 11.5e-6, u_alpha_workpiece=5e-6, u_measured_length=1e-4)
    contributions = {e.quantity: e.contribution for e in res.budget}
    assert contributions["alpha_workpiece"] == 0.0
    assert res.standard_uncertainty == pytest.approx(1e-4, abs=1e-15)


def test_sensitivities_match_finite_differences() -> None:
    base = {
        "measured_length": 150.0,
        "temperature_workpiece": 23.5,
        "alpha_workpiece": 23.1e-6,
        "temperature_scale": 21.0,
        "alpha_scale": 11.5e-6,
    }
    res = correct_length(**base)
    steps = {
        "measured_length": 1e-3,
        "temperature_workpiece": 1e-3,
        "alpha_workpiece": 1e-9,
        "temperature_scale": 1e-3,
        "alpha_scale": 1e-9,
    }
    for entry in res.budget:
        h = steps[entry.quantity]
        up = correct_length(**{**base, entry.quantity: base[entry.quantity] + h}).value
        down = correct_length(**{**base, entry.quantity: base[entry.quantity] - h}).value
        assert entry.sensitivity == pytest.approx((up - down) / (2 * h), rel=1e-6)


def test_bad_input() -> None:
    with pytest.raises(InvalidInputError, match="positive"):
        correct_length(-1.0, 20.0, 1e-5)
    with pytest.raises(InvalidInputError, match="non-negative"):
        correct_length(1.0, 20.0, 1e-5, u_alpha_workpiece=-1.0)
    with pytest.raises(InvalidInputError, match="finite"):
        correct_length(1.0, float("nan"), 1e-5)
