"""The unknowns of a log and their starting values: one height per stretch a pivot stands still.

Row logic (thesis Appendix D, the seed's rules kept)
----------------------------------------------------
Between two movements of its motor a pivot keeps its height: that height is one unknown, a
*segment*.  The log starts at its datum (the start position: ``initial_heights``, three fixed
segments).  A stop row (``start_stop = 0``) begins a new segment of the motor it names.  A start
row whose lasers repeat the previous row's exactly is the same reading (not a new observation);
one whose lasers differ by no more than the readings' noise allows (``same_pose``: the gate's
critical value times the standard deviation of a difference of two readings) is a new reading
of the same pose; one whose lasers differ by more (the machine had not settled, thesis 3.5)
begins a new segment of the *previous* row's motor, as the seed did for any difference -- if the
difference has the pattern of a move of that motor (:func:`moved_further`); a difference in one
laser that no height change explains is a faulty reading of the same pose, for the gate.  Every
other row observes the three segments standing at that time with its three lasers.  So a log of
``R`` observed rows and ``S`` moves has ``3 R`` readings and ``S`` unknowns.

The misfit of one height
------------------------
The lasers see squared height differences (:mod:`~pcmm_geo.machine.analysis.logproc.geometry`),
so a moved height usually has two values that fit a row's lasers, mirror images about the level
of the two held pivots.  :func:`segment_misfit` writes the misfit of rows in one height as a
quartic (squared distances weighted with the readings' covariance) and :func:`misfit_minima`
finds its minima in closed form; :mod:`~pcmm_geo.machine.analysis.logproc.branches` chooses
among them.

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

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.machine.analysis.logproc.geometry import PAIRS
from pcmm_geo.machine.analysis.logproc.rows import MeasurementLog
from pcmm_geo.machine.kinematics import pose_solver as solver

__all__ = ["LogSegments", "misfit_minima", "moved_further", "reading_weights", "segment_log", "segment_misfit",
           "taylor_shift"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: a height change at most this large (mm) counts as "did not move" when checked against ``direction``
STILL = 1e-3


@record
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


def segment_log(log: MeasurementLog, same_pose: FloatArray | None = None,
                settled: frozenset[int] = frozenset()) -> LogSegments:
    """The segments of a log (module notes: row logic).

    ``same_pose`` ``(3,)`` (mm): a start row whose lasers differ from the previous row's by at most
    this (each laser) is a new reading of the same pose, observing the same segments; beyond it
    the previous row's motor is still moving.  Default 0: only identical lasers are the same pose
    (then they are the same reading, not a new observation).  Start rows in ``settled`` (0-based)
    are the same pose whatever their difference (it is not the pattern of a move).
    """
    rows = len(log)
    tolerance = np.zeros(3) if same_pose is None else np.asarray(same_pose, dtype=float)
    active = np.zeros((rows, 3), dtype=np.int64)
    source = np.arange(rows)
    moved = np.full(rows, -1, dtype=np.int64)
    arm, birth, direction, previous = [0, 1, 2], [0, 0, 0], [0, 0, 0], [-1, -1, -1]
    current = np.array([0, 1, 2])
    active[0] = current
    for row in range(1, rows):
        start = log.start_stop[row] == 1
        if start and np.array_equal(log.lasers[row], log.lasers[row - 1]):
            active[row], source[row] = current, source[row - 1]
            continue
        if start and (row in settled or np.all(np.abs(log.lasers[row] - log.lasers[row - 1]) <= tolerance)):
            active[row] = current  # settled: another reading of the same pose
            continue
        moving = int(log.motor[row] if not start else log.motor[row - 1]) - 1
        previous.append(int(current[moving]))
        current = current.copy()
        current[moving] = len(arm)
        arm.append(moving)
        birth.append(row)
        direction.append(int(log.direction[row] if not start else log.direction[row - 1]))
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


#: (9, 5): the entry (i, j) of a product of two quadratics' coefficients (ascending) goes to degree i + j,
#: columns highest degree first
_DEGREE_OF_PRODUCT = np.array([[1.0 if i + j == 4 - k else 0.0 for k in range(5)] for i in range(3) for j in range(3)])


def segment_misfit(
    geometry: solver.Geometry,
    distances: FloatArray,
    weights: FloatArray,
    heights: FloatArray,
    arm: int,
    *,
    per_row: bool = False,
) -> FloatArray:
    """Coefficients (highest first, 5) of the misfit ``sum_r g_r^T W_r g_r``, a quartic in the height of ``arm``.

    ``g_r = d_r^2 - D^2(H_r)`` with the joint distances ``distances`` ``(R, 3)`` of the measured
    lasers, ``weights`` ``(R, 3, 3)`` from :func:`reading_weights` and the other two pivots at
    ``heights`` ``(R, 3)`` (the entry of ``arm`` is ignored).  Its minima are the heights that fit
    the rows' lasers (chi-square units; to first order the laser misfit of the adjustment).
    ``per_row``: the ``(R, 5)`` quartics of the rows instead of their sum.

    Examples
    --------
    One row of the level pose: the misfit is even about the level height (mirror images).

    >>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
    >>> from pcmm_geo.machine.analysis.logproc.geometry import joint_distances
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
    if per_row:
        products = np.einsum("rpq,rpi,rqj->rij", weights, ascending, ascending)  # (R, 3, 3)
        return products.reshape(count, 9) @ _DEGREE_OF_PRODUCT
    products = np.einsum("rpq,rpi,rqj->ij", weights, ascending, ascending)  # (3, 3): degree i times degree j
    return products.reshape(9) @ _DEGREE_OF_PRODUCT


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


