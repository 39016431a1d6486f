"""Starting values of a log's heights: the branches (mirror images) that fit the lasers and the motor directions.

A moved height usually has two values that fit its row's lasers, mirror images about the level
of the two held pivots (:mod:`~pcmm_geo.machine.analysis.logproc.segments`).  Far from that
level the wrong one fits far worse; near it both fit, and only the recorded ``direction`` of the
move (+1 up, -1 down) and the rows after it can tell them apart.  A wrong branch is not a small
error: every height measured against it later is wrong too, by millimetres.

:func:`branch_hypotheses` walks the log once, holding earlier heights, and keeps a beam of
:data:`BEAM` hypotheses.  For each new segment every hypothesis branches into the minima of the
row's misfit (a quartic in the height, solved in closed form) that fit within the gate's critical
value of the row's best; a hypothesis scores the sum of its rows' misfits (chi-square units),
plus :data:`DIRECTION_PENALTY` for each move that went against its recorded direction (by more
than 1 um) and :data:`STILL_PENALTY` for a stop row whose pivot did not move.  A wrong branch
taken where both fit shows a few rows later: heights measured against it contradict their
directions or their lasers, and a hypothesis that kept the right branch wins.  Two
hypotheses that reach the same heights have the same future, so only the better one goes on
(Viterbi): the beam holds distinct present states, and a pivot moving about the level of two
standing ones does not multiply them.  The best hypothesis starts the network adjustment; the
runners-up that fit within the critical value and agree with the directions as well are the
*competing fits* that :mod:`~pcmm_geo.machine.analysis.logproc.ambiguity` adjusts and compares
(another complete set of branches that fits the lasers and the directions is a genuine
ambiguity).

A row whose lasers miss the held heights grossly (misfit above :data:`GROSS` times the squared
critical value: a reading far off) starts from the best height with one of its readings left
out, so that a gross error does not pull the heights measured after it onto another branch; the
gate still tests every reading.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.machine.analysis.logproc.geometry import joint_distances
from pcmm_geo.machine.analysis.logproc.rows import MeasurementLog
from pcmm_geo.machine.analysis.logproc.segments import (
    STILL,
    LogSegments,
    misfit_minima,
    reading_weights,
    segment_misfit,
)
from pcmm_geo.machine.kinematics import pose_solver as solver

__all__ = ["BEAM", "Hypothesis", "branch_hypotheses"]

FloatArray = NDArray[np.float64]

#: hypotheses (distinct present states) kept while walking the log
BEAM = 8
#: alternative pasts recorded when two hypotheses reach the same state with scores within the gate
MAX_RIVALS = 16
#: score of a move against its recorded direction (chi-square units)
DIRECTION_PENALTY = 50.0
#: score of a stop row whose pivot did not move (contact may hold a stage; rarely)
STILL_PENALTY = 1.0
#: two hypotheses whose present heights agree within this (mm) are in the same state and are merged: far
#: below any height a log resolves (laser steps of um), far above the rounding of the closed-form minima
#: (1e-10 mm), so that no merge depends on the last bits of a height (a key rounded to 1e-9 mm did)
SAME_STATE = 1e-6
#: a row misfit this many times the squared critical value is a gross error (starting values only)
GROSS = 1e4


@record
class Hypothesis:
    """One set of branches: segment heights ``values`` (S,), its ``score`` and ``violations`` (moves against their
    recorded direction); ``agrees`` (S,) marks the segments whose move agrees with its direction."""

    values: FloatArray
    score: float
    violations: int
    agrees: NDArray[np.bool_]
    forks: tuple[int, ...] = ()  # segments where another branch fitted within the critical value and agreed too


def _stand_ins(lasers: FloatArray, sigmas: FloatArray) -> FloatArray:
    """Lasers with each reading left out replaced by the arm's last reading kept (or its first).

    A reading left out has no weight, but the joint distances it enters still set the point
    where the misfit is linearised: a reading far off must not set it.
    """
    kept = np.isfinite(sigmas)
    filled = lasers.copy()
    for arm in range(3):
        good = np.flatnonzero(kept[:, arm])
        if good.size == 0 or good.size == len(lasers):
            continue
        last = good[np.clip(np.searchsorted(good, np.arange(len(lasers)), side="right") - 1, 0, None)]
        filled[~kept[:, arm], arm] = lasers[last[~kept[:, arm]], arm]
    return filled


def _reachable(candidates: FloatArray, misfits: FloatArray,
               reach: FloatArray | None) -> tuple[FloatArray, FloatArray]:
    if reach is None:
        return candidates, misfits
    inside = (candidates >= reach[0]) & (candidates <= reach[1])
    return candidates[inside], misfits[inside]


def _options(candidates: FloatArray, misfits: FloatArray, previous: float, direction: int,
             critical: float) -> list[tuple[float, float, bool]]:
    """``(height, score, agrees)`` of the minima that fit within ``critical^2`` of the row's best."""
    best = float(misfits.min())
    options = []
    for height, misfit in zip(candidates, misfits, strict=True):
        if misfit > best + critical**2:
            continue
        change = float(height - previous)
        agrees = direction == 0 or change * direction > -STILL
        score = float(misfit) - best + (0.0 if agrees else DIRECTION_PENALTY)
        if direction != 0 and abs(change) <= STILL:
            score += STILL_PENALTY
        options.append((float(height), score, agrees))
    return options


