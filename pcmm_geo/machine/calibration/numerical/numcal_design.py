"""Planning and brute force for the numerical calibration: design identifiability, sample selection, random search.

See :mod:`pcmm_geo.machine.calibration.numerical.numcal`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from pcmm_geo.machine.calibration.numerical.numcal_data import (
    PARAMETER_NAMES,
    NumcalData,
    NumcalParameters,
    synthesise_design_data,
)
from pcmm_geo.machine.calibration.numerical.numcal_model import Pairs, _check_bounds, _costs, residuals_and_jacobian

__all__ = ["design_identifiability", "random_search", "select_samples"]


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
    >>> from pcmm_geo.machine.calibration.numerical.numcal_data import NumcalParameters, synthesise_numcal_data
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
    >>> from pcmm_geo.machine.calibration.numerical.numcal_data import NumcalParameters, synthesise_numcal_data
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
