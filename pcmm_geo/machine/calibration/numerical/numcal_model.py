"""The height-gauge model of the numerical calibration (thesis eqs 2.5, 2.7): residuals, Jacobian, weights.

See :mod:`pcmm_geo.machine.calibration.numerical.numcal` for the experiment and the solvers.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.machine.calibration.numerical.numcal_data import (
    _PAIR_INDEX,
    ARMS,
    MOVED_PAIR,
    PAIR_ARMS,
    SEED_BOUNDS,
    START_OF_RANGE,
    NumcalData,
)

__all__ = ["equation_rows", "height_errors", "reading_whitener", "residuals_and_jacobian"]

FloatArray = NDArray[np.float64]
Pairs = Literal["moved", "all"]


def equation_rows(data: NumcalData, pairs: str = "moved") -> tuple[NDArray[np.int_], ...]:
    """Per equation: sample index, arm i, arm in and pair index; ``pairs`` "moved" (one per sample) or "all".

    The arrays are read-only (they are shared by every evaluation on the same samples).
    """
    if pairs not in ("moved", "all"):
        raise InvalidInputError("pairs", "'moved' or 'all'", repr(pairs))
    return _equation_rows(tuple(data.moved), pairs)


@lru_cache(maxsize=64)
def _equation_rows(moved: tuple[str, ...], pairs: str) -> tuple[NDArray[np.int_], ...]:
    count = len(moved)
    if pairs == "moved":
        sample = np.arange(count)
        first = np.array([ARMS.index(MOVED_PAIR[m][0]) for m in moved], dtype=int)
        second = np.array([ARMS.index(MOVED_PAIR[m][1]) for m in moved], dtype=int)
        pair = np.array([_PAIR_INDEX[MOVED_PAIR[m][2]] for m in moved], dtype=int)
        rows: tuple[NDArray[np.int_], ...] = (sample, first, second, pair)
    else:
        sample = np.repeat(np.arange(count), 3)
        first = np.tile([i for i, _ in PAIR_ARMS], count)
        second = np.tile([n for _, n in PAIR_ARMS], count)
        rows = (sample, first, second, np.tile([0, 1, 2], count))
    for array in rows:
        array.flags.writeable = False
    return rows


def residuals_and_jacobian(
    data: NumcalData, parameters: ArrayLike, *, pairs: Pairs = "moved", start_of_range: float = START_OF_RANGE
) -> tuple[FloatArray, FloatArray]:
    """Distance residuals ``L - sqrt(dz² + b²)`` (R,) and their Jacobian (R, 9) (eqs 2.5, 2.7).

    Parameters are in :data:`PARAMETER_NAMES` order (beta in radians).  ``R`` is the number of
    samples (``pairs="moved"``) or three times it (``"all"``, order ab, bc, ca per sample).

    Examples
    --------
    >>> from pcmm_geo.machine.calibration.numerical.numcal_data import NumcalParameters, synthesise_numcal_data
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
    # the two arms of a pair differ, so each row receives each column once
    jac[rows, first] = (length_i - length_n * cosine) / distance
    jac[rows, second] = (length_n - length_i * cosine) / distance
    jac[rows, 3 + pair] = length_i * length_n * sine / distance
    jac[rows, 6 + pair] = -base / implied
    return residuals, jac


