"""Independent check of a minimax fit's certificate on the caller's points.

The solvers prove their answers (an exact bound, a branch and bound, the KKT system of the contacts);
this module checks the *reported* answer again from the result's own fields and the points alone,
with its own distance formulas in the machine frame (no solver code):

1. **feasibility** -- every input point lies inside the claimed zone (between ``r_in`` and ``r_out``,
   the two planes / lines / cones), inside the claimed enclosing element (MCC, 3-D line zone) or outside
   the claimed inscribed one (MIC), within ``feasibility_tolerance``;
2. **value** -- each contact lies on the level it supports (the claimed radius, or the zone's inner /
   outer level), so the claimed value is the one the contacts give; the contacts are distinct points
   (no two within the merge tolerance) and there is at least one per level;
3. **stationarity** (KKT) -- the multipliers are non-negative, those of each level sum to 1, and
   ``|sum_k s_k lambda_k grad d_k| <= STATIONARITY_TOLERANCE`` with the gradients of the point
   distances ``d_k`` with respect to the element's position (unit vectors) and orientation (divided by
   the data's extent), ``s_k = +1`` on the outer and ``-1`` on the inner level.  Not checked for a zone
   of width 0 within the tolerance (0 is a lower bound of every zone: exact data) and for an axial
   optimum on the edge of its axis region (the region's edge constraints carry multipliers of their own).

A fit that fails the check keeps its numbers but is reported ``certified=False``, ``scope="local"``,
``converged=False``, with no proven bound (``bound_mm`` and ``gap_mm`` NaN) and the reason in its message
and in ``certificate.check``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.fit._kernels._core import FitResult

FloatArray = NDArray[np.float64]
ResultT = TypeVar("ResultT", bound=FitResult)

#: feasibility / level tolerance relative to the data's extent (the solvers' own is 1e-11 x the rms size)
FEASIBILITY_RELATIVE = 1e-11
#: machine epsilons of the largest coordinate magnitude added to it (distances evaluated in the machine frame)
FEASIBILITY_ULPS = 64.0
#: largest norm of the weighted sum of the contacts' (dimensionless) distance gradients
STATIONARITY_TOLERANCE = 1e-6
#: multipliers may be this far below 0, and each level's sum this far from 1
MULTIPLIER_TOLERANCE = 1e-6


@dataclass(frozen=True)
class CheckOutcome:
    """What the independent check found.

    Attributes
    ----------
    passed : bool
        Every condition holds.
    feasibility_mm : float
        Largest distance of an input point outside the claimed zone / element (0 when all inside).
    level_mm : float
        Largest distance of a contact from the level it supports.
    stationarity : float
        Norm of ``sum_k s_k lambda_k grad d_k`` (dimensionless; NaN when not checked).
    tolerance_mm : float
        The feasibility and level tolerance used.
    reason : str
        The first condition that failed ("" when passed); or what was not checked.
    """

    passed: bool
    feasibility_mm: float
    level_mm: float
    stationarity: float
    tolerance_mm: float
    reason: str

    def summary(self) -> str:
        """One line for the certificate."""
        head = "passed" if self.passed else f"FAILED: {self.reason}"
        note = f" ({self.reason})" if self.passed and self.reason else ""
        return (f"independent check {head}{note}; every point inside to {self.feasibility_mm:.3g} mm, contacts on "
                f"their levels to {self.level_mm:.3g} mm (tolerance {self.tolerance_mm:.3g} mm), stationarity "
                f"{self.stationarity:.3g}")


def _frame(axis: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Two unit vectors normal to ``axis`` and to each other."""
    helper = np.zeros(len(axis))
    helper[int(np.argmin(np.abs(axis)))] = 1.0
    e1 = np.cross(helper, axis)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(axis, e1)


def _unit(vectors: FloatArray) -> tuple[FloatArray, FloatArray]:
    norm = np.linalg.norm(vectors, axis=1)
    return norm, vectors / np.where(norm > 0, norm, 1.0)[:, None]


