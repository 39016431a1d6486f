"""Result types of the uncertainty evaluations: one budget line, one result (GUM or Monte Carlo).

Both :func:`~pcmm_geo.uncertainty.gum.propagate` (JCGM 100, law of propagation of
uncertainty) and :func:`~pcmm_geo.uncertainty.montecarlo.adaptive_monte_carlo` (JCGM 101)
return an :class:`UncertaintyResult` with the same fields, so a caller can compare them or
switch method without changing code; ``method`` says which produced it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

__all__ = ["BudgetEntry", "UncertaintyResult"]


@dataclass(frozen=True)
class BudgetEntry:
    """One line of an uncertainty budget: what one input (or group of inputs) contributes.

    Attributes
    ----------
    name : str
        Input or input group (``"laser_noise"``, ``"slider_a.laser_scale"``, ...).
    contribution : float
        ``u_i(y)``: the standard uncertainty of the output caused by this input alone
        (unit of the output).  GUM: ``|c_i| u(x_i)``; Monte Carlo: standard deviation of
        the output with only this input group varied.
    share : float
        ``u_i(y)^2 / sum_j u_j(y)^2``: fraction of the variance budget (0..1).
    sensitivity : float
        ``c_i = dy/dx_i`` (GUM, unit of y per unit of x_i); NaN for groups and Monte Carlo.
    input_value, input_uncertainty : float
        ``x_i`` and ``u(x_i)``; NaN for groups.
    dof : float
        Degrees of freedom of ``u(x_i)`` (``inf`` when known exactly / Type B).
    """

    name: str
    contribution: float
    share: float
    sensitivity: float = math.nan
    input_value: float = math.nan
    input_uncertainty: float = math.nan
    dof: float = math.inf

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (non-finite numbers as None)."""
        return {key: _json_number(value) for key, value in self.__dict__.items()}


@dataclass(frozen=True)
class UncertaintyResult:
    """Estimate of a measurand with its uncertainty (JCGM 100 / JCGM 101 terms).

    Attributes
    ----------
    quantity : str
        What was measured (``"gauge_block_central_length"``).
    unit : str
    method : str
        ``"GUM linear"`` (JCGM 100 law of propagation) or ``"Monte Carlo"`` (JCGM 101).
    value : float
        Estimate ``y`` (GUM: ``f(x)``; Monte Carlo: mean of the trials).
    standard_uncertainty : float
        ``u(y)``.
    coverage_probability : float
        ``p`` (0.95 by default).
    coverage_interval : tuple of float
        ``(y_low, y_high)`` containing the measurand with probability ``p``.
    interval_kind : str
        ``"symmetric"`` (GUM: ``y -/+ k u``; Monte Carlo: probabilistically symmetric) or
        ``"shortest"`` (Monte Carlo, JCGM 101 §7.7.2).
    expanded_uncertainty : float
        ``U``: half-width of the coverage interval.
    coverage_factor : float
        ``k = U / u(y)`` (GUM: the t-quantile for ``dof``; Monte Carlo: implied).
    dof : float
        Effective degrees of freedom (Welch-Satterthwaite, GUM G.4); ``inf`` for Monte Carlo.
    budget : tuple of BudgetEntry
    n_trials : int
        Monte Carlo trials (0 for GUM).
    converged : bool
        Monte Carlo: the adaptive procedure met its numerical tolerance (JCGM 101 §7.9);
        GUM: always True.
    numerical_tolerance : float
        JCGM 101 §7.9.2 tolerance ``delta`` the results were stabilised to (NaN for GUM).
    message : str
    """

    quantity: str
    unit: str
    method: str
    value: float
    standard_uncertainty: float
    coverage_probability: float
    coverage_interval: tuple[float, float]
    interval_kind: str
    expanded_uncertainty: float
    coverage_factor: float
    dof: float = math.inf
    budget: tuple[BudgetEntry, ...] = ()
    n_trials: int = 0
    converged: bool = True
    numerical_tolerance: float = math.nan
    message: str = ""
    extra: dict[str, Any] = field(default_factory=dict, compare=False, repr=False)
    #: Monte Carlo output values (M,) when kept (``keep_values=True``); not in :meth:`to_dict`
    values: Any = field(default=None, compare=False, repr=False)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (non-finite numbers as None)."""
        out: dict[str, Any] = {}
        for key, value in self.__dict__.items():
            if key == "values":
                continue
            if key == "budget":
                out[key] = [entry.to_dict() for entry in value]
            elif key == "coverage_interval":
                out[key] = [float(v) for v in value]
            elif key == "extra":
                out[key] = {k: _json_number(v) for k, v in value.items()}
            else:
                out[key] = _json_number(value)
        return out

    def format(self, digits: int = 2) -> str:
        """``y ± U unit (k = .., p = 95 %)`` with ``U`` to ``digits`` significant digits.

        Examples
        --------
        >>> r = UncertaintyResult("L", "mm", "GUM linear", 100.000371, 0.00021, 0.95,
        ...                       (99.99996, 100.00078), "symmetric", 0.000412, 1.96)
        >>> r.format()
        '100.00037 ± 0.00041 mm (k = 1.96, coverage 95 %)'
        """
        decimals = decimals_for(self.expanded_uncertainty, digits)
        return (
            f"{self.value:.{decimals}f} ± {self.expanded_uncertainty:.{decimals}f} {self.unit} "
            f"(k = {self.coverage_factor:.2f}, coverage {100 * self.coverage_probability:.0f} %)"
        )


def decimals_for(uncertainty: float, digits: int = 2) -> int:
    """Decimal places that show ``uncertainty`` with ``digits`` significant digits (>= 0).

    Examples
    --------
    >>> decimals_for(0.000412), decimals_for(3.2), decimals_for(250.0)
    (5, 1, 0)
    """
    if not (math.isfinite(uncertainty) and uncertainty > 0):
        return 6
    return max(0, digits - 1 - math.floor(math.log10(uncertainty)))


def _json_number(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if hasattr(value, "item") and not isinstance(value, (str, bytes)):
        try:
            value = value.item()
        except (ValueError, AttributeError):
            return value
        return None if isinstance(value, float) and not math.isfinite(value) else value
    return value
