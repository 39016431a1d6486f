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
multi-start, in place of the seed's GA and 8e7-sample brute force (:func:`random_search`
reproduces the latter) -- then :func:`~.numcal_solver.refine`: least squares within bounds
until the Gauss-Newton step test is met.  Both of the seed's strategies are available:
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

from collections.abc import Callable, Sequence
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import ConvergenceError, InvalidInputError
from pcmm_geo.machine.calibration.numerical.numcal_data import (
    _PAIR_INDEX,
    ARMS,
    MOVED_PAIR,
    PAIR_ARMS,
    PARAMETER_NAMES,
    SEED_BOUNDS,
    START_OF_RANGE,
    NumcalData,
    NumcalParameters,
    read_numcal_csv,
    synthesise_design_data,
    synthesise_numcal_data,
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
    "height_errors",
    "random_search",
    "read_numcal_csv",
    "residuals_and_jacobian",
    "select_samples",
    "synthesise_design_data",
    "synthesise_numcal_data",
]

FloatArray = NDArray[np.float64]
Pairs = Literal["moved", "all"]
#: generations of differential evolution per search (scipy's ``maxiter``)
DE_GENERATIONS = 1000


def equation_rows(data: NumcalData, pairs: str = "moved") -> tuple[NDArray[np.int_], ...]:
    """Per equation: sample index, arm i, arm in and pair index; ``pairs`` "moved" (one per sample) or "all"."""
    count = len(data.moved)
    if pairs == "moved":
        sample = np.arange(count)
        first = np.array([ARMS.index(MOVED_PAIR[m][0]) for m in data.moved], dtype=int)
        second = np.array([ARMS.index(MOVED_PAIR[m][1]) for m in data.moved], dtype=int)
        pair = np.array([_PAIR_INDEX[MOVED_PAIR[m][2]] for m in data.moved], dtype=int)
        return sample, first, second, pair
    if pairs == "all":
        sample = np.repeat(np.arange(count), 3)
        first = np.tile([i for i, _ in PAIR_ARMS], count)
        second = np.tile([n for _, n in PAIR_ARMS], count)
        return sample, first, second, np.tile([0, 1, 2], count)
    raise InvalidInputError("pairs", "'moved' or 'all'", repr(pairs))


def residuals_and_jacobian(
    data: NumcalData, parameters: ArrayLike, *, pairs: Pairs = "moved", start_of_range: float = START_OF_RANGE
) -> tuple[FloatArray, FloatArray]:
    """Distance residuals ``L - sqrt(dz² + b²)`` (R,) and their Jacobian (R, 9) (eqs 2.5, 2.7).

    Parameters are in :data:`PARAMETER_NAMES` order (beta in radians).  ``R`` is the number of
    samples (``pairs="moved"``) or three times it (``"all"``, order ab, bc, ca per sample).

    Examples
    --------
    >>> truth = NumcalParameters.from_seed_table()
    >>> data = synthesise_numcal_data(truth, seed=0)
    >>> r, jac = residuals_and_jacobian(data, truth.vector())
    >>> bool(np.abs(r).max() < 1e-9), jac.shape
    (True, (45, 9))
    """
    p = np.asarray(parameters, dtype=float)
    sample, first, second, pair = equation_rows(data, pairs)
    rows = np.arange(sample.size)
    length_i = data.lasers[sample, first] + start_of_range + p[first]
    length_n = data.lasers[sample, second] + start_of_range + p[second]
    pivots = np.asarray(data.pivot_heights)
    rise = pivots[sample, second] - pivots[sample, first]
    beta = p[3 + pair]
    base = p[6 + pair]
    cosine, sine = np.cos(beta), np.sin(beta)
    distance = np.sqrt(np.maximum(length_i**2 + length_n**2 - 2.0 * length_i * length_n * cosine, 1e-300))
    implied = np.sqrt(rise**2 + base**2)
    residuals = distance - implied
    jac = np.zeros((rows.size, 9))
    np.add.at(jac, (rows, first), (length_i - length_n * cosine) / distance)
    np.add.at(jac, (rows, second), (length_n - length_i * cosine) / distance)
    jac[rows, 3 + pair] = length_i * length_n * sine / distance
    jac[rows, 6 + pair] = -base / implied
    return residuals, jac


def height_errors(data: NumcalData, parameters: ArrayLike, *, start_of_range: float = START_OF_RANGE) -> FloatArray:
    """The seed's error ``sqrt(L² - b²) - |dz|`` per sample, moved pair (mm), NaN where the root is complex.

    Examples
    --------
    >>> truth = NumcalParameters.from_seed_table()
    >>> data = synthesise_numcal_data(truth)
    >>> errors = height_errors(data, truth.vector())
    >>> bool(np.abs(errors[data.heights > 1.0]).max() < 1e-9)  # near h = 0, L² - b² cancels
    True
    """
    p = np.asarray(parameters, dtype=float)
    residuals, _ = residuals_and_jacobian(data, p, start_of_range=start_of_range)
    sample, first, second, pair = equation_rows(data, "moved")
    pivots = np.asarray(data.pivot_heights)
    rise = np.abs(pivots[sample, second] - pivots[sample, first])
    base = p[6 + pair]
    distance = residuals + np.sqrt(rise**2 + base**2)
    squared = distance**2 - base**2
    with np.errstate(invalid="ignore"):
        return np.where(squared >= 0, np.sqrt(np.maximum(squared, 0.0)), np.nan) - rise


