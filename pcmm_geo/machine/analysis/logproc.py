"""Processing of the seed's measurement log (thesis 3.6, Table 3.2; 5.2; Appendix D).

The log rows (``start_stop,probe,motor,direction,laser_a,laser_b,laser_c``), their array
type :class:`MeasurementLog` and the CSV reader/writer live in
:mod:`pcmm_geo.machine.analysis.logproc_rows` and are re-exported here.

How the seed used the rows (Appendix D, lines 98-257)
-----------------------------------------------------
* Row 1 sets the datum ``z_a = 0`` and derives the other heights from laser pairs.
* On a *stop* row only the motor moved can have changed height: the other two pivots
  keep their previous heights and the moved pivot's height is re-derived from the
  laser pair with its neighbour (eqs 2.3-2.8: a from c, b from a, c from b).
* On a *start* row whose lasers differ from the previous row (the machine had not
  settled, thesis 3.5) the motor of the *previous* row is treated as still moving; if
  the lasers are identical the heights are copied.
* ``direction`` chose the sign of ``dz`` (moved pivot above or below its neighbour);
  with ``direction = 0`` the sign that keeps the height nearest its previous value was
  used.  Note that the joystick direction says whether the pivot moved *up or down*,
  not whether it ends *above or below* its neighbour: the seed's use of it as the sign
  of ``dz`` is only right when the pivot stays on one side of its neighbour.
* Probe points are the rows with ``probe = 1``.

This module keeps the seed's row logic (which heights are held, which arm moved)
but replaces the per-pair height formula by the rigid-body model: for each row the
pose is solved from the three lasers with the two held heights fixed, starting from
the previous heights, so the branch (above/below) follows continuity; the direction
flag is only *checked* (``direction_consistent``).

Examples
--------
>>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
>>> machine = RigidBodyMachine.from_dpkm()
>>> start = machine.reference_heights + [0.0, 60.0, -50.0]  # not level: see process_log
>>> log = synthesise_log(machine, start, [(1, 5.0, True), (2, -4.0, True)])
>>> processed = process_log(machine, log, initial_heights=start)
>>> processed.probe_points.shape
(2, 3)
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import ConvergenceError, InvalidInputError
from pcmm_geo.machine.analysis.logproc_closure import (
    CLOSURE_SIGMAS,
    SEED_LASER_SIGMA,
    closure_sigmas,
    first_row_pose,
    row_closure_error,
    row_derivatives,
    solve_moved_row,
)
from pcmm_geo.machine.analysis.logproc_rows import LOG_COLUMNS, MeasurementLog, read_log, write_log
from pcmm_geo.machine.analysis.logproc_synthesis import synthesise_log
from pcmm_geo.machine.analysis.logproc_uncertainty import DEFAULT_MAX_TIP_UNCERTAINTY, flag_uncertain_tips
from pcmm_geo.machine.analysis.parameter_laws import DpkmParameterLaws
from pcmm_geo.machine.kinematics import _pose_solver as solver
from pcmm_geo.machine.kinematics.model import ARMS, RigidBodyMachine, as_readings

__all__ = [
    "CLOSURE_SIGMAS",
    "DEFAULT_MAX_TIP_UNCERTAINTY",
    "SEED_LASER_SIGMA",
    "LOG_COLUMNS",
    "MeasurementLog",
    "ProcessedLog",
    "process_log",
    "process_log_dpkm",
    "read_log",
    "synthesise_log",
    "write_log",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@dataclass(frozen=True)
class ProcessedLog:
    """Result of :func:`process_log`.

    Attributes
    ----------
    heights : ndarray, shape (N, 3)
        Pivot height readings per row (mm; absolute only up to the datum of row 1).
    tips : ndarray, shape (N, 3)
        Probe-tip centre per row (machine frame, mm).
    probe_rows : ndarray of int, shape (M,)
        Indices (0-based) of the rows with ``probe = 1`` that passed the closure test.
    probe_points : ndarray, shape (M, 3)
        ``tips[probe_rows]``.
    moved_arm : ndarray of int, shape (N,)
        Arm index (0, 1, 2) whose height was solved on each row; -1 = all (row 1) or copied.
    residuals : ndarray, shape (N, 9)
        Loop-closure residuals with the measured lasers and held heights (mm).
    direction_consistent : ndarray of bool, shape (N,)
        False where the solved height change of the moved arm contradicts ``direction``
        by more than 1 um.
    converged : ndarray of bool, shape (N,)
    closure_residual : ndarray, shape (N,)
        Euclidean norm of each row's 9 closure residuals (mm): the laser misfit the pose
        could not absorb.
    closure_sigmas : ndarray, shape (N,)
        The residual in standard deviations of its predicted scatter (from ``laser_sigma``
        and the carried uncertainty of the held heights; NaN where not computed).
    closure_tolerance : ndarray, shape (N,)
        Residual size (mm) at which each row is refused: the explicit ``closure_tolerance``,
        or, by default, :data:`CLOSURE_SIGMAS` predicted standard deviations along the row's
        residual (infinite: not tested).
    inconsistent : ndarray of bool, shape (N,)
        Rows whose closure failed the test or whose pose solve did not converge; they give
        no probe point.
    rejected_probe_rows : ndarray of int, shape (K,)
        Indices of rows with ``probe = 1`` left out of ``probe_points`` because inconsistent.
    tip_covariance : ndarray, shape (N, 3, 3)
        First-order (GUM) covariance of each row's tip (mm^2) from ``laser_sigma`` and the
        carried uncertainty of the held heights, relative to the datum of row 1
        (:mod:`~pcmm_geo.machine.analysis.logproc_uncertainty`; NaN where not computed).
    tip_uncertainty : ndarray, shape (N,)
        ``sqrt(trace(tip_covariance))`` (mm): the root-mean-square length of the tip's error.
    uncertain : ndarray of bool, shape (N,)
        Rows whose ``tip_uncertainty`` exceeds ``max_tip_uncertainty`` (or is not finite):
        their points are kept but are not measurements at the stated limit.
    max_tip_uncertainty : float
        The limit used for ``uncertain`` (mm).
    """

    heights: FloatArray
    tips: FloatArray
    probe_rows: IntArray
    probe_points: FloatArray
    moved_arm: IntArray
    residuals: FloatArray
    direction_consistent: NDArray[np.bool_]
    converged: NDArray[np.bool_]
    closure_residual: FloatArray
    closure_sigmas: FloatArray
    closure_tolerance: FloatArray
    inconsistent: NDArray[np.bool_]
    rejected_probe_rows: IntArray
    tip_covariance: FloatArray
    tip_uncertainty: FloatArray
    uncertain: NDArray[np.bool_]
    max_tip_uncertainty: float

    @property
    def tip_u(self) -> FloatArray:
        """Per-axis standard uncertainty of each row's tip, shape (N, 3), mm."""
        return np.sqrt(np.diagonal(self.tip_covariance, axis1=1, axis2=2))


