"""Criterion validation and the fields every minimax result shares."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.fit._kernels._core import Certificate
from pcmm_geo.fit._kernels._linear import frozen
from pcmm_geo.fit.zone._solver import ZoneSolution

FloatArray = NDArray[np.float64]

CRITERIA = ("gaussian", "chebyshev", "mcc", "mic")
#: criteria each element supports
SUPPORTED = {
    "line": ("gaussian", "chebyshev"),
    "plane": ("gaussian", "chebyshev"),
    "circle": CRITERIA,
    "sphere": CRITERIA,
    "cylinder": CRITERIA,
    "cone": ("gaussian", "chebyshev"),
    "torus": ("gaussian",),
}
_MODE = {"chebyshev": "zone", "mcc": "mcc", "mic": "mic"}
METHOD = "slp+kkt-newton"


def check_criterion(criterion: object, element: str, **gaussian_only: object) -> str:
    """Validate ``criterion`` for ``element``; options that only a Gaussian fit takes must be None.

    Raises
    ------
    InvalidInputError
        Unknown criterion, a criterion the element does not support, or a Gaussian-only
        option (weights, fixed radius, ...) combined with another criterion.
    """
    if not isinstance(criterion, str) or criterion not in CRITERIA:
        raise InvalidInputError("criterion", "one of " + ", ".join(repr(c) for c in CRITERIA), repr(criterion))
    allowed = SUPPORTED[element]
    if criterion not in allowed:
        raise InvalidInputError(
            "criterion", f"one of {', '.join(repr(c) for c in allowed)} for a {element}", repr(criterion)
        )
    if criterion != "gaussian":
        for name, value in gaussian_only.items():
            if value is not None and value is not False:
                raise InvalidInputError(name, f"None with criterion={criterion!r} (Gaussian fits only)", repr(value))
    return criterion


def mode_of(criterion: str) -> str:
    """Solver mode (``zone``, ``mcc``, ``mic``) of a non-Gaussian criterion."""
    return _MODE[criterion]


def shared_fields(
    residuals: FloatArray,
    solution: ZoneSolution,
    *,
    criterion: str,
    parameter_names: tuple[str, ...],
    parameters: FloatArray,
    form: float,
    n_free: int,
    n_residuals: int | None = None,
) -> dict[str, Any]:
    """Keyword arguments of the :class:`FitResult` base for a minimax result.

    The covariance is NaN: the least-squares error model behind it does not apply to a
    minimax fit.
    """
    n = len(residuals)
    n_par = len(parameter_names)
    certificate = Certificate(
        multipliers=frozen(solution.multipliers),
        kkt_residual=solution.kkt_residual,
        feasibility=solution.feasibility,
        certified=solution.certified,
        method=METHOD,
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
        "converged": solution.certified,
        "iterations": solution.iterations,
        "message": solution.message,
        "method": METHOD,
        "criterion": criterion,
        "contacts": frozen_index(solution.contacts),
        "certificate": certificate,
    }


def frozen_index(index: NDArray[np.intp]) -> NDArray[np.intp]:
    """A copy of contact indices owned by the result."""
    return np.array(index, dtype=np.intp)