def _without_one_reading(
    geometry: solver.Geometry, distances: FloatArray, gradients: FloatArray, sigmas: FloatArray, heights: FloatArray,
    arm: int, previous: float, reach: FloatArray | None,
) -> float | None:
    """The height of the best fit with one of the row's readings left out, or None (module notes)."""
    best_misfit, best = np.inf, None
    for left_out in range(3):
        reduced = sigmas.copy()
        reduced[left_out] = np.inf
        weights = reading_weights(distances[None], gradients[None], reduced[None])
        coefficients = segment_misfit(geometry, distances[None], weights, heights[None], arm)
        candidates, misfits = _reachable(*misfit_minima(coefficients, previous), reach)
        if candidates.size and float(misfits.min()) < best_misfit:
            best_misfit, best = float(misfits.min()), float(candidates[np.argmin(misfits)])
    return best


def _completed(rival: Hypothesis, kept: Hypothesis, segment: int,
               finals: list[Hypothesis]) -> Hypothesis | None:
    """A past merged into ``kept`` at ``segment``, completed with the future of ``kept``'s best surviving descendant.

    Both reached the same state, so they share that future; its score and violations are added
    to the rival's.  None when no descendant of ``kept`` survived the beam.
    """
    past = slice(0, segment + 1)
    for final in finals:  # best first; a descendant carries kept's values up to the merge unchanged
        if np.array_equal(final.values[past], kept.values[past]) and final.forks[:len(kept.forks)] == kept.forks:
            values = np.concatenate([rival.values[past], final.values[segment + 1:]])
            agrees = np.concatenate([rival.agrees[past], final.agrees[segment + 1:]])
            return Hypothesis(values, rival.score + final.score - kept.score,
                              rival.violations + final.violations - kept.violations, agrees,
                              rival.forks + final.forks[len(kept.forks):])
    return None


