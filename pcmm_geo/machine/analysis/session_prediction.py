"""The tip uncertainty a planned acquisition session will state, predicted before any device moves.

A session's points are stated by the log processing (:func:`~pcmm_geo.machine.analysis.logproc.process_log`):
every height from every laser reading, the start heights held as the datum, each point's ``u``
from the readings' noise through that adjustment.  The lasers of a planned path are known before
the session (the rigid-body model at the planned heights), so the processing of the planned,
noise-free log *is* the prediction of what the session will state, with the same noise model
(``sigma_j = sqrt(laser_sigma^2 + q_j^2 / 12)``), the same row logic (a stop row begins a new
height, the next start row is the same reading) and the same mirror-branch checks.  Where the
session reads other values (its count steps, a contact that stops a move and turns the programme
back) its u differs from the prediction as the poses do; ``tests/machine/test_session_prediction.py``
measures the agreement on simulated sessions.

Beside it, each row's pose is given its single-move conditioning
(:func:`~pcmm_geo.machine.analysis.conditioning.pose_conditioning`): the worst tip u one move to
it leaves and the distance of the mirror branch in the readings' noise.

Examples
--------
>>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
>>> m = RigidBodyMachine.from_dpkm()
>>> level = predict_session(m, m.reference_heights, [(1, 2.0), (2, -3.0), (3, 2.5)])
>>> good = predict_session(m, m.reference_heights + [70.0, -70.0, 0.0], [(1, 2.0), (2, -3.0), (3, 2.5)])
>>> bool(level.max_tip_uncertainty > 1.0), bool(good.max_tip_uncertainty < 0.15)  # mm
(True, True)
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import ConvergenceError, InvalidInputError, PcmmGeoWarning
from pcmm_geo.machine.analysis.conditioning import pose_conditioning
from pcmm_geo.machine.analysis.logproc.gate import SEED_LASER_SIGMA, SEED_LASER_STEPS
from pcmm_geo.machine.analysis.logproc.process import process_log
from pcmm_geo.machine.analysis.logproc.synthesis import synthesise_log
from pcmm_geo.machine.kinematics.model import RigidBodyMachine, as_readings

__all__ = ["SessionPrediction", "predict_session"]

FloatArray = NDArray[np.float64]


@record
class SessionPrediction:
    """Predicted statement of a planned session (:func:`predict_session`; ``R = 2 x moves`` log rows, mm).

    Attributes
    ----------
    start_heights : ndarray, shape (3,)
        The datum: pivot heights at the start.
    motor, change : ndarray, shape (M,)
        The planned moves: motor (1, 2, 3) and height change (mm).
    heights, tips : ndarray, shape (R, 3)
        Planned pivot heights and tips of the rows (start row, stop row of each move).
    tip_uncertainty : ndarray, shape (R,)
        The ``u`` the log processing states for each row of the planned log (inf: not determined).
    ambiguous : ndarray of bool, shape (R,)
        Rows the processing flags ambiguous on the planned log (a mirror pose fits as well).
    move_tip_u, ambiguity_ratio : ndarray, shape (R,)
        Single-move conditioning of each row's pose: the worst tip u one move to it leaves, and the
        mirror branch's distance over the w-test's critical value (below 1: in reach of the noise).
    """

    start_heights: FloatArray
    motor: NDArray[np.int64]
    change: FloatArray
    heights: FloatArray
    tips: FloatArray
    tip_uncertainty: FloatArray
    ambiguous: NDArray[np.bool_]
    move_tip_u: FloatArray
    ambiguity_ratio: FloatArray

    @property
    def max_tip_uncertainty(self) -> float:
        """The largest predicted ``u`` along the path (mm; inf when some row is not determined)."""
        return float(np.max(self.tip_uncertainty)) if self.tip_uncertainty.size else 0.0

    @property
    def median_tip_uncertainty(self) -> float:
        """The median predicted ``u`` of the rows (mm)."""
        return float(np.median(self.tip_uncertainty)) if self.tip_uncertainty.size else 0.0

    def rows_above(self, limit: float) -> NDArray[np.int64]:
        """0-based rows whose predicted ``u`` exceeds ``limit`` (mm), or is not finite."""
        return np.flatnonzero(~(self.tip_uncertainty <= limit))


def predict_session(
    machine: RigidBodyMachine,
    start_heights: ArrayLike,
    moves: Sequence[tuple[int, float]],
    *,
    laser_sigma: float = SEED_LASER_SIGMA,
    laser_steps: ArrayLike = SEED_LASER_STEPS,
) -> SessionPrediction:
    """What the log processing will state about a planned session (module notes).

    Parameters
    ----------
    machine : RigidBodyMachine
        The model the session's log will be processed with.
    start_heights : array_like, shape (3,)
        Pivot heights at the start (the log's ``start_heights_mm``, the processing's datum), mm.
    moves : sequence of (int, float)
        The planned moves in order: motor 1, 2 or 3 and its height change in mm.
    laser_sigma, laser_steps : float, array_like (3,)
        The processing's noise model (defaults: ``pcmm process-log``'s).

    Returns
    -------
    SessionPrediction
        With no move, the start row alone.

    Raises
    ------
    InvalidInputError
        A bad motor, a non-finite change or bad start heights.
    """
    start = as_readings(start_heights, "start_heights").reshape(-1)
    if start.shape != (3,):
        raise InvalidInputError("start_heights", "three heights in mm", f"shape {start.shape}")
    planned = [(int(motor), float(change)) for motor, change in moves]
    for index, (motor, change) in enumerate(planned):
        if motor not in (1, 2, 3) or not np.isfinite(change):
            raise InvalidInputError(f"moves[{index}]", "a motor 1, 2 or 3 and a finite change in mm",
                                    repr(moves[index]))
    if not planned:
        planned_log = None
        heights = start[None, :]
    else:
        planned_log = synthesise_log(machine, start, [(motor, change, False) for motor, change in planned])
        heights = np.repeat(start[None, :], 2 * len(planned), axis=0)
        current = start.copy()
        for index, (motor, change) in enumerate(planned):
            heights[2 * index] = current
            current = current.copy()
            current[motor - 1] += change
            heights[2 * index + 1] = current
    conditioning = pose_conditioning(machine, heights, laser_sigma=laser_sigma, laser_steps=laser_steps)
    if planned_log is None:
        tip_uncertainty = np.zeros(1)  # the datum itself
        ambiguous = np.zeros(1, dtype=bool)
    else:
        tip_uncertainty, ambiguous = _stated(machine, planned_log, start, laser_sigma, laser_steps)
    return SessionPrediction(
        start_heights=start, motor=np.array([m for m, _ in planned], dtype=np.int64),
        change=np.array([c for _, c in planned], dtype=float), heights=heights, tips=conditioning.tips,
        tip_uncertainty=tip_uncertainty, ambiguous=ambiguous, move_tip_u=conditioning.tip_u,
        ambiguity_ratio=conditioning.ambiguity_ratio,
    )


def _stated(machine: RigidBodyMachine, log: object, start: FloatArray, laser_sigma: float,
            laser_steps: ArrayLike) -> tuple[FloatArray, NDArray[np.bool_]]:
    """``(u, ambiguous)`` per row, as :func:`process_log` states them for the planned log (its warnings muted)."""
    rows = len(log)  # type: ignore[arg-type]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PcmmGeoWarning)  # the prediction reports them itself
        try:
            out = process_log(machine, log, initial_heights=start, laser_sigma=laser_sigma,  # type: ignore[arg-type]
                              laser_steps=laser_steps, on_inconsistent="flag", max_tip_uncertainty=np.inf)
        except ConvergenceError:  # no adjustment of the planned path: nothing it would state can be trusted
            return np.full(rows, np.inf), np.ones(rows, dtype=bool)
    u = np.where(out.inconsistent | ~np.isfinite(out.bound), np.inf, out.tip_uncertainty)
    return u, np.asarray(out.ambiguous, dtype=bool)
