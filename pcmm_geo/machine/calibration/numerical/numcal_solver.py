"""Least squares to a real convergence test, and the result of a numerical calibration (thesis ch. 6).

:func:`refine` runs :func:`scipy.optimize.least_squares` (trust-region reflective, within
bounds) in rounds, each followed by full Gauss-Newton steps (SVD pseudo-inverse, step halving,
accepted only when the sum of squares falls), and stops only when the **Gauss-Newton step**
at the current point, computed by SVD of the column-equilibrated Jacobian, is below a stated
tolerance for every parameter (``STEP_TOLERANCE`` relative, the step that rounding of the
residuals alone can cause, or ``UNCERTAINTY_FRACTION`` of the parameter's standard
uncertainty, whichever is largest).  A round that ends on scipy's evaluation limit, or on its
``ftol`` / ``xtol`` tests while the Gauss-Newton step is still large (a flat, ill-conditioned valley), is
continued from where it stopped: the trust region restarts.  Nothing stops silently: the
outcome says whether the test was met and why not.

:func:`assess` turns the point into a :class:`NumericalCalibration`: residuals, rms, the
parameter covariance ``s² (JᵀJ)⁻¹`` with ``s² = Σr² / dof`` (the residual scale; the
standard first-order estimate, checked against a seeded Monte Carlo of recalibrations in
``tests/machine/test_numcal_convergence.py``), the condition number and rank of the
column-equilibrated Jacobian.  It flags the result ``converged=False`` -- and warns with
:class:`~pcmm_geo.errors.CalibrationNotConvergedWarning` -- when the solver did not meet its
test, when the Jacobian is rank deficient or its condition number exceeds
:data:`MAX_CONDITION`, or when there are fewer residuals than parameters.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import CalibrationNotConvergedWarning

__all__ = ["MAX_CONDITION", "MAX_ROUNDS", "STEP_TOLERANCE", "UNCERTAINTY_FRACTION", "LocalSolution",
           "NumericalCalibration", "assess", "refine"]

FloatArray = NDArray[np.float64]

#: condition number of the column-equilibrated Jacobian above which a calibration is flagged
#: ill-determined: even exact data then fix the parameters to no better than about
#: ``MAX_CONDITION * 2.2e-16`` relative (about 7e-6 mm on a 300 mm dead distance) and a reading
#: noise ``sigma`` moves them by up to ``MAX_CONDITION * sigma`` along the weakest combination
MAX_CONDITION = 1e8
#: relative singular value below which a direction counts as outside the numerical rank
RANK_TOLERANCE = 1e-10
#: Gauss-Newton step below which a parameter counts as converged, relative to ``1 + |value|``
STEP_TOLERANCE = 1e-11
#: Gauss-Newton step below this fraction of a parameter's standard uncertainty counts as converged
#: (noisy data: a smaller step changes nothing a user could see)
UNCERTAINTY_FRACTION = 1e-3
#: rounds of least squares (each restarts the trust region from the last point)
MAX_ROUNDS = 40


@record
class LocalSolution:
    """Outcome of :func:`refine`: the point, evaluations used, whether the step test was met, why."""

    x: FloatArray
    evaluations: int
    converged: bool
    message: str
    rounds: int


def _equilibrated_svd(jacobian: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    norms = np.linalg.norm(jacobian, axis=0)
    safe = np.where(norms > 0, norms, 1.0)
    u, s, vt = np.linalg.svd(jacobian / safe, full_matrices=False)
    return u, s, vt, safe


def gauss_newton_step(jacobian: FloatArray, residuals: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Gauss-Newton step ``-J⁺ r`` and the smallest step worth taking, both (P,).

    The pseudo-inverse keeps singular values above ``RANK_TOLERANCE * s_max`` of the
    column-equilibrated Jacobian.  The smallest step worth taking is the larger of the step
    that rounding of the residuals alone can cause (``|J⁺|`` applied to ``8 eps`` times
    ``1 + max|r| + 1000``, the machine's lengths in mm) and :data:`UNCERTAINTY_FRACTION` of
    the parameter's standard uncertainty from the residual scale.
    """
    u, s, vt, norms = _equilibrated_svd(jacobian)
    keep = s > RANK_TOLERANCE * (s[0] if s.size and s[0] > 0 else 1.0)
    inverse = np.where(keep, 1.0 / np.where(keep, s, 1.0), 0.0)
    step = -(vt.T @ (inverse * (u.T @ residuals))) / norms
    rounding = 8.0 * np.finfo(float).eps * (1.0 + float(np.max(np.abs(residuals), initial=0.0)) + 1000.0)
    spread = np.linalg.norm(vt.T * inverse, axis=1) / norms  # sqrt(diag((JᵀJ)⁺))
    floor = rounding * np.sqrt(len(residuals)) * spread
    dof = max(len(residuals) - int(np.count_nonzero(keep)), 1)
    uncertainty = np.sqrt(float(residuals @ residuals) / dof) * spread
    return step, np.maximum(floor, UNCERTAINTY_FRACTION * uncertainty)


