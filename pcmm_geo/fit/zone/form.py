"""ISO form evaluation by minimum zone: straightness, flatness, roundness, sphericity, cylindricity.

The form deviation of ISO 1101 / ISO 12180-12181 / ISO 12780-12781 is the width of the
minimum zone (``criterion="chebyshev"``) containing the measured points.  The verdict
against a tolerance is decided soundly: any zone that contains the points is at least
as wide as the minimum one, so a zone within the tolerance proves *pass* even without a
certificate; *fail* is only reported when the minimum zone is certified.  An uncertified
zone wider than the tolerance gives no verdict (``passed`` is None), never a guess.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.fit._kernels._core import FitResult

__all__ = ["CHARACTERISTICS", "FormEvaluation", "evaluate_form"]

#: element -> ISO characteristic evaluated by its minimum zone
CHARACTERISTICS = {
    "line": "straightness",
    "plane": "flatness",
    "circle": "roundness",
    "sphere": "sphericity",
    "cylinder": "cylindricity",
    "cone": "conicity",
}


@dataclass(frozen=True, eq=False)
class FormEvaluation:
    """Result of :func:`evaluate_form`.

    Attributes
    ----------
    element, characteristic : str
        E.g. ``"circle"``, ``"roundness"``.
    deviation : float
        Width of the minimum zone (mm); for a 3-D line the diameter of the smallest
        enclosing cylinder.
    tolerance : float or None
        Tolerance (mm) when one was given.
    passed : bool or None
        ``deviation <= tolerance``; None without a tolerance or when an uncertified zone
        exceeds it (no verdict).
    certified : bool
        The minimum zone carries an optimality certificate.
    fit : FitResult
        The Chebyshev fit (mid-zone element, residuals, ``contacts``, ``certificate``).
    points : ndarray, shape (N, D)
        The evaluated points (mm).
    """

    element: str
    characteristic: str
    deviation: float
    tolerance: float | None
    passed: bool | None
    certified: bool
    fit: FitResult
    points: np.ndarray

    @property
    def verdict(self) -> str:
        """``"pass"``, ``"fail"``, ``"no verdict"`` (uncertified and above tolerance) or ``"no tolerance"``."""
        if self.tolerance is None:
            return "no tolerance"
        if self.passed is None:
            return "no verdict"
        return "pass" if self.passed else "fail"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (the fit without its residuals)."""
        fit = self.fit.to_dict()
        fit.pop("residuals", None)
        fit.pop("residual_components", None)
        fit.get("extra", {}).pop("residual_components", None)
        return {
            "element": self.element,
            "characteristic": self.characteristic,
            "deviation_mm": self.deviation,
            "tolerance_mm": self.tolerance,
            "passed": self.passed,
            "verdict": self.verdict,
            "certified": self.certified,
            "contacts": self.fit.contacts.tolist(),
            "fit": fit,
        }


def evaluate_form(points: ArrayLike, element: str, tolerance: float | None = None) -> FormEvaluation:
    """Evaluate the form deviation of ``points`` by the minimum zone of ``element``.

    Parameters
    ----------
    points : array_like, shape (N, 3) (or (N, 2) for a line or circle)
        Measured points (mm).
    element : {"line", "plane", "circle", "sphere", "cylinder", "cone"}
    tolerance : float, optional
        Form tolerance (mm, positive) for a pass/fail verdict.

    Returns
    -------
    FormEvaluation

    Raises
    ------
    InvalidInputError
        Unknown element, bad tolerance, bad points.
    TooFewPointsError, DegenerateGeometryError
        As the element's fit.

    Examples
    --------
    >>> angles = np.radians(np.arange(0, 360, 30))
    >>> radii = 5 + 0.002 * np.cos(3 * angles)
    >>> result = evaluate_form(np.c_[radii * np.cos(angles), radii * np.sin(angles)], "circle", tolerance=0.005)
    >>> result.characteristic, round(result.deviation, 9), result.verdict
    ('roundness', 0.004, 'pass')
    """
    from pcmm_geo import fit as fit_module

    if element not in CHARACTERISTICS:
        raise InvalidInputError("element", "one of " + ", ".join(CHARACTERISTICS), repr(element))
    if tolerance is not None and not (np.isfinite(tolerance) and tolerance > 0):
        raise InvalidInputError("tolerance", "a positive finite number of mm", repr(tolerance))
    result: FitResult = getattr(fit_module, f"fit_{element}")(points, criterion="chebyshev")
    data = np.array(points, dtype=float)
    residuals = np.asarray(result.residuals)
    is_3d_line = element == "line" and result.parameters.size == 6
    # the width of a zone that certainly contains every point, about the reported element
    contained = 2.0 * float(residuals.max()) if is_3d_line else float(np.ptp(residuals))
    deviation = float(result.form) if result.converged else contained
    passed: bool | None = None
    if tolerance is not None:
        if contained <= tolerance:
            passed = True
        elif result.converged:
            passed = False
    return FormEvaluation(
        element=element,
        characteristic=CHARACTERISTICS[element],
        deviation=deviation,
        tolerance=None if tolerance is None else float(tolerance),
        passed=passed,
        certified=bool(result.converged),
        fit=result,
        points=data,
    )
