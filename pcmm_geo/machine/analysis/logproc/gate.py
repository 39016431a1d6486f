"""The gate of a processed log: Baarda's w-test per laser reading, its limits and the lasers' uncertainty.

The readings' uncertainty
-------------------------
Each laser reading has the standard uncertainty ``sigma_j = sqrt(laser_sigma^2 + q_j^2 / 12)``
(:func:`reading_sigmas`): ``laser_sigma`` for noise and accuracy (default :data:`SEED_LASER_SIGMA`:
the thesis' 50 um accuracy, section 3.1, read as the bounds of a rectangular distribution, GUM
4.3.7: 28.9 um), and the sensor's reading step ``q_j`` (resolution, rectangular: ``q/sqrt(12)``):
ILD1302 (lasers a, b) ``200 mm * 1.02 / 16368 = 12.46 um``, ILD1420 (laser c) ``3.11 um``
(:data:`SEED_LASER_STEPS`, the drivers' scaling).  A log written by ``pcmm acquire`` names its
sensors (``laser_models``); ``pcmm process-log`` takes their steps from it.

Redundancy and the w-test (data snooping, Baarda 1968)
------------------------------------------------------
The network adjustment (:mod:`~pcmm_geo.machine.analysis.logproc.adjustment`) gives every
reading ``i`` its correction ``v_i`` and the correction's variance
``sigma_vi^2 = sigma_i^2 r_i``, with the *redundancy number* ``r_i = 1 - w_i a_i^T N^-1 a_i``
(``a_i`` its row of the design matrix; ``0 <= r_i <= 1``, ``sum r_i`` = the redundancy of the
log).  ``r_i`` is the share of a fault ``nabla`` in reading ``i`` that shows in its own
correction, ``E(v_i) = r_i nabla``; the rest moves the heights.  Where a row begins a new segment
its three lasers share one unknown; the rows after it, while the segment stands, measure it
again: a reading's redundancy comes from its own row *and* from the rows that carry its state.
The w-test statistic is ``w_i = v_i / sigma_vi``, standard normal for a clean log.  A reading is
refused when ``|w_i| > k`` with ``k`` the two-sided critical value of the significance
``alpha0`` (default :data:`DEFAULT_ALPHA` = 0.1 %: ``k = 3.29``); the largest ``|w|`` is refused
first, the log is adjusted again without it, and so on (:func:`worst_reading`).

Minimal detectable bias and power
---------------------------------
The fault a w-test finds with probability ``beta0`` (default :data:`DEFAULT_POWER` = 80 %) has
non-centrality ``delta0`` with ``P(|N(delta0, 1)| > k) = beta0``: ``delta0 = 4.13`` for 0.1 % and
80 % (the B-method's classic pair).  Its size is the minimal detectable bias
``MDB_i = delta0 sigma_i / sqrt(r_i)`` (mm).  A reading with ``r_i = 0`` (below
:data:`MIN_REDUNDANCY`) cannot be checked at all: its MDB is infinite, and so is the external
reliability of every point it moves (:mod:`~pcmm_geo.machine.analysis.logproc.reliability`).

With an explicit tolerance ``T`` (``closure_tolerance``, ``--max-closure-mm``) a row is refused when
the length of its three corrections exceeds ``T``; a fault then passes as long as
``r_i nabla <= T`` and the MDB at power ``beta0`` is ``(T + z_beta0 sigma_vi) / r_i``.

Why 0.1 % per reading
---------------------
The classic value keeps the MDBs small.  Its price is a family-wise false-alarm rate: a log of
``n`` readings with Gaussian errors at the stated ``sigma`` is refused with probability
``1 - (1 - alpha0)^n`` (``n = 180``, a 60-move session: 16 %).  The default ``sigma`` is the
bound of the lasers' stated accuracy read as a rectangular distribution: if the lasers keep
their statement, ``|w| > 3.29`` needs several readings at their bounds at once and a clean log
is practically never refused (the simulated sessions, whose readings carry their count steps
only, never are).  If your ``laser_sigma`` is a Gaussian noise, pass ``alpha = a / n`` to hold
the whole log's false-alarm rate at ``a`` (Bonferroni); the MDBs grow with ``k``.

Examples
--------
>>> limits = gate_limits(0.001, 0.8)
>>> round(limits.critical, 4), round(limits.noncentrality, 3)
(3.2905, 4.132)
>>> np.round(reading_sigmas(SEED_LASER_SIGMA, SEED_LASER_STEPS) * 1e3, 2).tolist()  # um
[29.09, 29.09, 28.88]
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.acquisition.drivers.lasers import ILD1302_FULL_SCALE, ILD1420_FULL_SCALE, MEASURING_RANGE_MM
from pcmm_geo.errors import InconsistentMeasurementError, InvalidInputError
from pcmm_geo.machine.kinematics.model_parts import ARMS

__all__ = [
    "DEFAULT_ALPHA",
    "DEFAULT_POWER",
    "MIN_REDUNDANCY",
    "SEED_LASER_ACCURACY",
    "SEED_LASER_SIGMA",
    "SEED_LASER_STEPS",
    "GateLimits",
    "gate_limits",
    "reading_error",
    "reading_sigmas",
    "w_test_power",
    "worst_reading",
]

FloatArray = NDArray[np.float64]

#: accuracy of the seed's lasers as the thesis states it (section 3.1), mm
SEED_LASER_ACCURACY = 0.05
#: default standard uncertainty of a laser reading: the stated accuracy as rectangular bounds, mm
SEED_LASER_SIGMA = SEED_LASER_ACCURACY / float(np.sqrt(3.0))
#: reading steps of the seed's sensors a, b (ILD1302, 14 bit) and c (ILD1420, 16 bit) over 200 mm, mm
SEED_LASER_STEPS: tuple[float, float, float] = (
    MEASURING_RANGE_MM * 1.02 / ILD1302_FULL_SCALE,
    MEASURING_RANGE_MM * 1.02 / ILD1302_FULL_SCALE,
    MEASURING_RANGE_MM * 1.02 / ILD1420_FULL_SCALE,
)
#: reading steps by sensor model (``laser_models`` metadata of ``pcmm acquire`` logs), mm
LASER_STEPS_BY_MODEL = {"ILD1302": SEED_LASER_STEPS[0], "ILD1420": SEED_LASER_STEPS[2]}
#: significance of the w-test per reading (B-method)
DEFAULT_ALPHA = 0.001
#: power of the w-test for a fault of the minimal detectable bias (B-method)
DEFAULT_POWER = 0.80
#: a reading with a smaller redundancy number is uncontrolled (infinite MDB)
MIN_REDUNDANCY = 1e-8


def reading_sigmas(laser_sigma: float, laser_steps: ArrayLike = SEED_LASER_STEPS) -> FloatArray:
    """Standard uncertainty of readings of lasers a, b, c: ``sqrt(laser_sigma^2 + q^2/12)`` (mm), shape (3,).

    Raises
    ------
    InvalidInputError
        A negative or non-finite ``laser_sigma`` or step, or all zero.
    """
    steps = np.asarray(laser_steps, dtype=float)
    if steps.shape != (3,) or not np.all(np.isfinite(steps)) or np.any(steps < 0):
        raise InvalidInputError("laser_steps", "three non-negative reading steps in mm", repr(laser_steps))
    if not (np.isfinite(laser_sigma) and laser_sigma >= 0):
        raise InvalidInputError("laser_sigma", "a non-negative finite number of mm", str(laser_sigma))
    sigmas = np.sqrt(laser_sigma**2 + steps**2 / 12.0)
    if not np.all(sigmas > 0):
        raise InvalidInputError("laser_sigma", "a positive uncertainty (or non-zero reading steps)", str(laser_sigma))
    return sigmas


@dataclass(frozen=True)
class GateLimits:
    """Significance ``alpha`` and power ``power`` of the w-test, with ``critical`` (k) and ``noncentrality`` (delta0).

    ``tolerance`` (mm) replaces the w-test by a limit on each row's closure residual when given.
    """

    alpha: float
    power: float
    critical: float
    noncentrality: float
    tolerance: float | None = None

    def mdb(self, sigma: ArrayLike, redundancy: ArrayLike) -> FloatArray:
        """Minimal detectable bias (mm) of readings of uncertainty ``sigma`` and redundancy number ``redundancy``."""
        from scipy.stats import norm

        sigma = np.asarray(sigma, dtype=float)
        r = np.asarray(redundancy, dtype=float)
        controlled = r >= MIN_REDUNDANCY
        safe = np.where(controlled, r, 1.0)
        if self.tolerance is None:
            size = self.noncentrality * sigma / np.sqrt(safe)
        else:
            size = (self.tolerance + norm.ppf(self.power) * sigma * np.sqrt(safe)) / safe
        return np.where(controlled, size, np.inf)


@lru_cache(maxsize=64)
def gate_limits(alpha: float = DEFAULT_ALPHA, power: float = DEFAULT_POWER,
                tolerance: float | None = None) -> GateLimits:
    """The w-test's critical value and the non-centrality of a fault found with probability ``power``.

    Raises
    ------
    InvalidInputError
        ``alpha`` or ``power`` outside (0, 1), ``power <= alpha``, or a tolerance that is not positive.
    """
    from scipy.optimize import brentq
    from scipy.stats import norm

    if not 0.0 < alpha < 1.0:
        raise InvalidInputError("alpha", "a significance in (0, 1)", str(alpha))
    if not alpha < power < 1.0:
        raise InvalidInputError("power", "a probability in (alpha, 1)", str(power))
    if tolerance is not None and not (np.isfinite(tolerance) and tolerance > 0):
        raise InvalidInputError("closure_tolerance", "a positive finite number of mm", str(tolerance))
    critical = float(norm.isf(alpha / 2.0))
    noncentrality = float(brentq(lambda delta: w_test_power(delta, critical) - power, 0.0, critical + 10.0,
                                 xtol=1e-12))
    return GateLimits(float(alpha), float(power), critical, noncentrality, tolerance)


def w_test_power(noncentrality: float, critical: float) -> float:
    """``P(|N(delta, 1)| > k)``: the probability that a w-test with critical value ``k`` finds a fault that
    shifts its statistic by ``delta`` standard deviations.

    Examples
    --------
    >>> limits = gate_limits(0.001, 0.8)
    >>> round(w_test_power(limits.noncentrality, limits.critical), 6)
    0.8
    """
    from scipy.stats import norm

    return float(norm.sf(critical - noncentrality) + norm.cdf(-critical - noncentrality))


def worst_reading(
    residuals: FloatArray, sigmas: FloatArray, redundancy: FloatArray, used: NDArray[np.bool_], limits: GateLimits
) -> tuple[int, int] | None:
    """``(row, arm)`` (indices into the given ``(R, 3)`` arrays) of the reading to refuse first, or None.

    Statistical gate: the largest ``|w|`` beyond the critical value among readings that can be
    tested.  Explicit tolerance: the largest correction of the row with the largest closure
    residual beyond the tolerance.
    """
    if limits.tolerance is not None:
        closure = np.linalg.norm(np.where(used, residuals, 0.0), axis=1)
        row = int(np.argmax(closure))
        if closure[row] <= limits.tolerance:
            return None
        return row, int(np.argmax(np.where(used[row], np.abs(residuals[row]), -1.0)))
    statistic = np.abs(w_statistics(residuals, sigmas, redundancy, used))
    statistic = np.where(np.isfinite(statistic), statistic, -1.0)
    flat = int(np.argmax(statistic))
    if statistic.flat[flat] <= limits.critical:
        return None
    return divmod(flat, 3)


def w_statistics(residuals: FloatArray, sigmas: FloatArray, redundancy: FloatArray,
                 used: NDArray[np.bool_]) -> FloatArray:
    """Baarda's ``w = v / (sigma sqrt(r))``; NaN where a reading is left out or cannot be tested (``r`` ~ 0)."""
    testable = used & (redundancy >= MIN_REDUNDANCY)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(testable, residuals / (sigmas * np.sqrt(redundancy)), np.nan)


