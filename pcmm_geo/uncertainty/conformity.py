"""ISO 14253-1 decision rules: conformity or nonconformity with a specification, proved with the uncertainty.

A measured value ``y`` with expanded uncertainty ``U`` (95 % coverage) is compared with a
specification zone ``[lower, upper]`` (for an MPE: ``[-MPE, MPE]`` or ``[0, MPE]``):

* the **acceptance zone** is the specification zone reduced by ``U`` at each limit (a
  guard band of ``U``): inside it **conformity is proved** -- verdict ``PASS``;
* the **rejection zone** lies beyond the specification zone enlarged by ``U``: there
  **nonconformity is proved** -- verdict ``FAIL``;
* in between, within ``U`` of a limit, **neither conformity nor nonconformity is proved**
  -- verdict ``NOT PROVEN``.

This is the default rule of ISO 14253-1 (the uncertainty always counts against the party
that has to prove its claim: the supplier proving conformity, the customer proving
nonconformity).  With ``U = 0`` it reduces to simple acceptance (no ``NOT PROVEN``
except exactly on a limit, which counts as conforming).  A limit that is ``None`` is
absent (one-sided specification).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from pcmm_geo.errors import InvalidInputError

__all__ = ["DECISION_RULE_TEXT", "VERDICTS", "ConformityDecision", "decide_conformity", "overall_verdict"]

#: verdict -> state as ISO 14253-1 words it
VERDICTS = {
    "PASS": "conformity proved",
    "FAIL": "nonconformity proved",
    "NOT PROVEN": "neither conformity nor nonconformity proved",
}
DECISION_RULE_TEXT = (
    "ISO 14253-1: conformity proved inside the specification zone reduced by U (guard band U), "
    "nonconformity proved outside it enlarged by U, otherwise not proven"
)


@dataclass(frozen=True)
class ConformityDecision:
    """Decision for one value (units of the value).

    Attributes
    ----------
    value, expanded_uncertainty : float
    lower_limit, upper_limit : float or None
        Specification limits (None: one-sided).
    acceptance_zone : tuple of float
        ``(lower + U, upper - U)`` (``-inf`` / ``inf`` for an absent limit).
    verdict : str
        ``"PASS"``, ``"FAIL"`` or ``"NOT PROVEN"``.
    state : str
        The ISO 14253-1 wording (:data:`VERDICTS`).
    rule : str
    """

    value: float
    expanded_uncertainty: float
    lower_limit: float | None
    upper_limit: float | None
    acceptance_zone: tuple[float, float]
    verdict: str
    state: str
    rule: str = DECISION_RULE_TEXT

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (infinite zone limits as None)."""
        zone = [v if math.isfinite(v) else None for v in self.acceptance_zone]
        return {**self.__dict__, "acceptance_zone": zone}


def decide_conformity(
    value: float,
    expanded_uncertainty: float,
    *,
    upper_limit: float | None = None,
    lower_limit: float | None = None,
) -> ConformityDecision:
    """Apply the ISO 14253-1 default decision rule to one measured value.

    Parameters
    ----------
    value : float
    expanded_uncertainty : float
        ``U`` (>= 0), same unit.
    upper_limit, lower_limit : float, optional
        At least one.

    Returns
    -------
    ConformityDecision

    Raises
    ------
    InvalidInputError
        Non-finite value, negative U, no limit, or a lower limit above the upper.

    Examples
    --------
    ``|E0|`` against MPE = 2.0 µm with U = 0.5 µm:

    >>> [decide_conformity(e, 0.5, upper_limit=2.0).verdict for e in (1.2, 1.8, 2.7)]
    ['PASS', 'NOT PROVEN', 'FAIL']
    """
    if not math.isfinite(value):
        raise InvalidInputError("value", "a finite measured value", repr(value))
    if not (math.isfinite(expanded_uncertainty) and expanded_uncertainty >= 0):
        raise InvalidInputError("expanded_uncertainty", "a finite U >= 0", repr(expanded_uncertainty))
    if upper_limit is None and lower_limit is None:
        raise InvalidInputError("limits", "an upper and/or a lower specification limit", "neither")
    upper = math.inf if upper_limit is None else float(upper_limit)
    lower = -math.inf if lower_limit is None else float(lower_limit)
    if lower > upper:
        raise InvalidInputError("lower_limit", f"at most the upper limit {upper}", repr(lower))
    u = float(expanded_uncertainty)
    if lower + u <= value <= upper - u:
        verdict = "PASS"
    elif value > upper + u or value < lower - u:
        verdict = "FAIL"
    else:
        verdict = "NOT PROVEN"
    return ConformityDecision(
        value=float(value), expanded_uncertainty=u, lower_limit=lower_limit, upper_limit=upper_limit,
        acceptance_zone=(lower + u, upper - u), verdict=verdict, state=VERDICTS[verdict],
    )


def overall_verdict(verdicts: list[str]) -> str:
    """A test of several values: ``FAIL`` if any nonconformity is proved, ``PASS`` if all conform, else ``NOT PROVEN``.

    Examples
    --------
    >>> overall_verdict(["PASS", "NOT PROVEN"]), overall_verdict(["PASS", "FAIL", "NOT PROVEN"])
    ('NOT PROVEN', 'FAIL')
    """
    if any(v == "FAIL" for v in verdicts):
        return "FAIL"
    return "PASS" if all(v == "PASS" for v in verdicts) else "NOT PROVEN"
