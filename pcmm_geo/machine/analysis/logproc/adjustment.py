"""Network adjustment of a log: every segment height from every laser reading at once (Gauss-Markov).

Model
-----
Observations: the laser readings of the observed rows, ``l_rj`` (row ``r``, arm ``j``),
independent with standard uncertainties ``sigma_j`` (:mod:`~pcmm_geo.machine.analysis.logproc.gate`).
Unknowns: the segment heights ``s`` (:mod:`~pcmm_geo.machine.analysis.logproc.segments`); the
three datum segments are fixed at the start heights.  Functional model ``l_r = f(H_r) + e_r``
with ``H_r = s[active_r]`` and ``f`` the lasers that fit the heights
(:func:`~pcmm_geo.machine.analysis.logproc.geometry.lasers_for_heights`).  Linearised, row
``r`` contributes ``F_r = dl/dH`` to the three columns of its standing segments: the design
matrix ``A`` is sparse (three segments per row), and so are the normal equations
``N = A^T W A`` (``W = diag(1/sigma^2)``) of a long log.

Gauss-Newton from the starting values of
:func:`~pcmm_geo.machine.analysis.logproc.branches.branch_hypotheses` (from the third iteration
on Newton's step with the second-order term where it is a descent direction: a height at the
turning point of its mirror images, with the lasers just beyond it, is a minimum Gauss-Newton
only crawls towards), with step halving when the weighted sum of squares grows; converged when
``step^T N step <= 1e-6``, i.e. every segment's step is below 1e-3 of its standard uncertainty
(Cauchy-Schwarz), or every step below 1e-10 mm,
or three steps in a row lower the weighted sum of squares by less than 1e-3 (a flat valley
along a height near its turning point, where the remaining moves are a few hundredths of its
standard uncertainty).
The step is computed and then taken, so the result is within that of the optimum.  The
solution is the least-squares estimate of all segments from all readings: a height that
stands over several rows is measured by each of them, which is where a single reading gets
its redundancy (the lasers of the row that moved a pivot tell its new height; the rows after
it, while it stands, check it).

A weak prior of :data:`PRIOR_SIGMA` (1000 mm) on every segment, centred on the current value
(so it never pulls the solution), keeps ``N`` regular where the lasers see a segment not at all
(a pivot at the exact turning point of its mirror images, a segment whose readings were all
left out); such a segment is *undetermined* (:attr:`Adjustment.undetermined`) and its rows get
no finite uncertainty.

Examples
--------
>>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
>>> from pcmm_geo.machine.analysis.logproc.segments import segment_log
>>> from pcmm_geo.machine.analysis.logproc.synthesis import synthesise_log
>>> m = RigidBodyMachine.from_dpkm()
>>> start = m.reference_heights + [0.0, 60.0, -50.0]
>>> log = synthesise_log(m, start, [(1, 5.0, True), (2, -4.0, True)])
>>> segments = segment_log(log)
>>> guess = np.r_[start, start[0] + 4.0, start[1] - 3.0]  # 1 mm off each
>>> result = adjust(m.geometry, log, segments, guess, np.full((len(log), 3), 0.03))
>>> np.round(result.values[3:] - start[:2], 9).tolist(), result.converged
([5.0, -4.0], True)
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.machine.analysis.logproc.geometry import RowKinematics, row_kinematics
from pcmm_geo.machine.analysis.logproc.rows import MeasurementLog
from pcmm_geo.machine.analysis.logproc.segments import LogSegments
from pcmm_geo.machine.kinematics import pose_solver as solver

__all__ = ["PRIOR_SIGMA", "Adjustment", "adjust"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: standard deviation of the weak prior on every segment (mm); a segment known no better is undetermined
PRIOR_SIGMA = 1000.0
MAX_ITERATIONS = 60
#: converged when every step is below this fraction of the segment's standard uncertainty ...
STEP_FRACTION = 1e-3
#: ... or when three steps in a row lower the weighted sum of squares by less than this (a flat valley)
STALL = 1e-3
#: ... or below this (mm)
STEP_FLOOR = 1e-10
_MAX_STEP = 20.0  # mm per iteration: a trust region for starts far off
_DENSE_LIMIT = 4_000_000  # entries of the design matrix up to which it is held dense


@record
class Adjustment:
    """Result of :func:`adjust` (``R`` observed rows, ``S`` segments, the first three fixed).

    Attributes
    ----------
    values : ndarray, shape (S,)
        Segment heights (mm).
    rows : ndarray of int, shape (R,)
        The observed rows (indices into the log).
    active : ndarray of int, shape (R, 3)
        Segments standing on each observed row.
    kinematics : RowKinematics
        Fitted lasers, tips and gains of the observed rows.
    residuals : ndarray, shape (R, 3)
        Laser corrections ``v = l - f(H)`` (mm), also of readings left out.
    weights : ndarray, shape (R, 3)
        ``1/sigma^2`` of each reading (0: left out).
    converged : bool
    iterations : int
    """

    values: FloatArray
    rows: IntArray
    active: IntArray
    kinematics: RowKinematics
    residuals: FloatArray
    weights: FloatArray
    converged: bool
    iterations: int
    normal: _Normal | None

    @property
    def free(self) -> int:
        """Number of unknown segments (datum excluded)."""
        return int(len(self.values) - 3)

    def design(self) -> Any:
        """The design matrix ``A`` (``3 R x free``; dense, or scipy.sparse CSR for long logs): ``dl_rj / ds``."""
        return _design(self.kinematics.laser_gain, self.active, self.free)

    def solve(self, right: FloatArray) -> FloatArray:
        """``(N + prior)^-1 right`` for ``right`` of shape (free,) or (free, k)."""
        assert self.normal is not None
        return self.normal.solve(np.asarray(right, dtype=float))

    @property
    def undetermined(self) -> NDArray[np.bool_]:
        """Free segments the lasers do not determine to better than :data:`PRIOR_SIGMA` (shape (free,))."""
        if self.normal is None:
            return np.zeros(0, dtype=bool)
        information = self.normal.diagonal - 1.0 / PRIOR_SIGMA**2
        return ~(information > 1.0 / PRIOR_SIGMA**2)


class _Normal:
    """Normal equations ``A^T W A + prior`` of the free segments, factorised (dense Cholesky or sparse LU)."""

    def __init__(self, design: Any, weights: FloatArray, curvature: Any = None, blocks: Any = None) -> None:
        if blocks is not None:  # dense: summed from each row's 3 x 3 block (small logs; no threaded BLAS)
            gains, active = blocks
            per_row = np.einsum("rja,rj,rjb->rab", gains, weights, gains)
            rows = np.repeat(active[:, :, None], 3, axis=2) - 3
            columns = np.repeat(active[:, None, :], 3, axis=1) - 3
            keep = (rows >= 0) & (columns >= 0)
            matrix = np.zeros((design.shape[1], design.shape[1]))
            np.add.at(matrix, (rows[keep], columns[keep]), per_row[keep])
        else:
            weighted = design.T * weights.ravel() if isinstance(design, np.ndarray) else design.T.multiply(
                weights.ravel()).tocsr()
            matrix = weighted @ design
        if curvature is not None:
            matrix = matrix - curvature
        if isinstance(matrix, np.ndarray):
            from scipy.linalg import cho_factor

            matrix = matrix + np.eye(len(matrix)) / PRIOR_SIGMA**2
            self.diagonal = np.diagonal(matrix).copy()
            self._dense = cho_factor(matrix, check_finite=False)
            self._sparse = None
        else:
            from scipy.sparse import identity
            from scipy.sparse.linalg import splu

            matrix = (matrix + identity(matrix.shape[0]) / PRIOR_SIGMA**2).tocsc()
            self.diagonal = np.asarray(matrix.diagonal())
            self._sparse = splu(matrix)
            self._dense = None
        self.matrix = matrix

    def solve(self, right: FloatArray) -> FloatArray:
        if self._dense is not None:
            from scipy.linalg import cho_solve

            return np.asarray(cho_solve(self._dense, right, check_finite=False))
        assert self._sparse is not None
        return np.asarray(self._sparse.solve(right))


def _curvature(geometry: solver.Geometry, kinematics: RowKinematics, heights: FloatArray, active: IntArray,
               weights: FloatArray, residuals: FloatArray, free: int, dense: bool) -> Any:
    """``sum_rj w_rj v_rj d2l_rj/ds ds`` (free x free): the second-order part of the sum of squares' Hessian.

    Gauss-Newton leaves it out; it matters where the lasers' derivative by a height vanishes while
    the residual does not (a height at the turning point of its mirror images, the lasers just
    beyond it), where Gauss-Newton crawls.  Forward differences of the analytic ``dl/dH``.
    """
    step = 1e-4
    count = len(heights)
    shifted = np.tile(heights, (3, 1))  # the three shifts at once: rows of arm 0, then 1, then 2
    shifted.reshape(3, count, 3)[np.arange(3), :, np.arange(3)] += step
    gains = row_kinematics(geometry, shifted, np.tile(kinematics.lasers, (3, 1))).laser_gain.reshape(3, count, 3, 3)
    second = np.moveaxis((gains - kinematics.laser_gain) / step, 0, -1)  # row, laser, arm a, arm b
    blocks = np.einsum("rj,rjab->rab", weights * residuals, 0.5 * (second + second.transpose(0, 1, 3, 2)))
    rows = np.repeat(active[:, :, None], 3, axis=2) - 3
    columns = np.repeat(active[:, None, :], 3, axis=1) - 3
    keep = (rows >= 0) & (columns >= 0)
    if dense:
        matrix = np.zeros((free, free))
        np.add.at(matrix, (rows[keep], columns[keep]), blocks[keep])
        return matrix
    from scipy.sparse import csr_matrix

    return csr_matrix((blocks[keep], (rows[keep], columns[keep])), shape=(free, free))


def _gradient(gains: FloatArray, active: IntArray, weighted_residuals: FloatArray, free: int) -> FloatArray:
    """``A^T W v`` (free,) summed row by row."""
    per_row = np.einsum("rja,rj->ra", gains, weighted_residuals)
    columns = active - 3
    keep = columns >= 0
    gradient = np.zeros(free)
    np.add.at(gradient, columns[keep], per_row[keep])
    return gradient


def _design(gains: FloatArray, active: IntArray, free: int) -> Any:
    count = len(gains)
    readings = np.repeat(np.arange(3 * count).reshape(count, 3)[:, :, None], 3, axis=2)  # (R, laser, arm)
    columns = np.repeat(active[:, None, :] - 3, 3, axis=1)
    keep = columns >= 0
    if 3 * count * free <= _DENSE_LIMIT:
        design = np.zeros((3 * count, free))
        np.add.at(design, (readings[keep], columns[keep]), gains[keep])
        return design
    from scipy.sparse import csr_matrix

    return csr_matrix((gains[keep], (readings[keep], columns[keep])), shape=(3 * count, free))


def adjust(
    geometry: solver.Geometry,
    log: MeasurementLog,
    segments: LogSegments,
    values: FloatArray,
    sigmas: FloatArray,
    *,
    geometry_gains: bool = False,
    max_iterations: int = MAX_ITERATIONS,
) -> Adjustment:
    """Least-squares segment heights from all readings, starting from ``values`` ``(S,)`` (module notes).

    ``sigmas`` ``(N, 3)`` are the readings' standard uncertainties (``inf``: left out);
    ``geometry_gains`` also returns the derivatives by the tetrahedron parameters.
    """
    rows = np.flatnonzero(segments.observed)
    active = segments.active[rows]
    measured = log.lasers[rows]
    with np.errstate(divide="ignore"):
        weights = np.where(np.isfinite(sigmas[rows]), 1.0 / sigmas[rows] ** 2, 0.0)
    free = segments.count - 3
    current = np.array(values, dtype=float, copy=True)
    start = measured.copy()  # a reading left out may be far off: its laser starts from the log's typical value
    for arm in range(3):
        used = weights[:, arm] > 0
        start[~used, arm] = np.median(measured[used, arm]) if used.any() else 0.0
    kinematics = row_kinematics(geometry, current[active], start)
    residuals = measured - kinematics.lasers
    cost = float(np.sum(weights * residuals**2))
    converged, iterations, stalled = free == 0, 0, 0
    while not converged and iterations < max_iterations:
        iterations += 1
        design = _design(kinematics.laser_gain, active, free)
        dense = isinstance(design, np.ndarray)
        normal = _Normal(design, weights, blocks=(kinematics.laser_gain, active) if dense else None)
        gradient = _gradient(kinematics.laser_gain, active, weights * residuals, free) if dense else np.asarray(
            design.T @ (weights * residuals).ravel()).ravel()
        full_step = normal.solve(gradient)
        # every step below STEP_FRACTION of its standard uncertainty: step^T N step <= STEP_FRACTION^2
        converged = bool(float(full_step @ (normal.matrix @ full_step)) <= STEP_FRACTION**2
                         or np.all(np.abs(full_step) <= STEP_FLOOR))
        if iterations > 2:  # Newton's step (second-order term) where Gauss-Newton is slow: turning points
            try:
                newton = _Normal(design, weights, _curvature(geometry, kinematics, current[active], active, weights,
                                                             residuals, free, dense),
                                 blocks=(kinematics.laser_gain, active) if dense else None)
                candidate = newton.solve(gradient)
                if np.all(np.isfinite(candidate)) and float(candidate @ gradient) > 0.0:
                    full_step = candidate
            except (np.linalg.LinAlgError, RuntimeError, ValueError):
                pass  # not positive definite: keep the Gauss-Newton step
        step = np.clip(full_step, -_MAX_STEP, _MAX_STEP)
        for _ in range(30):  # step halving while the sum of squares grows
            trial = current.copy()
            trial[3:] += step
            trial_kinematics = row_kinematics(geometry, trial[active], kinematics.lasers)
            trial_residuals = measured - trial_kinematics.lasers
            trial_cost = float(np.sum(weights * trial_residuals**2))
            if trial_cost <= cost * (1.0 + 1e-12) + 1e-300 and trial_kinematics.converged.all():
                break
            step = step / 2.0
        else:
            converged = True  # no descent along the step left: a minimum to rounding
            break
        stalled = stalled + 1 if cost - trial_cost < STALL else 0
        converged = converged or stalled >= 3
        current, kinematics, residuals, cost = trial, trial_kinematics, trial_residuals, trial_cost
    kinematics = row_kinematics(geometry, current[active], kinematics.lasers, geometry_gains=geometry_gains)
    normal = None
    if free:
        design = _design(kinematics.laser_gain, active, free)
        normal = _Normal(design, weights, blocks=(kinematics.laser_gain, active) if isinstance(design, np.ndarray)
                         else None)
    return Adjustment(current, rows, active, kinematics, measured - kinematics.lasers, weights,
                      bool(converged and kinematics.converged.all()), iterations, normal)