def reading_error(row: int, arm: int, kind: str, residual: float, statistic: float, redundancy: float,
                  sigma: float, limits: GateLimits, closure: float) -> InconsistentMeasurementError:
    """The refusal of reading ``arm`` of log row ``row`` (0-based); ``kind`` is "first", "start" or "stop".

    Examples
    --------
    >>> limits = gate_limits()
    >>> error = reading_error(4, 1, "stop", 0.5, 12.0, 0.5, 0.029, limits, 0.6)
    >>> error.what, error.residual, error.tolerance
    ('closure of log row 5', 0.5, 0.06748)
    """
    if limits.tolerance is None:
        tolerance = limits.critical * sigma * np.sqrt(redundancy)
        test = (f"laser {ARMS[arm]}: w = {statistic:.3g} beyond the critical value {limits.critical:.3g} "
                f"(alpha0 = {limits.alpha:g}, redundancy number {redundancy:.2f})")
        size, bound = residual, tolerance
    else:
        test = f"closure residual of the row {closure:.3g} mm, largest correction at laser {ARMS[arm]}"
        size, bound = closure, limits.tolerance
    detail = (f"{kind} row, {test}: a laser reading is wrong, the machine model does not fit this pose, or the "
              "start heights (datum) are not where the log started")
    return InconsistentMeasurementError(f"closure of log row {row + 1}", round(float(abs(size)), 6),
                                        float(f"{bound:.4g}"), "mm", detail)
