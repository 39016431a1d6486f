"""Probe points from a Table 3.2 log: network adjustment, gate, uncertainty and reliability of every row.

How the pieces combine (flags of :class:`ProcessedLog`, ``pcmm process-log`` options)
-------------------------------------------------------------------------------------
1. *Gate* (``inconsistent``): a reading whose w-test fails (or, with ``closure_tolerance`` /
   ``--max-closure-mm MM``, a row whose closure residual exceeds MM) is refused.  By default the
   log is refused (:class:`~pcmm_geo.errors.InconsistentMeasurementError`, exit 2).  With
   ``on_inconsistent="flag"`` / ``--keep-inconsistent`` the reading is left out, the log is
   adjusted again, and so on; rows that lost a reading are ``inconsistent`` and give no point.
2. *Ambiguity* (``ambiguous``): another branch of a pose fits the lasers within the gate and
   moved the recorded way.  Never refused: the point is kept, flagged, warned about (exit 0);
   its ``ambiguity`` (mm, the other branch's tip) is part of its stated bound.
3. *Bound* (``bound = 2 tip_uncertainty + tip_reliability + ambiguity``): an accepted point
   lies within it of the truth unless an undetected fault exceeds the MDB (the w-test finds
   such a fault with probability ``power``) or the noise exceeds U.  ``tip_reliability`` is
   infinite where a reading that no test can check moves the tip, or the tip stands on an
   unsettled start row read as a further move beyond the settling play (R is first order;
   :func:`~pcmm_geo.machine.analysis.logproc.reliability.implausible_settling`): ``unbounded``, warned
   about.  ``max_bound`` / ``--max-bound-mm MM`` leaves points with a larger bound out
   (``over_bound``; exit 0, listed).
4. *Uncertainty* (``uncertain``): ``tip_uncertainty`` above ``max_tip_uncertainty`` /
   ``--max-tip-u-mm`` (default 1 mm): kept, flagged, warned about; ``--refuse-uncertain`` makes such
   a probe point refuse the log (exit 2).

The gate decides first (it changes the adjustment), the other flags describe the final one.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import ConvergenceError, InvalidInputError
from pcmm_geo.machine.analysis.logproc.adjustment import Adjustment, adjust
from pcmm_geo.machine.analysis.logproc.ambiguity import competing_fits, find_ambiguities
from pcmm_geo.machine.analysis.logproc.branches import branch_hypotheses
from pcmm_geo.machine.analysis.logproc.gate import (
    DEFAULT_ALPHA,
    DEFAULT_POWER,
    SEED_LASER_SIGMA,
    SEED_LASER_STEPS,
    gate_limits,
    reading_error,
    reading_sigmas,
    w_statistics,
    worst_reading,
)
from pcmm_geo.machine.analysis.logproc.geometry import GEOMETRY_PARAMETERS
from pcmm_geo.machine.analysis.logproc.reliability import (
    change_uncertainty,
    further_move_mdb,
    geometry_tip_covariance,
    implausible_settling,
    reading_influence,
    warn_flags,
)
from pcmm_geo.machine.analysis.logproc.rows import MeasurementLog
from pcmm_geo.machine.analysis.logproc.segments import STILL, LogSegments, moved_further, segment_log
from pcmm_geo.machine.analysis.logproc.uncertainty import DEFAULT_MAX_TIP_UNCERTAINTY, flag_uncertain_tips
from pcmm_geo.machine.kinematics.model import RigidBodyMachine, as_readings

__all__ = ["ProcessedLog", "process_log"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]


@record
class ProcessedLog:
    """Result of :func:`process_log` (``N`` rows; lengths in mm).

    Attributes
    ----------
    heights, tips : ndarray, shape (N, 3)
        Pivot heights (relative to the datum of row 1) and probe-tip centres (machine frame).
    probe_rows : ndarray of int, shape (M,)
        Rows (0-based) with ``probe = 1`` that passed the gate and are within ``max_bound``.
    probe_points : ndarray, shape (M, 3)
        ``tips[probe_rows]``.
    rejected_probe_rows : ndarray of int, shape (K,)
        Rows with ``probe = 1`` left out: ``inconsistent`` or ``over_bound``.
    moved_arm : ndarray of int, shape (N,)
        Arm (0, 1, 2) whose new height a row begins; -1 on row 1 and on repeated start rows.
    residuals : ndarray, shape (N, 3)
        Laser corrections ``v = l - f(H)`` of the adjustment (also of readings left out).
    closure_residual : ndarray, shape (N,)
        ``|v|`` of each row: the laser misfit the heights cannot absorb.
    w_test, redundancy, mdb : ndarray, shape (N, 3)
        Per reading: Baarda's w (NaN where it cannot be tested or was left out), the redundancy
        number (0..1) and the minimal detectable bias (inf: uncontrolled),
        :mod:`~pcmm_geo.machine.analysis.logproc.gate`; near the level pose the larger of a reading's
        MDBs with the next start row settled or read as a further move,
        :func:`~pcmm_geo.machine.analysis.logproc.reliability.further_move_mdb`.
    faulty_readings : ndarray of bool, shape (N, 3)
        Readings the gate refused and left out (``on_inconsistent="flag"``).
    inconsistent : ndarray of bool, shape (N,)
        Rows with a refused reading or whose pose did not converge: no probe point.
    converged, direction_consistent : ndarray of bool, shape (N,)
        Pose found; the height change agrees with the row's ``direction`` (checked, never forced).
    tip_covariance : ndarray, shape (N, 3, 3)
        First-order covariance of each tip (mm^2): the readings through the adjustment, plus
        the calibration's covariance when ``model_covariance`` is given.
    tip_uncertainty : ndarray, shape (N,)
        ``sqrt(trace(tip_covariance))``: the standard uncertainty of the 3-D point, the RMS
        length of its error vector (:mod:`~pcmm_geo.machine.analysis.logproc.uncertainty`).
    tip_reliability : ndarray, shape (N,)
        External reliability: the largest tip shift an undetected fault of MDB size in any one
        reading causes on this row (inf: unbounded), :mod:`~pcmm_geo.machine.analysis.logproc.reliability`.
    ambiguous : ndarray of bool, shape (N,); ambiguity : ndarray, shape (N,)
        Another branch fits as well; the distance of its tip (0 where none),
        :mod:`~pcmm_geo.machine.analysis.logproc.ambiguity`.
    uncertain, over_bound : ndarray of bool, shape (N,)
        ``tip_uncertainty > max_tip_uncertainty``; ``bound > max_bound`` (consistent rows only).
    max_tip_uncertainty, max_bound, alpha, power, critical_value : float
    closure_tolerance : float or None
        The explicit tolerance that replaced the w-test, if any.
    laser_sigmas : ndarray, shape (3,)
        Standard uncertainty of readings of lasers a, b, c.
    calibration_included : bool
        Whether ``tip_covariance`` contains the calibration's covariance.
    """

    heights: FloatArray
    tips: FloatArray
    probe_rows: IntArray
    probe_points: FloatArray
    rejected_probe_rows: IntArray
    moved_arm: IntArray
    residuals: FloatArray
    closure_residual: FloatArray
    w_test: FloatArray
    redundancy: FloatArray
    mdb: FloatArray
    faulty_readings: BoolArray
    inconsistent: BoolArray
    converged: BoolArray
    direction_consistent: BoolArray
    tip_covariance: FloatArray
    tip_uncertainty: FloatArray
    tip_reliability: FloatArray
    ambiguous: BoolArray
    ambiguity: FloatArray
    uncertain: BoolArray
    over_bound: BoolArray
    max_tip_uncertainty: float
    max_bound: float
    alpha: float
    power: float
    critical_value: float
    closure_tolerance: float | None
    laser_sigmas: FloatArray
    calibration_included: bool

    @property
    def tip_u(self) -> FloatArray:
        """Per-axis standard uncertainty of each row's tip, shape (N, 3), mm."""
        return np.sqrt(np.clip(np.diagonal(self.tip_covariance, axis1=1, axis2=2), 0.0, None))

    @property
    def bound(self) -> FloatArray:
        """Stated bound of each tip (mm): ``2 tip_uncertainty + tip_reliability + ambiguity`` (inf: unbounded)."""
        return 2.0 * self.tip_uncertainty + self.tip_reliability + self.ambiguity

    @property
    def unbounded(self) -> BoolArray:
        """Consistent rows whose bound is not finite (an unchecked reading, a contradicted direction or an
        implausible further move)."""
        return ~np.isfinite(self.bound) & ~self.inconsistent

    def __repr__(self) -> str:
        flags = {name: int(np.sum(getattr(self, name))) for name in ("inconsistent", "ambiguous", "uncertain",
                                                                      "over_bound")}
        flags["unbounded"] = int(np.sum(self.unbounded))
        shown = ", ".join(f"{name}={count}" for name, count in flags.items() if count)
        accepted = self.bound[self.probe_rows]
        largest = f", largest bound {float(accepted.max()):.3g} mm" if accepted.size else ""
        return (f"ProcessedLog(rows={len(self.tips)}, probe_points={len(self.probe_rows)}"
                + (f", {shown}" if shown else "") + largest + ")")