def _gauss_newton_polish(
    fun: Callable[[FloatArray], FloatArray],
    jac: Callable[[FloatArray], FloatArray],
    x: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    max_evaluations: int,
    iterations: int = 30,
) -> tuple[FloatArray, int]:
    """Full Gauss-Newton steps (SVD pseudo-inverse) with step halving, kept inside the bounds.

    Trust-region steps crawl along a flat valley of an ill-conditioned problem; the full
    Gauss-Newton step crosses it at once (quadratic convergence on zero-residual problems).
    A step is accepted only when it lowers the sum of squares.
    """
    used = 0
    residuals = fun(x)
    cost = float(residuals @ residuals)
    for _ in range(iterations):
        step, _ = gauss_newton_step(jac(x), residuals)
        scale, accepted = 1.0, False
        for _ in range(12):
            if used >= max_evaluations:
                return x, used
            trial = np.clip(x + scale * step, lower, upper)
            trial_residuals = fun(trial)
            used += 1
            trial_cost = float(trial_residuals @ trial_residuals)
            if np.isfinite(trial_cost) and trial_cost < cost:
                x, residuals, cost, accepted = trial, trial_residuals, trial_cost, True
                break
            scale *= 0.5
        if not accepted or cost == 0.0:
            break
    return x, used


def refine(
    fun: Callable[[FloatArray], FloatArray],
    jac: Callable[[FloatArray], FloatArray],
    x0: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    *,
    max_evaluations: int | None = None,
    max_rounds: int = MAX_ROUNDS,
    names: Sequence[str] | None = None,
) -> LocalSolution:
    """Least squares within bounds until the Gauss-Newton step test is met (see module docstring).

    Parameters
    ----------
    fun, jac : callable
        Residuals (M,) and Jacobian (M, P) at a point (P,).
    x0, lower, upper : ndarray, shape (P,)
    max_evaluations : int, optional
        Limit on residual evaluations over all rounds (default ``2000 * P``).
    max_rounds : int
    names : sequence of str, optional
        Parameter names for the messages.

    Returns
    -------
    LocalSolution
    """
    from scipy.optimize import least_squares

    budget = 2000 * x0.size if max_evaluations is None else int(max_evaluations)
    x = np.clip(np.asarray(x0, dtype=float), lower, upper)
    used, rounds, last = 0, 0, "not started"
    while rounds < max_rounds and used < budget:
        rounds += 1
        found = least_squares(fun, x, jac=jac, bounds=(lower, upper), method="trf", x_scale="jac", ftol=1e-15,
                              xtol=1e-15, gtol=1e-15, max_nfev=max(1, min(100 * x0.size, budget - used)))
        used += int(found.nfev)
        x = found.x
        last = str(found.message)
        if found.status < 0:
            return LocalSolution(x, used, False, f"least squares failed: {last}", rounds)
        x, polish_evaluations = _gauss_newton_polish(fun, jac, x, lower, upper, budget - used)
        used += polish_evaluations
        step, floor = gauss_newton_step(jac(x), fun(x))
        tolerance = np.maximum(STEP_TOLERANCE * (1.0 + np.abs(x)), floor)
        near = 1e-7 * (upper - lower)  # trf keeps its iterates strictly inside the bounds
        at_bound = ((x - lower <= near) & (step < 0)) | ((upper - x <= near) & (step > 0))
        if np.all(np.abs(step) <= tolerance):
            return LocalSolution(x, used, True, f"Gauss-Newton step below tolerance after {rounds} round(s)", rounds)
        if np.any(at_bound):
            labels = [str(names[k]) if names is not None else f"#{k}" for k in np.flatnonzero(at_bound)]
            return LocalSolution(x, used, False, "the minimum lies outside the bounds: " + ", ".join(labels)
                                 + " stop(s) on a bound", rounds)
    step, floor = gauss_newton_step(jac(x), fun(x))
    worst = float(np.max(np.abs(step) / np.maximum(STEP_TOLERANCE * (1.0 + np.abs(x)), floor)))
    return LocalSolution(
        x, used, False,
        f"no convergence after {rounds} round(s) and {used} evaluations (limit {budget}): the Gauss-Newton step is "
        f"still {worst:.3g} times its tolerance (last least-squares status: {last})", rounds,
    )


