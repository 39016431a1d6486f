"""Poses the lasers cannot tell apart: other branches that fit as well and moved the recorded way.

The lasers see squared height differences, so a pivot height ``h`` and its mirror image about
the level of the pivots it stands with give (nearly) the same readings
(:mod:`~pcmm_geo.machine.analysis.logproc.geometry`).  The recorded motor ``direction`` picks
between them when only one of the two moved that way; rows after the move, where the other
pivots stand at other heights, usually tell them apart too.  Near the level pose neither may:
e.g. a pivot 3 mm above two level pivots moved down, to +1 or to -1 mm, both down.

Two checks, both after the network adjustment.  :func:`competing_fits` adjusts the runner-up
hypotheses of the branch search (:mod:`~pcmm_geo.machine.analysis.logproc.branches`: whole sets
of branches, each as consistent with the directions as the best) and accepts one as a genuine
alternative when its weighted sum of squares exceeds the best one's by less than the square of
the w-test's critical value; every row whose tip differs between the two is ambiguous, by that
distance.  (One that fits better by more than that replaces the best.)
:func:`find_ambiguities` takes every adjusted segment in turn, holds the others, and writes the
misfit of all rows that observe it as a quartic in its height
(:func:`~pcmm_geo.machine.analysis.logproc.segments.segment_misfit`).  The heights whose misfit
exceeds the adjusted one by less than the square of the w-test's critical value, and that agree
with the directions of the move that began the segment and of the arm's next move (moved that
way, or not at all), are what the data allow.  Where the first-order model holds, they reach
``critical * sigma`` either side.  Where they reach more than :data:`NONLINEAR` times that -- a
mirror branch within reach, or a turning point making the interval lopsided -- the
first-order uncertainty understates what is known: the segment is *ambiguous*.  Its far end,
carried to the other heights through their covariance with it (linearly) and to the tips,
gives every affected row its ``ambiguity`` (mm), the distance the tip could be from the stated
one; the stated bound of such a point includes it.  Holding the other segments makes the check
local; :func:`competing_fits` covers whole alternative sets of branches.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.machine.analysis.logproc.adjustment import Adjustment, adjust
from pcmm_geo.machine.analysis.logproc.branches import Hypothesis
from pcmm_geo.machine.analysis.logproc.geometry import joint_distances
from pcmm_geo.machine.analysis.logproc.rows import MeasurementLog
from pcmm_geo.machine.analysis.logproc.segments import (
    STILL,
    LogSegments,
    reading_weights,
    segment_misfit,
    taylor_shift,
)
from pcmm_geo.machine.kinematics import pose_solver as solver

__all__ = ["MAX_COMPETITORS", "competing_fits", "find_ambiguities"]

#: runner-up hypotheses of the branch search that are adjusted and compared
MAX_COMPETITORS = 3
#: iterations allowed to a competitor's adjustment (one that needs more is not a close rival)
COMPETITOR_ITERATIONS = 15

FloatArray = NDArray[np.float64]

#: a height whose misfit interval reaches this many times farther than the first-order one is ambiguous
NONLINEAR = 1.5


def _admissible(segments: LogSegments, values: FloatArray, segment: int) -> tuple[float, float]:
    """The heights ``[low, high]`` a segment may take without contradicting its move's direction or the next one's."""
    low, high = -np.inf, np.inf
    previous, direction = float(values[segments.previous[segment]]), int(segments.direction[segment])
    if direction > 0:
        low = previous - STILL
    elif direction < 0:
        high = previous + STILL
    following = int(segments.following[segment])
    if following >= 0:
        after, next_direction = float(values[following]), int(segments.direction[following])
        if next_direction > 0:
            high = min(high, after + STILL)
        elif next_direction < 0:
            low = max(low, after - STILL)
    return low, high


def _reach(coefficients: FloatArray, estimate: float, critical: float, low: float, high: float) -> float:
    """Signed shift from ``estimate`` to the farthest height in ``[low, high]`` with a misfit within ``critical^2``."""
    level = float(np.polyval(coefficients, estimate)) + critical**2
    shifted = np.array(taylor_shift([float(value) for value in coefficients], estimate))  # in s - estimate
    shifted[-1] -= level
    roots = np.roots(shifted) if np.any(shifted[:-1]) else np.zeros(0)
    ends = [r.real + estimate for r in roots if abs(r.imag) <= 1e-9 * max(1.0, abs(r))]
    ends += [bound for bound in (low, high) if np.isfinite(bound) and np.polyval(coefficients, bound) <= level]
    ends = [end for end in ends if low - 1e-9 <= end <= high + 1e-9]
    if not ends:
        return 0.0
    far = max(ends, key=lambda end: abs(end - estimate))
    return float(far - estimate)


def find_ambiguities(
    geometry: solver.Geometry,
    log: MeasurementLog,
    segments: LogSegments,
    adjustment: Adjustment,
    sigmas: FloatArray,
    critical: float,
) -> tuple[FloatArray, FloatArray]:
    """``(shift (S,), ambiguity (N,))``: per segment the reach of its misfit interval beyond the first-order one
    (0: linear enough), and per row the largest tip shift (mm) that such a segment's far end causes.

    ``sigmas`` ``(N, 3)``: standard uncertainty of every reading (``inf``: left out).  See the module
    notes: heights whose misfit stays within ``critical^2`` over a range more than
    :data:`NONLINEAR` times the first-order ``critical * sigma`` (a mirror branch within reach, or a
    lopsided interval at a turning point) are ambiguous; the far end of that range moves the
    other heights as their covariance with it says, and every row's tip with them.
    """
    values = adjustment.values
    observed = adjustment.rows
    kept = np.isfinite(sigmas[observed])  # a reading left out: the lasers that fit the heights stand in for it
    distances, gradients = joint_distances(geometry, np.where(kept, log.lasers[observed],
                                                              adjustment.kinematics.lasers))
    weights = reading_weights(distances, gradients, sigmas[observed])
    shift = np.zeros(segments.count)
    undetermined = adjustment.undetermined
    for segment in range(3, segments.count):
        if undetermined[segment - 3]:
            continue
        arm = int(segments.arm[segment])
        rows = np.flatnonzero(segments.active[observed, arm] == segment)
        if rows.size == 0:
            continue
        coefficients = segment_misfit(geometry, distances[rows], weights[rows], values[segments.active[observed[rows]]],
                                      arm)
        estimate = float(values[segment])
        curvature = float(np.polyval(np.polyder(coefficients, 2), estimate))
        linear = critical * np.sqrt(2.0 / curvature) if curvature > 0 else np.inf
        reach = _reach(coefficients, estimate, critical, *_admissible(segments, values, segment))
        if abs(reach) > NONLINEAR * linear:
            shift[segment] = reach
    ambiguity = np.zeros(len(segments.source))
    flagged = np.flatnonzero(shift)
    if flagged.size == 0:
        return shift, ambiguity
    unit = np.zeros((adjustment.free, flagged.size))
    unit[flagged - 3, np.arange(flagged.size)] = 1.0
    columns = np.concatenate([np.zeros((3, flagged.size)), adjustment.solve(unit)])  # Q[:, q]
    moved = columns / columns[flagged, np.arange(flagged.size)] * shift[flagged]  # others re-adjusted, linear
    gains = adjustment.kinematics.tip_gain[np.searchsorted(observed, segments.source)]
    tips = np.einsum("nij,njq->niq", gains, moved[segments.active])  # (N, 3, flagged)
    ambiguity = np.linalg.norm(tips, axis=1).max(axis=1)
    return shift, ambiguity


def _cost(adjustment: Adjustment) -> float:
    return float(np.sum(adjustment.weights * adjustment.residuals**2))


def competing_fits(
    geometry: solver.Geometry,
    log: MeasurementLog,
    segments: LogSegments,
    sigmas: FloatArray,
    hypotheses: list[Hypothesis],
    best: Adjustment,
    critical: float,
    *,
    geometry_gains: bool = False,
) -> tuple[Adjustment, FloatArray]:
    """``(adjustment, ambiguity (N,))``: the best-fitting adjusted hypothesis and per row the largest distance (mm)
    from its tip to the tip of a competing fit within ``critical^2`` of it (module notes).

    ``best`` is the adjustment of ``hypotheses[0]``.
    """
    ambiguity = np.zeros(len(segments.source))
    if len(hypotheses) < 2:
        return best, ambiguity
    leader = hypotheses[0]
    rivals: list[Hypothesis] = []
    for hypothesis in sorted(hypotheses[1:], key=lambda h: h.score):
        if hypothesis.violations > leader.violations:
            continue
        if any(np.max(np.abs(hypothesis.values - other.values)) <= 1e-3 for other in [leader, *rivals]):
            continue
        rivals.append(hypothesis)
        if len(rivals) == MAX_COMPETITORS:
            break
    fits = [best]
    for hypothesis in rivals:
        fitted = adjust(geometry, log, segments, hypothesis.values, sigmas, geometry_gains=geometry_gains,
                        max_iterations=COMPETITOR_ITERATIONS)
        if fitted.converged:
            fits.append(fitted)
    costs = [_cost(fit) for fit in fits]
    winner = fits[int(np.argmin(costs))] if min(costs) < costs[0] - critical**2 else best
    source = np.searchsorted(best.rows, segments.source)
    tips = winner.kinematics.tips[source]
    for fit, cost in zip(fits, costs, strict=True):
        if fit is winner or cost > _cost(winner) + critical**2:
            continue
        ambiguity = np.maximum(ambiguity, np.linalg.norm(fit.kinematics.tips[source] - tips, axis=1))
    return winner, ambiguity
