"""Numerical calibration of d, beta, b from laser readings and height-gauge heights (thesis ch. 6).

What the seed measured (6.2.1-6.2.2, Appendix B): one pivot bracket at a time is moved
vertically; a height gauge on the bracket gives its height change ``h`` relative to the
start, where the pivots are level, while the three lasers are read.  For a pair of arms
``i, in`` (``in`` the next arm clockwise), eqs 2.5 and 2.7 give

    ``L² = L_i² + L_in² - 2 L_i L_in cos(beta_in)`` with ``L_k = laser_k + 60 + d_k``
    ``L² = dz² + b_in²``,  ``dz`` the height difference of the two pivots.

The seed used one pair per sample -- the moved arm and the previous one: moving a uses c-a,
b uses a-b, c uses b-c (Appendix D ``zcalc``; Figure 6.4; ``pairs="moved"``).  The two other
pairs hold as well (``pairs="all"``, three equations per sample): all pivot heights are
known.  Nine parameters: ``d_a, d_b, d_c``, ``beta_ab, beta_bc, beta_ca``, ``b_ab, b_bc, b_ca``.

Residuals.  The seed minimised ``sqrt(L² - b²) - h`` (Appendix B), which is complex when
``L < b`` and has an infinite slope at the level start point.  We minimise the equivalent
smooth distance residual ``L - sqrt(dz² + b²)`` (mm) and also report the seed's height
errors.  Solvers: a global stage -- :func:`scipy.optimize.differential_evolution` or a seeded
multi-start, in place of the seed's GA and brute force (8e6 samples per stage as Appendix F
codes it; the text says 80e6, erratum F12; :func:`random_search` reproduces it) -- then
:func:`~pcmm_geo.machine.calibration.numerical.numcal_solver.refine`: least squares within
bounds until the Gauss-Newton step test is met.  Both of the seed's strategies are available:
**simultaneous** (all nine parameters on all data, 6.2.2) and **sequential** (arm a:
``d_c, d_a, beta_ca, b_ca``; arm b: ``d_b, beta_ab, b_ab``; arm c: ``beta_bc, b_bc``).

What the data determine (``docs/machine.md``, physical rigid-body data): with the seed's
one-pair model the stationary laser of a pair changes by only about 1.6 um over 50 mm, so
each pair fixes two combinations of its four parameters -- three weak directions in nine
(condition about 6e8): the result is flagged ``converged=False``.  Using all pairs leaves
one weak "size" direction (condition 1.5e7 for 50 mm moves); moving the pivots over 200 mm
in combinations determines all nine (condition about 4e3).

Examples
--------
>>> import numpy as np
>>> truth = NumcalParameters.from_seed_table()
>>> design = np.random.default_rng(1).uniform(0.0, 200.0, (30, 3))
>>> data = synthesise_design_data(truth, design)
>>> result = calibrate_numerically(data, pairs="all", global_search=None, start=truth)
>>> result.converged, bool(result.rms < 1e-9)
(True, True)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import ConvergenceError, InvalidInputError
from pcmm_geo.machine.calibration.numerical.numcal_data import (
    MOVED_PAIR,
    PARAMETER_NAMES,
    SEED_BOUNDS,
    NumcalData,
    NumcalParameters,
    read_numcal_csv,
    synthesise_design_data,
    synthesise_numcal_data,
)
from pcmm_geo.machine.calibration.numerical.numcal_design import design_identifiability, random_search, select_samples
from pcmm_geo.machine.calibration.numerical.numcal_model import (
    Pairs,
    _check_bounds,
    _costs,
    equation_rows,
    height_errors,
    reading_whitener,
    residuals_and_jacobian,
)
from pcmm_geo.machine.calibration.numerical.numcal_solver import (
    MAX_CONDITION,
    LocalSolution,
    NumericalCalibration,
    assess,
    refine,
)

__all__ = [
    "MAX_CONDITION",
    "MOVED_PAIR",
    "PARAMETER_NAMES",
    "SEED_BOUNDS",
    "NumcalData",
    "NumcalParameters",
    "NumericalCalibration",
    "calibrate_numerically",
    "design_identifiability",
    "equation_rows",
    "height_errors",
    "random_search",
    "read_numcal_csv",
    "reading_whitener",
    "residuals_and_jacobian",
    "select_samples",
    "synthesise_design_data",
    "synthesise_numcal_data",
]

FloatArray = NDArray[np.float64]
#: generations of differential evolution per search (scipy's ``maxiter``)
DE_GENERATIONS = 1000


def _solve(
    data: NumcalData,
    free: NDArray[np.int_],
    fixed_vector: FloatArray,
    bounds: tuple[FloatArray, FloatArray],
    start: FloatArray | None,
    global_search: str | None,
    seed: int,
    starts: int,
    pairs: str,
    max_evaluations: int | None,
    report: Callable[[int], None] | None = None,
    reading_sigma: tuple[float, float] | None = None,
) -> tuple[FloatArray, int, LocalSolution]:
    """Global stage, a short least squares from each candidate, then :func:`refine` from the best.

    With ``reading_sigma`` the refinement is weighted (:func:`reading_whitener`, weights taken
    at the screened point, then once more at the solution).
    """
    from scipy.optimize import differential_evolution, least_squares

    lower, upper = bounds[0][free], bounds[1][free]

    def full(x: FloatArray) -> FloatArray:
        vector = fixed_vector.copy()
        vector[free] = x
        return vector

    last: dict[bytes, tuple[FloatArray, FloatArray]] = {}

    def evaluate(x: FloatArray) -> tuple[FloatArray, FloatArray]:
        # the solvers ask for the Jacobian at the point whose residuals they just took: compute both once
        key = np.asarray(x, dtype=float).tobytes()
        if key not in last:
            last.clear()
            last[key] = residuals_and_jacobian(data, full(x), pairs=pairs)  # type: ignore[arg-type]
        return last[key]

    def fun(x: FloatArray) -> FloatArray:
        return evaluate(x)[0].copy()

    def jac(x: FloatArray) -> FloatArray:
        return evaluate(x)[1][:, free]

    evaluations = 0
    candidates: list[FloatArray] = []
    if global_search == "differential_evolution":
        population_size = [0]

        def population_cost(x: FloatArray) -> FloatArray:  # x: (n_free, S), vectorised
            population_size[0] += x.shape[1]
            trials = np.repeat(fixed_vector[None, :], x.shape[1], axis=0)
            trials[:, free] = x.T
            return _costs(data, trials, pairs)

        generation = [0]

        def callback(intermediate_result: Any) -> None:  # scipy passes an OptimizeResult by this name
            generation[0] += 1
            if report is not None:
                report(min(generation[0], DE_GENERATIONS))

        found = differential_evolution(
            population_cost, list(zip(lower, upper, strict=True)), seed=seed, tol=1e-12, polish=False,
            maxiter=DE_GENERATIONS, vectorized=True, updating="deferred", callback=callback,
        )
        if report is not None:
            report(DE_GENERATIONS)  # converged before maxiter: the search is done
        evaluations += population_size[0]  # individual parameter sets (found.nfev counts calls)
        candidates.append(found.x)
    elif global_search == "multistart":
        rng = np.random.default_rng(seed)
        candidates.extend(rng.uniform(lower, upper) for _ in range(starts))
    elif global_search is not None:
        raise InvalidInputError("global_search", "'differential_evolution', 'multistart' or None", repr(global_search))
    if start is not None:
        candidates.append(np.clip(start[free], lower, upper))
    if not candidates:
        candidates.append(0.5 * (lower + upper))
    best_x, best_cost = None, np.inf
    searched = DE_GENERATIONS if global_search == "differential_evolution" else 0
    for index, x0 in enumerate(candidates, start=1):
        # screening only: a short run per candidate; the best one is refined to convergence below
        found = least_squares(fun, x0, jac=jac, bounds=(lower, upper), method="trf", x_scale="jac", ftol=1e-15,
                              xtol=1e-15, gtol=1e-15,
                              max_nfev=50 * free.size if max_evaluations is None else min(50 * free.size,
                                                                                          max_evaluations))
        evaluations += int(found.nfev)
        if report is not None:
            report(searched + index)
        if found.cost < best_cost:
            best_x, best_cost = found.x, float(found.cost)
    if best_x is None or not np.isfinite(best_cost):
        raise ConvergenceError("numerical calibration", evaluations, "no finite solution found")
    names = [PARAMETER_NAMES[k] for k in free]
    if reading_sigma is None:
        local = refine(fun, jac, best_x, lower, upper, max_evaluations=max_evaluations, names=names)
        return full(local.x), evaluations + local.evaluations, local
    local = LocalSolution(best_x, 0, False, "not refined", 0)
    for _ in range(2):  # weights at the screened point, then at the weighted solution
        whiten = reading_whitener(data, full(local.x), pairs=pairs, laser_sigma=reading_sigma[0],  # type: ignore[arg-type]
                                  height_sigma=reading_sigma[1])
        local = refine(lambda x, w=whiten: w(fun(x)), lambda x, w=whiten: w(jac(x)), local.x, lower, upper,
                       max_evaluations=max_evaluations, names=names)
        evaluations += local.evaluations
    return full(local.x), evaluations, local


def _units(global_search: str | None, starts: int, has_start: bool) -> int:
    """Progress units of one solver stage: DE generations (at most) plus one per least-squares start."""
    local = starts if global_search == "multistart" else (1 if global_search == "differential_evolution" else 0)
    local += int(has_start)
    return (DE_GENERATIONS if global_search == "differential_evolution" else 0) + max(local, 1)


def calibrate_numerically(
    data: NumcalData,
    *,
    method: Literal["simultaneous", "sequential"] = "simultaneous",
    pairs: Pairs = "moved",
    global_search: Literal["differential_evolution", "multistart"] | None = "differential_evolution",
    start: NumcalParameters | None = None,
    bounds: tuple[ArrayLike, ArrayLike] | None = None,
    seed: int = 0,
    starts: int = 20,
    max_evaluations: int | None = None,
    laser_sigma: float | None = None,
    height_sigma: float | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> NumericalCalibration:
    """Identify d, beta, b per arm from height-gauge data (thesis 6.2), with uncertainties.

    Parameters
    ----------
    data : NumcalData
    method : {"simultaneous", "sequential"}
        All nine parameters at once (6.2.2, Table 6.4) or the seed's arm-by-arm sequence.
    pairs : {"moved", "all"}
        The seed's one equation per sample (the moved arm's pair) or all three pair equations.
    global_search : {"differential_evolution", "multistart"} or None
        Global stage before least squares; None refines ``start`` only.
    start : NumcalParameters, optional
        Starting point (used in addition to the global search); default mid-bounds.
    bounds : (lower, upper), optional
        Each shape (9,) in :data:`PARAMETER_NAMES` order (beta in radians); default
        :data:`SEED_BOUNDS` (Appendix B's GA bounds, d without the 60 mm start of range).
    seed : int
        Seed of the global search.
    starts : int
        Number of seeded starts for ``"multistart"``.
    max_evaluations : int, optional
        Limit on the residual evaluations of each least-squares start and of the final
        refinement (per stage); default ``2000 * P``.  Reaching it gives ``converged=False``.
    laser_sigma, height_sigma : float, optional
        Standard uncertainties of the laser and pivot-height readings (mm).  When given (either),
        the refinement is weighted least squares with the equations' covariance from the
        readings (:func:`~pcmm_geo.machine.calibration.numerical.numcal_model.reading_whitener`;
        the three pair equations of a sample share readings) and the covariance is that of the
        weighted estimate.  Without them the equations count as independent and equally
        uncertain, which misstates the uncertainty by 10-25 % (measured; see
        ``docs/machine.md``).
    progress : callable, optional
        ``progress(done, total)``, called after every generation of differential evolution and
        after every least-squares start.  A stage counts ``1000`` units for the evolution plus
        one per start; the sequential method has three stages.  The last call has
        ``done == total``.

    Returns
    -------
    NumericalCalibration
        ``converged`` False (with ``message``) when the Gauss-Newton step test was not met,
        the Jacobian is rank deficient or its condition number exceeds :data:`MAX_CONDITION`.
        The covariance is that of all nine parameters from the full Jacobian at the solution:
        exact to first order for ``"simultaneous"``, an approximation for ``"sequential"``
        (whose stages each see only part of the data).

    Raises
    ------
    InvalidInputError
        Unknown method, pairs or search, malformed bounds, no samples for an arm the method needs.
    ConvergenceError
        No finite solution.

    Warns
    -----
    CalibrationNotConvergedWarning
        Whenever the result has ``converged=False``; the message names the reason (e.g. the
        undetermined parameter combinations when only one arm was moved).

    Examples
    --------
    See the module docstring.
    """
    lower, upper = _check_bounds(bounds)
    if global_search not in ("differential_evolution", "multistart", None):
        raise InvalidInputError("global_search", "'differential_evolution', 'multistart' or None", repr(global_search))
    equation_rows(data, pairs)  # validates pairs
    reading_sigma = None if laser_sigma is None and height_sigma is None else (
        float(laser_sigma or 0.0), float(height_sigma or 0.0))
    start_vector = None if start is None else start.vector()
    per_stage = _units(global_search, starts, start is not None)

    def reporter(stage: int, stage_count: int) -> Callable[[int], None] | None:
        if progress is None:
            return None
        return lambda done: progress(stage * per_stage + done, stage_count * per_stage)

    if method == "simultaneous":
        vector, evaluations, local = _solve(data, np.arange(9), np.zeros(9), (lower, upper), start_vector,
                                            global_search, seed, starts, pairs, max_evaluations, reporter(0, 1),
                                            reading_sigma)
    elif method == "sequential":
        if pairs != "moved":
            raise InvalidInputError("pairs", "'moved' with the sequential method (the seed's arm-by-arm stages)",
                                    repr(pairs))
        vector = 0.5 * (lower + upper) if start_vector is None else start_vector.copy()
        stages = (("a", [2, 0, 5, 8]), ("b", [1, 3, 6]), ("c", [4, 7]))  # d_c d_a beta_ca b_ca | d_b .. | beta_bc b_bc
        evaluations, messages, all_converged = 0, [], True
        for index, (arm, free) in enumerate(stages):
            subset = data.subset((arm,))
            if not subset.moved:
                raise InvalidInputError("data", f"samples with arm {arm} moved (sequential stage {arm})", "none")
            vector, used, stage = _solve(subset, np.array(free), vector, (lower, upper), start_vector, global_search,
                                         seed, starts, pairs, max_evaluations, reporter(index, len(stages)),
                                         reading_sigma)
            evaluations += used
            all_converged &= stage.converged
            messages.append(f"stage {arm}: {stage.message}")
        local = LocalSolution(vector, evaluations, all_converged, "; ".join(messages), len(stages))
    else:
        raise InvalidInputError("method", "'simultaneous' or 'sequential'", repr(method))
    residuals, jacobian = residuals_and_jacobian(data, vector, pairs=pairs)
    weighted = None
    if reading_sigma is not None:
        whiten = reading_whitener(data, vector, pairs=pairs, laser_sigma=reading_sigma[0],
                                  height_sigma=reading_sigma[1])
        weighted = (whiten(residuals), whiten(jacobian))
    return assess(
        parameters=NumcalParameters.from_vector(vector), names=PARAMETER_NAMES, values=vector, residuals=residuals,
        jacobian=jacobian, local=local, height_errors=height_errors(data, vector), method=method, pairs=pairs,
        global_search=global_search, evaluations=evaluations, weighted=weighted, reading_sigma=reading_sigma,
    )


