"""What the tip uncertainty of a processed log is, and the limit above which a point is marked.

Definition for a 3-D point
--------------------------
Each row's tip comes with its first-order covariance ``C`` (3 x 3, mm^2,
:attr:`~pcmm_geo.machine.analysis.logproc.ProcessedLog.tip_covariance`): the laser readings
propagated through the network adjustment (``sum_i sigma_i^2 s_i s_i^T`` over all readings,
:mod:`~pcmm_geo.machine.analysis.logproc.reliability`), plus, when the calibration file holds
one, the calibration's covariance propagated the same way.  The standard uncertainty of the
point is one number, ``u = tip_uncertainty = sqrt(trace C) = sqrt(u_x^2 + u_y^2 + u_z^2)``: the
root-mean-square length of its error vector.  ``U = 2 u`` used as the radius of a ball about the
point covers the true point with probability at least 95.4 % for every Gaussian ``C`` (95.4 %
when the error lies along one line, 98.2 % for a flat isotropic one, 99.3 % for a round one),
so "within U (k = 2)" is a statement at (at least) 95 %.  ``tip_u`` gives ``u_x, u_y, u_z``.

``u`` is relative to the datum (the start heights of row 1, held exactly); the lasers never see
a height common to all pivots, so its ``z`` part grows along a log as every new height inherits
the errors of the ones it was measured against.  The calibration's part is systematic: the
same parameter error moves all points of a log together.  A row standing on a height the
lasers do not determine (:attr:`~pcmm_geo.machine.analysis.logproc.adjustment.Adjustment.undetermined`)
has ``u = inf``.

Near the level pose
-------------------
With the pivots at nearly equal heights the distances between them change only with the
square of their height differences, so the lasers hardly see the heights and ``u`` is large:
a 12.5 um reading step leaves a height 2 mm from level uncertain by about 1 mm.  There the
first-order value is a poor description (the true error is a square root of the laser error),
but it errs on the large side as long as the branch is right; the branch is what
:mod:`~pcmm_geo.machine.analysis.logproc.ambiguity` checks.

The limit
---------
:data:`DEFAULT_MAX_TIP_UNCERTAINTY` = 1 mm.  A micro-CMM point whose standard uncertainty is a
millimetre or more is not a measurement at the machine's purpose; the value separates the
well-conditioned poses (0.1-0.6 mm with the thesis' lasers, pivots 15 mm or more apart in
height) from the near-level ones.  Pass your own limit for your sensors and task.  A row above
it is *marked* (``uncertain``), not dropped: the point is consistent with its readings, only
poorly determined, and it comes with its uncertainty; :func:`flag_uncertain_tips` warns
(:class:`~pcmm_geo.errors.IllConditionedWarning`) with the count.

Examples
--------
>>> import warnings
>>> cov = np.stack([np.diag([1e-4, 1e-4, 2e-4]), np.diag([1.0, 1.0, 2.0])])
>>> with warnings.catch_warnings(record=True) as caught:
...     warnings.simplefilter("always")
...     u, marked = flag_uncertain_tips(cov, 1.0)
>>> np.round(u, 3).tolist(), marked.tolist(), len(caught)
([0.02, 2.0], [False, True], 1)
"""

from __future__ import annotations

import warnings

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.errors import IllConditionedWarning, InvalidInputError

__all__ = ["DEFAULT_MAX_TIP_UNCERTAINTY", "flag_uncertain_tips"]

FloatArray = NDArray[np.float64]

#: default largest tip uncertainty of a row (mm), see the module notes
DEFAULT_MAX_TIP_UNCERTAINTY = 1.0


def flag_uncertain_tips(
    tip_covariance: FloatArray,
    max_tip_uncertainty: float = DEFAULT_MAX_TIP_UNCERTAINTY,
    tested: NDArray[np.bool_] | None = None,
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """``(tip_uncertainty (N,), uncertain (N,))`` of tip covariances ``(N, 3, 3)`` (mm^2) and a limit (mm).

    ``tip_uncertainty = sqrt(trace)``; a row is uncertain when it exceeds
    ``max_tip_uncertainty`` or is not finite.  Rows where ``tested`` ``(N,)`` is False (e.g. rows
    already refused by the closure test) are never marked.  When any row is marked, one
    :class:`~pcmm_geo.errors.IllConditionedWarning` says how many and how large.

    Raises
    ------
    InvalidInputError
        ``tip_covariance`` not of shape (N, 3, 3), or a limit that is not positive.
    """
    covariance = np.asarray(tip_covariance, dtype=float)
    if covariance.ndim != 3 or covariance.shape[1:] != (3, 3):
        raise InvalidInputError("tip_covariance", "an array of shape (N, 3, 3)", str(covariance.shape))
    if not max_tip_uncertainty > 0:
        raise InvalidInputError("max_tip_uncertainty", "a positive number of mm (inf: no limit)",
                                str(max_tip_uncertainty))
    trace = np.trace(covariance, axis1=1, axis2=2)
    uncertainty = np.sqrt(np.clip(trace, 0.0, None))
    uncertain = ~(uncertainty <= max_tip_uncertainty)  # NaN counts as uncertain
    if tested is not None:
        uncertain &= np.asarray(tested, dtype=bool)
    if uncertain.any():
        worst = float(np.nanmax(np.where(uncertain, uncertainty, np.nan))) if np.isfinite(
            uncertainty[uncertain]).any() else float("nan")
        warnings.warn(
            f"{int(uncertain.sum())} of {len(uncertain)} log rows have a tip uncertainty above "
            f"{max_tip_uncertainty:g} mm (largest {worst:.3g} mm): the lasers hardly see the pivot heights "
            "there (pivots near level); those points are not measurements at that limit",
            IllConditionedWarning, stacklevel=3,
        )
    return uncertainty, uncertain
