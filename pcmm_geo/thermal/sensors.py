"""Temperature sensors: platinum RTDs (IEC 60751 Callendar-Van Dusen) and NTC thermistors (Steinhart-Hart).

RTD (replaces the garbled thesis eq 2.1, erratum 7).  IEC 60751 gives for a
platinum resistor with ``R0`` ohm at 0 °C

* ``R(T) = R0 (1 + A T + B T²)`` for 0 °C ≤ T ≤ 850 °C,
* ``R(T) = R0 (1 + A T + B T² + C (T − 100 °C) T³)`` for −200 °C ≤ T < 0 °C,

with A = 3.9083e-3 /°C, B = −5.775e-7 /°C², C = −4.183e-12 /°C⁴.  Above 0 °C the
inverse is the root of a quadratic; below 0 °C it is found by Newton iteration
(the quartic has no convenient closed form) to 1e-12 °C.

Thermistor (thesis eq 2.2): ``1/T = A + B ln R + C (ln R)³`` with T in kelvin.  The
inverse R(T) is the single real root of a depressed cubic in ``ln R`` (exact, by
Cardano).  Coefficients are fitted from three or more calibration points by linear
least squares in ``1/T``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import ConvergenceError, DegenerateGeometryError, InvalidInputError, TooFewPointsError

__all__ = [
    "IEC60751",
    "KELVIN_OFFSET",
    "CallendarVanDusen",
    "SteinhartHart",
    "fit_steinhart_hart",
    "rtd_resistance",
    "rtd_temperature",
]

FloatArray = NDArray[np.float64]

#: 0 °C in kelvin.
KELVIN_OFFSET = 273.15


def _array(value: ArrayLike, name: str) -> FloatArray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInputError(name, "a number or an array of numbers", type(value).__name__) from None
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(name, "finite values", f"{np.ravel(arr).tolist()}")
    return arr


def _out(arr: FloatArray) -> FloatArray | float:
    return float(arr) if arr.ndim == 0 else arr


@dataclass(frozen=True)
class CallendarVanDusen:
    """Callendar-Van Dusen coefficients of a platinum resistance thermometer (IEC 60751).

    Attributes
    ----------
    r0 : float
        Resistance at 0 °C (ohm): 100 for Pt100, 1000 for Pt1000.
    a : float
        Coefficient A (1/°C).
    b : float
        Coefficient B (1/°C²).
    c : float
        Coefficient C (1/°C⁴), used below 0 °C only.
    t_min, t_max : float
        Validity range (°C), −200 °C to 850 °C in IEC 60751.

    Examples
    --------
    >>> round(IEC60751.resistance(100.0), 4)
    138.5055
    >>> round(IEC60751.temperature(138.5055), 9)
    100.0
    """

    r0: float = 100.0
    a: float = 3.9083e-3
    b: float = -5.775e-7
    c: float = -4.183e-12
    t_min: float = -200.0
    t_max: float = 850.0

    def resistance(self, temperature: ArrayLike) -> FloatArray | float:
        """Resistance (ohm) at ``temperature`` (°C), any shape.

        Raises
        ------
        InvalidInputError
            Non-finite input or a temperature outside ``[t_min, t_max]``.
        """
        t = _array(temperature, "temperature")
        if np.any((t < self.t_min) | (t > self.t_max)):
            raise InvalidInputError(
                "temperature", f"values in [{self.t_min}, {self.t_max}] °C", f"{np.ravel(t).tolist()}"
            )
        low = np.where(t < 0.0, self.c * (t - 100.0) * t**3, 0.0)
        return _out(self.r0 * (1.0 + self.a * t + self.b * t**2 + low))

    def temperature(self, resistance: ArrayLike) -> FloatArray | float:
        """Temperature (°C) from ``resistance`` (ohm), the exact inverse of :meth:`resistance`.

        At and above ``r0`` the quadratic is solved in closed form,
        ``T = (−A + sqrt(A² − 4B(1 − R/R0))) / (2B)``; below ``r0`` the quartic is
        solved by Newton iteration started from the quadratic's root.

        Raises
        ------
        InvalidInputError
            Non-finite input or a resistance outside the range of ``[t_min, t_max]``.
        ConvergenceError
            Newton iteration failed (does not happen inside the range).
        """
        r = _array(resistance, "resistance")
        r_low = self.resistance(self.t_min)
        r_high = self.resistance(self.t_max)
        if np.any((r < r_low) | (r > r_high)):
            raise InvalidInputError(
                "resistance", f"values in [{r_low:.4f}, {r_high:.4f}] ohm", f"{np.ravel(r).tolist()}"
            )
        ratio = r / self.r0
        disc = self.a**2 - 4.0 * self.b * (1.0 - ratio)
        # numerically stable form of the quadratic root: 2(ratio-1) / (A + sqrt(disc))
        t = 2.0 * (ratio - 1.0) / (self.a + np.sqrt(disc))
        below = ratio < 1.0
        if np.any(below):
            tb = t[below] if t.ndim else t
            target = ratio[below] if ratio.ndim else ratio
            for _ in range(50):
                f = 1.0 + self.a * tb + self.b * tb**2 + self.c * (tb - 100.0) * tb**3 - target
                df = self.a + 2.0 * self.b * tb + self.c * (4.0 * tb**3 - 300.0 * tb**2)
                step = f / df
                tb = tb - step
                if np.all(np.abs(step) < 1e-13):
                    break
            else:
                raise ConvergenceError("Callendar-Van Dusen inverse", 50, "Newton steps did not shrink below 1e-13 °C")
            if t.ndim:
                t = t.copy()
                t[below] = tb
            else:
                t = tb
        return _out(np.asarray(t, dtype=float))


#: The IEC 60751 standard coefficients for a Pt100.
IEC60751 = CallendarVanDusen()


def rtd_resistance(temperature: ArrayLike, r0: float = 100.0) -> FloatArray | float:
    """Resistance (ohm) of an IEC 60751 platinum RTD at ``temperature`` (°C).

    Parameters
    ----------
    temperature : float or array_like
        Temperature (°C), −200 to 850.
    r0 : float
        Resistance at 0 °C (ohm), 100 for Pt100.

    Returns
    -------
    float or ndarray

    Raises
    ------
    InvalidInputError
        Out-of-range or non-finite temperatures, non-positive ``r0``.

    Examples
    --------
    >>> round(rtd_resistance(-100.0), 4)
    60.2558
    """
    if not (math.isfinite(r0) and r0 > 0):
        raise InvalidInputError("r0", "a positive resistance in ohm", repr(r0))
    return CallendarVanDusen(r0=r0).resistance(temperature)


def rtd_temperature(resistance: ArrayLike, r0: float = 100.0) -> FloatArray | float:
    """Temperature (°C) of an IEC 60751 platinum RTD reading ``resistance`` (ohm).

    Parameters
    ----------
    resistance : float or array_like
        Measured resistance (ohm).
    r0 : float
        Resistance at 0 °C (ohm).

    Returns
    -------
    float or ndarray

    Raises
    ------
    InvalidInputError
        Out-of-range or non-finite resistance, non-positive ``r0``.

    Examples
    --------
    >>> round(rtd_temperature(100.0), 9)
    0.0
    """
    if not (math.isfinite(r0) and r0 > 0):
        raise InvalidInputError("r0", "a positive resistance in ohm", repr(r0))
    return CallendarVanDusen(r0=r0).temperature(resistance)


@dataclass(frozen=True)
class SteinhartHart:
    """Steinhart-Hart thermistor model ``1/T = A + B ln R + C (ln R)³`` (thesis eq 2.2).

    Attributes
    ----------
    a : float
        Coefficient A (1/K).
    b : float
        Coefficient B (1/K).
    c : float
        Coefficient C (1/K).
    rms_residual : float
        RMS temperature residual of the calibration points (K); 0 when not fitted.

    Examples
    --------
    >>> sh = SteinhartHart(1.009249522e-3, 2.378405444e-4, 2.019202697e-7)
    >>> r = sh.resistance(25.0)
    >>> round(sh.temperature(r), 9)
    25.0
    """

    a: float
    b: float
    c: float
    rms_residual: float = 0.0

    def temperature(self, resistance: ArrayLike) -> FloatArray | float:
        """Temperature (°C) for a resistance (ohm), any shape.

        Raises
        ------
        InvalidInputError
            Non-positive or non-finite resistance, or a model giving ``1/T <= 0``.
        """
        r = _array(resistance, "resistance")
        if np.any(r <= 0):
            raise InvalidInputError("resistance", "positive values in ohm", f"{np.ravel(r).tolist()}")
        x = np.log(r)
        inv_t = self.a + self.b * x + self.c * x**3
        if np.any(inv_t <= 0):
            raise InvalidInputError("resistance", "values the model maps to a positive kelvin temperature",
                                    f"{np.ravel(r).tolist()}")
        return _out(1.0 / inv_t - KELVIN_OFFSET)

    def resistance(self, temperature: ArrayLike) -> FloatArray | float:
        """Resistance (ohm) at ``temperature`` (°C): the real root of ``C x³ + B x + A − 1/T = 0``, ``x = ln R``.

        For ``B, C > 0`` (every physical NTC) the cubic is monotonic and has one real root,
        given exactly by Cardano's formula ``x = ∛(−q/2 + √Δ) + ∛(−q/2 − √Δ)``,
        ``p = B/C``, ``q = (A − 1/T)/C``, ``Δ = (q/2)² + (p/3)³``; one Newton step polishes
        rounding.  With ``C = 0`` it is the linear ``x = (1/T − A)/B``.

        Raises
        ------
        InvalidInputError
            Temperature at or below absolute zero, or coefficients with ``B <= 0``.
        """
        t = _array(temperature, "temperature") + KELVIN_OFFSET
        if np.any(t <= 0):
            raise InvalidInputError("temperature", "values above −273.15 °C", f"{np.ravel(t - KELVIN_OFFSET).tolist()}")
        if self.b <= 0 or self.c < 0:
            raise InvalidInputError("coefficients", "B > 0 and C >= 0 (a monotonic NTC model)",
                                    f"B={self.b}, C={self.c}")
        if self.c == 0:
            x = (1.0 / t - self.a) / self.b
        else:
            p = self.b / self.c
            q = (self.a - 1.0 / t) / self.c
            root = np.sqrt((q / 2.0) ** 2 + (p / 3.0) ** 3)
            x = np.cbrt(-q / 2.0 + root) + np.cbrt(-q / 2.0 - root)
            f = self.c * x**3 + self.b * x + self.a - 1.0 / t
            x = x - f / (3.0 * self.c * x**2 + self.b)
        return _out(np.exp(x))


def fit_steinhart_hart(temperatures: ArrayLike, resistances: ArrayLike) -> SteinhartHart:
    """Fit Steinhart-Hart coefficients to calibration points (linear least squares in 1/T).

    Parameters
    ----------
    temperatures : array_like, shape (N,)
        Calibration temperatures (°C), N >= 3, at least 3 distinct.
    resistances : array_like, shape (N,)
        Resistances at those temperatures (ohm), positive.

    Returns
    -------
    SteinhartHart
        Coefficients; ``rms_residual`` is the RMS of (model − given) temperatures (K).
        With exactly three points the model passes through all three.

    Raises
    ------
    InvalidInputError
        Mismatched shapes, non-finite or non-positive values.
    TooFewPointsError
        Fewer than 3 points.
    DegenerateGeometryError
        Fewer than 3 distinct resistances.

    Examples
    --------
    >>> sh = fit_steinhart_hart([0.0, 25.0, 50.0], [32650.0, 10000.0, 3603.0])
    >>> round(sh.temperature(10000.0), 6)
    25.0
    """
    t = _array(temperatures, "temperatures")
    r = _array(resistances, "resistances")
    if t.ndim != 1 or r.shape != t.shape:
        raise InvalidInputError("resistances", f"shape {t.shape} like temperatures (1-D)", f"shape {r.shape}")
    if t.size < 3:
        raise TooFewPointsError("Steinhart-Hart", 3, int(t.size))
    if np.any(r <= 0):
        raise InvalidInputError("resistances", "positive values in ohm", f"{r.tolist()}")
    if np.unique(r).size < 3:
        raise DegenerateGeometryError("Steinhart-Hart", "fewer than 3 distinct resistances")
    x = np.log(r)
    design = np.column_stack([np.ones_like(x), x, x**3])
    target = 1.0 / (t + KELVIN_OFFSET)
    # scale columns for conditioning, solve by QR (lstsq), unscale
    scale = np.abs(design).max(axis=0)
    coef, *_ = np.linalg.lstsq(design / scale, target, rcond=None)
    coef = coef / scale
    model = SteinhartHart(float(coef[0]), float(coef[1]), float(coef[2]))
    fitted = np.asarray(model.temperature(r))
    rms = float(np.sqrt(np.mean((fitted - t) ** 2)))
    return SteinhartHart(model.a, model.b, model.c, rms_residual=rms)