def _axis_terms(rel: FloatArray, axis: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Height along ``axis``, distance from it and the radial unit vector of each relative point."""
    height = rel @ axis
    rho, radial = _unit(rel - np.outer(height, axis))
    return height, rho, radial


def geometry(result: Any, points: FloatArray, extent: float) -> tuple[FloatArray, FloatArray, float, float, str]:
    """Distances ``d`` (N,), their gradients (N, P), the claimed lower / upper levels and the mode.

    Levels not claimed (the outer level of a MIC, the inner one of an MCC) are -inf / +inf.
    """
    criterion = result.criterion
    mode = {"chebyshev": "zone", "mcc": "mcc", "mic": "mic"}[criterion]
    inf = float("inf")
    if hasattr(result, "apex"):  # cone: d = rho cos(alpha) - h sin(alpha), level radius_at_point cos(alpha)
        axis, alpha = np.asarray(result.axis), float(result.half_angle)
        height, rho, radial = _axis_terms(points - result.point, axis)
        cos_a, sin_a = np.cos(alpha), np.sin(alpha)
        d = rho * cos_a - height * sin_a
        e1, e2 = _frame(axis)
        tilt = -(height * cos_a + rho * sin_a) / extent
        grad = np.column_stack([-radial * cos_a + axis * sin_a, tilt * (radial @ e1), tilt * (radial @ e2),
                                (-rho * sin_a - height * cos_a) / extent])
        mid = float(result.radius_at_point) * cos_a
        return d, grad, mid - 0.5 * result.form, mid + 0.5 * result.form, mode
    if hasattr(result, "axis"):  # cylinder
        axis = np.asarray(result.axis)
        height, d, radial = _axis_terms(points - result.point, axis)
        e1, e2 = _frame(axis)
        grad = np.column_stack([-radial, -height * (radial @ e1) / extent, -height * (radial @ e2) / extent])
        levels = {"zone": (result.r_in, result.r_out), "mcc": (-inf, result.radius), "mic": (result.radius, inf)}
        return d, grad, *levels[mode], mode
    if hasattr(result, "direction"):  # line
        direction = np.asarray(result.direction)
        rel = points - result.point
        if direction.size == 3:  # zone: the smallest enclosing cylinder, of diameter ``form``
            height, d, radial = _axis_terms(rel, direction)
            e1, e2 = _frame(direction)
            grad = np.column_stack([-radial, -height * (radial @ e1) / extent, -height * (radial @ e2) / extent])
            return d, grad, -inf, 0.5 * result.form, "mcc"
        normal = np.array([-direction[1], direction[0]])
        d = rel @ normal
        grad = np.column_stack([np.tile(-normal, (len(d), 1)), (rel @ direction) / extent])
        return d, grad, -0.5 * result.form, 0.5 * result.form, mode
    if hasattr(result, "radius"):  # circle (2-D, or in its plane) and sphere
        rel = points - result.center
        normal = getattr(result, "normal", None)
        if normal is not None:
            rel = rel - np.outer(rel @ normal, normal)
        d, unit = _unit(rel)
        levels = {"zone": (result.r_in, result.r_out), "mcc": (-inf, result.radius), "mic": (result.radius, inf)}
        return d, -unit, *levels[mode], mode
    normal = np.asarray(result.normal)  # plane
    rel = points - result.point
    e1, e2 = _frame(normal)
    d = rel @ normal
    grad = np.column_stack([np.tile(-normal, (len(d), 1)), (rel @ e1) / extent, (rel @ e2) / extent])
    return d, grad, -0.5 * result.form, 0.5 * result.form, mode


def check_answer(result: Any, points: FloatArray, *, merge_tolerance: float = 0.0) -> CheckOutcome:
    """Check a minimax ``result`` (its geometry, contacts and multipliers) against every one of ``points``.

    Parameters
    ----------
    result : FitResult
        A Chebyshev / MCC / MIC fit of ``points`` (circle, sphere, plane, line, cylinder or cone).
    points : ndarray, shape (N, D)
        The points the fit claims to hold (mm, machine frame).
    merge_tolerance : float
        Points closer than this are one point (mm; see :mod:`pcmm_geo.fit.zone._distinct`).

    Returns
    -------
    CheckOutcome
    """
    points = np.asarray(points, dtype=float)
    centroid = points.mean(axis=0)
    extent = max(float(np.linalg.norm(points - centroid, axis=1).max()), 1e-300)
    tolerance = (FEASIBILITY_RELATIVE * extent + FEASIBILITY_ULPS * float(np.finfo(float).eps)
                 * float(np.abs(points).max()) + 2.0 * merge_tolerance)
    d, grad, lower, upper, mode = geometry(result, points, extent)
    nan = float("nan")

    def outcome(passed: bool, reason: str, feas: float = nan, level: float = nan, stat: float = nan) -> CheckOutcome:
        return CheckOutcome(passed, feas, level, stat, tolerance, reason)

    if not (np.all(np.isfinite(d)) and np.isfinite(lower) | (mode == "mcc") and np.isfinite(upper) | (mode == "mic")):
        return outcome(False, "the claimed element or its levels are not finite")
    feasibility = float(max(0.0, float((d - upper).max()), float((lower - d).max())))
    if feasibility > tolerance:
        worst = int(np.argmax(np.maximum(d - upper, lower - d)))
        return outcome(False, f"point {worst} lies {feasibility:.3g} mm outside the claimed zone", feasibility)
    contacts = np.asarray(result.contacts, dtype=np.intp)
    multipliers = np.asarray(result.certificate.multipliers, dtype=float)
    if contacts.size == 0 or multipliers.shape != contacts.shape:
        return outcome(False, "no contacts, or not one multiplier per contact", feasibility)
    if contacts.min() < 0 or contacts.max() >= len(points) or len(np.unique(contacts)) < contacts.size:
        return outcome(False, "contact indices out of range or repeated", feasibility)
    support = points[contacts]
    gaps = np.linalg.norm(support[:, None, :] - support[None, :, :], axis=2)
    gaps[np.diag_indices(len(support))] = np.inf
    if gaps.min() <= merge_tolerance:
        return outcome(False, "two contacts are the same point (duplicated support points)", feasibility)
    dk = d[contacts]
    sign = np.where(np.abs(dk - upper) <= np.abs(dk - lower), 1.0, -1.0)
    level = float(np.max(np.abs(dk - np.where(sign > 0, upper, lower))))
    if level > tolerance:
        return outcome(False, f"a contact lies {level:.3g} mm off its level: the claimed value is not the contacts'",
                       feasibility, level)
    # 0 bounds every zone width and every enclosing radius: a zone of width 0 (exact data) or an enclosing
    # cylinder of radius 0 (collinear points) is optimal whatever the multipliers
    trivial = (mode == "zone" and upper - lower <= tolerance) or (mode == "mcc" and upper <= tolerance)
    if mode == "zone" and not trivial and not (np.any(sign > 0) and np.any(sign < 0)):
        return outcome(False, "a zone needs contacts on both levels", feasibility, level)
    if trivial:
        return outcome(True, "stationarity not needed: a zone of width 0 (radius 0)", feasibility, level)
    if multipliers.min() < -MULTIPLIER_TOLERANCE:
        return outcome(False, f"a negative multiplier ({multipliers.min():.3g})", feasibility, level)
    sums = [float(multipliers[sign == s].sum()) for s in (1.0, -1.0) if np.any(sign == s)]
    if max(abs(s - 1.0) for s in sums) > MULTIPLIER_TOLERANCE:
        return outcome(False, f"the multipliers of a level sum to {sums} instead of 1", feasibility, level)
    if bool(getattr(result.certificate, "on_region_boundary", False)):
        return outcome(True, "stationarity not checked: the optimum lies on the edge of the axis region",
                       feasibility, level)
    stationarity = float(np.linalg.norm((sign * multipliers) @ grad[contacts]))
    if stationarity > STATIONARITY_TOLERANCE:
        return outcome(False, f"not stationary: |sum s lambda grad d| = {stationarity:.3g}", feasibility, level,
                       stationarity)
    return outcome(True, "", feasibility, level, stationarity)


def apply_check(result: ResultT, points: FloatArray, *, tolerance: float) -> ResultT:
    """``result`` with the check of :func:`check_answer` in its certificate (not certified if it failed)."""
    certificate = result.certificate
    if certificate is None:
        return result
    found = check_answer(result, points, merge_tolerance=tolerance)
    changes: dict[str, Any] = {"feasibility": float(found.feasibility_mm), "check": found.summary()}
    if found.passed:
        return dataclasses.replace(result, certificate=dataclasses.replace(certificate, **changes))
    # the answer's proof is not trusted either: no bound (a form verdict can then not FAIL on it)
    changes.update(certified=False, scope="local", bound_mm=float("nan"), gap_mm=float("nan"))
    message = f"not certified: the independent check failed ({found.reason}); the solver said: {result.message}"
    return dataclasses.replace(result, certificate=dataclasses.replace(certificate, **changes), converged=False,
                               message=message)
