"""Single-arm four-parameter numerical calibration (thesis 6.2.1, Table 6.2, Appendix B).

The seed first calibrated one arm at a time: pivot ``in`` is raised by a height gauge from
the level start while pivot ``i`` (the previous arm) stands still, and four parameters are
fitted to eqs 2.5 and 2.7 -- the dead distances ``d_i`` and ``d_in``, the angle ``beta_in``
and the pivot spacing ``b_in`` (Appendix B's ``X(1)..X(4)``).  Table 6.2 prints the results
of three such tests with 6, 11 and 3 points for the pair c-a (arm a moved: its "Expected" row is
Table 3.1's ``d_c`` = 289.40 and ``d_a`` = 294.02 mm plus the 60 mm start of range,
``beta_ca`` = 68.36 degrees; erratum 8: the header swaps the units, beta is in degrees and b
in mm).  The raw laser data of those tests are not in the thesis; only the heights of the
11-point test are (Appendix B line 2, :data:`APPENDIX_B_HEIGHTS`).

What this experiment can determine.  With physical data (the rigid-body model) the stationary
laser ``l_i`` changes by about 1.6 um while pivot ``in`` rises 50 mm.  If ``L_i`` were
constant, ``L² = L_i² + L_in² - 2 L_i L_in cos(beta)`` would be a quadratic in the moved laser
reading with only two free coefficients: of the four parameters, two combinations are seen
well, a third only through that 1.6 um change, and the fourth not at all.  The
column-equilibrated Jacobian has relative singular values of about ``1, 1e-3, 3e-9, 1e-16``
(rank 3): :func:`calibrate_single_arm` reports ``converged=False`` for it, and with a 0.01 mm
height gauge the fitted parameters can land anywhere in the bounds -- the mechanism behind
Table 6.2's spread.  Test 3's three points cannot determine four parameters at all
(``dof = -1``).  Moving both pivots of the pair independently over 0-200 mm determines all
four (condition number about 150).

Examples
--------
>>> truth = NumcalParameters.from_seed_table()
>>> data = synthesise_numcal_data(truth, samples_per_arm=11, arms=("a",))
>>> import warnings
>>> with warnings.catch_warnings(record=True) as caught:
...     warnings.simplefilter("always")
...     result = calibrate_single_arm(data, "a", global_search=None, start=truth, max_evaluations=200)
>>> result.names, result.converged, caught[0].category.__name__
(('d_a', 'd_c', 'beta_ca', 'b_ca'), False, 'CalibrationNotConvergedWarning')
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.machine.calibration.numerical.numcal import _solve
from pcmm_geo.machine.calibration.numerical.numcal_data import (
    ARMS,
    MOVED_PAIR,
    PARAMETER_NAMES,
    NumcalData,
    NumcalParameters,
    synthesise_numcal_data,
)
from pcmm_geo.machine.calibration.numerical.numcal_model import (
    _check_bounds,
    height_errors,
    reading_whitener,
    residuals_and_jacobian,
)
from pcmm_geo.machine.calibration.numerical.numcal_solver import NumericalCalibration, assess

__all__ = ["APPENDIX_B_HEIGHTS", "TABLE_6_2", "TABLE_6_2_EXPECTED", "calibrate_single_arm", "seed_sigma_err",
           "single_arm_parameters", "synthesise_numcal_data"]

FloatArray = NDArray[np.float64]

#: Appendix B line 2: the height-gauge readings of the 11-point test (mm)
APPENDIX_B_HEIGHTS = (0.0, 3.16, 5.79, 9.15, 12.4, 15.05, 17.93, 20.03, 23.79, 26.27, 29.95)
#: Table 6.2 as printed, units corrected (erratum 8): test -> (d_i mm, d_in mm, beta_in deg, b mm,
#: sigma_err mm, points); the seed's dead distances include the 60 mm start of range
TABLE_6_2: Mapping[str, tuple[float, float, float, float, float, int]] = {
    "test 1": (320.94, 372.83, 79.93, 493.01, 0.91, 6),
    "test 2": (363.95, 374.49, 62.75, 421.38, 0.76, 11),
    "test 3": (383.07, 343.57, 69.16, 453.62, 0.11, 3),
}
#: Table 6.2's "Expected" row (d_i, d_in including the 60 mm, beta_in deg, b mm)
TABLE_6_2_EXPECTED = (349.40, 354.02, 68.36, 434.60)


def single_arm_parameters(arm: str) -> tuple[str, ...]:
    """Names of the four parameters of moving ``arm`` (in :data:`PARAMETER_NAMES` order).

    Examples
    --------
    >>> single_arm_parameters("b")
    ('d_a', 'd_b', 'beta_ab', 'b_ab')
    """
    if arm not in ARMS:
        raise InvalidInputError("arm", "'a', 'b' or 'c'", repr(arm))
    stationary, moving, pair = MOVED_PAIR[arm]
    wanted = {f"d_{stationary}", f"d_{moving}", f"beta_{pair}", f"b_{pair}"}
    return tuple(name for name in PARAMETER_NAMES if name in wanted)


def calibrate_single_arm(
    data: NumcalData,
    arm: str,
    *,
    global_search: Literal["differential_evolution", "multistart"] | None = "differential_evolution",
    start: NumcalParameters | None = None,
    bounds: tuple[ArrayLike, ArrayLike] | None = None,
    seed: int = 0,
    starts: int = 20,
    max_evaluations: int | None = None,
    laser_sigma: float | None = None,
    height_sigma: float | None = None,
) -> NumericalCalibration:
    """Fit ``d_i, d_in, beta_in, b_in`` of one arm's pair to the samples where ``arm`` was moved (6.2.1).

    Parameters
    ----------
    data : NumcalData
        Only the samples with ``moved == arm`` are used.
    arm : {"a", "b", "c"}
        The moved arm ``in``; its pair is (previous arm, ``arm``) as in :data:`MOVED_PAIR`.
    global_search, start, bounds, seed, starts, max_evaluations, laser_sigma, height_sigma
        As :func:`~pcmm_geo.machine.calibration.numerical.numcal.calibrate_numerically`; the
        five parameters not fitted stay at ``start`` (default mid-bounds) and do not enter the
        residuals.

    Returns
    -------
    NumericalCalibration
        ``method="single-arm"``, ``names`` the four fitted parameters, covariance 4 x 4.
        ``converged=False`` (with a warning) when the step test fails, when there are fewer
        than four samples, or when the four parameters are not determined (condition number
        above :data:`~pcmm_geo.machine.calibration.numerical.numcal_solver.MAX_CONDITION` -- the
        usual case, see the module docstring).

    Raises
    ------
    InvalidInputError
        Unknown arm, malformed bounds, no sample with ``arm`` moved.

    Warns
    -----
    CalibrationNotConvergedWarning
    """
    names = single_arm_parameters(arm)
    lower, upper = _check_bounds(bounds)
    subset = data.subset((arm,))
    if not subset.moved:
        raise InvalidInputError("data", f"samples with arm {arm} moved", "none")
    free = np.array([PARAMETER_NAMES.index(name) for name in names], dtype=int)
    fixed = 0.5 * (lower + upper) if start is None else start.vector()
    reading_sigma = None if laser_sigma is None and height_sigma is None else (
        float(laser_sigma or 0.0), float(height_sigma or 0.0))
    vector, evaluations, local = _solve(
        subset, free, fixed.copy(), (lower, upper), None if start is None else start.vector(), global_search, seed,
        starts, "moved", max_evaluations, None, reading_sigma,
    )
    residuals, jacobian = residuals_and_jacobian(subset, vector)
    weighted = None
    if reading_sigma is not None:
        whiten = reading_whitener(subset, vector, laser_sigma=reading_sigma[0], height_sigma=reading_sigma[1])
        weighted = (whiten(residuals), whiten(jacobian[:, free]))
    return assess(
        parameters=NumcalParameters.from_vector(vector), names=names, values=vector[free], residuals=residuals,
        jacobian=jacobian[:, free], local=local, height_errors=height_errors(subset, vector), method="single-arm",
        pairs="moved", global_search=global_search, evaluations=evaluations, weighted=weighted,
        reading_sigma=reading_sigma,
    )


def seed_sigma_err(result: NumericalCalibration) -> float:
    """Table 6.2's ``sigma_err``: sample standard deviation of the seed's height errors (mm; NaN if complex).

    Appendix B line 19 (``std(err)``, MATLAB's N-1 normalisation).
    """
    errors = np.asarray(result.height_errors, dtype=float)
    return float(np.std(errors, ddof=1)) if errors.size > 1 and np.all(np.isfinite(errors)) else float("nan")

