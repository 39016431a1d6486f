"""Predicted tip uncertainty of a pose: how well three lasers tell the pivot heights, and the mirror branch.

What a log's processing states (:mod:`~pcmm_geo.machine.analysis.logproc`) starts from one pose at a
time: a move of motor ``i`` changes one height, and the row after it measures that height with its
three lasers while the two other pivots stand.  This module predicts, for any pose, what such a row
can tell, with the processing's own noise model (the readings' standard uncertainties
``sigma_j = sqrt(laser_sigma^2 + q_j^2 / 12)``, :func:`~pcmm_geo.machine.analysis.logproc.gate.reading_sigmas`):

* ``F = dl/dH`` (lasers per height) and ``T = dtip/dH`` (tip per height), 3 x 3, from the
  linearised loop closure (:func:`~pcmm_geo.machine.analysis.logproc.geometry.row_kinematics`;
  checked against central differences of :meth:`RigidBodyMachine.forward` in
  ``tests/machine/test_conditioning.py``);
* ``height_u[i] = 1 / sqrt(F_i^T W F_i)`` with ``W = diag(1 / sigma_j^2)``: the standard uncertainty of
  pivot ``i``'s height measured by one row's three lasers, the other two held (weighted least
  squares in one unknown);
* ``move_tip_u[i] = |T_i| height_u[i]``: the tip's standard uncertainty that leaves (the length of the
  error vector, as ``tip_uncertainty`` of a processed log);
* ``tip_u = max_i move_tip_u[i]``: the worst of the three moves from this pose.

Near the level pose the pivot distances change only with the square of the height differences
(``D^2 = b^2 + (H_i - H_j)^2``), ``F`` vanishes and ``tip_u`` grows without bound.

The mirror branch
-----------------
The same row's lasers are also fitted by another height of the moved pivot, its mirror about the
level of the two held pivots (exactly so when these two are level).  The misfit of the moved height
is a quartic (:func:`~pcmm_geo.machine.analysis.logproc.segments.segment_misfit`, chi-square units);
its other minimum is the mirror branch.  ``mirror_chi[i] = sqrt(misfit there)`` is the distance of
that branch from the true pose measured in the readings' noise (the lasers differ between the two
by ``mirror_chi`` standard deviations): below the w-test's critical value (3.29) one row cannot
tell the two apart, and the processing must rely on the recorded move direction
(:mod:`~pcmm_geo.machine.analysis.logproc.branches`, flag ``ambiguous``).  ``mirror_distance[i]``
is how far the tip of the mirror pose lies from the true one (mm).

Examples
--------
>>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
>>> m = RigidBodyMachine.from_dpkm()
>>> poses = pose_conditioning(m, m.reference_heights + np.array([[0.0, 0.0, 1.0], [0.0, 60.0, -60.0]]))
>>> poses.tip_u.round(3).tolist()  # mm: 1 mm from level, and the pivots 60 mm apart
[7.39, 0.088]
>>> poses.ambiguous.tolist()  # a and b level: c's mirror fits the lasers exactly
[True, False]
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.machine.analysis.logproc.gate import (
    DEFAULT_ALPHA,
    SEED_LASER_SIGMA,
    SEED_LASER_STEPS,
    gate_limits,
    reading_sigmas,
)
from pcmm_geo.machine.analysis.logproc.geometry import joint_distances, row_kinematics
from pcmm_geo.machine.analysis.logproc.segments import reading_weights, segment_misfit
from pcmm_geo.machine.kinematics.model import RigidBodyMachine, as_readings

__all__ = ["PoseConditioning", "pose_conditioning", "reachable_poses"]

FloatArray = NDArray[np.float64]



@record
class PoseConditioning:
    """Predicted uncertainty of ``N`` poses (:func:`pose_conditioning`; lengths in mm).

    Attributes
    ----------
    heights, lasers, tips : ndarray, shape (N, 3)
        Pivot heights, the lasers that fit them and the probe-tip centres.
    laser_per_height, tip_per_height : ndarray, shape (N, 3, 3)
        ``F = dl/dH`` (rows lasers a, b, c) and ``T = dtip/dH`` (rows x, y, z); column ``i``: pivot ``i``
        rises by 1 mm.
    laser_sigmas : ndarray, shape (3,)
        Standard uncertainty of a reading of lasers a, b, c (the processing's noise model).
    height_u : ndarray, shape (N, 3)
        ``1 / sqrt(F_i^T W F_i)``: pivot ``i``'s height from one row's lasers, the others held (inf: blind).
    move_tip_u : ndarray, shape (N, 3)
        ``|T_i| height_u[i]``: the tip's standard uncertainty after a move of motor ``i`` to this pose.
    mirror_heights : ndarray, shape (N, 3)
        The other branch's height of pivot ``i`` for the same lasers (NaN: none within the column travel).
    mirror_chi : ndarray, shape (N, 3)
        ``sqrt`` of the misfit at the other branch, in standard deviations of the readings (inf: none).
    mirror_distance : ndarray, shape (N, 3)
        Distance of the mirror pose's tip from the tip (0 where there is none).
    critical : float
        The w-test's critical value the ambiguity is judged against (3.29 at alpha0 = 0.1 %).
    converged : ndarray of bool, shape (N,)
        A pose meets the heights (False: no lasers fit them; every value of that row is NaN or inf).
    """

    heights: FloatArray
    lasers: FloatArray
    tips: FloatArray
    laser_per_height: FloatArray
    tip_per_height: FloatArray
    laser_sigmas: FloatArray
    height_u: FloatArray
    move_tip_u: FloatArray
    mirror_heights: FloatArray
    mirror_chi: FloatArray
    mirror_distance: FloatArray
    critical: float
    converged: NDArray[np.bool_]

    @property
    def tip_u(self) -> FloatArray:
        """The largest ``move_tip_u`` of each pose (N,), mm: the worst single move to it."""
        return np.max(self.move_tip_u, axis=1)

    @property
    def ambiguity_ratio(self) -> FloatArray:
        """The smallest ``mirror_chi`` of each pose over the critical value (N,): below 1 the mirror is in reach."""
        return np.min(self.mirror_chi, axis=1) / self.critical

    @property
    def ambiguous(self) -> NDArray[np.bool_]:
        """Poses where one row cannot tell some moved height from its mirror (N,)."""
        return self.ambiguity_ratio < 1.0


def _heights_from(machine: RigidBodyMachine, heights: ArrayLike | None, lasers: ArrayLike | None,
                  tips: ArrayLike | None) -> tuple[FloatArray, FloatArray]:
    """Heights ``(N, 3)`` and the lasers to start the solve from, for whichever description of the poses is given."""
    if (heights is None) == (tips is None):
        raise InvalidInputError("heights/tips", "exactly one of heights or tips", "both" if heights is not None
                                else "neither")
    if tips is not None:
        if lasers is not None:
            raise InvalidInputError("lasers", "no lasers with tips (the inverse kinematics gives them)", "lasers")
        solution = machine.inverse(as_readings(tips, "tips").reshape(-1, 3))
        return np.asarray(solution.heights, dtype=float).reshape(-1, 3), np.asarray(solution.lasers).reshape(-1, 3)
    base = as_readings(heights, "heights").reshape(-1, 3)
    if lasers is None:  # Newton from the reference lasers, as the simulated machine starts
        return base, np.broadcast_to(machine.reference_lasers, base.shape).copy()
    measured = as_readings(lasers, "lasers").reshape(-1, 3)
    if measured.shape != base.shape:
        raise InvalidInputError("lasers", f"one laser triple per pose, shape {base.shape}", f"shape {measured.shape}")
    return base, measured


def pose_conditioning(
    machine: RigidBodyMachine,
    heights: ArrayLike | None = None,
    *,
    lasers: ArrayLike | None = None,
    tips: ArrayLike | None = None,
    laser_sigma: float = SEED_LASER_SIGMA,
    laser_steps: ArrayLike = SEED_LASER_STEPS,
    alpha: float = DEFAULT_ALPHA,
) -> PoseConditioning:
    """Predicted tip uncertainty and mirror-branch distance of poses (module notes).

    Parameters
    ----------
    machine : RigidBodyMachine
    heights : array_like, shape (N, 3) or (3,), optional
        Pivot heights of the poses (mm).
    lasers : array_like, same shape as ``heights``, optional
        Laser readings at those heights: they pick the branch of the lasers the derivatives are taken
        on (default: :meth:`RigidBodyMachine.forward` from the heights).
    tips : array_like, shape (N, 3) or (3,), optional
        Commanded tip positions instead of heights (:meth:`RigidBodyMachine.inverse`).
    laser_sigma, laser_steps : float, array_like (3,)
        The processing's noise model (mm): ``sqrt(laser_sigma^2 + q^2 / 12)`` per reading.
    alpha : float
        Significance of the w-test the mirror distance is compared with.

    Returns
    -------
    PoseConditioning

    Raises
    ------
    InvalidInputError
        Neither or both of ``heights`` and ``tips``, or badly shaped readings.
    OutOfRangeError, NoRealSolutionError
        A commanded tip outside the workspace (from :meth:`RigidBodyMachine.inverse`).
    """
    sigmas = reading_sigmas(laser_sigma, laser_steps)
    critical = gate_limits(alpha).critical
    base, start = _heights_from(machine, heights, lasers, tips)
    geometry = machine.geometry
    kinematics = row_kinematics(geometry, base, start)
    gain, tip_gain = kinematics.laser_gain, kinematics.tip_gain
    information = np.einsum("nji,j,nji->ni", gain, 1.0 / sigmas**2, gain)
    with np.errstate(divide="ignore"):
        height_u = np.where(information > 0.0, 1.0 / np.sqrt(information), np.inf)
    move_tip_u = np.linalg.norm(tip_gain, axis=1) * height_u
    mirror_heights, mirror_chi, mirror_distance = _mirrors(machine, base, kinematics.lasers, kinematics.tips, sigmas,
                                                           kinematics.converged)
    failed = ~kinematics.converged
    move_tip_u[failed] = np.inf
    return PoseConditioning(
        heights=base, lasers=kinematics.lasers, tips=kinematics.tips, laser_per_height=gain,
        tip_per_height=tip_gain, laser_sigmas=sigmas, height_u=np.where(failed[:, None], np.inf, height_u),
        move_tip_u=move_tip_u, mirror_heights=mirror_heights, mirror_chi=mirror_chi,
        mirror_distance=mirror_distance, critical=float(critical), converged=kinematics.converged,
    )


def _shifted(coefficients: FloatArray, about: FloatArray) -> FloatArray:
    """Coefficients ``(K, 5)`` (highest first) of ``p(about + x)`` for quartics ``p`` ``(K, 5)`` (Horner division)."""
    values = coefficients.copy()
    for stop in range(4, 0, -1):
        for k in range(1, stop + 1):
            values[:, k] += about * values[:, k - 1]
    return values


def _quartic_minima(coefficients: FloatArray, about: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Local minima ``(K, 3)`` (NaN-padded) of quartics ``(K, 5)`` (highest first) and the quartics' values there.

    The stationary points are the eigenvalues of the derivative's companion matrix, solved in
    ``x = h - about`` and polished by Newton steps (the vectorised form of
    :func:`~pcmm_geo.machine.analysis.logproc.segments.misfit_minima`).
    """
    shifted = _shifted(coefficients, about)
    a, b, c, d = shifted[:, 0], shifted[:, 1], shifted[:, 2], shifted[:, 3]
    count = len(shifted)
    minima = np.full((count, 3), np.nan)
    values = np.full((count, 3), np.nan)
    usable = (a > 0.0) & np.all(np.isfinite(shifted), axis=1)
    if not usable.any():
        return minima, values
    slope = np.stack([4.0 * a, 3.0 * b, 2.0 * c, d], axis=1)[usable]
    companion = np.zeros((len(slope), 3, 3))
    companion[:, 0, :] = -slope[:, 1:] / slope[:, :1]
    companion[:, 1, 0] = companion[:, 2, 1] = 1.0
    roots = np.linalg.eigvals(companion)
    real = np.abs(roots.imag) <= 1e-7 * np.maximum(1.0, np.abs(roots.real))
    x = roots.real.copy()
    for _ in range(3):  # Newton on the slope
        first = ((slope[:, 0, None] * x + slope[:, 1, None]) * x + slope[:, 2, None]) * x + slope[:, 3, None]
        second = (3.0 * slope[:, 0, None] * x + 2.0 * slope[:, 1, None]) * x + slope[:, 2, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(second != 0.0, first / second, 0.0)
        x = x - np.where(np.isfinite(step), step, 0.0)
    curvature = (12.0 * a[usable, None] * x + 6.0 * b[usable, None]) * x + 2.0 * c[usable, None]
    keep = real & (curvature > 0.0)
    quartic = shifted[usable]
    value = np.zeros_like(x)
    for k in range(5):
        value = value * x + quartic[:, k, None]
    minima[usable] = np.where(keep, x + about[usable, None], np.nan)
    values[usable] = np.where(keep, value, np.nan)
    return minima, values


def _mirrors(machine: RigidBodyMachine, heights: FloatArray, lasers: FloatArray, tips: FloatArray,
             sigmas: FloatArray, converged: NDArray[np.bool_]) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The other branch of each moved height: ``(heights, chi, tip distance)``, each ``(N, 3)``."""
    count = len(heights)
    geometry = machine.geometry
    travel = machine.limits.height_travel
    mirror = np.full((count, 3), np.nan)
    chi = np.full((count, 3), np.inf)
    distances, gradients = joint_distances(geometry, lasers)
    weights = reading_weights(distances, gradients, np.broadcast_to(sigmas, (count, 3)))
    for arm in range(3):
        quartics = segment_misfit(geometry, distances, weights, heights, arm, per_row=True)  # (N, 5)
        minima, misfits = _quartic_minima(quartics, heights[:, arm])
        own = heights[:, arm, None]
        others = (converged[:, None] & (minima >= travel[arm, 0]) & (minima <= travel[arm, 1])
                  & (np.abs(minima - own) > 1e-6 * (1.0 + np.abs(own))))
        misfits = np.where(others, misfits, np.inf)
        best = np.argmin(misfits, axis=1)
        found = np.isfinite(misfits[np.arange(count), best])
        mirror[found, arm] = minima[found, best[found]]
        chi[found, arm] = np.sqrt(np.maximum(misfits[found, best[found]], 0.0))
    distance = np.zeros((count, 3))
    found = np.isfinite(mirror)
    if found.any():
        rows, arms = np.nonzero(found)
        moved = heights[rows].copy()
        moved[np.arange(len(rows)), arms] = mirror[rows, arms]
        other = row_kinematics(geometry, moved, lasers[rows])
        gap = np.linalg.norm(other.tips - tips[rows], axis=1)
        distance[rows, arms] = np.where(other.converged, gap, np.nan)
    return mirror, chi, distance


def reachable_poses(machine: RigidBodyMachine, heights: FloatArray,
                    conditioning: PoseConditioning) -> NDArray[np.bool_]:
    """Which poses ``heights`` ``(N, 3)`` (their ``conditioning``) lie within the column travel with every laser in
    its measuring range (N,)."""
    limits = machine.limits
    travel, lasers = limits.height_travel, limits.laser_range
    inside = np.all((heights >= travel[:, 0]) & (heights <= travel[:, 1]), axis=1)
    in_range = np.all((conditioning.lasers >= lasers[:, 0]) & (conditioning.lasers <= lasers[:, 1]), axis=1)
    return inside & in_range & conditioning.converged