@record
class NumericalCalibration:
    """Result of a numerical calibration (``calibrate_numerically``, ``calibrate_single_arm``).

    Attributes
    ----------
    parameters : NumcalParameters
        All nine parameters (fixed ones at their start values).
    names : tuple of str
        The parameters that were estimated (P of them), in ``PARAMETER_NAMES`` order.
    values : ndarray, shape (P,)
        Their values (mm, rad).
    residuals : ndarray, shape (R,)
        Distance residuals at the solution (mm), one per equation used.
    rms : float
        Root mean square of ``residuals`` (mm).
    covariance : ndarray, shape (P, P)
        ``s² (JᵀJ)⁻¹`` (mm², mm rad, rad²) with ``s² = Σr²/dof``; NaN where it cannot be stated
        (rank deficient, ``dof <= 0``).
    dof : int
        ``R - P``.
    converged : bool
        The solver met its convergence test **and** the problem is determined (full rank,
        condition number at most :data:`MAX_CONDITION`, ``dof >= 0``).
    message : str
        Why (not) converged, in words.
    condition_number : float
        Of the column-equilibrated Jacobian at the solution (inf when rank deficient).
    rank : int
        Numerical rank of that Jacobian (relative tolerance :data:`RANK_TOLERANCE`).
    height_errors : ndarray, shape (M,)
        The seed's height errors per sample (mm, NaN where complex), Tables 6.3/6.5.
    method : str
        ``"simultaneous"``, ``"sequential"`` or ``"single-arm"``.
    pairs : str
        ``"moved"`` (the seed's one equation per sample) or ``"all"`` (three per sample).
    global_search : str or None
    evaluations : int
        Objective evaluations used (global search plus local refinement).
    identifiability : Identifiability
        Singular-value analysis of the Jacobian of the estimated parameters at the solution.
    reading_sigma : (float, float) or None
        ``(laser_sigma, height_sigma)`` (mm) of a weighted fit; None for unweighted (equations
        taken as independent and equally uncertain).
    """

    parameters: Any
    names: tuple[str, ...]
    values: FloatArray
    residuals: FloatArray
    rms: float
    covariance: FloatArray
    dof: int
    converged: bool
    message: str
    condition_number: float
    rank: int
    height_errors: FloatArray
    method: str
    pairs: str
    global_search: str | None
    evaluations: int
    identifiability: Any
    reading_sigma: tuple[float, float] | None = None

    @property
    def standard_uncertainties(self) -> dict[str, float]:
        """Standard uncertainty of each estimated parameter (mm or rad), ``sqrt(diag(covariance))``."""
        return dict(zip(self.names, np.sqrt(np.diag(self.covariance)).tolist(), strict=True))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (angles also in degrees, named ``*_deg``)."""

        def number(value: float) -> float | None:
            return float(value) if np.isfinite(value) else None

        uncertainties = self.standard_uncertainties
        return {
            "method": self.method,
            "pairs": self.pairs,
            "global_search": self.global_search,
            "converged": self.converged,
            "message": self.message,
            "d": dict(self.parameters.d),
            "beta_deg": self.parameters.beta_deg,
            "b": dict(self.parameters.b),
            "estimated": list(self.names),
            "standard_uncertainty": {name: number(u) for name, u in uncertainties.items()},
            "standard_uncertainty_beta_deg": {name: number(np.degrees(u)) for name, u in uncertainties.items()
                                              if name.startswith("beta")},
            "covariance": [[number(v) for v in row] for row in self.covariance.tolist()],
            "dof": self.dof,
            "reading_sigma": None if self.reading_sigma is None else list(self.reading_sigma),
            "rms": self.rms,
            "condition_number": number(self.condition_number),
            "rank": self.rank,
            "evaluations": self.evaluations,
            "height_errors": [number(e) for e in self.height_errors],
            "identifiability": self.identifiability.to_dict(),
        }


def assess(
    *,
    parameters: Any,
    names: Sequence[str],
    values: FloatArray,
    residuals: FloatArray,
    jacobian: FloatArray,
    local: LocalSolution,
    height_errors: FloatArray,
    method: str,
    pairs: str,
    global_search: str | None,
    evaluations: int,
    weighted: tuple[FloatArray, FloatArray] | None = None,
    reading_sigma: tuple[float, float] | None = None,
    stacklevel: int = 3,
) -> NumericalCalibration:
    """Build the result from the solution; flag and warn when it is not a determined, converged calibration.

    ``weighted`` holds the whitened residuals and Jacobian of a weighted fit; the covariance and
    the identifiability then come from them, the residuals and rms stay in mm.
    """
    from pcmm_geo.machine.calibration.numerical.identifiability import analyse_identifiability

    fit_residuals, fit_jacobian = (residuals, jacobian) if weighted is None else weighted
    identifiability = analyse_identifiability(fit_jacobian, names, tolerance=RANK_TOLERANCE)
    count, width = jacobian.shape
    dof = count - width
    rank = identifiability.rank
    condition = identifiability.condition_number
    covariance = np.full((width, width), np.nan)
    if rank == width and dof > 0:
        _, s, vt, norms = _equilibrated_svd(fit_jacobian)
        scale = float(np.sum(fit_residuals**2)) / dof
        covariance = scale * (vt.T / s**2) @ vt / np.outer(norms, norms)
    problems = []
    if dof < 0:
        problems.append(f"fewer equations ({count}) than parameters ({width}): the data cannot determine them")
    if rank < width:
        problems.append(f"rank {rank} of {width}: the data do not determine " + "; ".join(identifiability.undetermined))
    elif condition > MAX_CONDITION:
        weakest = identifiability.weak_combinations[0].text
        problems.append(f"ill-determined: condition number {condition:.3g} above {MAX_CONDITION:.0e}; "
                        f"weakest combination {weakest}")
    if not local.converged:
        problems.append(local.message)
    if dof == 0 and not problems:
        message = "converged; exactly determined (dof 0): no residual scale, so no uncertainty"
    else:
        message = "; ".join(problems) if problems else local.message
    converged = not problems
    result = NumericalCalibration(
        parameters=parameters, names=tuple(names), values=np.asarray(values, dtype=float), residuals=residuals,
        rms=float(np.sqrt(np.mean(residuals**2))) if residuals.size else 0.0, covariance=covariance, dof=dof,
        converged=converged, message=message, condition_number=float(condition), rank=rank,
        height_errors=height_errors, method=method, pairs=pairs, global_search=global_search,
        evaluations=evaluations, identifiability=identifiability, reading_sigma=reading_sigma,
    )
    if not converged:
        warnings.warn(f"numerical calibration ({method}) not converged: {message}", CalibrationNotConvergedWarning,
                      stacklevel=stacklevel)
    return result