def process_log(
    machine: RigidBodyMachine,
    log: MeasurementLog,
    *,
    initial_heights: ArrayLike | None = None,
    laser_sigma: float = SEED_LASER_SIGMA,
    closure_tolerance: float | None = None,
    on_inconsistent: str = "raise",
    max_tip_uncertainty: float = DEFAULT_MAX_TIP_UNCERTAINTY,
    progress: Callable[[int, int], None] | None = None,
) -> ProcessedLog:
    """Pivot heights and probe points from a Table 3.2 log (see the module notes).

    Every row is tested for closure: the three lasers over-determine the pose, and a row
    whose closure residual is too large for its readings' uncertainty is not turned into
    a point (see *Closure test* below).

    Parameters
    ----------
    machine : RigidBodyMachine
    log : MeasurementLog
    initial_heights : array_like, shape (3,), optional
        Heights of the first row used as datum and starting branch (default: the
        machine's reference heights).  With parallel columns the lasers cannot see a
        common height offset, so this datum carries through the whole log.
    laser_sigma : float
        Standard uncertainty of a laser reading (mm); default :data:`SEED_LASER_SIGMA`
        (28.9 um: the thesis' 50 um laser accuracy as rectangular bounds).  Sets the
        closure test's scale; the points do not depend on it.
    closure_tolerance : float, optional
        Largest accepted closure residual of a row (mm, :attr:`ProcessedLog.closure_residual`)
        instead of the default statistical test (residual within :data:`CLOSURE_SIGMAS`
        standard deviations of its predicted scatter).
    on_inconsistent : {"raise", "flag"}
        ``"raise"`` (default): the first row beyond the tolerance raises
        :class:`~pcmm_geo.errors.InconsistentMeasurementError`.  ``"flag"``: such rows are
        kept, marked in :attr:`ProcessedLog.inconsistent` and left out of the probe points.
    max_tip_uncertainty : float
        Rows whose tip uncertainty (:attr:`ProcessedLog.tip_uncertainty`, mm) exceeds this are
        marked :attr:`ProcessedLog.uncertain` (default :data:`DEFAULT_MAX_TIP_UNCERTAINTY`;
        ``inf`` marks none); a :class:`~pcmm_geo.errors.IllConditionedWarning` counts them.
    progress : callable, optional
        ``progress(rows_done, rows_total)``, called every 100 rows and at the end.

    Returns
    -------
    ProcessedLog

    Notes
    -----
    With level pivots the lasers do not see the pivot heights to first order (the pivot
    distances change only with the square of a height difference), see
    :mod:`pcmm_geo.machine.analysis.sensitivity`.  A log that starts in or passes through the
    level pose is poorly determined there (mirror poses: the motor ``direction`` picks
    one, ``solve_moved_row``); keep the pivots a few tens of millimetres apart in height.

    *Closure test.*  The three lasers over-determine each row (two redundant combinations
    on a row that moved one motor, one on the first row); the closure residual is the laser
    misfit the pose cannot absorb.  By default it is compared with its predicted scatter
    (laser noise plus the carried uncertainty of the held heights) and refused beyond
    :data:`CLOSURE_SIGMAS` = 6 standard deviations (a clean row: probability 1.5e-8; a 5 mm
    fault on one laser leaves 0.9-5 mm); derivation in
    :mod:`pcmm_geo.machine.analysis.logproc_closure`.  A machine model that does not fit the
    machine shows up the same way: give ``closure_tolerance`` in mm for it.

    *What an inconsistent row does to the rows after it* (``on_inconsistent="flag"``):
    the heights that row solved are not trusted.  Held heights come from the last
    consistent row, and every untrusted height is solved again, from the lasers, on the
    next row that re-solves any pivot (that row then has one redundant combination
    instead of two); once a row closes, all heights are trusted again.  A start row that
    repeats the lasers of an inconsistent stop row is itself marked.  An inconsistent
    *first* row loses the datum: the later rows are then right up to one common vertical
    offset of all points (the lasers cannot see a common height), distances are unaffected.

    Raises
    ------
    InvalidInputError
        Bad ``initial_heights``, ``laser_sigma``, ``closure_tolerance`` or ``on_inconsistent``.
    InconsistentMeasurementError
        ``on_inconsistent="raise"`` and a row's closure residual exceeds the tolerance;
        ``what`` names the row (1-based data row), ``residual`` and ``tolerance`` are in mm.
    ConvergenceError
        ``on_inconsistent="raise"`` and a row's pose solve did not converge (``element``
        names the row); with ``"flag"`` such a row is marked inconsistent.

    Examples
    --------
    >>> m = RigidBodyMachine.from_dpkm()
    >>> start = m.reference_heights + [0.0, 60.0, -50.0]
    >>> log = synthesise_log(m, start, [(2, 10.0, True)])
    >>> out = process_log(m, log, initial_heights=start)
    >>> bool(abs(out.heights[-1, 1] - start[1] - 10.0) < 1e-6)
    True
    >>> lasers = log.lasers.copy()
    >>> lasers[1, 0] += 5.0  # laser a of the stop row 5 mm off
    >>> faulty = MeasurementLog(log.start_stop, log.probe, log.motor, log.direction, lasers)
    >>> flagged = process_log(m, faulty, initial_heights=start, on_inconsistent="flag")
    >>> flagged.inconsistent.tolist(), flagged.probe_points.shape
    ([False, True], (0, 3))
    """
    if not (np.isfinite(laser_sigma) and laser_sigma > 0):
        raise InvalidInputError("laser_sigma", "a positive finite number", str(laser_sigma))
    if closure_tolerance is not None and not (np.isfinite(closure_tolerance) and closure_tolerance > 0):
        raise InvalidInputError("closure_tolerance", "a positive finite number of mm", str(closure_tolerance))
    if on_inconsistent not in ("raise", "flag"):
        raise InvalidInputError("on_inconsistent", "'raise' or 'flag'", repr(on_inconsistent))
    if not max_tip_uncertainty > 0:  # NaN too; inf allowed
        raise InvalidInputError("max_tip_uncertainty", "a positive number of mm (inf: no limit)",
                                str(max_tip_uncertainty))
    datum = machine.reference_heights if initial_heights is None else as_readings(initial_heights, "initial_heights")
    count = len(log)
    geometry = machine.geometry
    heights = np.empty((count, 3))
    tips = np.empty((count, 3))
    residuals = np.zeros((count, 9))
    moved = np.full(count, -1, dtype=np.int64)
    consistent = np.ones(count, dtype=bool)
    converged = np.ones(count, dtype=bool)
    inconsistent = np.zeros(count, dtype=bool)
    sigmas = np.zeros(count)
    tolerances = np.full(count, np.nan if closure_tolerance is None else float(closure_tolerance))
    trusted = np.ones(3, dtype=bool)  # heights of the last consistent state that may be held
    good: solver.PoseState | None = None  # last consistent state (start of the next solve)
    good_covariance = np.zeros((3, 3))  # covariance of its heights (mm^2)
    tip_covariance = np.full((count, 3, 3), np.nan)
    laser_variance = laser_sigma**2 * np.eye(3)
    for row in range(count):
        if progress is not None and row % 100 == 0:
            progress(row, count)
        lasers = log.lasers[row : row + 1]
        if row == 0:
            state = first_row_pose(geometry, lasers, datum, laser_sigma)
            solved = np.ones(3, dtype=bool)
            previous = None
            input_covariance = laser_variance
        else:
            if log.start_stop[row] == 1 and np.array_equal(log.lasers[row], log.lasers[row - 1]):
                heights[row], tips[row] = heights[row - 1], tips[row - 1]
                residuals[row], inconsistent[row] = residuals[row - 1], inconsistent[row - 1]
                sigmas[row], tolerances[row] = sigmas[row - 1], tolerances[row - 1]
                tip_covariance[row] = tip_covariance[row - 1]
                continue
            arm = int(log.motor[row] if log.start_stop[row] == 0 else log.motor[row - 1]) - 1
            direction = int(log.direction[row] if log.start_stop[row] == 0 else log.direction[row - 1])
            moved[row] = arm
            assert good is not None
            previous = good.heights[0]
            solved = ~trusted
            solved[arm] = True  # held pivots: their motors did not move
            start = solver.PoseState(
                good.rotation, good.translation, lasers.copy(), previous[None].copy(), good.converged, 0
            )
            state = solve_moved_row(geometry, start, lasers, previous[None], solved, arm, direction, laser_sigma)
            change = state.heights[0, arm] - previous[arm]
            consistent[row] = direction == 0 or abs(change) <= 1e-3 or np.sign(change) == direction
            input_covariance = np.block([[laser_variance, np.zeros((3, 3))], [np.zeros((3, 3)), good_covariance]])
        residuals[row] = solver.closure(geometry, state)[0]
        heights[row] = state.heights[0]
        tips[row] = state.rotation[0] @ geometry.tip_center + state.translation[0]
        converged[row] = bool(state.converged[0])
        closure_size = float(np.linalg.norm(residuals[row]))
        d_residual, d_heights, d_tip = row_derivatives(geometry, state, previous, solved, laser_sigma)
        tip_covariance[row] = d_tip @ input_covariance @ d_tip.T
        sigmas[row], scale = closure_sigmas(residuals[row], d_residual @ input_covariance @ d_residual.T)
        if closure_tolerance is None:
            tolerances[row] = CLOSURE_SIGMAS * scale
            refused = sigmas[row] > CLOSURE_SIGMAS
        else:
            refused = closure_size > closure_tolerance
        if refused or not converged[row]:  # no closure statistic without a converged solve
            if on_inconsistent == "raise" and not converged[row]:
                raise ConvergenceError(f"pose of log row {row + 1}", state.iterations,
                                       "no pose near the previous one meets these lasers (a reading far off?)")
            if on_inconsistent == "raise":
                kind = "first" if row == 0 else ("stop" if log.start_stop[row] == 0 else "start")
                raise row_closure_error(row, kind, residuals[row], tolerances[row], solved,
                                        sigmas[row] if closure_tolerance is None else None)
            inconsistent[row] = True
            trusted &= ~solved
            if good is None:  # the first row: keep its pose as the start, trust no height
                good = state
        else:
            trusted[:] = True
            good = state
            good_covariance = d_heights @ input_covariance @ d_heights.T
    if progress is not None:
        progress(count, count)
    probe_rows = np.flatnonzero((log.probe == 1) & ~inconsistent)
    tip_uncertainty, uncertain = flag_uncertain_tips(tip_covariance, max_tip_uncertainty, ~inconsistent)
    return ProcessedLog(
        heights=heights,
        tips=tips,
        probe_rows=probe_rows,
        probe_points=tips[probe_rows],
        moved_arm=moved,
        residuals=residuals,
        direction_consistent=consistent,
        converged=converged,
        closure_residual=np.linalg.norm(residuals, axis=1),
        closure_sigmas=sigmas,
        closure_tolerance=tolerances,
        inconsistent=inconsistent,
        rejected_probe_rows=np.flatnonzero((log.probe == 1) & inconsistent),
        tip_covariance=tip_covariance,
        tip_uncertainty=tip_uncertainty,
        uncertain=uncertain,
        max_tip_uncertainty=float(max_tip_uncertainty),
    )


