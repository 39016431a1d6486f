"""ISO form evaluation by minimum zone: straightness, flatness, roundness, sphericity, cylindricity.

The form deviation of ISO 1101 / ISO 12180-12181 / ISO 12780-12781 is the width of the
minimum zone (``criterion="chebyshev"``) containing the measured points.  The verdict against a
tolerance rests on two numbers of the fit, never on a guess (:func:`decide_form`):

- ``PASS`` when the reported zone, which contains every point, is within the tolerance -- the
  minimum zone is no wider, whether or not the reported one is proven minimal;
- ``FAIL`` when the certificate's proven *lower bound* of the minimum-zone width exceeds the
  tolerance (a global answer's bound equals its width to rounding);
- ``NOT PROVEN`` in between: a local answer wider than the tolerance whose bound does not
  exceed it.

The measurement uncertainty is not part of this rule (a zone of measured points, no guard band).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from pcmm_geo._records import record
from pcmm_geo.elements import SPECS, Element
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.fit._kernels._core import FitResult

if TYPE_CHECKING:
    from pcmm_geo.fit.zone.axial.region import AxisRegion, SearchBudget

__all__ = ["CHARACTERISTICS", "FORM_DECISION_RULE", "FormEvaluation", "decide_form", "evaluate_form"]

#: element -> ISO characteristic evaluated by its minimum zone (pcmm_geo.elements)
CHARACTERISTICS: dict[str, str] = {name: row.form for name, row in SPECS.items() if row.fitted and row.form}

#: the decision rule of :func:`decide_form`, in words (reports print it beside the verdict)
FORM_DECISION_RULE = (
    "PASS if the width of a zone containing every point is within the tolerance; FAIL if the proven lower "
    "bound of the minimum-zone width exceeds it; otherwise NOT PROVEN (measurement uncertainty not included)"
)


def decide_form(value_mm: float, bound_mm: float, tolerance_mm: float) -> str:
    """Verdict of a minimum-zone width against a form tolerance: ``"PASS"``, ``"FAIL"`` or ``"NOT PROVEN"``.

    Parameters
    ----------
    value_mm : float
        Width of a zone that contains every point (the reported minimum zone), mm.
    bound_mm : float
        Proven lower bound of the minimum-zone width over the certificate's domain, mm (NaN: none).
    tolerance_mm : float
        Form tolerance, mm.

    Returns
    -------
    str
        ``"PASS"`` when ``value_mm <= tolerance_mm``; ``"FAIL"`` when ``bound_mm > tolerance_mm``;
        otherwise ``"NOT PROVEN"``.

    Raises
    ------
    InvalidInputError
        A non-finite value or a tolerance that is not a positive finite number.

    Examples
    --------
    >>> decide_form(0.008, 0.008, 0.010), decide_form(0.012, 0.012, 0.010)
    ('PASS', 'FAIL')
    >>> decide_form(0.012, 0.009, 0.010), decide_form(0.012, float("nan"), 0.010)
    ('NOT PROVEN', 'NOT PROVEN')
    """
    if not np.isfinite(value_mm):
        raise InvalidInputError("value_mm", "a finite zone width in mm", repr(value_mm))
    if not (np.isfinite(tolerance_mm) and tolerance_mm > 0):
        raise InvalidInputError("tolerance_mm", "a positive finite number of mm", repr(tolerance_mm))
    if value_mm <= tolerance_mm:
        return "PASS"
    if np.isfinite(bound_mm) and bound_mm > tolerance_mm:
        return "FAIL"
    return "NOT PROVEN"


@record
class FormEvaluation:
    """Result of :func:`evaluate_form`.

    Attributes
    ----------
    element, characteristic : str
        E.g. ``"circle"``, ``"roundness"``.
    deviation : float
        Width of the minimum zone (mm); for a 3-D line the diameter of the smallest
        enclosing cylinder.  For an uncertified fit, the width of the zone about the reported
        element that contains every point.
    tolerance : float or None
        Tolerance (mm) when one was given.
    passed : bool or None
        True for ``PASS``, False for ``FAIL``; None for ``NOT PROVEN`` or without a tolerance.
    certified : bool
        The minimum zone carries an optimality certificate.
    fit : FitResult
        The Chebyshev fit (mid-zone element, residuals, ``contacts``, ``certificate``).
    points : ndarray, shape (N, D)
        The evaluated points (mm).
    scope : str
        ``"global"``: the deviation is the minimum over ``domain`` (to ``gap`` mm); ``"local"``: only
        a local minimum is proven, ``bound`` is the proven lower bound (NaN when none).
    bound : float
        Proven lower bound of the minimum-zone width over ``domain`` (mm; NaN when none).
    gap : float
        ``|deviation - bound|`` (mm; NaN when no bound).
    domain : str
        The elements the scope refers to (e.g. ``"all planes"``).
    """

    element: Element
    characteristic: str
    deviation: float
    tolerance: float | None
    passed: bool | None
    certified: bool
    fit: FitResult
    points: np.ndarray
    scope: str = "local"
    bound: float = float("nan")
    gap: float = float("nan")
    domain: str = ""

    @property
    def verdict(self) -> str:
        """``"PASS"``, ``"FAIL"``, ``"NOT PROVEN"`` (:func:`decide_form`) or ``"no tolerance"``."""
        if self.tolerance is None:
            return "no tolerance"
        if self.passed is None:
            return "NOT PROVEN"
        return "PASS" if self.passed else "FAIL"

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
            "decision_rule": FORM_DECISION_RULE,
            "certified": self.certified,
            "scope": self.scope,
            "bound_mm": None if np.isnan(self.bound) else self.bound,
            "gap_mm": None if np.isnan(self.gap) else self.gap,
            "domain": self.domain,
            "contacts": self.fit.contacts.tolist(),
            "fit": fit,
        }


def evaluate_form(
    points: ArrayLike,
    element: Element,
    tolerance: float | None = None,
    *,
    axis_region: AxisRegion | None = None,
    search_budget: SearchBudget | None = None,
) -> FormEvaluation:
    r"""Evaluate the form deviation of ``points`` by the minimum zone of ``element``.

    Parameters
    ----------
    points : array_like, shape (N, 3) (or (N, 2) for a line or circle)
        Measured points (mm).
    element : {"line", "plane", "circle", "sphere", "cylinder", "cone"}
    tolerance : float, optional
        Form tolerance (mm, positive) for a verdict (:func:`decide_form`).
    axis_region : AxisRegion, optional
        Cylinder: the axes searched (see :func:`pcmm_geo.fit.fit_cylinder`).
    search_budget : SearchBudget, optional
        Cylinder, 3-D line: limits of the global axis search.

    Returns
    -------
    FormEvaluation

    Raises
    ------
    InvalidInputError
        Unknown element, bad tolerance, bad points.
    TooFewPointsError, DegenerateGeometryError
        As the element's fit.

    See Also
    --------
    decide_form : the verdict of a value and its proven bound against a tolerance
    pcmm_geo.fit.fit_cylinder : the fits with ``criterion='chebyshev'``
    pcmm_geo.fit.zone.check_answer : the independent check of a minimax answer

    Notes
    -----
    The form deviation is the width of the minimum zone (Chebyshev criterion) of ISO 1101 [1]_,

    .. math::

        t = \min_{\mathbf{a}} \Bigl( \max_i d_i(\mathbf{a}) - \min_i d_i(\mathbf{a}) \Bigr) ,

    with :math:`d_i` the signed distance of the element fitted by :func:`pcmm_geo.fit.fit_sphere`
    and the other fits (for a circle, sphere or cylinder the zone between two concentric
    surfaces; for a line or plane between two parallel ones).  At the optimum the support points
    satisfy the Karush-Kuhn-Tucker conditions; the certificate reports their residual and, where
    the optimum is proven over the whole domain, a bound [2]_.  The Gaussian form
    (``max - min`` of least-squares residuals) is never smaller.  A verdict (:func:`decide_form`) is
    given in the words of the ISO 14253-1 decision rules [3]_: PASS, FAIL or NOT PROVEN.

    References
    ----------
    .. [1] ISO 1101:2017, *Geometrical product specifications (GPS) -- Geometrical tolerancing -- Tolerances
           of form, orientation, location and run-out* (the form zone is the smallest one containing the
           feature).
    .. [2] G. T. Anthony et al., "Reference software for finding Chebyshev best-fit geometric elements",
           *Precision Engineering* 19(1), 28-36 (1996).
    .. [3] ISO 14253-1:2017, *Geometrical product specifications (GPS) -- Inspection by measurement of
           workpieces and measuring equipment -- Part 1: Decision rules for verifying conformity or
           nonconformity with specifications*.

    Examples
    --------
    >>> angles = np.radians(np.arange(0, 360, 30))
    >>> radii = 5 + 0.002 * np.cos(3 * angles)
    >>> result = evaluate_form(np.c_[radii * np.cos(angles), radii * np.sin(angles)], "circle", tolerance=0.005)
    >>> result.characteristic, round(result.deviation, 9), result.verdict, result.scope
    ('roundness', 0.004, 'PASS', 'global')
    """
    from pcmm_geo import fit as fit_module

    if element not in CHARACTERISTICS:
        raise InvalidInputError("element", "one of " + ", ".join(CHARACTERISTICS), repr(element))
    if tolerance is not None and not (np.isfinite(tolerance) and tolerance > 0):
        raise InvalidInputError("tolerance", "a positive finite number of mm", repr(tolerance))
    search: dict[str, Any] = {}
    if axis_region is not None:
        search["axis_region"] = axis_region
    if search_budget is not None:
        search["search_budget"] = search_budget
    if search and element not in ("cylinder", "line"):
        raise InvalidInputError("axis_region / search_budget", "element cylinder or line", repr(element))
    result: FitResult = getattr(fit_module, f"fit_{element}")(points, criterion="chebyshev", **search)
    data = np.array(points, dtype=float)
    residuals = np.asarray(result.residuals)
    is_3d_line = element == "line" and result.parameters.size == 6
    # the width of a zone that certainly contains every point, about the reported element
    contained = 2.0 * float(residuals.max()) if is_3d_line else float(np.ptp(residuals))
    deviation = float(result.form) if result.converged else contained
    certificate = result.certificate
    scope = "local" if certificate is None else certificate.scope
    bound = float("nan") if certificate is None else float(certificate.bound_mm)
    passed: bool | None = None
    if tolerance is not None:
        verdict = decide_form(contained, bound, float(tolerance))
        passed = {"PASS": True, "FAIL": False}.get(verdict)
    return FormEvaluation(
        element=element,
        characteristic=CHARACTERISTICS[element],
        deviation=deviation,
        tolerance=None if tolerance is None else float(tolerance),
        passed=passed,
        certified=bool(result.converged),
        fit=result,
        points=data,
        scope=scope,
        bound=bound,
        gap=abs(deviation - bound) if np.isfinite(bound) else float("nan"),
        domain="" if certificate is None else certificate.domain,
    )
