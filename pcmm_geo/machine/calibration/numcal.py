"""Numerical calibration of d, beta, b from laser readings and height-gauge heights (thesis ch. 6).

What the seed measured (6.2.1-6.2.2, Appendix B): one pivot bracket at a time is moved
vertically; a height gauge on the bracket gives its height change ``h`` relative to the
start, where the pivots are level, while the three lasers are read.  Moving pivot ``in``
with pivot ``i`` (the previous arm, clockwise) standing still, eqs 2.5 and 2.7 give

    ``L² = L_i² + L_in² - 2 L_i L_in cos(beta_in)`` with ``L_k = laser_k + 60 + d_k``
    ``h² = L² - b_in²``

so moving pivot a involves the pair c-a, b the pair a-b and c the pair b-c (Appendix D
``zcalc``; Figure 6.4).  Nine parameters: ``d_a, d_b, d_c``, ``beta_ab, beta_bc, beta_ca``,
``b_ab, b_bc, b_ca``.

Residuals.  The seed minimised ``sqrt(L² - b²) - h`` (Appendix B), which is complex when
``L < b`` and has an infinite slope at the level start point.  We minimise the equivalent
smooth distance residual ``L - sqrt(h² + b²)`` (mm) and also report the seed's height
errors.  Solvers: :func:`scipy.optimize.least_squares` (trust-region reflective, within
bounds) started from a global search -- :func:`scipy.optimize.differential_evolution` or a
seeded multi-start -- in place of the seed's GA and its 8e7-sample brute force
(:func:`random_search` reproduces the latter for comparison).  Both of the seed's
strategies are available: **simultaneous** (all nine parameters on all data, 6.2.2) and
**sequential** (arm a: ``d_c, d_a, beta_ca, b_ca``; arm b: ``d_b, beta_ab, b_ab``;
arm c: ``beta_bc, b_bc``).

Examples
--------
>>> truth = NumcalParameters.from_seed_table()
>>> data = synthesise_numcal_data(truth, seed=1)
>>> result = calibrate_numerically(data, method="simultaneous", global_search=None, start=truth)
>>> bool(result.rms < 1e-9)
True
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import ConvergenceError, IllConditionedWarning, InvalidInputError
from pcmm_geo.machine.calibration.numcal_data import (
    _PAIR_INDEX,
    ARMS,
    MOVED_PAIR,
    PARAMETER_NAMES,
    SEED_BOUNDS,
    START_OF_RANGE,
    NumcalData,
    NumcalParameters,
    read_numcal_csv,
    synthesise_numcal_data,
)

__all__ = [
    "MOVED_PAIR",
    "PARAMETER_NAMES",
    "SEED_BOUNDS",
    "NumcalData",
    "NumcalParameters",
    "NumericalCalibration",
    "calibrate_numerically",
    "height_errors",
    "random_search",
    "read_numcal_csv",
    "residuals_and_jacobian",
    "select_samples",
    "synthesise_numcal_data",
]

FloatArray = NDArray[np.float64]
#: generations of differential evolution per search (scipy's ``maxiter``)
DE_GENERATIONS = 1000


def _pair_arrays(data: NumcalData) -> tuple[NDArray[np.int_], NDArray[np.int_], NDArray[np.int_]]:
    stationary = np.array([ARMS.index(MOVED_PAIR[m][0]) for m in data.moved], dtype=int)
    moving = np.array([ARMS.index(MOVED_PAIR[m][1]) for m in data.moved], dtype=int)
    pair = np.array([_PAIR_INDEX[MOVED_PAIR[m][2]] for m in data.moved], dtype=int)
    return stationary, moving, pair


def residuals_and_jacobian(
    data: NumcalData, parameters: ArrayLike, *, start_of_range: float = START_OF_RANGE
) -> tuple[FloatArray, FloatArray]:
    """Distance residuals ``L - sqrt(h² + b²)`` (M,) and their Jacobian (M, 9) (eqs 2.5, 2.7).

    Parameters are in :data:`PARAMETER_NAMES` order (beta in radians).

    Examples
    --------
    >>> truth = NumcalParameters.from_seed_table()
    >>> data = synthesise_numcal_data(truth, seed=0)
    >>> r, jac = residuals_and_jacobian(data, truth.vector())
    >>> bool(np.abs(r).max() < 1e-9), jac.shape
    (True, (45, 9))
    """
    p = np.asarray(parameters, dtype=float)
    stationary, moving, pair = _pair_arrays(data)
    rows = np.arange(len(data.moved))
    length_i = data.lasers[rows, stationary] + start_of_range + p[stationary]
    length_n = data.lasers[rows, moving] + start_of_range + p[moving]
    beta = p[3 + pair]
    base = p[6 + pair]
    cosine, sine = np.cos(beta), np.sin(beta)
    distance = np.sqrt(np.maximum(length_i**2 + length_n**2 - 2.0 * length_i * length_n * cosine, 1e-300))
    implied = np.sqrt(data.heights**2 + base**2)
    residuals = distance - implied
    jac = np.zeros((rows.size, 9))
    np.add.at(jac, (rows, stationary), (length_i - length_n * cosine) / distance)
    np.add.at(jac, (rows, moving), (length_n - length_i * cosine) / distance)
    jac[rows, 3 + pair] = length_i * length_n * sine / distance
    jac[rows, 6 + pair] = -base / implied
    return residuals, jac


def height_errors(data: NumcalData, parameters: ArrayLike, *, start_of_range: float = START_OF_RANGE) -> FloatArray:
    """The seed's error ``sqrt(L² - b²) - |h|`` per sample (mm), NaN where the root is complex.

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
    _, _, pair = _pair_arrays(data)
    base = p[6 + pair]
    distance = residuals + np.sqrt(data.heights**2 + base**2)
    squared = distance**2 - base**2
    with np.errstate(invalid="ignore"):
        return np.where(squared >= 0, np.sqrt(np.maximum(squared, 0.0)), np.nan) - np.abs(data.heights)