def _costs(data: NumcalData, trials: FloatArray, pairs: str) -> FloatArray:
    """Sum of squared distance residuals (mm²) for many parameter sets ``trials`` (S, 9) at once."""
    sample, first, second, pair = equation_rows(data, pairs)
    pivots = np.asarray(data.pivot_heights)
    rise = pivots[sample, second] - pivots[sample, first]
    length_i = data.lasers[sample, first] + START_OF_RANGE + trials[:, first]
    length_n = data.lasers[sample, second] + START_OF_RANGE + trials[:, second]
    squared = length_i**2 + length_n**2 - 2 * length_i * length_n * np.cos(trials[:, 3 + pair])
    distance = np.sqrt(np.maximum(squared, 0.0))
    return np.sum((distance - np.sqrt(rise**2 + trials[:, 6 + pair] ** 2)) ** 2, axis=1)


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
) -> tuple[FloatArray, int, LocalSolution]:
    """Global stage, a short least squares from each candidate, then :func:`refine` from the best."""
    from scipy.optimize import differential_evolution, least_squares

    lower, upper = bounds[0][free], bounds[1][free]

    def full(x: FloatArray) -> FloatArray:
        vector = fixed_vector.copy()
        vector[free] = x
        return vector

    def fun(x: FloatArray) -> FloatArray:
        return residuals_and_jacobian(data, full(x), pairs=pairs)[0]  # type: ignore[arg-type]

    def jac(x: FloatArray) -> FloatArray:
        return residuals_and_jacobian(data, full(x), pairs=pairs)[1][:, free]  # type: ignore[arg-type]

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
                              xtol=1e-15, gtol=1e-15, max_nfev=50 * free.size)
        evaluations += int(found.nfev)
        if report is not None:
            report(searched + index)
        if found.cost < best_cost:
            best_x, best_cost = found.x, float(found.cost)
    if best_x is None or not np.isfinite(best_cost):
        raise ConvergenceError("numerical calibration", evaluations, "no finite solution found")
    local = refine(fun, jac, best_x, lower, upper, max_evaluations=max_evaluations,
                   names=[PARAMETER_NAMES[k] for k in free])
    return full(local.x), evaluations + local.evaluations, local


def _units(global_search: str | None, starts: int, has_start: bool) -> int:
    """Progress units of one solver stage: DE generations (at most) plus one per least-squares start."""
    local = starts if global_search == "multistart" else (1 if global_search == "differential_evolution" else 0)
    local += int(has_start)
    return (DE_GENERATIONS if global_search == "differential_evolution" else 0) + max(local, 1)


def _check_bounds(bounds: tuple[ArrayLike, ArrayLike] | None) -> tuple[FloatArray, FloatArray]:
    lower, upper = (np.asarray(b, dtype=float) for b in (bounds or SEED_BOUNDS))
    if lower.shape != (9,) or upper.shape != (9,) or np.any(lower >= upper):
        raise InvalidInputError("bounds", "two arrays of shape (9,) with lower < upper", f"{lower} / {upper}")
    return lower, upper


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
        Limit on the residual evaluations of the final refinement (per stage); default
        ``2000 * P``.  Reaching it gives ``converged=False``.
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
    start_vector = None if start is None else start.vector()
    per_stage = _units(global_search, starts, start is not None)

    def reporter(stage: int, stage_count: int) -> Callable[[int], None] | None:
        if progress is None:
            return None
        return lambda done: progress(stage * per_stage + done, stage_count * per_stage)

    if method == "simultaneous":
        vector, evaluations, local = _solve(data, np.arange(9), np.zeros(9), (lower, upper), start_vector,
                                            global_search, seed, starts, pairs, max_evaluations, reporter(0, 1))
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
                                         seed, starts, pairs, max_evaluations, reporter(index, len(stages)))
            evaluations += used
            all_converged &= stage.converged
            messages.append(f"stage {arm}: {stage.message}")
        local = LocalSolution(vector, evaluations, all_converged, "; ".join(messages), len(stages))
    else:
        raise InvalidInputError("method", "'simultaneous' or 'sequential'", repr(method))
    residuals, jacobian = residuals_and_jacobian(data, vector, pairs=pairs)
    return assess(
        parameters=NumcalParameters.from_vector(vector), names=PARAMETER_NAMES, values=vector, residuals=residuals,
        jacobian=jacobian, local=local, height_errors=height_errors(data, vector), method=method, pairs=pairs,
        global_search=global_search, evaluations=evaluations,
    )


