"""IEC 60751 Callendar-Van Dusen RTD and Steinhart-Hart thermistor conversions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError, TooFewPointsError
from pcmm_geo.thermal import (
    IEC60751,
    CallendarVanDusen,
    SteinhartHart,
    fit_steinhart_hart,
    rtd_resistance,
    rtd_temperature,
)

# IEC 60751 Pt100 reference table (ohm, published to 2 decimals)
IEC_TABLE = {
    -200.0: 18.52,
    -100.0: 60.26,
    -50.0: 80.31,
    0.0: 100.00,
    100.0: 138.51,
    200.0: 175.86,
    300.0: 212.05,
    400.0: 247.09,
    500.0: 280.98,
    850.0: 390.48,
}


def test_pt100_at_100_degrees() -> None:
    # 100 (1 + 0.39083 - 0.005775) = 138.5055 exactly
    assert rtd_resistance(100.0) == pytest.approx(138.5055, abs=1e-10)


def test_iec_table() -> None:
    temps = np.array(list(IEC_TABLE))
    np.testing.assert_allclose(rtd_resistance(temps), list(IEC_TABLE.values()), atol=0.005 + 1e-9)


def test_below_zero_uses_c_term() -> None:
    # -100 C by hand: 1 - 0.39083 - 0.005775 + C * (-200) * (-1e6)
    expected = 100.0 * (1 - 0.39083 - 0.005775 - 4.183e-12 * 2e8)
    assert rtd_resistance(-100.0) == pytest.approx(expected, abs=1e-12)
    assert rtd_temperature(expected) == pytest.approx(-100.0, abs=1e-10)


def test_inverse_round_trip_both_ranges() -> None:
    temps = np.linspace(-200.0, 850.0, 2101)
    back = IEC60751.temperature(IEC60751.resistance(temps))
    np.testing.assert_allclose(back, temps, atol=1e-9)
    # above 0 C the inverse is the quadratic root, by hand for 138.5055 ohm
    a, b = 3.9083e-3, -5.775e-7
    hand = (-a + math.sqrt(a * a - 4 * b * (1 - 1.385055))) / (2 * b)
    assert rtd_temperature(138.5055) == pytest.approx(hand, abs=1e-12)
    assert hand == pytest.approx(100.0, abs=1e-9)


def test_pt1000_scales() -> None:
    assert rtd_resistance(100.0, r0=1000.0) == pytest.approx(1385.055, abs=1e-9)
    assert CallendarVanDusen(r0=1000.0).temperature(1000.0) == 0.0


def test_rtd_out_of_range() -> None:
    with pytest.raises(InvalidInputError, match="expected values in"):
        rtd_resistance(900.0)
    with pytest.raises(InvalidInputError, match="resistance"):
        rtd_temperature(10.0)
    with pytest.raises(InvalidInputError, match="positive"):
        rtd_resistance(10.0, r0=-100.0)


# a common 10 kOhm NTC's coefficients; the "manufacturer table" is derived from them with
# an independent root finder (brentq), rounded to 5 significant digits like a datasheet
KNOWN = (1.009249522e-3, 2.378405444e-4, 2.019202697e-7)


def _table_resistance(t_celsius: float) -> float:
    a, b, c = KNOWN

    def f(x: float) -> float:
        return a + b * x + c * x**3 - 1.0 / (t_celsius + 273.15)

    return math.exp(brentq(f, 0.0, 30.0, xtol=1e-15, rtol=1e-15))


def test_steinhart_hart_exact_inverse() -> None:
    model = SteinhartHart(*KNOWN)
    temps = np.arange(-40.0, 126.0, 5.0)
    expected = np.array([_table_resistance(t) for t in temps])
    np.testing.assert_allclose(model.resistance(temps), expected, rtol=1e-12)
    np.testing.assert_allclose(model.temperature(expected), temps, atol=1e-9)


def test_steinhart_hart_fit_from_datasheet_table() -> None:
    temps = np.arange(-40.0, 126.0, 5.0)
    table = np.array([float(f"{_table_resistance(t):.5g}") for t in temps])
    fitted = fit_steinhart_hart(temps, table)
    # 5 significant digits ~ 1e-5 relative in R ~ 2.5 mK worst case in T
    assert fitted.rms_residual < 2e-3
    check = np.linspace(-40.0, 125.0, 34)
    exact_r = np.array([_table_resistance(t) for t in check])
    np.testing.assert_allclose(fitted.temperature(exact_r), check, atol=3e-3)
    np.testing.assert_allclose([fitted.a, fitted.b, fitted.c], KNOWN, rtol=2e-3)


def test_steinhart_hart_three_points_exact() -> None:
    temps = np.array([0.0, 25.0, 70.0])
    table = np.array([_table_resistance(t) for t in temps])
    fitted = fit_steinhart_hart(temps, table)
    np.testing.assert_allclose([fitted.a, fitted.b, fitted.c], KNOWN, rtol=1e-7)
    assert fitted.rms_residual < 1e-9


def test_steinhart_hart_bad_input() -> None:
    with pytest.raises(TooFewPointsError):
        fit_steinhart_hart([0.0, 25.0], [32650.0, 10000.0])
    with pytest.raises(DegenerateGeometryError, match="distinct"):
        fit_steinhart_hart([0.0, 25.0, 50.0], [1000.0, 1000.0, 1000.0])
    with pytest.raises(InvalidInputError, match="positive"):
        SteinhartHart(*KNOWN).temperature(-5.0)
    with pytest.raises(InvalidInputError, match="shape"):
        fit_steinhart_hart([0.0, 25.0, 50.0], [1.0, 2.0])