@dataclass(frozen=True)
class NumericalCalibration:
    """Result of :func:`calibrate_numerically`.

    Attributes
    ----------
    parameters : NumcalParameters
    residuals : ndarray, shape (M,)
        Distance residuals at the solution (mm).
    rms : float
        Root mean square of ``residuals`` (mm).
    height_errors : ndarray, shape (M,)
        The seed's height errors (mm, NaN where complex) for comparison with Tables 6.3/6.5.
    method : str
        ``"simultaneous"`` or ``"sequential"``.
    global_search : str or None
    evaluations : int
        Objective evaluations used (global search plus local refinement).
    identifiability : Identifiability
        Jacobian analysis at the solution (all nine parameters, all data).
    """

    parameters: NumcalParameters
    residuals: FloatArray
    rms: float
    height_errors: FloatArray
    method: str
    global_search: str | None
    evaluations: int
    identifiability: Any

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary."""
        return {
            "method": self.method,
            "global_search": self.global_search,
            "d": dict(self.parameters.d),
            "beta_deg": self.parameters.beta_deg,
            "b": dict(self.parameters.b),
            "rms": self.rms,
            "evaluations": self.evaluations,
            "height_errors": [None if not np.isfinite(e) else float(e) for e in self.height_errors],
            "identifiability": self.identifiability.to_dict(),
        }


def _costs(data: NumcalData, trials: FloatArray) -> FloatArray:
    """Sum of squared distance residuals (mm²) for many parameter sets ``trials`` (S, 9) at once."""
    stationary, moving, pair = _pair_arrays(data)
    rows = np.arange(len(data.moved))
    length_i = data.lasers[rows, stationary] + START_OF_RANGE + trials[:, stationary]
    length_n = data.lasers[rows, moving] + START_OF_RANGE + trials[:, moving]
    squared = length_i**2 + length_n**2 - 2 * length_i * length_n * np.cos(trials[:, 3 + pair])
    distance = np.sqrt(np.maximum(squared, 0.0))
    return np.sum((distance - np.sqrt(data.heights**2 + trials[:, 6 + pair] ** 2)) ** 2, axis=1)


def _solve(
    data: NumcalData,
    free: NDArray[np.int_],
    fixed_vector: FloatArray,
    bounds: tuple[FloatArray, FloatArray],
    start: FloatArray | None,
    global_search: str | None,
    seed: int,
    starts: int,
    max_evaluations: int = 300,
    report: Callable[[int], None] | None = None,
) -> tuple[FloatArray, int]:
    """Global search then least squares over the ``free`` parameters; ``report(units_done)`` (see :func:`_units`)."""
    from scipy.optimize import differential_evolution, least_squares

    lower, upper = bounds[0][free], bounds[1][free]

    def full(x: FloatArray) -> FloatArray:
        vector = fixed_vector.copy()
        vector[free] = x
        return vector

    def fun(x: FloatArray) -> FloatArray:
        return residuals_and_jacobian(data, full(x))[0]

    def jac(x: FloatArray) -> FloatArray:
        return residuals_and_jacobian(data, full(x))[1][:, free]

    evaluations = 0
    candidates: list[FloatArray] = []
    if global_search == "differential_evolution":
        population_size = [0]

        def population_cost(x: FloatArray) -> FloatArray:  # x: (n_free, S), vectorised
            population_size[0] += x.shape[1]
            trials = np.repeat(fixed_vector[None, :], x.shape[1], axis=0)
            trials[:, free] = x.T
            return _costs(data, trials)

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
        found = least_squares(fun, x0, jac=jac, bounds=(lower, upper), method="trf", x_scale="jac", xtol=1e-14,
                              ftol=1e-14, gtol=1e-14, max_nfev=max_evaluations)
        evaluations += int(found.nfev)
        if report is not None:
            report(searched + index)
        if found.cost < best_cost:
            best_x, best_cost = found.x, float(found.cost)
    if best_x is None or not np.isfinite(best_cost):
        raise ConvergenceError("numerical calibration", evaluations, "no finite solution found")
    return full(best_x), evaluations


def _units(global_search: str | None, starts: int, has_start: bool) -> int:
    """Progress units of one solver stage: DE generations (at most) plus one per least-squares start."""
    local = starts if global_search == "multistart" else (1 if global_search == "differential_evolution" else 0)
    local += int(has_start)
    return (DE_GENERATIONS if global_search == "differential_evolution" else 0) + max(local, 1)


def calibrate_numerically(
    data: NumcalData,
    *,
    method: Literal["simultaneous", "sequential"] = "simultaneous",
    global_search: Literal["differential_evolution", "multistart"] | None = "differential_evolution",
    start: NumcalParameters | None = None,
    bounds: tuple[ArrayLike, ArrayLike] | None = None,
    seed: int = 0,
    starts: int = 20,
    progress: Callable[[int, int], None] | None = None,
) -> NumericalCalibration:
    """Identify d, beta, b per arm from height-gauge data (thesis 6.2).

    Parameters
    ----------
    data : NumcalData
    method : {"simultaneous", "sequential"}
        All nine parameters at once (6.2.2, Table 6.4) or the seed's arm-by-arm sequence.
    global_search : {"differential_evolution", "multistart"} or None
        Global stage before :func:`scipy.optimize.least_squares`; None refines ``start`` only.
    start : NumcalParameters, optional
        Starting point (used in addition to the global search); default mid-bounds.
    bounds : (lower, upper), optional
        Each shape (9,) in :data:`PARAMETER_NAMES` order (beta in radians); default
        :data:`SEED_BOUNDS` (Appendix B's GA bounds).
    seed : int
        Seed of the global search.
    starts : int
        Number of seeded starts for ``"multistart"``.
    progress : callable, optional
        ``progress(done, total)``, called from the global search's callback after every
        generation of differential evolution and after every least-squares start.  A stage
        counts ``1000`` units for the evolution (its generation limit; the count jumps ahead
        when the population converges earlier) plus one per least-squares start; the
        sequential method has three stages.  The last call has ``done == total``.

    Returns
    -------
    NumericalCalibration

    Raises
    ------
    InvalidInputError
        Unknown method or search, malformed bounds, no samples for an arm the method needs.
    ConvergenceError
        No finite solution.

    Warns
    -----
    IllConditionedWarning
        The Jacobian at the solution is rank deficient: the undetermined parameter
        combinations are named (e.g. only one arm was moved).

    Examples
    --------
    See the module docstring.
    """
    from pcmm_geo.machine.calibration.identifiability import analyse_identifiability

    lower, upper = (np.asarray(b, dtype=float) for b in (bounds or SEED_BOUNDS))
    if lower.shape != (9,) or upper.shape != (9,) or np.any(lower >= upper):
        raise InvalidInputError("bounds", "two arrays of shape (9,) with lower < upper", f"{lower} / {upper}")
    if global_search not in ("differential_evolution", "multistart", None):
        raise InvalidInputError("global_search", "'differential_evolution', 'multistart' or None", repr(global_search))
    start_vector = None if start is None else start.vector()
    evaluations = 0
    per_stage = _units(global_search, starts, start is not None)

    def reporter(stage: int, stage_count: int) -> Callable[[int], None] | None:
        if progress is None:
            return None
        return lambda done: progress(stage * per_stage + done, stage_count * per_stage)

    if method == "simultaneous":
        vector, evaluations = _solve(data, np.arange(9), np.zeros(9), (lower, upper), start_vector, global_search,
                                     seed, starts, report=reporter(0, 1))
    elif method == "sequential":
        vector = 0.5 * (lower + upper) if start_vector is None else start_vector.copy()
        stages = (("a", [2, 0, 5, 8]), ("b", [1, 3, 6]), ("c", [4, 7]))  # d_c d_a beta_ca b_ca | d_b .. | beta_bc b_bc
        for index, (arm, free) in enumerate(stages):
            subset = data.subset((arm,))
            if not subset.moved:
                raise InvalidInputError("data", f"samples with arm {arm} moved (sequential stage {arm})", "none")
            vector, used = _solve(subset, np.array(free), vector, (lower, upper), start_vector, global_search, seed,
                                  starts, report=reporter(index, len(stages)))
            evaluations += used
    else:
        raise InvalidInputError("method", "'simultaneous' or 'sequential'", repr(method))
    residuals, jacobian = residuals_and_jacobian(data, vector)
    identifiability = analyse_identifiability(jacobian, PARAMETER_NAMES)
    if identifiability.undetermined:
        warnings.warn(
            "numerical calibration: the data do not determine "
            + "; ".join(identifiability.undetermined)
            + f" (rank {identifiability.rank} of 9); those parameters stay at their start values",
            IllConditionedWarning,
            stacklevel=2,
        )
    return NumericalCalibration(
        parameters=NumcalParameters.from_vector(vector),
        residuals=residuals,
        rms=float(np.sqrt(np.mean(residuals**2))),
        height_errors=height_errors(data, vector),
        method=method,
        global_search=global_search,
        evaluations=evaluations,
        identifiability=identifiability,
    )


def random_search(
    data: NumcalData,
    samples: int,
    *,
    bounds: tuple[ArrayLike, ArrayLike] | None = None,
    seed: int = 0,
    chunk: int = 200_000,
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
    lower, upper = (np.asarray(b, dtype=float) for b in (bounds or SEED_BOUNDS))
    rng = np.random.default_rng(seed)
    best_vector, best_cost = lower.copy(), np.inf
    done = 0
    while done < samples:
        count = min(chunk, samples - done)
        trial = rng.uniform(lower, upper, (count, 9))
        cost = _costs(data, trial)
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
) -> tuple[NumcalData, Any]:
    """Choose the ``count`` samples whose identification Jacobian is best conditioned (Verl et al. 2008).

    Each sample (one height-gauge pose) contributes one row of the Jacobian of
    :func:`residuals_and_jacobian` at ``parameters``;
    :func:`pcmm_geo.machine.calibration.identifiability.select_poses` adds, one at a time, the sample
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
    >>> subset, selection = select_samples(data, 12)
    >>> len(subset.moved), bool(selection.final_condition_number < 1e7)
    (12, True)
    """
    from pcmm_geo.machine.calibration.identifiability import select_poses

    at = NumcalParameters.from_seed_table() if parameters is None else parameters
    _, jacobian = residuals_and_jacobian(data, at.vector())
    selection = select_poses([jacobian[k : k + 1] for k in range(jacobian.shape[0])], count, initial=initial,
                             exchange_passes=exchange_passes)
    chosen = np.array(selection.indices, dtype=int)
    subset = NumcalData(tuple(data.moved[k] for k in chosen), data.lasers[chosen], data.heights[chosen])
    return subset, selection