def taylor_shift(coefficients: list[float], about: float) -> list[float]:
    """Coefficients (highest first) of ``p(about + x)`` for ``p`` given highest first (repeated Horner division)."""
    values = list(coefficients)
    degree = len(values) - 1
    for stop in range(degree, 0, -1):
        for k in range(1, stop + 1):
            values[k] += about * values[k - 1]
    return values


def _horner(coefficients: list[float] | tuple[float, ...], x: float) -> float:
    """``p(x)`` for ``p`` given highest first (the order of :func:`numpy.polyval`, on Python floats)."""
    value = 0.0
    for coefficient in coefficients:
        value = value * x + coefficient
    return value


def misfit_minima(coefficients: FloatArray, about: float = 0.0) -> tuple[FloatArray, FloatArray]:
    """``(heights, misfits)`` of the local minima of a quartic (coefficients highest first, leading one > 0).

    The stationary points are solved in ``h - about`` (pass a height near them: the coefficients
    stay of moderate size) in closed form, polished by Newton's method, and checked against
    :func:`numpy.roots` when a polished root does not make the slope vanish.  Scalar arithmetic on
    Python floats: the branch search calls this for every hypothesis of every segment.
    """
    shifted = taylor_shift([float(value) for value in coefficients], about)
    a, b, c, d, _ = shifted
    if not a > 0.0:
        return np.zeros(0), np.zeros(0)
    slope = (4.0 * a, 3.0 * b, 2.0 * c, d)
    stationary = _cubic_real_roots(*slope)
    magnitudes = [abs(value) for value in slope]
    if any(abs(_horner(slope, x)) > 1e-8 * _horner(magnitudes, abs(x)) for x in stationary):
        roots = np.roots(slope)
        stationary = [float(root.real) for root in roots if abs(root.imag) <= 1e-9 * max(1.0, abs(root))]
    minima = sorted(x for x in stationary if (12.0 * a * x + 6.0 * b) * x + 2.0 * c > 0.0)
    return np.array(minima) + about, np.array([_horner(shifted, x) for x in minima])


def moved_further(difference: FloatArray, gain: FloatArray, sigmas: FloatArray, critical: float,
                  direction: int = 0) -> bool:
    """Whether a start row's laser difference from the row before ``(3,)`` is a further move of the previous motor.

    ``gain`` ``(3,)`` is ``dl/dH`` of that motor at the row before (mm/mm), ``sigmas`` the readings'
    standard uncertainties.  The difference of two readings has variance ``2 sigma^2``; it is a move
    when a height change ``delta`` explains it (the rest within ``critical^2``, chi-square with two
    degrees of freedom read conservatively) and ``delta`` itself is beyond ``critical`` standard
    deviations.  A single faulty laser is not a move (its pattern is not the gain's), unless the
    gain is nearly that laser's alone (near level), where the seed's rule stands.  With the motor's
    recorded ``direction`` (+1 up, -1 down; 0 unknown) the height change must also go that way:
    the tetrahedron settles after the motor stopped by following it (thesis 3.5), so a difference
    that would take the pivot back is a faulty reading of the same pose, for the gate.

    Examples
    --------
    >>> gain = np.array([-0.02, -0.20, 0.19])
    >>> bool(moved_further(gain * 2.0, gain, np.full(3, 0.01), 3.29))  # 2 mm further
    True
    >>> bool(moved_further(np.array([0.0, 0.2, 0.0]), gain, np.full(3, 0.01), 3.29))  # laser b off by 0.2 mm
    False
    >>> bool(moved_further(gain * 2.0, gain, np.full(3, 0.01), 3.29, direction=-1))  # 2 mm back down
    False
    """
    weight = 1.0 / (2.0 * np.asarray(sigmas, dtype=float) ** 2)
    information = float(np.sum(weight * gain**2))
    if not information > 0:
        return False
    delta = float(np.sum(weight * gain * difference)) / information
    rest = float(np.sum(weight * (difference - gain * delta) ** 2))
    along = delta * np.sign(direction) if direction else abs(delta)
    return rest <= critical**2 and along * np.sqrt(information) > critical
