"""Internal and external reliability of a processed log, and the tip covariance that comes with them.

Influence of one reading
------------------------
In the network adjustment (:mod:`~pcmm_geo.machine.analysis.logproc.adjustment`) a change
``delta`` of reading ``i`` moves the segment heights by ``z_i delta`` with
``z_i = N^-1 a_i / sigma_i^2`` (``a_i`` the reading's row of the design matrix), and the tip of
every row ``n`` by ``s_ni delta``, ``s_ni = T_n z_i[active_n]`` (``T_n = dtip/dH``).  A fault in a
reading therefore moves its own row's tip *and* every row whose heights are solved with it:
the rows after it that hold the segment it measured, the rows before it that share that
segment, and, through the chain of held heights, the common height of all later rows (the
lasers never see it, so nothing pulls it back).  The same vectors give everything here:

* redundancy numbers ``r_i = 1 - a_i^T z_i`` (:mod:`~pcmm_geo.machine.analysis.logproc.gate`);
* the tip covariance of row ``n`` from the readings, ``sum_i sigma_i^2 s_ni s_ni^T``
  (the first-order law ``T Q T^T`` written reading by reading, ``Q = N^-1 (A^T W A) N^-1``);
* the external reliability (Baarda): the tip shift of an undetected fault of minimal detectable
  size, ``MDB_i |s_ni|``, and per row its largest over all readings,
  :attr:`~pcmm_geo.machine.analysis.logproc.ProcessedLog.tip_reliability`.  A reading that no
  test can check (``r_i = 0``, infinite MDB) that moves a row's tip makes that row's reliability
  infinite: the point is *unbounded*.

The MDB under either reading of a start row
-------------------------------------------
A start row that repeats the pose of the row before within its noise observes the same heights
(:mod:`~pcmm_geo.machine.analysis.logproc.segments`, row logic).  A fault in a reading of either
row changes their difference, and where the previous motor's laser gain ``g`` is nearly one
laser's (``c_i^2 = (g_i / sigma_i)^2 / sum_k (g_k / sigma_k)^2 > 1/2``, near the level pose)
the difference ``f e_i`` of a fault ``f`` in laser ``i`` has the pattern of a further move of
that motor for ``k sigma_i sqrt(2) / |c_i| < |f| <= k sigma_i sqrt(2) / sqrt(1 - c_i^2)``
(:func:`~pcmm_geo.machine.analysis.logproc.segments.moved_further`).  The log is then adjusted
with one more height, which absorbs part of the fault: the w-test of that reading works in the
other model, with a smaller redundancy.  The stated MDB of such a reading is the larger of its
MDBs in the two models (:func:`further_move_mdb`): a fault at least that large is found with
the stated power whichever way the rows are read.  The second model's redundancy comes from the
first's factorisation: splitting a segment at the start row adds one unknown with design
column ``b`` (the segment's column on the rows from the start row on), and
``r_i' = r_i - w_i e_i^2 / (b^T W e)`` with ``e = b - A N^-1 A^T W b``.

The calibration's covariance ``Sigma_theta`` (tetrahedron parameters,
:data:`~pcmm_geo.machine.analysis.logproc.geometry.GEOMETRY_PARAMETERS`) reaches the tips the
same way: a parameter change moves every row's lasers by ``dl/dtheta`` (a systematic error,
common to all rows), the adjustment answers with ``Y = -N^-1 A^T W dl/dtheta``, and row ``n``'s
tip moves by ``dtip/dtheta + T_n Y[active_n]``; its covariance is added to the readings' part.

Cost: one sparse solve per reading, in chunks; ``O(N R)`` for ``N`` rows and ``R`` readings
(a 600-row log: milliseconds; ``N = 10^4``: seconds).
"""

from __future__ import annotations

import warnings

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import IllConditionedWarning
from pcmm_geo.machine.analysis.logproc.adjustment import Adjustment
from pcmm_geo.machine.analysis.logproc.gate import GateLimits
from pcmm_geo.machine.analysis.logproc.segments import LogSegments

__all__ = ["SETTLING_PLAY", "Influence", "change_uncertainty", "further_move_mdb", "geometry_tip_covariance",
           "implausible_settling", "reading_influence", "warn_flags"]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

