"""Uncertainty of the probe tips of a processed log (:func:`~pcmm_geo.machine.analysis.logproc.process_log`).

What is propagated
------------------
Each row's tip is a function of the row's inputs: its three lasers (independent,
standard uncertainty ``laser_sigma``) and, after row 1, the three heights it starts from,
whose covariance ``C`` the closure test already carries from row to row
(:mod:`~pcmm_geo.machine.analysis.logproc_closure`: ``C_next = G C_in G^T``).  The same
batched finite-difference solve that gives ``G`` gives the tip's Jacobian ``T`` (3 x 6,
3 x 3 on row 1), and the tip covariance is the first-order (GUM 5.1.2) law

``U_tip = T C_in T^T``,  ``C_in = diag(laser_sigma^2 I_3, C)``.

``tip_uncertainty = sqrt(trace U_tip)`` is the root-mean-square length of the tip error
(``sqrt(u_x^2 + u_y^2 + u_z^2)``).  It is relative to the datum of row 1 (the lasers
cannot see a common height of all pivots, so the datum's own error shifts every point
alike and is not included).  Errors of the machine model (calibration) are not included:
this is the part the lasers contribute, a lower bound of the points' uncertainty.

Why it matters: near the level pose
-----------------------------------
With the pivots at nearly equal heights the distances between them change only with the
square of their height differences, so the lasers hardly see the heights and ``T`` is
large: a row there can be millimetres wrong and still close (the closure residual is as
blind as the solve).  With the default ``laser_sigma`` (28.9 um, the thesis' 50 um laser
accuracy) and the DPKM machine, short logs give (mm): pivots (0, +60, -50) mm from level
0.11-0.14; (0, +20, -15) 0.31-0.44; (0, +5, -4) 1.2-1.9; (0, +1, -1) 3.8-5.3; the tip
moves about ten times as much as the lasers, which is this mechanism's gain.  The first-order value is
validated against a seeded Monte Carlo over synthesised logs in
``tests/machine/test_logproc_uncertainty.py``.  Very close to level (where the Jacobian
itself changes within one laser sigma) the first-order value becomes optimistic; such rows
are far above any useful limit anyway.

The limit
---------
:data:`DEFAULT_MAX_TIP_UNCERTAINTY` = 1 mm.  A micro-CMM point whose standard
uncertainty is a millimetre or more is not a measurement at the machine's purpose; the
value separates the well-conditioned poses above (0.1-0.6 mm with the thesis' lasers,
pivots 15 mm or more apart in height) from the near-level ones (1 mm and more within
about 5 mm of level).  Pass your own limit for your sensors and task.  A row above it
is *marked* (``uncertain``), not dropped: the point is consistent with its readings,
only poorly determined, and it comes with its uncertainty.  But a point whose
uncertainty is millimetres must not pass for a measurement, so
:func:`flag_uncertain_tips` warns (:class:`~pcmm_geo.errors.IllConditionedWarning`) with
the count, and ``pcmm process-log`` lists ``u`` and "u ok" for every point.

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
