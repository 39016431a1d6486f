"""Closure test of the rows of a measurement log (used by :func:`~pcmm_geo.machine.analysis.logproc.process_log`).

Why a row can be tested
-----------------------
On a row that moved one motor, the two held heights and the three lasers are five
readings for one unknown reading (the moved height; the pose follows from the three
pivots through the rigid tetrahedron): two combinations of the lasers are redundant.
On the first row (lasers only, parallel columns: two observable height differences; the
common height is held at the datum, :func:`first_row_pose`) one is.  The solve takes the
held heights as exact and adjusts the lasers; the *closure residual* ``r`` of a row (9
components, mm) is the loop closure evaluated with the *measured* lasers, i.e. the laser
misfit the pose could not absorb.

The test (default)
------------------
``r`` is compared with the scatter it would have if the readings were only noisy.  To
first order ``r = A e`` where ``e`` are the errors of the row's inputs: its three lasers
(independent, standard uncertainty ``laser_sigma``) and the three heights it starts from,
whose covariance is carried from row to row (``C_next = G C_in G^T``; ``A`` and ``G``
are the derivatives of the row's solve, by finite differences of 1 um).  With
``S = A C_in A^T`` the statistic ``t = r^T S^+ r`` follows a chi-square law with
``nu = rank S`` degrees of freedom (2 on a row that moved one motor, 1 on the first
row); :attr:`~pcmm_geo.machine.analysis.logproc.ProcessedLog.closure_sigmas` is
``sqrt(t)``.  A row is inconsistent when ``sqrt(t) >`` :data:`CLOSURE_SIGMAS` (6):
``P(chi2_2 > 36) = exp(-18) = 1.5e-8`` per row (2e-9 for ``nu = 1``), so a clean log
of a million rows is refused with probability 1.5 %, while a 5 mm fault on one laser
is thousands of sigmas.  Measured (``tests/machine/test_logproc_closure.py``): 800 rows
with 1 um Gaussian laser noise give a mean ``t`` of 2.5 and at most 4.4 sigmas; lasers
rounded to the seed sensors' counts give a mean of 1.9-2.1.  Without the held heights'
covariance (a fixed multiple of ``laser_sigma``) the mean was 3.2 and the tail depended
on the path.  A fault along the one combination the moved height absorbs is invisible
to any closure test.

Near the level pose (pivots within a few mm of each other in height) the lasers hardly
see the heights, the first-order model fails, and clean rows are refused with large
``t``: there the processed tips are themselves wrong by millimetres (simulated
acquisitions, which start level, gave tip errors up to 18 mm on such rows), so the
refusal is warranted; keep the pivots tens of millimetres apart.  Most such rows still
pass this test (a level-start simulated session, seed 12: 2 of 600 refused, the rest up to
17.2 mm wrong); their tip uncertainty flags them
(:mod:`~pcmm_geo.machine.analysis.logproc_uncertainty`).

An explicit ``closure_tolerance`` (mm) replaces the statistical test by ``|r| <=
closure_tolerance``: use it when the machine model itself is uncertain (calibration
error, nonlinear lasers), which shows up in the residual like a laser fault.

Default laser uncertainty (:data:`SEED_LASER_SIGMA`)
----------------------------------------------------
The thesis states its lasers' accuracy as 50 um (section 3.1: Micro-Epsilon, 200 mm
range).  Read as the bounds of a rectangular distribution (GUM 4.3.7), that is a
standard uncertainty of ``0.05 / sqrt(3) = 28.9 um``: the default.  It is a type B
value from a statement; pass your sensors' own.  The lasers' count step is the floor:
lasers a and b (ILD1302) report 14-bit counts of ``200 * 1.02 / 16368 = 12.46 um``,
i.e. ``12.46 / sqrt(12) = 3.6 um`` from rounding alone (laser c, an ILD1420: 0.9 um).
With the default, a row is refused from residuals of about 0.2-0.3 mm; a 5 mm laser
fault leaves 0.9-5 mm.

Examples
--------
>>> round(SEED_LASER_SIGMA * 1e3, 1)  # um
28.9
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.errors import InconsistentMeasurementError
from pcmm_geo.machine.kinematics import _pose_solver as solver
from pcmm_geo.machine.kinematics.model_parts import ARMS

__all__ = [
    "CLOSURE_SIGMAS",
    "MIRROR_TOLERANCE",
    "SEED_LASER_ACCURACY",
    "SEED_LASER_SIGMA",
    "closure_sigmas",
    "common_height_weight",
    "first_row_pose",
    "row_closure_error",
    "row_derivatives",
    "solve_moved_row",
    "solve_row",
]

FloatArray = NDArray[np.float64]

#: a row is inconsistent beyond this many standard deviations of its predicted closure scatter (module notes)
CLOSURE_SIGMAS = 6.0
#: accuracy of the seed's lasers as the thesis states it (section 3.1), mm
SEED_LASER_ACCURACY = 0.05
#: default standard uncertainty of a laser reading: the stated accuracy as rectangular bounds (module notes), mm
SEED_LASER_SIGMA = SEED_LASER_ACCURACY / float(np.sqrt(3.0))
#: finite-difference step of the inputs for the row derivatives, mm
STEP = 1e-3
#: two poses whose closure residuals differ by less than this (mm) fit the lasers alike (solve_moved_row)
MIRROR_TOLERANCE = 1e-6
#: height weight of a held pivot relative to a laser's (the motor did not move)
HELD_WEIGHT = 1e3


def common_height_weight(geometry: solver.Geometry, laser_sigma: float) -> FloatArray:
    """Square-root information ``(1, 3, 3)`` of the first row's datum: one row on the common height only.

    The common height is the heights' combination ``n . H`` with ``n_i = 1 / (e_i v_iz)``
    (unit length): the one that lifts all pivots alike, which parallel columns leave
    exactly unobservable.  It is held at the datum like a reading of standard uncertainty
    ``laser_sigma`` (mm); the height differences carry no prior.
    """
    lift = 1.0 / (geometry.encoder_scale * geometry.column_directions[:, 2])
    weight = np.zeros((1, 3, 3))
    weight[0, 0] = lift / np.linalg.norm(lift) / laser_sigma
    return weight


def first_row_pose(
    geometry: solver.Geometry, lasers: FloatArray, datum: FloatArray, laser_sigma: float
) -> solver.PoseState:
    """Pose of a log's first row from its lasers ``(1, 3)`` and the datum's common height (``datum`` ``(3,)``).

    Two stages as in :meth:`~pcmm_geo.machine.kinematics.model.RigidBodyMachine.forward`: a
    weak prior towards ``datum`` reaches the solution, then it is replaced by one row that
    holds the common height (:func:`common_height_weight`) at the datum, so that the lasers
    set the height differences they observe and never the common height.  The log starts
    at a known start position (an exact encoder count), so the datum is the physical
    reference; with slanted columns (Appendix E) the lasers do see the common height, but
    about 2700 times more weakly than a height difference (10 um on laser a moved it by
    27 mm before this row held it; now by < 1 um).  With parallel columns the result is the
    lasers-only solution (the common height is then exactly unobservable).
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
    state = first_row_refine(geometry, state, lasers, heights, laser_sigma)
    return solver.PoseState(state.rotation, state.translation, lasers, state.heights, state.converged, state.iterations)