#: a tip moving less than this per mm of a reading's fault (mm/mm) counts as not moved by it
NO_EFFECT = 1e-9
#: largest height change (mm) a pivot can make while the tetrahedron settles after its motor stopped: the
#: play at the sliders (thesis 6: a pivot moved about 4 mm before the lasers followed; thesis 3.5: the
#: motors stop at their count, only the tetrahedron settles)
SETTLING_PLAY = 4.0
#: floats held at once by one chunk of the influence loop
_CHUNK_FLOATS = 4_000_000


@record
class Influence:
    """What :func:`reading_influence` returns (``R`` observed rows, ``N`` log rows).

    Attributes
    ----------
    redundancy : ndarray, shape (R, 3)
        Redundancy number of every reading (0 for readings left out).
    mdb : ndarray, shape (R, 3)
        Minimal detectable bias (mm; inf: uncontrolled or left out).
    tip_covariance : ndarray, shape (N, 3, 3) or None
        Covariance of each row's tip from the readings (mm^2).
    tip_reliability : ndarray, shape (N,) or None
        Largest tip shift of an undetected fault of MDB size in any one reading (mm).
    """

    redundancy: FloatArray
    mdb: FloatArray
    tip_covariance: FloatArray | None
    tip_reliability: FloatArray | None


def _row_gains(adjustment: Adjustment, segments: LogSegments, name: str) -> FloatArray:
    index = np.searchsorted(adjustment.rows, segments.source)
    return np.asarray(getattr(adjustment.kinematics, name))[index]