def height_errors(data: NumcalData, parameters: ArrayLike, *, start_of_range: float = START_OF_RANGE) -> FloatArray:
    """The seed's error ``sqrt(L² - b²) - |dz|`` per sample, moved pair (mm), NaN where the root is complex.

    Examples
    --------
    >>> from pcmm_geo.machine.calibration.numerical.numcal_data import NumcalParameters, synthesise_numcal_data
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


def _check_bounds(bounds: tuple[ArrayLike, ArrayLike] | None) -> tuple[FloatArray, FloatArray]:
    lower, upper = (np.asarray(b, dtype=float) for b in (bounds or SEED_BOUNDS))
    if lower.shape != (9,) or upper.shape != (9,) or np.any(lower >= upper):
        raise InvalidInputError("bounds", "two arrays of shape (9,) with lower < upper", f"{lower} / {upper}")
    return lower, upper


def reading_whitener(
    data: NumcalData, parameters: ArrayLike, *, pairs: Pairs = "moved", laser_sigma: float, height_sigma: float
) -> Callable[[FloatArray], FloatArray]:
    """Map residuals (R,) or Jacobians (R, P) to whitened ones, from the reading uncertainties.

    Each equation is linear, to first order, in its sample's six readings (three lasers, three
    pivot heights) with the coefficients of the Jacobian of the distance residual; the readings
    are independent with standard uncertainties ``laser_sigma`` and ``height_sigma`` (mm).  The
    covariance ``C_k`` of a sample's equations (1 x 1 with ``pairs="moved"``, 3 x 3 with
    ``"all"``: the three pair equations share readings) gives the weight ``L_k⁻¹`` with
    ``L_k L_kᵀ = C_k``.  Weighted least squares with it is the maximum-likelihood estimate, and
    ``s² (J̃ᵀJ̃)⁻¹`` its covariance (``s`` near 1 when the sigmas are right).

    Raises
    ------
    InvalidInputError
        Negative or non-finite sigmas, or both zero.

    Examples
    --------
    >>> from pcmm_geo.machine.calibration.numerical.numcal_data import NumcalParameters, synthesise_numcal_data
    >>> truth = NumcalParameters.from_seed_table()
    >>> data = synthesise_numcal_data(truth, samples_per_arm=3)
    >>> whiten = reading_whitener(data, truth.vector(), laser_sigma=1e-3, height_sigma=1e-3)
    >>> whiten(np.ones(9)).shape
    (9,)
    """
    sigmas = np.array([laser_sigma, height_sigma], dtype=float)
    if not np.all(np.isfinite(sigmas)) or np.any(sigmas < 0) or not np.any(sigmas > 0):
        raise InvalidInputError("laser_sigma, height_sigma", "finite, non-negative, not both zero",
                                f"{laser_sigma}, {height_sigma}")
    p = np.asarray(parameters, dtype=float)
    sample, first, second, pair = equation_rows(data, pairs)
    rows = np.arange(sample.size)
    length_i = data.lasers[sample, first] + START_OF_RANGE + p[first]
    length_n = data.lasers[sample, second] + START_OF_RANGE + p[second]
    pivots = np.asarray(data.pivot_heights)
    rise = pivots[sample, second] - pivots[sample, first]
    cosine = np.cos(p[3 + pair])
    distance = np.sqrt(np.maximum(length_i**2 + length_n**2 - 2.0 * length_i * length_n * cosine, 1e-300))
    implied = np.sqrt(rise**2 + p[6 + pair] ** 2)
    sensitivity = np.zeros((rows.size, 6))  # d(residual) / d(laser a, b, c, height a, b, c)
    np.add.at(sensitivity, (rows, first), (length_i - length_n * cosine) / distance)
    np.add.at(sensitivity, (rows, second), (length_n - length_i * cosine) / distance)
    np.add.at(sensitivity, (rows, 3 + second), -rise / implied)
    np.add.at(sensitivity, (rows, 3 + first), rise / implied)
    per_sample = 1 if pairs == "moved" else 3
    blocks = sensitivity.reshape(-1, per_sample, 6)
    variances = np.repeat(sigmas**2, 3)
    covariance = np.einsum("kij,j,klj->kil", blocks, variances, blocks)
    # a tiny floor keeps an equation with no reading sensitivity (cannot happen on real poses) invertible
    covariance += np.eye(per_sample) * 1e-30
    factor = np.linalg.cholesky(covariance)

    def whiten(values: FloatArray) -> FloatArray:
        array = np.asarray(values, dtype=float)
        shaped = array.reshape(-1, per_sample, int(np.prod(array.shape[1:], dtype=int)))
        return np.linalg.solve(factor, shaped).reshape(array.shape)

    return whiten
