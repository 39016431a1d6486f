"""Correction of a measured length to the reference temperature 20 °C (ISO 1) and its uncertainty.

Model.  A workpiece of length ``L20`` at 20 °C measures ``L20 (1 + α_w ΔT_w)`` at its
temperature ``T_w``; the machine's scale at ``T_s`` has graduations stretched by
``(1 + α_s ΔT_s)``, so it indicates

    ``L_m = L20 (1 + α_w ΔT_w) / (1 + α_s ΔT_s)``,   ``ΔT = T − 20 °C``,

and the corrected length is ``L20 = L_m (1 + α_s ΔT_s) / (1 + α_w ΔT_w)``.  To first
order this is the familiar differential-expansion correction
``L20 ≈ L_m (1 − (α_w ΔT_w − α_s ΔT_s))``.  For a machine whose indication is already
scale-compensated (or a laser in vacuum wavelengths) pass ``alpha_scale = 0``.

Uncertainty (GUM, first-order law of propagation for uncorrelated inputs):
``u²(L20) = Σ (∂L20/∂x_i)² u²(x_i)`` over ``x = (L_m, α_w, T_w, α_s, T_s)`` with

* ``∂L20/∂L_m = (1 + α_s ΔT_s)/(1 + α_w ΔT_w)``
* ``∂L20/∂α_w = −L20 ΔT_w/(1 + α_w ΔT_w)``,  ``∂L20/∂T_w = −L20 α_w/(1 + α_w ΔT_w)``
* ``∂L20/∂α_s = L_m ΔT_s/(1 + α_w ΔT_w)``,   ``∂L20/∂T_s = L_m α_s/(1 + α_w ΔT_w)``

Note that the ``α`` terms vanish at exactly 20 °C: measuring near 20 °C is what makes an
uncertain expansion coefficient harmless.  Correlation between workpiece and scale
temperatures (same thermometer) is not modelled; treat such inputs as independent
only if their errors are.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.thermal.expansion import REFERENCE_TEMPERATURE

__all__ = ["BudgetEntry", "LengthCorrection", "correct_length"]


@dataclass(frozen=True)
class BudgetEntry:
    """One line of an uncertainty budget.

    Attributes
    ----------
    quantity : str
        Input name (``"measured_length"``, ``"alpha_workpiece"``, ...).
    value : float
        Input estimate (mm, 1/K or °C).
    standard_uncertainty : float
        ``u(x_i)`` in the unit of ``value``.
    sensitivity : float
        ``c_i = ∂L20/∂x_i`` (mm per unit of ``value``).
    contribution : float
        ``|c_i| u(x_i)`` (mm).
    """

    quantity: str
    value: float
    standard_uncertainty: float
    sensitivity: float
    contribution: float


@dataclass(frozen=True)
class LengthCorrection:
    """A length corrected to 20 °C with its standard uncertainty and budget.

    Attributes
    ----------
    measured_length : float
        Indicated length ``L_m`` (mm).
    value : float
        Corrected length ``L20`` (mm).
    correction : float
        ``L20 − L_m`` (mm).
    standard_uncertainty : float
        Combined standard uncertainty ``u(L20)`` (mm).
    budget : tuple of BudgetEntry
        Contributions, largest first.
    reference_temperature : float
        20 °C unless changed (°C).
    """

    measured_length: float
    value: float
    correction: float
    standard_uncertainty: float
    budget: tuple[BudgetEntry, ...]
    reference_temperature: float = REFERENCE_TEMPERATURE

    def expanded_uncertainty(self, coverage_factor: float = 2.0) -> float:
        """``U = k u(L20)`` (mm), default k = 2."""
        return coverage_factor * self.standard_uncertainty


def _check(name: str, value: float, *, positive: bool = False, non_negative: bool = False) -> float:
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
        raise InvalidInputError(name, "a finite number", repr(value))
    if positive and value <= 0:
        raise InvalidInputError(name, "a positive value", repr(value))
    if non_negative and value < 0:
        raise InvalidInputError(name, "a non-negative standard uncertainty", repr(value))
    return float(value)


def correct_length(
    measured_length: float,
    temperature_workpiece: float,
    alpha_workpiece: float,
    *,
    temperature_scale: float = REFERENCE_TEMPERATURE,
    alpha_scale: float = 0.0,
    u_measured_length: float = 0.0,
    u_alpha_workpiece: float = 0.0,
    u_temperature_workpiece: float = 0.0,
    u_alpha_scale: float = 0.0,
    u_temperature_scale: float = 0.0,
    reference_temperature: float = REFERENCE_TEMPERATURE,
) -> LengthCorrection:
    """Correct a measured length to 20 °C for workpiece and scale expansion, with a GUM budget.

    Parameters
    ----------
    measured_length : float
        Indicated length ``L_m`` (mm), positive.
    temperature_workpiece : float
        Workpiece temperature ``T_w`` (°C).
    alpha_workpiece : float
        Workpiece expansion coefficient ``α_w`` (1/K).
    temperature_scale : float
        Machine scale temperature ``T_s`` (°C); default 20 °C.
    alpha_scale : float
        Scale expansion coefficient ``α_s`` (1/K); 0 for a compensated machine.
    u_measured_length, u_alpha_workpiece, u_temperature_workpiece, u_alpha_scale, u_temperature_scale : float
        Standard uncertainties of the inputs (mm, 1/K, K, 1/K, K).
    reference_temperature : float
        Reference temperature (°C), 20 °C by ISO 1.

    Returns
    -------
    LengthCorrection

    Raises
    ------
    InvalidInputError
        Non-finite input, non-positive length, negative uncertainty, or an expansion
        factor ``1 + α ΔT`` that is not positive.

    Examples
    --------
    >>> res = correct_length(100.0, 23.0, 11.5e-6, u_alpha_workpiece=1e-6)
    >>> round(res.value, 9), round(res.standard_uncertainty, 7)
    (99.996550119, 0.0003)
    """
    lm = _check("measured_length", measured_length, positive=True)
    tw = _check("temperature_workpiece", temperature_workpiece)
    aw = _check("alpha_workpiece", alpha_workpiece)
    ts = _check("temperature_scale", temperature_scale)
    a_s = _check("alpha_scale", alpha_scale)
    t_ref = _check("reference_temperature", reference_temperature)
    uncertainties = {
        "measured_length": _check("u_measured_length", u_measured_length, non_negative=True),
        "alpha_workpiece": _check("u_alpha_workpiece", u_alpha_workpiece, non_negative=True),
        "temperature_workpiece": _check("u_temperature_workpiece", u_temperature_workpiece, non_negative=True),
        "alpha_scale": _check("u_alpha_scale", u_alpha_scale, non_negative=True),
        "temperature_scale": _check("u_temperature_scale", u_temperature_scale, non_negative=True),
    }
    dtw, dts = tw - t_ref, ts - t_ref
    grow_w, grow_s = 1.0 + aw * dtw, 1.0 + a_s * dts
    if grow_w <= 0 or grow_s <= 0:
        raise InvalidInputError("temperatures", "expansion factors 1 + α ΔT > 0", f"{grow_w}, {grow_s}")
    l20 = lm * grow_s / grow_w
    values = {
        "measured_length": lm,
        "alpha_workpiece": aw,
        "temperature_workpiece": tw,
        "alpha_scale": a_s,
        "temperature_scale": ts,
    }
    sensitivities = {
        "measured_length": grow_s / grow_w,
        "alpha_workpiece": -l20 * dtw / grow_w,
        "temperature_workpiece": -l20 * aw / grow_w,
        "alpha_scale": lm * dts / grow_w,
        "temperature_scale": lm * a_s / grow_w,
    }
    entries = [
        BudgetEntry(
            quantity=name,
            value=values[name],
            standard_uncertainty=uncertainties[name],
            sensitivity=sensitivities[name],
            contribution=abs(sensitivities[name]) * uncertainties[name],
        )
        for name in values
    ]
    entries.sort(key=lambda e: e.contribution, reverse=True)
    u_total = math.sqrt(sum(e.contribution**2 for e in entries))
    return LengthCorrection(
        measured_length=lm,
        value=l20,
        correction=l20 - lm,
        standard_uncertainty=u_total,
        budget=tuple(entries),
        reference_temperature=t_ref,
    )