def first_row_refine(
    geometry: solver.Geometry, start: solver.PoseState, lasers: FloatArray, datum: FloatArray, laser_sigma: float
) -> solver.PoseState:
    """Second stage of :func:`first_row_pose` for ``K`` samples (lasers ``(K, 3)``, datum ``(K, 3)``)."""
    count = len(lasers)
    return solver.solve_pose(
        geometry, start, laser_weight=np.full((count, 3), 1.0 / laser_sigma),
        height_weight=np.repeat(common_height_weight(geometry, laser_sigma), count, axis=0), laser_target=lasers,
        height_target=datum, rcond=solver.UNOBSERVABLE,
    )


def solve_row(
    geometry: solver.Geometry,
    start: solver.PoseState,
    lasers: FloatArray,
    previous: FloatArray,
    solved: NDArray[np.bool_],
    laser_sigma: float,
) -> solver.PoseState:
    """Pose of a later log row: lasers ``(K, 3)`` measured, heights ``(K, 3)`` held at ``previous`` except ``solved``.

    ``start`` gives the pose and the starting heights (their unobservable common part is
    kept).  The returned state carries the measured lasers (for
    :func:`~pcmm_geo.machine.kinematics._pose_solver.closure`).
    """
    count = len(lasers)
    w_lasers = np.full((count, 3), 1.0 / laser_sigma)
    w_heights = np.broadcast_to(np.where(solved, 0.0, HELD_WEIGHT / laser_sigma), (count, 3)).copy()
    state = solver.solve_pose(
        geometry, start, laser_weight=w_lasers, height_weight=w_heights, laser_target=lasers,
        height_target=previous, rcond=solver.UNOBSERVABLE,
    )
    return solver.PoseState(state.rotation, state.translation, lasers, state.heights, state.converged, state.iterations)


