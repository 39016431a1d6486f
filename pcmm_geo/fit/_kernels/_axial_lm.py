"""Levenberg-Marquardt for the axial fits, with re-centring after every accepted step.

Private to :mod:`pcmm_geo.fit`; used by :func:`pcmm_geo.fit._kernels._axial.solve_axial`.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.errors import ConvergenceError
from pcmm_geo.fit._kernels import _core
from pcmm_geo.fit._kernels._core import SolverOutcome

FloatArray = NDArray[np.float64]


#: A full Gauss-Newton step below this fraction of the problem size that no longer shrinks
#: means the iteration has reached the rounding floor.
_ROUNDING_FLOOR = 1e-13
#: Undamped steps below this fraction of the problem size are accepted without a cost test.
_TRUSTED_STEP = 1e-6
#: A start is abandoned when, over this many iterations and outside the trusted region, the
#: Gauss-Newton step has not halved and the cost has not dropped by 1e-6 (relative): it
#: wanders along a flat valley (e.g. a cylinder opening towards a plane).
_STALL_WINDOW = 20
#: Iterations a run may spend above the cost of a solution already found before it is abandoned
#: (a start in the basin of the better solution gets there well within this budget).
_WORSE_BUDGET = 20


def levenberg_marquardt(
    fun: Callable[[FloatArray], tuple[FloatArray, FloatArray]],
    x0: FloatArray,
    *,
    element: str,
    scale: float,
    sqrt_weights: FloatArray | None = None,
    recentre: Callable[[FloatArray], FloatArray] | None = None,
    abandon_above: float | None = None,
    max_iterations: int | None = None,
) -> SolverOutcome:
    """Levenberg-Marquardt (least-squares steps, Marquardt column scaling) with re-centring and a rounding-aware stop.

    Parameters
    ----------
    fun : callable
        ``fun(x) -> (r, J)``: residuals ``(M,)`` and analytic Jacobian ``(M, P)``.
    x0 : ndarray, shape (P,)
        Starting parameters.
    element : str
        Name for error messages.
    scale : float
        Size of the data (mm); steps are judged relative to ``scale + |x|``.
    sqrt_weights : ndarray, shape (M,), optional
        Square roots of the residual weights.
    recentre : callable, optional
        Called after every accepted step with the new parameters; may change the frame
        ``fun`` works in and returns the same element's parameters in the new frame
        (here: the data are rotated back to standard position).
    abandon_above : float, optional
        Cost of a solution found already: a run that reaches the trusted region (see Notes)
        with a cost above it, or is still above it after 20 iterations, is heading for a
        worse local minimum and is abandoned.
    max_iterations : int, optional
        Iteration budget, default ``TOL.max_iterations``.

    Returns
    -------
    SolverOutcome
        Weighted residuals and Jacobian at the solution (in the final frame).

    Raises
    ------
    ConvergenceError
        Iteration budget (``TOL.max_iterations``) or damping exhausted, or non-finite values.

    Notes
    -----
    The undamped Gauss-Newton step is computed at every iterate.  Convergence is declared
    when it is below ``TOL.step * (scale + |x|)`` (the test of
    :func:`pcmm_geo.fit._kernels._core.solve_least_squares`) or below ``1e-13 * (scale + |x|)`` while no
    longer contracting (at least half the previous Gauss-Newton step).  The second test
    recognises the rounding floor of ill-conditioned problems (a 30 degree arc with 0.1 mm
    form error), where the strict test alone may never fire.  Undamped steps below
    ``1e-6 * (scale + |x|)`` are accepted without testing the cost: near the solution
    the rounding error of the cost exceeds its decrease, while the Gauss-Newton step is
    still meaningful (local quadratic/linear convergence).
    """
    tol = _core.TOL

    def evaluate(params: FloatArray) -> tuple[FloatArray, FloatArray]:
        res, jac_ = fun(params)
        if sqrt_weights is not None:
            res = res * sqrt_weights
            jac_ = jac_ * sqrt_weights[:, None]
        return res, jac_

    x = np.array(x0, dtype=float)
    r, jac = evaluate(x)
    cost = float(r @ r)
    lam = 0.0
    previous_gn_step = np.inf
    history: list[tuple[float, float]] = []  # (cost, Gauss-Newton step) per iteration
    previous_step: FloatArray | None = None
    n_param = x.size
    budget = tol.max_iterations if max_iterations is None else max_iterations
    for iteration in range(1, budget + 1):
        if not (np.all(np.isfinite(r)) and np.all(np.isfinite(jac))):
            raise ConvergenceError(element, iteration, "non-finite residuals or Jacobian")
        gauss_newton = np.linalg.lstsq(jac, -r, rcond=None)[0]
        gn_norm = float(np.linalg.norm(gauss_newton))
        size = scale + float(np.linalg.norm(x))
        strict = gn_norm <= tol.step * size
        floor = gn_norm <= _ROUNDING_FLOOR * size and gn_norm >= 0.5 * previous_gn_step
        if strict or floor:
            reason = "Gauss-Newton step below tolerance" if strict else "Gauss-Newton step at rounding level"
            return SolverOutcome(
                x=x, residuals=r, jacobian=jac, converged=True, iterations=iteration, message=f"converged: {reason}"
            )
        previous_gn_step = gn_norm
        history.append((cost, gn_norm))
        worse = abandon_above is not None and cost > abandon_above * (1 + 1e-6)
        if worse and (gn_norm <= _TRUSTED_STEP * size or iteration > _WORSE_BUDGET):
            raise ConvergenceError(element, iteration, "heading for a worse local minimum")
        if len(history) > _STALL_WINDOW and gn_norm > _TRUSTED_STEP * size:
            old_cost, old_gn = history[-1 - _STALL_WINDOW]
            if gn_norm > 0.5 * old_gn and old_cost - cost <= 1e-6 * cost:
                raise ConvergenceError(element, iteration, "stalled in a flat valley (no progress)")
        if lam > 0:
            col_norm = np.linalg.norm(jac, axis=0)
            col_norm[col_norm == 0] = 1.0
            system = np.vstack([jac, np.diag(np.sqrt(lam) * col_norm)])
            step = np.linalg.lstsq(system, np.concatenate([-r, np.zeros(n_param)]), rcond=None)[0]
        else:
            step = _damp_oscillation(gauss_newton, previous_step)
        trial = x + step
        r_trial, jac_trial = evaluate(trial)
        cost_trial = float(r_trial @ r_trial)
        # near the solution the cost cannot resolve what Gauss-Newton still resolves (its rounding
        # error exceeds the decrease), so small undamped steps are taken without the cost test
        trusted = lam == 0.0 and gn_norm <= _TRUSTED_STEP * size
        if trusted or cost_trial <= cost:
            previous_step = step if lam == 0.0 else None
            x, r, jac = trial, r_trial, jac_trial
            if recentre is not None:
                x = recentre(x)
                r, jac = evaluate(x)
            cost = float(r @ r)
            lam = 0.0 if lam < 1e-6 else lam / 10.0
        else:
            previous_step = None
            lam = 1e-4 if lam == 0.0 else lam * 10.0
            if lam > 1e16:
                raise ConvergenceError(element, iteration, "damping exhausted without decrease")
    raise ConvergenceError(element, budget, "iteration budget exhausted")


def _damp_oscillation(step: FloatArray, previous_step: FloatArray | None) -> FloatArray:
    """Shorten a Gauss-Newton step that reverses the previous one (Aitken-style).

    With a large residual the Gauss-Newton iteration may converge linearly with
    alternating sign, ``e_{k+1} = -q e_k``; each step then overshoots by ``1 + q``.  When
    the new step points back (cosine below -0.8) and is shorter than the previous one,
    ``q`` is estimated from their length ratio and the step divided by ``1 + q``.  The
    convergence test is unaffected (it always uses the full Gauss-Newton step).
    """
    if previous_step is None:
        return step
    length, previous_length = float(np.linalg.norm(step)), float(np.linalg.norm(previous_step))
    if length == 0.0 or previous_length == 0.0 or length >= previous_length:
        return step
    if float(step @ previous_step) < -0.8 * length * previous_length:
        return step / (1.0 + length / previous_length)
    return step