def reading_influence(
    adjustment: Adjustment, segments: LogSegments, sigmas: FloatArray, limits: GateLimits, *, tips: bool = True,
    mdb_floor: FloatArray | None = None,
) -> Influence:
    """Redundancy numbers and MDBs of all readings; with ``tips``, the tip covariance and reliability per row.

    ``sigmas`` ``(R, 3)`` are the standard uncertainties of the observed rows' readings;
    ``mdb_floor`` ``(R, 3)`` (mm), MDBs the stated ones may not be below (:func:`further_move_mdb`);
    the external reliability uses the stated MDBs.
    """
    weights = adjustment.weights.ravel()
    readings = weights.size
    redundancy = np.where(weights > 0, 1.0, 0.0)
    rows = len(segments.source)
    covariance = np.zeros((rows, 3, 3)) if tips else None
    reliability = np.zeros(rows) if tips else None
    mdb = limits.mdb(sigmas, np.ones_like(sigmas))
    if adjustment.free == 0:
        mdb = np.where(weights.reshape(-1, 3) > 0, mdb, np.inf)
        return Influence(redundancy.reshape(-1, 3), mdb, covariance, reliability)
    design = adjustment.design()
    design = design.T if isinstance(design, np.ndarray) else design.tocsc().T.tocsr()  # (free, 3R): columns a_i
    gains = _row_gains(adjustment, segments, "tip_gain") if tips else None
    sigma_flat = sigmas.ravel()
    mdb = np.full(readings, np.inf)
    chunk = max(1, _CHUNK_FLOATS // (3 * rows + adjustment.free))
    for start in range(0, readings, chunk):
        part = np.arange(start, min(start + chunk, readings))
        columns = design[:, part] if isinstance(design, np.ndarray) else design[:, part].toarray()
        shift = adjustment.solve(columns * weights[part])  # z_i (free, c)
        redundancy[part] = np.clip(1.0 - np.sum(columns * shift, axis=0), 0.0, 1.0) * (weights[part] > 0)
        mdb[part] = np.where(weights[part] > 0, limits.mdb(sigma_flat[part], redundancy[part]), np.inf)
        if mdb_floor is not None:
            mdb[part] = np.maximum(mdb[part], mdb_floor.ravel()[part])
        if gains is None or covariance is None or reliability is None:
            continue
        moved = np.concatenate([np.zeros((3, len(part))), shift])[segments.active]  # (N, 3, c)
        tip_shift = np.einsum("nij,njc->nic", gains, moved)  # tip per unit fault
        variance = np.where(weights[part] > 0, 1.0 / np.where(weights[part] > 0, weights[part], 1.0), 0.0)
        covariance += np.einsum("nic,c,njc->nij", tip_shift, variance, tip_shift)
        size = np.linalg.norm(tip_shift, axis=1)
        effective = weights[part] > 0
        with np.errstate(invalid="ignore"):
            worst = np.where((size > NO_EFFECT) & effective, size * mdb[part], 0.0)
        reliability = np.maximum(reliability, worst.max(axis=1))
    return Influence(redundancy.reshape(-1, 3), mdb.reshape(-1, 3), covariance, reliability)


def further_move_mdb(adjustment: Adjustment, segments: LogSegments, start_stop: NDArray[np.int64],
                     motor: NDArray[np.int64], redundancy: FloatArray, sigmas: FloatArray,
                     limits: GateLimits) -> FloatArray | None:
    """MDBs ``(R, 3)`` (mm; 0 where it does not apply) of the readings of a row and the start row after it that
    repeats its pose, in the model where that start row is read as a further move of the row's motor (module
    notes), for the readings whose fault can have that pattern (``c_i^2 > 1/2``); None when no row pair has one.

    ``start_stop`` and ``motor`` (1-based) are the log's columns, ``redundancy`` the readings' redundancy
    numbers in the adjustment as it stands and ``sigmas`` ``(R, 3)`` their standard uncertainties.
    """
    rows = adjustment.rows
    weights = adjustment.weights
    gains = adjustment.kinematics.laser_gain  # (R, laser, arm)
    floor = np.zeros_like(weights)
    design = None
    for index in range(len(rows) - 1):
        row, start = int(rows[index]), int(rows[index + 1])
        if start != row + 1 or start_stop[start] != 1 or segments.moved_arm[start] >= 0:
            continue
        arm = int(motor[row]) - 1
        segment = int(segments.active[start, arm])
        information = gains[index, :, arm] ** 2 * weights[index]
        with np.errstate(invalid="ignore", divide="ignore"):
            pattern = information / np.sum(information)  # c_i^2
        candidates = (pattern > 0.5) & (weights[index] > 0)
        if segment < 3 or not candidates.any():
            continue
        if design is None:
            design = adjustment.design()
        later = np.flatnonzero((rows >= start) & (segments.active[rows, arm] == segment))
        split = np.zeros_like(weights)
        split[later] = gains[later, :, arm]  # the column of the new height: the segment's from the start row on
        answer = adjustment.solve(np.asarray(design.T @ (weights * split).ravel()))
        misfit = split.ravel() - np.asarray(design @ answer).ravel()
        denominator = float(np.sum(weights.ravel() * split.ravel() * misfit))
        if not denominator > 0:
            continue
        for observed in (index, index + 1):  # the row and the start row (observed right after it)
            chosen = candidates & (weights[observed] > 0)
            other = redundancy[observed] - weights[observed] * misfit.reshape(-1, 3)[observed] ** 2 / denominator
            floor[observed] = np.where(chosen, np.maximum(floor[observed],
                                                          limits.mdb(sigmas[observed], np.clip(other, 0.0, 1.0))),
                                       floor[observed])
    return floor if floor.any() else None


def geometry_tip_covariance(adjustment: Adjustment, segments: LogSegments, covariance: FloatArray) -> FloatArray:
    """Tip covariance ``(N, 3, 3)`` of every row from the tetrahedron parameters' covariance ``(28, 28)`` (mm^2).

    Needs an adjustment made with ``geometry_gains=True``.
    """
    kinematics = adjustment.kinematics
    if kinematics.laser_geometry_gain is None or kinematics.tip_geometry_gain is None:
        raise ValueError("the adjustment holds no geometry gains (adjust(..., geometry_gains=True))")
    parameters = covariance.shape[0]
    tip_by_geometry = _row_gains(adjustment, segments, "tip_geometry_gain")  # (N, 3, P)
    if adjustment.free:
        laser_by_geometry = kinematics.laser_geometry_gain.reshape(-1, parameters)  # (3R, P)
        right = np.asarray(adjustment.design().T @ (adjustment.weights.ravel()[:, None] * laser_by_geometry))
        response = -adjustment.solve(right)  # (free, P): how the segments answer a parameter change
        moved = np.concatenate([np.zeros((3, parameters)), response])[segments.active]  # (N, 3, P)
        tip_by_geometry = tip_by_geometry + _row_gains(adjustment, segments, "tip_gain") @ moved
    return np.einsum("nip,pq,njq->nij", tip_by_geometry, covariance, tip_by_geometry)


def change_uncertainty(adjustment: Adjustment, segments: FloatArray, previous: FloatArray) -> FloatArray:
    """Standard uncertainty (mm) of the height changes ``s[segments] - s[previous]`` (indices into all segments)."""
    free = adjustment.free
    result = np.zeros(len(segments))
    if free == 0:
        return result
    chunk = max(1, _CHUNK_FLOATS // max(free, 1))
    for start in range(0, len(segments), chunk):
        part = slice(start, min(start + chunk, len(segments)))
        columns = np.zeros((free + 3, len(range(*part.indices(len(segments))))))
        index = np.arange(columns.shape[1])
        np.add.at(columns, (np.asarray(segments)[part], index), 1.0)
        np.add.at(columns, (np.asarray(previous)[part], index), -1.0)
        columns = columns[3:]  # the datum is fixed
        result[part] = np.sqrt(np.clip(np.sum(columns * adjustment.solve(columns), axis=0), 0.0, None))
    return result


def implausible_settling(adjustment: Adjustment, segments: LogSegments, start_stop: NDArray[np.int64],
                         critical: float, play: float = SETTLING_PLAY) -> NDArray[np.bool_]:
    """Segments begun by an unsettled start row whose adjusted further move exceeds ``play`` by more than
    ``critical`` of its standard uncertainty (mm), and the segments they continue.

    The row logic reads such a row as the previous motor's further move (thesis 3.5).  A stepper
    stops at its count, so what still moves is the tetrahedron settling within the play at the
    sliders; a larger further move is not settling but a reading the row logic mistook for one (a
    faulty laser near the level pose, where one laser's change reads as a large height change).
    Either row of the pair may hold it (a faulty stop row is followed by a start row that seems to
    move back).  Their first-order reliability describes the adjusted pose, not the distance to the
    true one: the rows standing on either height get no bound (``unbounded``).
    """
    births = segments.birth
    further = np.flatnonzero((segments.previous >= 0) & (births > 0) & (start_stop[births] == 1))
    implausible = np.zeros(segments.count, dtype=bool)
    if further.size == 0:
        return implausible
    change = np.abs(adjustment.values[further] - adjustment.values[segments.previous[further]])
    suspects = further[change > play]
    if suspects.size:
        sigma = change_uncertainty(adjustment, suspects, segments.previous[suspects])
        excess = np.abs(adjustment.values[suspects] - adjustment.values[segments.previous[suspects]]) - play
        flagged = suspects[excess > critical * sigma]
        implausible[flagged] = True
        implausible[segments.previous[flagged]] = True  # the stop row before may hold the faulty reading
    return implausible


def warn_flags(ambiguous: BoolArray, ambiguity: FloatArray, unbounded: BoolArray, contradicted: BoolArray,
                settling: BoolArray) -> None:
    """One :class:`~pcmm_geo.errors.IllConditionedWarning` per kind of row whose bound is wide or not stated."""
    if ambiguous.any():
        warnings.warn(
            f"{int(ambiguous.sum())} of {len(ambiguous)} log rows are ambiguous: another pose (the mirror image about "
            f"the level of the other pivots) fits the lasers and the motor directions as well, its tip up to "
            f"{float(ambiguity[ambiguous].max()):.3g} mm away; their bound includes it",
            IllConditionedWarning, stacklevel=3,
        )
    if unbounded.any():
        warnings.warn(
            f"{int(unbounded.sum())} of {len(unbounded)} log rows are unbounded: a reading that no test can check "
            "(redundancy number 0) moves their tip, so an undetected fault of any size would",
            IllConditionedWarning, stacklevel=3,
        )
    if contradicted.any():
        warnings.warn(
            f"{int(contradicted.sum())} of {len(contradicted)} log rows stand on a height that moved against its "
            "recorded motor direction: the pose is on the wrong branch (mirror image) or the direction flag is "
            "wrong; no bound is stated for them",
            IllConditionedWarning, stacklevel=3,
        )
    if settling.any():
        warnings.warn(
            f"{int(settling.sum())} of {len(settling)} log rows stand on an unsettled start row read as a further move "
            f"beyond the settling play ({SETTLING_PLAY:g} mm): likely a faulty reading; no bound is stated for them",
            IllConditionedWarning, stacklevel=3,
        )