def _check_options(laser_sigma: float, on_inconsistent: str, max_tip_uncertainty: float, max_bound: float,
                   model_covariance: ArrayLike | None) -> FloatArray | None:
    if on_inconsistent not in ("raise", "flag"):
        raise InvalidInputError("on_inconsistent", "'raise' or 'flag'", repr(on_inconsistent))
    for name, value in (("max_tip_uncertainty", max_tip_uncertainty), ("max_bound", max_bound)):
        if not value > 0:  # NaN too; inf allowed
            raise InvalidInputError(name, "a positive number of mm (inf: no limit)", str(value))
    if model_covariance is None:
        return None
    covariance = np.asarray(model_covariance, dtype=float)
    size = len(GEOMETRY_PARAMETERS)
    if covariance.shape != (size, size) or not np.all(np.isfinite(covariance)):
        raise InvalidInputError("model_covariance", f"a finite ({size}, {size}) covariance of GEOMETRY_PARAMETERS",
                                f"shape {covariance.shape}")
    return 0.5 * (covariance + covariance.T)


def process_log(
    machine: RigidBodyMachine,
    log: MeasurementLog,
    *,
    initial_heights: ArrayLike | None = None,
    laser_sigma: float = SEED_LASER_SIGMA,
    laser_steps: ArrayLike = SEED_LASER_STEPS,
    closure_tolerance: float | None = None,
    on_inconsistent: str = "raise",
    alpha: float = DEFAULT_ALPHA,
    power: float = DEFAULT_POWER,
    max_tip_uncertainty: float = DEFAULT_MAX_TIP_UNCERTAINTY,
    max_bound: float = float("inf"),
    model_covariance: ArrayLike | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> ProcessedLog:
    """Pivot heights and probe points of a Table 3.2 log, each with its uncertainty and reliability.

    Every segment height is solved from every laser reading by least squares (the network
    adjustment of :mod:`~pcmm_geo.machine.analysis.logproc.adjustment`, started on the branches
    the motor directions pick), every reading is tested (Baarda's w-test,
    :mod:`~pcmm_geo.machine.analysis.logproc.gate`), and every tip gets its covariance and
    external reliability (:mod:`~pcmm_geo.machine.analysis.logproc.reliability`).

    Parameters
    ----------
    machine : RigidBodyMachine
    log : MeasurementLog
    initial_heights : array_like, shape (3,), optional
        Heights of the first row: the start position the log began at (default: the machine's
        reference heights, the level pose the thesis starts from).  They are the datum: held
        exactly, so the first row's lasers check them; points are relative to them.
    laser_sigma : float
        Standard uncertainty of a laser reading for noise and accuracy (mm; default 28.9 um, the
        thesis' 50 um accuracy as rectangular bounds); ``laser_steps`` (mm, a, b, c) adds each
        sensor's reading step as ``q/sqrt(12)``.
    closure_tolerance : float, optional
        Largest closure residual of a row (mm) instead of the w-test (a machine model known to
        misfit by more than the lasers' noise).
    on_inconsistent : {"raise", "flag"}
        Refuse the log at the first failed test, or leave the reading out and mark its row.
    alpha, power : float
        Significance of the w-test per reading and its power for a fault of MDB size (0.001, 0.8).
    max_tip_uncertainty : float
        Rows above it are marked ``uncertain`` (mm; ``inf``: none).
    max_bound : float
        Points whose stated bound exceeds it are left out (mm; ``inf``: none).
    model_covariance : array_like, shape (28, 28), optional
        Covariance of the tetrahedron parameters (:data:`GEOMETRY_PARAMETERS` order, mm, 1): the
        calibration's, added to every tip's covariance.
    progress : callable, optional
        ``progress(rows_done, rows_total)``.

    Returns
    -------
    ProcessedLog

    Raises
    ------
    InvalidInputError
        A bad option.
    InconsistentMeasurementError
        ``on_inconsistent="raise"`` and a reading fails the gate (``what`` names the 1-based row).
    ConvergenceError
        ``on_inconsistent="raise"`` and no pose fits a row's heights, or the adjustment did not
        converge.

    Examples
    --------
    >>> from pcmm_geo.machine.analysis.logproc import synthesise_log
    >>> m = RigidBodyMachine.from_dpkm()
    >>> start = m.reference_heights + [0.0, 60.0, -50.0]
    >>> log = synthesise_log(m, start, [(2, 10.0, True), (1, -6.0, True), (3, 8.0, True)])
    >>> out = process_log(m, log, initial_heights=start)
    >>> bool(abs(out.heights[-1, 2] - start[2] - 8.0) < 1e-6), out.probe_points.shape
    (True, (3, 3))
    >>> bool(np.all(out.bound[out.probe_rows] < 2.0))  # mm: U (k = 2) + external reliability
    True
    >>> lasers = log.lasers.copy()
    >>> lasers[1, 0] += 2.0  # laser a of the first stop row 2 mm off
    >>> faulty = MeasurementLog(log.start_stop, log.probe, log.motor, log.direction, lasers)
    >>> flagged = process_log(m, faulty, initial_heights=start, on_inconsistent="flag")
    >>> np.flatnonzero(flagged.inconsistent).tolist(), flagged.faulty_readings[1].tolist()
    ([1], [True, False, False])
    """
    covariance = _check_options(laser_sigma, on_inconsistent, max_tip_uncertainty, max_bound, model_covariance)
    limits = gate_limits(alpha, power, closure_tolerance)
    per_arm = reading_sigmas(laser_sigma, laser_steps)
    datum = machine.reference_heights if initial_heights is None else as_readings(initial_heights, "initial_heights")
    if datum.shape != (3,):
        raise InvalidInputError("initial_heights", "three heights in mm", f"shape {datum.shape}")
    geometry = machine.geometry
    travel = getattr(getattr(machine, "limits", None), "height_travel", None)
    count = len(log)
    sigmas = np.tile(per_arm, (count, 1))
    refused = _outside_range(machine, log, on_inconsistent)
    sigmas[refused] = np.inf
    segments = _settle_start_rows(machine, log, sigmas, datum, limits.critical, travel)
    failed_rows = np.zeros(count, dtype=bool)
    per_row = None if progress is None else _every_hundred_rows(progress, count)
    if progress is not None:
        progress(0, count)
    while True:
        hypotheses = branch_hypotheses(geometry, log, segments, datum, sigmas, limits.critical, travel,
                                       progress=per_row)
        per_row = None  # the first pass walks the rows; the gate's passes repeat it
        adjustment = adjust(geometry, log, segments, hypotheses[0].values, sigmas,
                            geometry_gains=covariance is not None)
        lost = ~adjustment.kinematics.converged & ~failed_rows[adjustment.rows]
        if lost.any() or not adjustment.converged:
            row = int(adjustment.rows[np.argmax(lost)]) if lost.any() else None
            if on_inconsistent == "raise" or row is None:
                what = f"pose of log row {row + 1}" if row is not None else "adjustment of the log's heights"
                raise ConvergenceError(what, adjustment.iterations,
                                       "no pose meets these lasers near the heights the log implies "
                                       "(a reading far off?)")
            failed_rows[row] = True
            sigmas[row] = np.inf
            continue
        observed_sigmas = sigmas[adjustment.rows]
        influence = reading_influence(adjustment, segments, observed_sigmas, limits, tips=False)  # the gate's part
        used = np.isfinite(observed_sigmas)
        worst = worst_reading(adjustment.residuals, observed_sigmas, influence.redundancy, used, limits)
        if worst is None:
            break
        row, arm = int(adjustment.rows[worst[0]]), worst[1]
        if on_inconsistent == "raise":
            raise _refusal(log, adjustment, influence.redundancy, observed_sigmas, used, limits, worst)
        refused[row, arm] = True
        sigmas[row, arm] = np.inf
    winner, rivals = competing_fits(geometry, log, segments, sigmas, hypotheses, adjustment, limits.critical,
                                    geometry_gains=covariance is not None)
    if winner is not adjustment:
        adjustment = winner
        influence = reading_influence(adjustment, segments, sigmas[adjustment.rows], limits, tips=False)
    # the MDB whichever way a start row is read, then tip covariance and reliability once, on the final adjustment
    floor = further_move_mdb(adjustment, segments, log.start_stop, log.motor, influence.redundancy,
                             sigmas[adjustment.rows], limits)
    influence = reading_influence(adjustment, segments, sigmas[adjustment.rows], limits, mdb_floor=floor)
    if progress is not None:
        progress(count, count)
    return _result(machine, log, segments, adjustment, influence, sigmas, refused, failed_rows, limits, per_arm,
                   covariance, max_tip_uncertainty, max_bound, rivals)


def _every_hundred_rows(progress: Callable[[int, int], None], count: int) -> Callable[[int], None]:
    """``progress(rows_done, count)`` at every hundredth row the branch search reaches."""
    reported = [0]

    def step(row: int) -> None:
        mark = row // 100 * 100
        if reported[0] < mark < count:
            reported[0] = mark
            progress(mark, count)

    return step


def _settle_start_rows(machine: RigidBodyMachine, log: MeasurementLog, sigmas: FloatArray, datum: FloatArray,
                       critical: float, travel: FloatArray | None) -> LogSegments:
    """The segments, with every start row whose difference from the row before is not the pattern of a further
    move of the previous motor read as the same pose (:func:`~pcmm_geo.machine.analysis.logproc.segments.moved_further`,
    judged at the laser gains of a first adjustment; near the level pose a motor's gain is almost one laser's
    alone, and the seed's rule stands)."""
    per_arm = np.nanmin(np.where(np.isfinite(sigmas), sigmas, np.nan), axis=0)
    segments = segment_log(log, critical * np.sqrt(2.0) * per_arm)
    starts = [int(r) for r in np.flatnonzero((segments.moved_arm >= 0) & (log.start_stop == 1)) if r > 0]
    if not starts:
        return segments
    hypotheses = branch_hypotheses(machine.geometry, log, segments, datum, sigmas, critical, travel)
    first = adjust(machine.geometry, log, segments, hypotheses[0].values, sigmas)
    index = np.searchsorted(first.rows, segments.source)
    gains = first.kinematics.laser_gain
    settled = frozenset(
        row for row in starts
        if np.all(np.isfinite(sigmas[[row, row - 1]])) and not moved_further(
            log.lasers[row] - log.lasers[row - 1], gains[index[row - 1]][:, segments.moved_arm[row]], per_arm, critical,
            int(log.direction[row - 1]))
    )
    return segment_log(log, critical * np.sqrt(2.0) * per_arm, settled) if settled else segments


def _outside_range(machine: RigidBodyMachine, log: MeasurementLog, on_inconsistent: str) -> BoolArray:
    """Readings outside their laser's measuring range (a sensor cannot report them): refused, or marked."""
    from pcmm_geo.errors import OutOfRangeError

    limits = getattr(machine, "limits", None)
    if limits is None:
        return np.zeros(log.lasers.shape, dtype=bool)
    low, high = limits.laser_range[:, 0], limits.laser_range[:, 1]
    outside = (log.lasers < low) | (log.lasers > high)
    if outside.any() and on_inconsistent == "raise":
        row, arm = (int(k) for k in np.argwhere(outside)[0])
        raise OutOfRangeError(f"laser {'abc'[arm]} of log row {row + 1}", float(log.lasers[row, arm]),
                              float(low[arm]), float(high[arm]), "mm")
    return outside


def _refusal(log: MeasurementLog, adjustment: Adjustment, redundancy: FloatArray, sigmas: FloatArray,
             used: BoolArray, limits: object, worst: tuple[int, int]) -> Exception:
    index, arm = worst
    row = int(adjustment.rows[index])
    kind = "first" if row == 0 else ("stop" if log.start_stop[row] == 0 else "start")
    statistic = w_statistics(adjustment.residuals, sigmas, redundancy, used)[index, arm]
    closure = float(np.linalg.norm(np.where(used[index], adjustment.residuals[index], 0.0)))
    return reading_error(row, arm, kind, float(adjustment.residuals[index, arm]), float(statistic),
                         float(redundancy[index, arm]), float(sigmas[index, arm]), limits,  # type: ignore[arg-type]
                         closure)


def _result(
    machine: RigidBodyMachine, log: MeasurementLog, segments: object, adjustment: Adjustment, influence: object,
    sigmas: FloatArray, refused: BoolArray, failed_rows: BoolArray, limits: object, per_arm: FloatArray,
    covariance: FloatArray | None, max_tip_uncertainty: float, max_bound: float, rivals: FloatArray,
) -> ProcessedLog:
    from pcmm_geo.machine.analysis.logproc.gate import GateLimits
    from pcmm_geo.machine.analysis.logproc.reliability import Influence
    from pcmm_geo.machine.analysis.logproc.segments import LogSegments

    assert isinstance(segments, LogSegments) and isinstance(influence, Influence)
    assert isinstance(limits, GateLimits)
    source = np.searchsorted(adjustment.rows, segments.source)  # observed-row index of every row
    heights = adjustment.values[segments.active]
    kinematics = adjustment.kinematics
    residuals = adjustment.residuals[source]
    used = np.isfinite(sigmas[adjustment.rows])
    w = w_statistics(adjustment.residuals, sigmas[adjustment.rows], influence.redundancy, used)[source]
    faulty = refused[segments.source]
    inconsistent = faulty.any(axis=1) | failed_rows[segments.source]
    converged = kinematics.converged[source] & ~failed_rows[segments.source]
    assert influence.tip_covariance is not None and influence.tip_reliability is not None
    tip_covariance = influence.tip_covariance.copy()
    if covariance is not None:
        tip_covariance += geometry_tip_covariance(adjustment, segments, covariance)
    reliability = influence.tip_reliability.copy()
    undetermined = np.concatenate([np.zeros(3, dtype=bool), adjustment.undetermined])[segments.active].any(axis=1)
    tip_covariance[undetermined] = np.inf
    reliability[undetermined] = np.inf
    _, ambiguity = find_ambiguities(machine.geometry, log, segments, adjustment, sigmas, limits.critical)
    ambiguity = np.maximum(ambiguity, rivals)
    ambiguous = ambiguity > STILL
    ambiguity = np.where(ambiguous, ambiguity, 0.0)
    consistent = ~inconsistent
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        tip_uncertainty, uncertain = flag_uncertain_tips(np.nan_to_num(tip_covariance, nan=np.inf, posinf=np.inf),
                                                         max_tip_uncertainty, consistent)
    probe = log.probe == 1
    contradicted = _contradicted_segments(adjustment, segments, limits.critical)
    direction = ~contradicted[segments.active].any(axis=1)
    unchecked = consistent & ~np.isfinite(reliability)
    reliability[~direction] = np.inf  # a branch (or the direction flag) is wrong: no bound can be stated
    settling = implausible_settling(adjustment, segments, log.start_stop, limits.critical)[segments.active].any(axis=1)
    reliability[settling] = np.inf  # a further move beyond the play: not settling, R (first order) does not hold
    bound = 2.0 * tip_uncertainty + reliability + ambiguity
    over_bound = consistent & ~(bound <= max_bound)
    probe_rows = np.flatnonzero(probe & consistent & ~over_bound)
    warn_flags(ambiguous & consistent, ambiguity, unchecked, consistent & ~direction, consistent & settling)
    return ProcessedLog(
        heights=heights, tips=kinematics.tips[source], probe_rows=probe_rows, probe_points=kinematics.tips[source][
            probe_rows], rejected_probe_rows=np.flatnonzero(probe & (inconsistent | over_bound)),
        moved_arm=segments.moved_arm, residuals=residuals, closure_residual=np.linalg.norm(residuals, axis=1),
        w_test=w, redundancy=influence.redundancy[source], mdb=influence.mdb[source], faulty_readings=faulty,
        inconsistent=inconsistent, converged=converged, direction_consistent=direction, tip_covariance=tip_covariance,
        tip_uncertainty=tip_uncertainty, tip_reliability=reliability, ambiguous=ambiguous, ambiguity=ambiguity,
        uncertain=uncertain, over_bound=over_bound, max_tip_uncertainty=float(max_tip_uncertainty),
        max_bound=float(max_bound), alpha=limits.alpha, power=limits.power, critical_value=limits.critical,
        closure_tolerance=limits.tolerance, laser_sigmas=per_arm, calibration_included=covariance is not None,
    )


def _contradicted_segments(adjustment: Adjustment, segments: object, critical: float) -> BoolArray:
    """Segments whose height change goes against its recorded direction by more than ``critical`` of its
    uncertainty (and 1 um): the branch of that pose, or the direction flag, is wrong."""
    from pcmm_geo.machine.analysis.logproc.segments import LogSegments

    assert isinstance(segments, LogSegments)
    contradicted = np.zeros(segments.count, dtype=bool)
    moved = np.flatnonzero((segments.previous >= 0) & (segments.direction != 0))
    if moved.size == 0:
        return contradicted
    change = (adjustment.values[moved] - adjustment.values[segments.previous[moved]]) * segments.direction[moved]
    suspects = change < -STILL
    if suspects.any():
        sigma = change_uncertainty(adjustment, moved[suspects], segments.previous[moved[suspects]])
        contradicted[moved[suspects]] = change[suspects] < -np.maximum(STILL, critical * sigma)
    return contradicted