def solve_moved_row(
    geometry: solver.Geometry,
    start: solver.PoseState,
    lasers: FloatArray,
    previous: FloatArray,
    solved: NDArray[np.bool_],
    arm: int,
    direction: int,
    laser_sigma: float,
) -> solver.PoseState:
    """:func:`solve_row` for one row that moved pivot ``arm`` (0-based) in ``direction`` (+1, -1, 0: unknown).

    The lasers see a pivot's height only through the pivot distances, which depend on the
    *squares* of the height differences: with parallel columns a moved height ``h`` and its
    mirror about the level of the two held pivots give the same lasers.  Far from that
    level the mirror is far away and the solve from the previous pose finds the right one;
    from (or near) the level pose the start sits between the two and the solve may take
    the mirror, or stay on the stationary point.  When the solve from the previous height
    did not move along the recorded ``direction`` by more than 1 um, or did not converge,
    it is repeated from a start on the recorded side (pivot at ``previous + direction *
    max(|change|, 1 mm)``, pose fitted to it by
    :func:`~pcmm_geo.machine.kinematics._pose_solver.kabsch`).  That result is kept if it
    converged, agrees with the direction and fits the lasers no worse (closure residual
    within :data:`MIRROR_TOLERANCE` of the first's): the direction decides between poses the
    lasers cannot tell apart, never against the lasers.  With ``direction = 0`` nothing
    tells the two apart: see ``docs/machine.md`` (start a log tens of mm away from level).
    """
    state = solve_row(geometry, start, lasers, previous, solved, laser_sigma)
    change = float(state.heights[0, arm] - previous[0, arm])
    if direction == 0 or (state.converged[0] and abs(change) > 1e-3 and np.sign(change) == direction):
        return state
    heights = start.heights.copy()
    heights[0, arm] = previous[0, arm] + direction * max(abs(change), 1.0)
    # the branch follows the starting pose: fit the tetrahedron to the pivots on the recorded side
    rotation, translation = solver.kabsch(
        solver.joints_in_tetrahedron(geometry, lasers), solver.pivots_in_machine(geometry, heights)
    )
    retry = solve_row(geometry, solver.PoseState(rotation, translation, lasers.copy(), heights, start.converged, 0),
                      lasers, previous, solved, laser_sigma)
    retry_change = float(retry.heights[0, arm] - previous[0, arm])
    if not (retry.converged[0] and np.sign(retry_change) == direction):
        return state
    misfit, retry_misfit = (float(np.linalg.norm(solver.closure(geometry, pose))) for pose in (state, retry))
    return retry if not state.converged[0] or retry_misfit <= misfit + MIRROR_TOLERANCE else state


