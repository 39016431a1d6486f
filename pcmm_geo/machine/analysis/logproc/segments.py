"""The unknowns of a log and their starting values: one height per stretch a pivot stands still.

Row logic (thesis Appendix D, the seed's rules kept)
----------------------------------------------------
Between two movements of its motor a pivot keeps its height: that height is one unknown, a
*segment*.  The log starts at its datum (the start position: ``initial_heights``, three fixed
segments).  A stop row (``start_stop = 0``) begins a new segment of the motor it names; a start
row whose lasers repeat the previous row's is the same reading (not a new observation); a
start row whose lasers differ (the machine had not settled, thesis 3.5) begins a new segment
of the *previous* row's motor.  Every other row observes the three segments standing at that
time with its three lasers.  So a log of ``R`` observed rows and ``S`` moves has ``3 R``
readings and ``S`` unknowns.

Starting values and branches
----------------------------
The lasers see squared height differences (:mod:`~pcmm_geo.machine.analysis.logproc.geometry`),
so a moved height usually has two values that fit a row's lasers, mirror images about the
level of the two held pivots.  :func:`initial_segments` walks the log once, holding the
earlier segments, and takes for each new one the minima of the row's misfit, a quartic in the
height (:func:`segment_misfit`, from the squared distances with the readings' covariance):
among the minima that fit within the gate's critical value of the best, one that moved the
way the row's ``direction`` says (+1 up, -1 down) is preferred, then one that did not move,
and among equals the better fit, then the nearer (continuity).  The network adjustment
(:mod:`~pcmm_geo.machine.analysis.logproc.adjustment`) then solves every segment from every
reading; :mod:`~pcmm_geo.machine.analysis.logproc.ambiguity` asks afterwards whether another
branch fits as well.

Examples
--------
>>> from pcmm_geo.machine.analysis.logproc.rows import MeasurementLog
>>> log = MeasurementLog([1, 0, 1, 0], [0, 0, 0, 1], [3, 3, 1, 1], [1, 1, -1, -1],
...                      [[50.0, 55.0, 67.0], [50.0, 55.0, 67.1], [50.0, 55.0, 67.1], [49.9, 55.0, 67.1]])
>>> segments = segment_log(log)
>>> segments.active.tolist(), segments.observed.tolist()
([[0, 1, 2], [0, 1, 3], [0, 1, 3], [4, 1, 3]], [True, True, False, True])
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.machine.analysis.logproc.geometry import PAIRS, joint_distances
from pcmm_geo.machine.analysis.logproc.rows import MeasurementLog
from pcmm_geo.machine.kinematics import _pose_solver as solver

__all__ = ["LogSegments", "initial_segments", "segment_log", "segment_misfit"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: a height change at most this large (mm) counts as "did not move" when checked against ``direction``
STILL = 1e-3
#: minima whose misfits differ by less than this (chi-square units) fit alike; the nearer one is taken
_TIE = 1.0
#: a row misfit this many times the squared critical value is a gross error (starting values only)
GROSS = 1e4


@dataclass(frozen=True)
class LogSegments:
    """Which unknown height stands at each pivot on each row (:func:`segment_log`).

    Attributes
    ----------
    active : ndarray of int, shape (N, 3)
        Segment index of pivots a, b, c on each row; segments 0, 1, 2 are the datum.
    source : ndarray of int, shape (N,)
        Row whose readings a row repeats (itself, or the earlier row a start row copies).
    observed : ndarray of bool, shape (N,)
        ``source == row``: rows that are observations.
    moved_arm : ndarray of int, shape (N,)
        Arm (0, 1, 2) whose new segment a row begins; -1 on the first row and on copies.
    arm, birth, direction, previous, following : ndarray of int, shape (S,)
        Per segment: its arm, the row that begins it (0 for the datum), the recorded direction of
        that move, the arm's segment before it (-1 for the datum) and after it (-1: none).
    """

    active: IntArray
    source: IntArray
    observed: NDArray[np.bool_]
    moved_arm: IntArray
    arm: IntArray
    birth: IntArray
    direction: IntArray
    previous: IntArray
    following: IntArray

    @property
    def count(self) -> int:
        """Number of segments (datum included)."""
        return len(self.arm)


def segment_log(log: MeasurementLog) -> LogSegments:
    """The segments of a log (module notes: row logic)."""
    rows = len(log)
    active = np.zeros((rows, 3), dtype=np.int64)
    source = np.arange(rows)
    moved = np.full(rows, -1, dtype=np.int64)
    arm, birth, direction, previous = [0, 1, 2], [0, 0, 0], [0, 0, 0], [-1, -1, -1]
    current = np.array([0, 1, 2])
    active[0] = current
    for row in range(1, rows):
        if log.start_stop[row] == 1 and np.array_equal(log.lasers[row], log.lasers[row - 1]):
            active[row], source[row] = current, source[row - 1]
            continue
        stop = log.start_stop[row] == 0
        moving = int(log.motor[row] if stop else log.motor[row - 1]) - 1
        previous.append(int(current[moving]))
        current = current.copy()
        current[moving] = len(arm)
        arm.append(moving)
        birth.append(row)
        direction.append(int(log.direction[row] if stop else log.direction[row - 1]))
        active[row], moved[row] = current, moving
    previous_array = np.array(previous, dtype=np.int64)
    following = np.full(len(arm), -1, dtype=np.int64)
    has_previous = previous_array >= 0
    following[previous_array[has_previous]] = np.flatnonzero(has_previous)
    return LogSegments(active, source, source == np.arange(rows), moved, np.array(arm, dtype=np.int64),
                       np.array(birth, dtype=np.int64), np.array(direction, dtype=np.int64), previous_array,
                       following)


def reading_weights(distances: FloatArray, gradients: FloatArray, sigmas: FloatArray) -> FloatArray:
    """Weight matrices ``(R, 3, 3)`` of the squared distances ``d^2`` of ``R`` rows.

    ``d^2 = d(l)^2`` carries the lasers' errors through ``B = 2 diag(d) dd/dl``; its weight is
    ``B^-T diag(1/sigma^2) B^-1`` (``sigmas`` ``(R, 3)``, ``inf`` for a reading left out).
    """
    scaled = 2.0 * distances[..., None] * gradients
    inverse = np.linalg.inv(scaled)
    with np.errstate(divide="ignore"):
        weight = 1.0 / sigmas**2
    return np.einsum("rji,rj,rjk->rik", inverse, weight, inverse)


def segment_misfit(
    geometry: solver.Geometry,
    distances: FloatArray,
    weights: FloatArray,
    heights: FloatArray,
    arm: int,
) -> FloatArray:
    """Coefficients (highest first, 5) of the misfit ``sum_r g_r^T W_r g_r``, a quartic in the height of ``arm``.

    ``g_r = d_r^2 - D^2(H_r)`` with the joint distances ``distances`` ``(R, 3)`` of the measured
    lasers, ``weights`` ``(R, 3, 3)`` from :func:`reading_weights` and the other two pivots at
    ``heights`` ``(R, 3)`` (the entry of ``arm`` is ignored).  Its minima are the heights that fit
    the rows' lasers (chi-square units; to first order the laser misfit of the adjustment).

    Examples
    --------
    One row of the level pose: the misfit is even about the level height (mirror images).

    >>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
    >>> m = RigidBodyMachine.from_dpkm()
    >>> heights = np.array([[400.0, 400.0, 403.0]])
    >>> lasers = m.forward(heights=heights[0]).lasers[None]
    >>> d, grad = joint_distances(m.geometry, lasers)
    >>> coefficients = segment_misfit(m.geometry, d, reading_weights(d, grad, np.full((1, 3), 0.01)), heights, 2)
    >>> np.round(np.polyval(coefficients, [397.0, 403.0]), 9).tolist()
    [0.0, 0.0]
    """
    count = len(distances)
    along = geometry.encoder_scale[arm] * geometry.column_directions[arm]
    polynomials = np.zeros((count, 3, 3))  # per row and pair: coefficients of g_p(h), highest first
    pivots = solver.pivots_in_machine(geometry, heights)
    for pair, (i, j) in enumerate(PAIRS):
        if arm not in (i, j):
            polynomials[:, pair, 2] = distances[:, pair] ** 2 - np.sum((pivots[:, i] - pivots[:, j]) ** 2, axis=1)
            continue
        partner = j if i == arm else i
        offset = geometry.column_points[arm] - pivots[:, partner]  # (R, 3)
        polynomials[:, pair, 0] = -(along @ along)
        polynomials[:, pair, 1] = -2.0 * offset @ along
        polynomials[:, pair, 2] = distances[:, pair] ** 2 - np.sum(offset**2, axis=1)
    ascending = polynomials[:, :, ::-1]  # (R, pair, degree 0..2)
    products = np.einsum("rpq,rpi,rqj->ij", weights, ascending, ascending)  # (3, 3): degree i times degree j
    total = np.array([np.trace(products[::-1], offset=offset) for offset in range(2, -3, -1)])  # degree 4 first
    return total


def _cubic_real_roots(a: float, b: float, c: float, d: float) -> list[float]:
    """Real roots of ``a x^3 + b x^2 + c x + d`` (``a != 0``), polished by two Newton steps."""
    shift = b / (3.0 * a)
    p = (3.0 * a * c - b * b) / (3.0 * a * a)
    q = (2.0 * b**3 - 9.0 * a * b * c + 27.0 * a * a * d) / (27.0 * a**3)
    discriminant = (q / 2.0) ** 2 + (p / 3.0) ** 3
    if discriminant > 0.0:  # one real root (Cardano)
        root = math.sqrt(discriminant)
        u, v = -q / 2.0 + root, -q / 2.0 - root
        depressed = [math.copysign(abs(u) ** (1.0 / 3.0), u) + math.copysign(abs(v) ** (1.0 / 3.0), v)]
    elif p == 0.0:
        depressed = [0.0]
    else:  # three real roots (trigonometric form)
        radius = 2.0 * math.sqrt(-p / 3.0)
        angle = math.acos(max(-1.0, min(1.0, 3.0 * q / (p * radius))))
        depressed = [radius * math.cos((angle - 2.0 * math.pi * k) / 3.0) for k in range(3)]
    roots = []
    for t in depressed:
        x = t - shift
        for _ in range(40):  # Newton: the closed form loses digits when the roots differ in scale
            slope = (3.0 * a * x + 2.0 * b) * x + c
            if slope == 0.0:
                break
            step = (((a * x + b) * x + c) * x + d) / slope
            x -= step
            if abs(step) <= 1e-14 * (1.0 + abs(x)):
                break
        roots.append(x)
    return roots


def _taylor(coefficients: list[float], about: float) -> list[float]:
    """Coefficients (highest first) of ``p(about + x)`` for ``p`` given highest first (repeated Horner division)."""
    values = list(coefficients)
    degree = len(values) - 1
    for stop in range(degree, 0, -1):
        for k in range(1, stop + 1):
            values[k] += about * values[k - 1]
    return values


def misfit_minima(coefficients: FloatArray, about: float = 0.0) -> tuple[FloatArray, FloatArray]:
    """``(heights, misfits)`` of the local minima of a quartic (coefficients highest first, leading one > 0).

    The stationary points are solved in ``h - about`` (pass a height near them: the coefficients
    stay of moderate size) in closed form, polished by Newton's method, and checked against
    :func:`numpy.roots` when a polished root does not make the slope vanish.
    """
    shifted = _taylor([float(value) for value in coefficients], about)
    a, b, c, d, _ = shifted
    if not a > 0.0:
        return np.zeros(0), np.zeros(0)
    slope = np.array([4.0 * a, 3.0 * b, 2.0 * c, d])
    stationary = np.array(_cubic_real_roots(*slope))
    scale = np.abs(slope) @ np.array([np.abs(stationary) ** k for k in (3, 2, 1, 0)])
    if np.any(np.abs(np.polyval(slope, stationary)) > 1e-8 * scale):
        roots = np.roots(slope)
        stationary = roots[np.abs(roots.imag) <= 1e-9 * np.maximum(1.0, np.abs(roots))].real
    minima = np.sort(np.array([x for x in stationary if (12.0 * a * x + 6.0 * b) * x + 2.0 * c > 0.0]))
    return minima + about, np.polyval(shifted, minima)


def choose_branch(
    candidates: FloatArray, misfits: FloatArray, previous: float, direction: int, critical: float
) -> tuple[float, bool, bool]:
    """``(height, direction_consistent, alternatives)``: the starting value of a segment among its minima.

    See the module notes; ``alternatives`` is True when another minimum was admissible too.
    """
    fits = misfits <= misfits.min() + critical**2
    change = candidates - previous
    moved = (direction == 0) | ((np.abs(change) > STILL) & (np.sign(change) == direction))
    still = np.abs(change) <= STILL
    for pool in (fits & moved, fits & still):
        if pool.any():
            best = float(misfits[pool].min())
            tied = pool & (misfits <= best + _TIE)
            choice = int(np.flatnonzero(tied)[np.argmin(np.abs(change[tied]))])
            return float(candidates[choice]), True, bool(pool.sum() > 1)
    return float(candidates[int(np.argmin(misfits))]), False, False


def initial_segments(
    geometry: solver.Geometry,
    log: MeasurementLog,
    segments: LogSegments,
    datum: FloatArray,
    sigmas: FloatArray,
    critical: float,
    travel: FloatArray | None = None,
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Starting values ``(S,)`` of all segments and whether each agrees with its ``direction`` (module notes).

    ``sigmas`` ``(N, 3)``: standard uncertainty of every reading (``inf``: left out).  A segment
    whose first row has no reading left starts at the arm's previous height.  ``travel`` ``(3, 2)``
    (height readings each column can reach) excludes minima beyond it.  A row whose lasers miss
    the held heights grossly (misfit above :data:`GROSS` times the squared critical value: a
    reading far off) starts from the best height with one of its readings left out.
    """
    values = np.zeros(segments.count)
    values[:3] = datum
    agrees = np.ones(segments.count, dtype=bool)
    rows = segments.birth[3:]
    distances, gradients = joint_distances(geometry, log.lasers[rows])
    weights = reading_weights(distances, gradients, sigmas[rows])
    for offset, segment in enumerate(range(3, segments.count)):
        row, arm = int(segments.birth[segment]), int(segments.arm[segment])
        previous = float(values[segments.previous[segment]])
        if not np.isfinite(sigmas[row]).any():
            values[segment] = previous
            continue
        heights = values[segments.active[row]][None]
        coefficients = segment_misfit(geometry, distances[offset:offset + 1], weights[offset:offset + 1], heights, arm)
        reach = None if travel is None else travel[arm]
        candidates, misfits = _reachable(*misfit_minima(coefficients, previous), reach)
        if candidates.size == 0:
            values[segment] = previous
            continue
        values[segment], agrees[segment], _ = choose_branch(candidates, misfits, previous,
                                                            int(segments.direction[segment]), critical)
        chosen = float(np.polyval(coefficients, values[segment]))
        if chosen > GROSS * critical**2 and np.isfinite(sigmas[row]).sum() == 3:
            values[segment] = _without_one_reading(geometry, distances[offset], gradients[offset], sigmas[row],
                                                   heights, arm, previous, int(segments.direction[segment]),
                                                   critical, chosen, values[segment], reach)
    return values, agrees