#: neighbour used by the seed to re-derive a moved pivot's height (Appendix D): a from c, b from a, c from b
SEED_NEIGHBOUR = {0: 2, 1: 0, 2: 1}


def process_log_dpkm(
    log: MeasurementLog,
    *,
    dead_distance: Mapping[str, float] | None = None,
    beta_deg: Mapping[str, float] | None = None,
    column_points: Mapping[str, ArrayLike],
    initial_heights: ArrayLike,
    sign_rule: str = "continuity",
    start_of_range: float = 60.0,
    parameter_laws: DpkmParameterLaws | None = None,
) -> ProcessedLog:
    """The seed's own processing: eqs 2.3-2.8 per laser pair, then eqs 2.9-2.18 (corrected).

    Row logic as in the module notes.  On each row the moved pivot ``i`` gets
    ``z_i = z_n +- |dz_in|`` from its seed neighbour ``n`` (a from c, b from a, c from b)
    with ``|dz|`` from eqs 2.5-2.8 and ``b`` the xy distance of the (vertical) columns.
    The probe is :func:`pcmm_geo.machine.kinematics.dpkm.dpkm_probe` of the pivots (the seed
    geometry: slider lines meeting at the tip, vertical columns).

    Parameters
    ----------
    log : MeasurementLog
    dead_distance, beta_deg : mapping
        ``d_i`` (mm, without the 60 mm start of range) and ``beta_in`` (degrees, "ab", "bc", "ca").
        Ignored when ``parameter_laws`` is given (pass ``None``).
    column_points : mapping arm -> (x, y)
        Vertical column positions (mm).
    initial_heights : array_like, shape (3,)
        Heights of the first row (the seed used ``z_a = 0``).
    sign_rule : {"continuity", "seed_direction"}
        ``"continuity"``: the sign giving the height nearest the previous one (correct while
        the pivot does not cross its neighbour's height); ``"seed_direction"``: the seed's
        rule, ``+`` when the row's direction is +1, ``-`` when -1 (continuity when 0).
    parameter_laws : DpkmParameterLaws, optional
        ``d_i`` and ``beta_in`` as laws of each row's lasers (thesis 8.2, variable parameters,
        :mod:`pcmm_geo.machine.analysis.parameter_laws`) instead of constants.

    Returns
    -------
    ProcessedLog
        ``residuals`` hold the b-c / c-a / a-b pair closure ``|z_j - z_k| - |dz_jk|`` in
        the first three columns (mm), zeros elsewhere.  Like the seed, this processing
        tests no row: ``inconsistent`` is all False and ``closure_tolerance`` infinite.

    Raises
    ------
    InvalidInputError
        Unknown ``sign_rule``.
    NoRealSolutionError
        A laser pair gives pivots closer than their column spacing, or the spheres miss.

    Examples
    --------
    >>> from pcmm_geo.machine.kinematics import dpkm
    >>> m = RigidBodyMachine.from_dpkm()
    >>> start = m.reference_heights + [0.0, 60.0, -50.0]
    >>> log = synthesise_log(m, start, [(1, 5.0, True)])
    >>> out = process_log_dpkm(log, dead_distance=dpkm.TABLE_3_1_DEAD_DISTANCE, beta_deg=dpkm.TABLE_3_1_BETA_DEG,
    ...                        column_points=dpkm.APPENDIX_D_COLUMN_POINTS, initial_heights=start)
    >>> bool(abs(out.heights[-1, 0] - start[0] - 5.0) < 1e-9)
    True
    """
    from pcmm_geo.machine.kinematics.dpkm import arm_lengths, dpkm_probe, height_difference

    if sign_rule not in ("continuity", "seed_direction"):
        raise InvalidInputError("sign_rule", "'continuity' or 'seed_direction'", repr(sign_rule))
    if parameter_laws is None:
        if dead_distance is None or beta_deg is None:
            raise InvalidInputError("dead_distance/beta_deg", "mappings (or parameter_laws)", "None")
        parameter_laws = DpkmParameterLaws.constant(dead_distance, beta_deg)
    xy = np.array([np.asarray(column_points[arm], dtype=float)[:2] for arm in ARMS])
    dead_rows, beta_rows = parameter_laws.evaluate(log.lasers)
    lengths = arm_lengths(log.lasers, dict(zip(ARMS, np.zeros(3), strict=True)), start_of_range=start_of_range)
    lengths = lengths + dead_rows
    pair_column = {(0, 1): 0, (1, 2): 1, (2, 0): 2}  # columns of beta_rows: ab, bc, ca

    def dz(row: int, i: int, j: int) -> float:
        key = (i, j) if (i, j) in pair_column else (j, i)
        beta = np.radians(beta_rows[row, pair_column[key]])
        return float(height_difference(lengths[row, i], lengths[row, j], beta, np.linalg.norm(xy[i] - xy[j])))

    count = len(log)
    heights = np.empty((count, 3))
    moved = np.full(count, -1, dtype=np.int64)
    consistent = np.ones(count, dtype=bool)
    heights[0] = as_readings(initial_heights, "initial_heights")
    for row in range(1, count):
        heights[row] = heights[row - 1]
        if log.start_stop[row] == 1 and np.array_equal(log.lasers[row], log.lasers[row - 1]):
            continue
        stop = log.start_stop[row] == 0
        arm = int(log.motor[row] if stop else log.motor[row - 1]) - 1
        direction = int(log.direction[row] if stop else log.direction[row - 1])
        moved[row] = arm
        neighbour = SEED_NEIGHBOUR[arm]
        size = dz(row, arm, neighbour)
        above, below = heights[row, neighbour] + size, heights[row, neighbour] - size
        nearest = above if abs(above - heights[row - 1, arm]) <= abs(below - heights[row - 1, arm]) else below
        if sign_rule == "seed_direction" and direction != 0:
            heights[row, arm] = above if direction > 0 else below
        else:
            heights[row, arm] = nearest
        change = heights[row, arm] - heights[row - 1, arm]
        consistent[row] = direction == 0 or abs(change) <= 1e-3 or np.sign(change) == direction
    pivots = np.concatenate([np.broadcast_to(xy, (count, 3, 2)), heights[..., None]], axis=-1)
    tips = dpkm_probe(pivots, lengths).point
    residuals = np.zeros((count, 9))
    for k, (i, j) in enumerate(((1, 2), (2, 0), (0, 1))):
        residuals[:, k] = [abs(heights[r, i] - heights[r, j]) - dz(r, i, j) for r in range(count)]
    probe_rows = np.flatnonzero(log.probe == 1)
    return ProcessedLog(
        heights=heights,
        tips=tips,
        probe_rows=probe_rows,
        probe_points=tips[probe_rows],
        moved_arm=moved,
        residuals=residuals,
        direction_consistent=consistent,
        converged=np.ones(count, dtype=bool),
        closure_residual=np.linalg.norm(residuals, axis=1),
        closure_sigmas=np.full(count, np.nan),
        closure_tolerance=np.full(count, np.inf),
        inconsistent=np.zeros(count, dtype=bool),  # the seed's processing tests nothing
        rejected_probe_rows=np.zeros(0, dtype=np.int64),
        tip_covariance=np.full((count, 3, 3), np.nan),  # not propagated: the seed's processing
        tip_uncertainty=np.full(count, np.nan),
        uncertain=np.zeros(count, dtype=bool),
        max_tip_uncertainty=float("inf"),
    )
