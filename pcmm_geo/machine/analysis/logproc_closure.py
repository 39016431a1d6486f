"""Closure test of the rows of a measurement log (used by :func:`~pcmm_geo.machine.analysis.logproc.process_log`).

Why a row can be tested
-----------------------
On a row that moved one motor, the two held heights and the three lasers are five
readings for one unknown reading (the moved height; the pose follows from the three
pivots through the rigid tetrahedron): two combinations of the lasers are redundant.
On the first row (lasers only, parallel columns: two observable height differences)
one is.  The solve takes the held heights as exact and adjusts the lasers; the
*closure residual* ``r`` of a row is the Euclidean norm (mm) of its nine loop-closure
components evaluated with the *measured* lasers, i.e. the laser misfit the pose could
not absorb.

Default tolerance (:data:`CLOSURE_SIGMAS` laser uncertainties)
-------------------------------------------------------------
If the lasers only scatter (independent, Gaussian, standard uncertainty ``sigma``) and
the held heights were exact, ``(r / sigma)^2`` would follow a chi-square law with two
degrees of freedom.  The held heights carry the errors of the rows that solved them:
simulated 800-row logs with Gaussian laser noise give a mean ``(r / sigma)^2`` of
3.1-3.2 instead of 2 (about a chi-square-2 law scaled by 1.6) and a largest ``r`` of
4.5 ``sigma``.  For that law ``P(r > k sigma) = exp(-k^2 / 3.2)``: ``k = 8`` gives
2e-9 per row, so a clean log of a million rows is refused with probability 0.2 %,
while any fault that leaves more than ``8 sigma`` in the redundant combinations is
caught (a 5 mm fault on one laser leaves 1.5-5 mm in the logs of the tests).  A fault
along the one combination the moved height absorbs is invisible to any closure test.
A machine model that does not fit the machine (calibration error, nonlinear lasers)
shows up the same way: give a tolerance that covers the model's uncertainty rather
than switching the test off.

Examples
--------
>>> round(CLOSURE_SIGMAS * 1e-3, 6)  # default tolerance for 1 um lasers, mm
0.008
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.errors import InconsistentMeasurementError
from pcmm_geo.machine.kinematics import _pose_solver as solver
from pcmm_geo.machine.kinematics.model_parts import ARMS

__all__ = ["CLOSURE_SIGMAS", "first_row_pose", "row_closure_error"]

FloatArray = NDArray[np.float64]

#: default closure tolerance in units of the laser uncertainty (derivation in the module notes)
CLOSURE_SIGMAS = 8.0


def first_row_pose(
    geometry: solver.Geometry, lasers: FloatArray, datum: FloatArray, laser_sigma: float
) -> solver.PoseState:
    """Pose of a log's first row from its lasers ``(1, 3)`` alone; heights start at ``datum`` ``(3,)``.

    Two stages as in :meth:`~pcmm_geo.machine.kinematics.model.RigidBodyMachine.forward`: a
    weak prior towards ``datum`` reaches the solution, then it is dropped so that the lasers
    are met wherever they can be and the unobservable common height stays at the datum.
    Solved here (not through ``forward``) so that this row's closure goes through the
    same test as every other row.  The returned state carries the *measured* lasers, so
    that :func:`~pcmm_geo.machine.kinematics._pose_solver.closure` gives the row's residuals.
    """
    heights = np.asarray(datum, dtype=float)[None].copy()
    rotation, translation = solver.kabsch(
        solver.joints_in_tetrahedron(geometry, lasers), solver.pivots_in_machine(geometry, heights)
    )
    start = solver.PoseState(rotation, translation, lasers.copy(), heights.copy(), np.zeros(1, bool), 0)
    w_lasers = np.full((1, 3), 1.0 / laser_sigma)
    prior = np.full((1, 3), 1.0 / (solver.PRIOR_RATIO * laser_sigma))
    state = solver.solve_pose(
        geometry, start, laser_weight=w_lasers, height_weight=prior, laser_target=lasers, height_target=heights
    )
    state = solver.solve_pose(
        geometry, state, laser_weight=w_lasers, height_weight=np.zeros((1, 3)), laser_target=lasers,
        height_target=heights, rcond=solver.UNOBSERVABLE,
    )
    return solver.PoseState(state.rotation, state.translation, lasers, state.heights, state.converged, state.iterations)


def row_closure_error(
    row: int, kind: str, residual: FloatArray, tolerance: float, solved: NDArray[np.bool_]
) -> InconsistentMeasurementError:
    """The error for log row ``row`` (0-based) whose closure residual ``(9,)`` exceeds ``tolerance`` (mm).

    ``kind`` is "first", "start" or "stop"; ``solved`` ``(3,)`` marks the pivots the row solved.
    The message names the row 1-based (the n-th data row of the log).

    Examples
    --------
    >>> error = row_closure_error(4, "stop", np.r_[0.0, 0.0, 0.0, 3.0, 0.0, 4.0, 0.0, 0.0, 0.0], 0.008,
    ...                           np.array([False, True, False]))
    >>> error.what, error.residual, error.tolerance
    ('closure of log row 5', 5.0, 0.008)
    """
    per_arm = np.linalg.norm(np.asarray(residual, dtype=float).reshape(3, 3), axis=1)
    worst = int(np.argmax(per_arm))
    pivots = ", ".join(ARMS[k] for k in np.flatnonzero(solved))
    detail = (
        f"{kind} row, pivots solved: {pivots}; largest misfit {per_arm[worst]:.3g} mm at arm {ARMS[worst]}: "
        "a laser reading is wrong or the machine model does not fit this pose"
    )
    size = float(np.linalg.norm(residual))
    return InconsistentMeasurementError(f"closure of log row {row + 1}", round(size, 6), round(float(tolerance), 6),
                                        "mm", detail)