def _reachable(candidates: FloatArray, misfits: FloatArray,
               reach: FloatArray | None) -> tuple[FloatArray, FloatArray]:
    if reach is None:
        return candidates, misfits
    inside = (candidates >= reach[0]) & (candidates <= reach[1])
    return candidates[inside], misfits[inside]


def _without_one_reading(
    geometry: solver.Geometry, distances: FloatArray, gradients: FloatArray, sigmas: FloatArray, heights: FloatArray,
    arm: int, previous: float, direction: int, critical: float, misfit: float, value: float,
    reach: FloatArray | None,
) -> float:
    """A robust start where a row's lasers do not fit its held heights: the best height with one reading left out.

    Only the starting value changes (a gross error should not pull a new height, and with it the
    heights solved against it, onto another branch); the gate still tests every reading.
    """
    best_misfit, best = misfit, value
    for left_out in range(3):
        reduced = sigmas.copy()
        reduced[left_out] = np.inf
        weights = reading_weights(distances[None], gradients[None], reduced[None])
        coefficients = segment_misfit(geometry, distances[None], weights, heights, arm)
        candidates, misfits = _reachable(*misfit_minima(coefficients, previous), reach)
        if candidates.size:
            height, _, _ = choose_branch(candidates, misfits, previous, direction, critical)
            if float(np.polyval(coefficients, height)) < best_misfit / GROSS:
                best_misfit, best = float(np.polyval(coefficients, height)), height
    return best
