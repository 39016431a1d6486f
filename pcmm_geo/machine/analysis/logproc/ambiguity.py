"""Poses the lasers cannot tell apart: another branch of a segment that fits as well and moved the recorded way.

The lasers see squared height differences, so a pivot height ``h`` and its mirror image about
the level of the pivots it stands with give (nearly) the same readings
(:mod:`~pcmm_geo.machine.analysis.logproc.geometry`).  The recorded motor ``direction`` picks
between them when only one of the two moved that way; rows after the move, where the other
pivots stand at other heights, usually tell them apart too.  Near the level pose neither may:
e.g. a pivot 3 mm above two level pivots moved down, to +1 or to -1 mm, both down.

:func:`find_ambiguities` takes every adjusted segment in turn, holds the others, and looks for
the minima of the misfit of all rows that observe it (a quartic in its height,
:func:`~pcmm_geo.machine.analysis.logproc.segments.segment_misfit`).  Another minimum is a
*genuine ambiguity* when its misfit exceeds the adjusted one by less than the square of the
w-test's critical value (the data cannot reject it at ``alpha0``) and it agrees with the
directions of the move that began the segment and of the arm's next move (moved that way, or
not at all).  The rows on which that segment stands are then flagged ``ambiguous``; their
``ambiguity`` is the distance from the stated tip to the tip of the other branch (mm), which
the stated bound of such a point includes.  Holding the other segments makes the check a
local one: a branch that fits only when several segments change together is not searched.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.machine.analysis.logproc.adjustment import Adjustment
from pcmm_geo.machine.analysis.logproc.geometry import joint_distances, row_kinematics
from pcmm_geo.machine.analysis.logproc.rows import MeasurementLog
from pcmm_geo.machine.analysis.logproc.segments import (
    STILL,
    LogSegments,
    misfit_minima,
    reading_weights,
    segment_misfit,
)
from pcmm_geo.machine.kinematics import _pose_solver as solver

__all__ = ["find_ambiguities"]

FloatArray = NDArray[np.float64]

#: minima closer than this (mm) are the same branch
_SAME = 1e-6


def _agrees(change: float, direction: int) -> bool:
    return direction == 0 or change * direction > -STILL


def find_ambiguities(
    geometry: solver.Geometry,
    log: MeasurementLog,
    segments: LogSegments,
    adjustment: Adjustment,
    sigmas: FloatArray,
    critical: float,
) -> tuple[FloatArray, FloatArray]:
    """``(alternative (S,), ambiguity (N,))``: another admissible height per segment (NaN: none) and per row the
    largest distance (mm) from its tip to a tip with one ambiguous segment on its other branch (0: none).

    ``sigmas`` ``(N, 3)``: standard uncertainty of every reading (``inf``: left out).
    """
    values = adjustment.values
    observed = adjustment.rows
    distances, gradients = joint_distances(geometry, log.lasers[observed])
    weights = reading_weights(distances, gradients, sigmas[observed])
    alternative = np.full(segments.count, np.nan)
    for segment in range(3, segments.count):
        arm = int(segments.arm[segment])
        rows = np.flatnonzero(segments.active[observed, arm] == segment)
        if rows.size == 0:
            continue
        coefficients = segment_misfit(geometry, distances[rows], weights[rows], values[segments.active[observed[rows]]],
                                      arm)
        minima, misfits = misfit_minima(coefficients, float(values[segment]))
        if minima.size < 2:
            continue
        estimate = float(np.polyval(coefficients, values[segment]))
        previous = float(values[segments.previous[segment]])
        following = int(segments.following[segment])
        best = np.inf
        for height, misfit in zip(minima, misfits, strict=True):
            if abs(height - values[segment]) <= max(_SAME, 1e-9 * abs(height)) or misfit - estimate > critical**2:
                continue
            if not _agrees(height - previous, int(segments.direction[segment])):
                continue
            if following >= 0 and not _agrees(values[following] - height, int(segments.direction[following])):
                continue
            if misfit < best:
                best, alternative[segment] = misfit, height
    ambiguity = np.zeros(len(segments.source))
    flagged = np.flatnonzero(np.isfinite(alternative))
    if flagged.size == 0:
        return alternative, ambiguity
    row_index, arms = np.nonzero(np.isin(segments.active, flagged))  # one entry per (row, ambiguous segment)
    heights = values[segments.active[row_index]].copy()
    heights[np.arange(row_index.size), arms] = alternative[segments.active[row_index, arms]]
    source = np.searchsorted(observed, segments.source[row_index])
    other = row_kinematics(geometry, heights, adjustment.kinematics.lasers[source])
    distance = np.linalg.norm(other.tips - adjustment.kinematics.tips[source], axis=1)
    np.maximum.at(ambiguity, row_index, np.where(other.converged, distance, np.inf))
    return alternative, ambiguity