def branch_hypotheses(
    geometry: solver.Geometry,
    log: MeasurementLog,
    segments: LogSegments,
    datum: FloatArray,
    sigmas: FloatArray,
    critical: float,
    travel: FloatArray | None = None,
    beam: int = BEAM,
    avoid: tuple[int, float] | None = None,
    progress: Callable[[int], None] | None = None,
) -> list[Hypothesis]:
    """The best hypothesis of all segment heights, then its competitors (module notes).

    Two hypotheses that reach the same heights on a row have the same future; only the better one
    walks on (a Viterbi merge), and the other is kept as a competitor when it is as consistent with
    the directions and its score is within ``critical^2``.  Competitors are also the surviving
    hypotheses at the end that meet the same conditions.

    ``sigmas`` ``(N, 3)``: standard uncertainty of every reading (``inf``: left out); ``travel``
    ``(3, 2)`` the height readings each column can reach (minima beyond it are not candidates).
    A segment whose first row has no reading left starts at the arm's previous height.
    ``avoid = (segment, height)`` drops that segment's branch at ``height`` (1 um): the best
    hypothesis that takes another branch there.  ``progress(row)`` is called as each segment's first
    row is reached.
    """
    start = np.zeros(segments.count)
    start[:3] = datum
    hypotheses = [Hypothesis(start, 0.0, 0, np.ones(segments.count, dtype=bool))]
    rows = segments.birth[3:]
    distances, gradients = joint_distances(geometry, _stand_ins(log.lasers, sigmas)[rows])
    weights = reading_weights(distances, gradients, sigmas[rows])
    rivals: list[tuple[Hypothesis, Hypothesis, int]] = []
    for offset, segment in enumerate(range(3, segments.count)):
        row, arm = int(segments.birth[segment]), int(segments.arm[segment])
        if progress is not None:
            progress(row)
        direction = int(segments.direction[segment])
        reach = None if travel is None else travel[arm]
        usable = np.isfinite(sigmas[row]).any()
        heights = np.array([h.values[segments.active[row]] for h in hypotheses])
        if usable:
            count = len(hypotheses)
            quartics = segment_misfit(geometry, np.repeat(distances[offset:offset + 1], count, axis=0),
                                      np.repeat(weights[offset:offset + 1], count, axis=0), heights, arm, per_row=True)
        grown: list[Hypothesis] = []
        for index, hypothesis in enumerate(hypotheses):
            previous = float(hypothesis.values[segments.previous[segment]])
            options: list[tuple[float, float, bool]] = [(previous, 0.0, True)]
            if usable:
                candidates, misfits = _reachable(*misfit_minima(quartics[index], previous), reach)
                if candidates.size and float(misfits.min()) > GROSS * critical**2 and np.isfinite(
                        sigmas[row]).all():
                    robust = _without_one_reading(geometry, distances[offset], gradients[offset], sigmas[row],
                                                  heights[index], arm, previous, reach)
                    if robust is not None:
                        candidates, misfits = np.array([robust]), np.array([float(np.polyval(quartics[index],
                                                                                               robust))])
                if candidates.size:
                    options = _options(candidates, misfits, previous, direction, critical)
            if avoid is not None and avoid[0] == segment:
                options = [option for option in options if abs(option[0] - avoid[1]) > STILL]
            forked = sum(agrees for _, _, agrees in options) > 1
            for height, score, agrees in options:
                values = hypothesis.values.copy()
                values[segment] = height
                agreement = hypothesis.agrees.copy()
                agreement[segment] = agrees
                grown.append(Hypothesis(values, hypothesis.score + score, hypothesis.violations + int(not agrees),
                                        agreement, hypothesis.forks + ((segment,) if forked else ())))
        grown.sort(key=lambda h: h.score)
        hypotheses = []
        states: list[FloatArray] = []
        for hypothesis in grown:  # one hypothesis per present state: it has the same future as any other
            state = hypothesis.values[segments.active[row]]
            same = [i for i, other in enumerate(states) if np.max(np.abs(state - other)) <= SAME_STATE]
            if not same:
                states.append(state)
                hypotheses.append(hypothesis)
                continue
            kept = hypotheses[same[0]]
            if (hypothesis.violations == kept.violations and hypothesis.score - kept.score <= critical**2
                    and len(rivals) < MAX_RIVALS):
                rivals.append((hypothesis, kept, segment))  # another past that explains the log as well
        hypotheses = hypotheses[:beam]
    if not hypotheses:
        return []
    final = hypotheses[0]
    completed = [whole for whole in (_completed(*rival, hypotheses) for rival in rivals) if whole is not None]
    alternatives = [h for h in hypotheses[1:] + completed if h.violations <= final.violations
                    and h.score - final.score <= critical**2]
    return [final, *alternatives]