def row_derivatives(
    geometry: solver.Geometry,
    state: solver.PoseState,
    previous: FloatArray | None,
    solved: NDArray[np.bool_],
    laser_sigma: float,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Derivatives of a row's closure residual ``(9, n)``, solved heights ``(3, n)`` and tip ``(3, n)`` by its inputs.

    Inputs: the three lasers, and (later rows, ``previous`` ``(3,)`` given) the three heights the
    row starts from (``n = 6``); the first row's datum is a convention, not an input (``n = 3``).
    Forward differences of :data:`STEP` from the converged ``state`` (batched in one solve).
    """
    n_inputs = 3 if previous is None else 6
    steps = STEP * np.eye(n_inputs)
    lasers = state.lasers[0] + steps[:, :3]
    base_heights = state.heights[0] if previous is None else previous
    targets = base_heights + (steps[:, 3:] if previous is not None else 0.0)
    start_heights = state.heights[0] + (steps[:, 3:] if previous is not None else 0.0)
    start = solver.PoseState(
        np.repeat(state.rotation, n_inputs, axis=0), np.repeat(state.translation, n_inputs, axis=0),
        lasers.copy(), np.broadcast_to(start_heights, (n_inputs, 3)).copy(), np.zeros(n_inputs, bool), 0,
    )
    targets = np.broadcast_to(targets, (n_inputs, 3)).copy()
    if previous is None:  # the first row: the datum holds the common height (first_row_pose)
        moved = first_row_refine(geometry, start, lasers, targets, laser_sigma)
        moved = solver.PoseState(moved.rotation, moved.translation, lasers, moved.heights, moved.converged, 0)
    else:
        moved = solve_row(geometry, start, lasers, targets, solved, laser_sigma)
    residual = solver.closure(geometry, moved) - solver.closure(geometry, state)
    tip = moved.rotation @ geometry.tip_center + moved.translation - (state.rotation[0] @ geometry.tip_center
                                                                      + state.translation[0])
    return residual.T / STEP, (moved.heights - state.heights).T / STEP, tip.T / STEP


def closure_sigmas(residual: FloatArray, covariance: FloatArray) -> tuple[float, float]:
    """``(sqrt(r^T S^+ r), scale)`` of a residual ``(9,)`` with predicted covariance ``S`` ``(9, 9)``.

    ``scale`` (mm) is the predicted standard deviation along ``r`` (the largest one when
    ``r`` lies within one standard deviation, where its direction means nothing).
    Components of ``r`` outside the range of ``S`` are measured with the smallest predicted
    standard deviation (they cannot come from the noise at all).

    Examples
    --------
    >>> cov = np.diag([4e-6, 1e-6] + [0.0] * 7)
    >>> sigmas, scale = closure_sigmas(np.r_[0.006, 0.0, [0.0] * 7], cov)
    >>> round(sigmas, 6), round(scale, 6)
    (3.0, 0.002)
    """
    values, vectors = np.linalg.eigh(covariance)
    keep = values > 1e-10 * max(float(values.max()), 0.0)
    if not keep.any():
        return (0.0 if not np.any(residual) else float("inf")), 0.0
    inside = vectors[:, keep].T @ residual
    outside = residual - vectors[:, keep] @ inside
    statistic = float(np.sum(inside**2 / values[keep]) + np.sum(outside**2) / values[keep].min())
    size = float(np.linalg.norm(residual))
    # along r when r stands out of the noise; below that its direction is rounding, use the widest spread
    scale = size / np.sqrt(statistic) if statistic > 1.0 else np.sqrt(values.max())
    return float(np.sqrt(statistic)), float(scale)


def row_closure_error(
    row: int,
    kind: str,
    residual: FloatArray,
    tolerance: float,
    solved: NDArray[np.bool_],
    sigmas: float | None = None,
) -> InconsistentMeasurementError:
    """The error for log row ``row`` (0-based) whose closure residual ``(9,)`` exceeds ``tolerance`` (mm).

    ``kind`` is "first", "start" or "stop"; ``solved`` ``(3,)`` marks the pivots the row solved;
    ``sigmas`` the residual in standard deviations of its predicted scatter (statistical test).
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
    scatter = "" if sigmas is None else f"{sigmas:.3g} standard deviations of its predicted scatter (limit " \
        f"{CLOSURE_SIGMAS:g}); "
    detail = (
        f"{kind} row, pivots solved: {pivots}; {scatter}largest misfit {per_arm[worst]:.3g} mm at arm "
        f"{ARMS[worst]}: a laser reading is wrong, the machine model does not fit this pose, or the pivots are "
        "near level where the lasers hardly see the heights"
    )
    size = float(np.linalg.norm(residual))
    return InconsistentMeasurementError(f"closure of log row {row + 1}", round(size, 6), float(f"{tolerance:.6g}"),
                                        "mm", detail)