def design_identifiability(
    pivot_heights: ArrayLike,
    *,
    truth: NumcalParameters | None = None,
    pairs: Pairs = "all",
    free: Sequence[str] = PARAMETER_NAMES,
) -> Any:
    """Identifiability of an experiment design before it is measured (physical rigid-body readings).

    Parameters
    ----------
    pivot_heights : array_like, shape (M, 3)
        Planned heights of pivots a, b, c relative to the level start (mm).
    truth : NumcalParameters, optional
        Nominal parameters (default Table 7.1's).
    pairs : {"moved", "all"}
    free : sequence of str
        The parameters to be estimated.

    Returns
    -------
    Identifiability

    Examples
    --------
    >>> seed_design = np.zeros((15, 3)); seed_design[:, 0] = np.linspace(0, 50, 15)
    >>> report = design_identifiability(seed_design, pairs="moved", free=("d_c", "d_a", "beta_ca", "b_ca"))
    >>> bool(report.condition_number > 1e8)  # one arm moved: the seed's Table 6.2 experiment
    True
    """
    from pcmm_geo.machine.calibration.numerical.identifiability import analyse_identifiability

    nominal = NumcalParameters.from_seed_table() if truth is None else truth
    columns = [PARAMETER_NAMES.index(name) for name in free]
    data = synthesise_design_data(nominal, pivot_heights)
    _, jacobian = residuals_and_jacobian(data, nominal.vector(), pairs=pairs)
    return analyse_identifiability(jacobian[:, columns], tuple(free))


def random_search(
    data: NumcalData,
    samples: int,
    *,
    bounds: tuple[ArrayLike, ArrayLike] | None = None,
    seed: int = 0,
    chunk: int = 200_000,
    pairs: Pairs = "moved",
) -> tuple[NumcalParameters, float]:
    """The seed's brute force (6.2.2): uniform random parameter sets, keep the lowest sum of squares.

    Evaluated in chunks of ``chunk`` samples (vectorised numpy).

    Returns
    -------
    (NumcalParameters, float)
        Best parameters and their sum of squared distance residuals (mm²).

    Examples
    --------
    >>> truth = NumcalParameters.from_seed_table()
    >>> best, cost = random_search(synthesise_numcal_data(truth), 1000, seed=3)
    >>> bool(cost > 0)
    True
    """
    lower, upper = _check_bounds(bounds)
    rng = np.random.default_rng(seed)
    best_vector, best_cost = lower.copy(), np.inf
    done = 0
    while done < samples:
        count = min(chunk, samples - done)
        trial = rng.uniform(lower, upper, (count, 9))
        cost = _costs(data, trial, pairs)
        index = int(np.argmin(cost))
        if cost[index] < best_cost:
            best_cost, best_vector = float(cost[index]), trial[index]
        done += count
    return NumcalParameters.from_vector(best_vector), best_cost


def select_samples(
    data: NumcalData,
    count: int,
    *,
    parameters: NumcalParameters | None = None,
    initial: Sequence[int] = (),
    exchange_passes: int = 2,
    pairs: Pairs = "moved",
) -> tuple[NumcalData, Any]:
    """Choose the ``count`` samples whose identification Jacobian is best conditioned (Verl et al. 2008).

    Each sample (one height-gauge pose) contributes one row (``pairs="moved"``) or three rows
    (``"all"``) of the Jacobian of :func:`residuals_and_jacobian` at ``parameters``;
    :func:`pcmm_geo.machine.calibration.numerical.identifiability.select_poses` adds, one at a time, the sample
    that lowers the condition number of the column-scaled Jacobian most and then exchanges
    chosen samples for better ones.  Use it to plan which poses to measure: synthesise
    candidate poses with the nominal parameters, select, and measure only those.

    Parameters
    ----------
    data : NumcalData
        Candidate samples (M of them).
    count : int
        Number of samples to keep (9 or more for all nine parameters).
    parameters : NumcalParameters, optional
        Where the Jacobian is evaluated; default Table 7.1's values.
    initial : sequence of int
        Samples that must be kept.
    exchange_passes : int
        Passes of the exchange step.

    Returns
    -------
    subset : NumcalData
        The chosen samples, in the order they were chosen.
    selection : PoseSelection
        Indices into ``data``, condition number after each addition and at the end.

    Raises
    ------
    InvalidInputError
        ``count`` not in 1..M.

    Examples
    --------
    >>> data = synthesise_numcal_data(NumcalParameters.from_seed_table())
    >>> subset, selection = select_samples(data, 12, pairs="all")
    >>> len(subset.moved), bool(selection.final_condition_number < 1e8)
    (12, True)
    """
    from pcmm_geo.machine.calibration.numerical.identifiability import select_poses

    at = NumcalParameters.from_seed_table() if parameters is None else parameters
    _, jacobian = residuals_and_jacobian(data, at.vector(), pairs=pairs)
    per_sample = 1 if pairs == "moved" else 3
    blocks = [jacobian[per_sample * k : per_sample * (k + 1)] for k in range(len(data.moved))]
    selection = select_poses(blocks, count, initial=initial, exchange_passes=exchange_passes)
    return data.take(selection.indices), selection
