"""Criterion validation and the fields every minimax result shares."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.elements import CRITERIA as CRITERIA
from pcmm_geo.elements import SPECS, Criterion, Element
from pcmm_geo.elements import check_criterion as check_criterion_name
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.fit._kernels._core import Certificate
from pcmm_geo.fit._kernels._linear import frozen
from pcmm_geo.fit.zone._solver import ZoneSolution

FloatArray = NDArray[np.float64]

#: criteria each element supports (pcmm_geo.elements)
SUPPORTED: dict[str, tuple[Criterion, ...]] = {name: row.criteria for name, row in SPECS.items() if row.fitted}
_MODE = {"chebyshev": "zone", "mcc": "mcc", "mic": "mic"}
METHOD = "slp+kkt-newton"
#: ``FitResult.method`` of an answer found by an exact global method (then polished by the KKT system)
EXACT_METHOD = "exact+kkt-polish"
#: a global search closes -- certificate scope ``"global"`` -- when its gap is at most this (mm)
GLOBAL_GAP_MM = 1e-9


@dataclass(frozen=True)
class Proof:
    """What an exact or global search proved about a minimax optimum (filled into the certificate).

    Attributes
    ----------
    bound_mm : float
        Proven bound of the optimum over ``domain``: a lower bound of the zone width (Chebyshev) or
        of the radius (MCC), an upper bound of the radius (MIC).
    value_mm : float
        The reported value the bound refers to (zone width or radius).
    domain : str
        The set of elements the bound holds for, in words (e.g. ``"all planes"``).
    method : str
        How the bound was proven.
    on_region_boundary : bool
        The optimum lies on the boundary of a restricted search region (axial elements).
    """

    bound_mm: float
    value_mm: float
    domain: str
    method: str
    on_region_boundary: bool = False

    @property
    def gap_mm(self) -> float:
        """``|value - bound|`` (mm)."""
        return abs(self.value_mm - self.bound_mm)

    @property
    def scope(self) -> str:
        """``"global"`` when the gap is within :data:`GLOBAL_GAP_MM`, else ``"local"``."""
        return "global" if self.gap_mm <= GLOBAL_GAP_MM else "local"


def check_criterion(criterion: object, element: Element, **gaussian_only: object) -> Criterion:
    """Validate ``criterion`` for ``element``; options that only a Gaussian fit takes must be None.

    Raises
    ------
    InvalidInputError
        Unknown criterion, a criterion the element does not support, or a Gaussian-only
        option (weights, fixed radius, ...) combined with another criterion.
    """
    checked = check_criterion_name(criterion)
    allowed = SUPPORTED[element]
    if checked not in allowed:
        raise InvalidInputError(
            "criterion", f"one of {', '.join(repr(c) for c in allowed)} for a {element}", repr(criterion)
        )
    if criterion != "gaussian":
        for name, value in gaussian_only.items():
            if value is not None and value is not False:
                raise InvalidInputError(name, f"None with criterion={criterion!r} (Gaussian fits only)", repr(value))
    return checked


def mode_of(criterion: Criterion) -> str:
    """Solver mode (``zone``, ``mcc``, ``mic``) of a non-Gaussian criterion."""
    return _MODE[criterion]


def shared_fields(
    residuals: FloatArray,
    solution: ZoneSolution,
    *,
    criterion: Criterion,
    parameter_names: tuple[str, ...],
    parameters: FloatArray,
    form: float,
    n_free: int,
    n_residuals: int | None = None,
    proof: Proof | None = None,
) -> dict[str, Any]:
    """Keyword arguments of the :class:`FitResult` base for a minimax result.

    The covariance is NaN: the least-squares error model behind it does not apply to a
    minimax fit.  With a ``proof`` of scope ``"global"`` the result is certified (and converged)
    whatever the KKT test says: exact data, whose contact system is degenerate, are certified so.
    """
    n = len(residuals)
    n_par = len(parameter_names)
    certified, message, method = solution.certified, solution.message, METHOD
    extra_fields: dict[str, Any] = {}
    if proof is not None:
        method = EXACT_METHOD
        extra_fields = {
            "scope": proof.scope,
            "bound_mm": float(proof.bound_mm),
            "gap_mm": float(proof.gap_mm),
            "on_region_boundary": proof.on_region_boundary,
            "domain": proof.domain,
        }
        if proof.scope == "global":
            certified = True
            kkt = "; KKT conditions hold on the contact set" if solution.certified else ""
            message = (
                f"certified: global optimum over {proof.domain} ({proof.method}; gap {proof.gap_mm:.1e} mm){kkt}"
            )
        else:
            message = f"{message}; proven bound {proof.bound_mm:.9g} mm over {proof.domain} (gap {proof.gap_mm:.3g} mm)"
    certificate = Certificate(
        multipliers=frozen(solution.multipliers),
        kkt_residual=solution.kkt_residual,
        feasibility=solution.feasibility,
        certified=certified,
        method=method if proof is None else f"{proof.method} + KKT polish",
        **extra_fields,
    )
    return {
        "residuals": frozen(residuals),
        "rms": float(np.sqrt(np.mean(residuals**2))),
        "form": float(form),
        "n": n,
        "dof": (n if n_residuals is None else n_residuals) - n_free,
        "parameter_names": parameter_names,
        "parameters": frozen(parameters),
        "covariance": frozen(np.full((n_par, n_par), np.nan)),
        "condition_number": float("nan"),
        "converged": certified,
        "iterations": solution.iterations,
        "message": message,
        "method": method,
        "criterion": criterion,
        "contacts": frozen_index(solution.contacts),
        "certificate": certificate,
    }


def frozen_index(index: NDArray[np.intp]) -> NDArray[np.intp]:
    """A copy of contact indices owned by the result."""
    return np.array(index, dtype=np.intp)
