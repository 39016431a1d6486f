"""Batched Gauss-Newton solver of the rigid-body closure equations (internal).

The unknowns of one sample are ``x = (dphi(3), t(3), lasers(3), heights(3))``: a
rotation-vector increment applied on the left of the current rotation, the
translation, and the three laser and three encoder *readings*.  The closure of arm
``i`` is

``F_i = R (q_i + (k_i L_i + o_i) w_i) + t - (c_i + e_i H_i v_i) = 0``    (3 equations)

and optionally the tip equation ``R p + t - X = 0`` (inverse kinematics).  These are
*hard* constraints.  Readings that were measured enter as *soft* rows
``(L_i - L_meas) / sigma``; readings that were not measured get a very weak prior
towards a hint, which only matters along directions the data cannot see (for example
the common height of the pivots when all columns are parallel and only the lasers
are known).  That prior is used only to reach the solution; a second stage drops it and
takes minimum-norm steps that ignore directions with relative singular value below
:data:`UNOBSERVABLE`, so observable quantities are exact and unobservable ones stay
where the first stage put them (nearest the hint).  Each step is the equality-constrained
linear least-squares step computed with the null-space method (SVD of the constraint Jacobian), vectorised over samples.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record

FloatArray = NDArray[np.float64]

#: ratio sigma_prior / sigma of the weak prior on readings that were not measured (first stage)
PRIOR_RATIO = 1e3
#: relative singular value below which a direction counts as unobservable (second stage)
UNOBSERVABLE = 1e-9
#: convergence: largest parameter step (mm, or rad times 1000 mm) below this
STEP_TOLERANCE = 1e-11
MAX_ITERATIONS = 60
#: a solve counts as converged only if its hard equations close to this (mm): closure, tip, and
#: with one kind of reading, the measured readings themselves
SOLVED_TOLERANCE = 1e-6
MAX_ROTATION_STEP = 0.1
MAX_LINEAR_STEP = 50.0


@record
class Geometry:
    """Machine geometry as stacked arrays (arm order a, b, c)."""

    slider_points: FloatArray  # (3, 3) q_i
    slider_directions: FloatArray  # (3, 3) w_i
    laser_scale: FloatArray  # (3,)
    laser_offset: FloatArray  # (3,)
    tip_center: FloatArray  # (3,)
    column_points: FloatArray  # (3, 3) c_i
    column_directions: FloatArray  # (3, 3) v_i
    encoder_scale: FloatArray  # (3,)


@record
class PoseState:
    """Solution of a batch: rotation (K,3,3), translation (K,3), lasers (K,3), heights (K,3)."""

    rotation: FloatArray
    translation: FloatArray
    lasers: FloatArray
    heights: FloatArray
    converged: NDArray[np.bool_]
    iterations: int


def skew(vectors: FloatArray) -> FloatArray:
    """Cross-product matrices ``[v]_x`` of vectors ``(..., 3)`` -> ``(..., 3, 3)``."""
    out = np.zeros((*vectors.shape[:-1], 3, 3))
    x, y, z = vectors[..., 0], vectors[..., 1], vectors[..., 2]
    out[..., 0, 1], out[..., 0, 2] = -z, y
    out[..., 1, 0], out[..., 1, 2] = z, -x
    out[..., 2, 0], out[..., 2, 1] = -y, x
    return out


def rotvec_to_matrix(rotvec: FloatArray) -> FloatArray:
    """Rotation matrices ``(..., 3, 3)`` of rotation vectors ``(..., 3)`` (scipy ``Rotation``)."""
    from scipy.spatial.transform import Rotation

    flat = rotvec.reshape(-1, 3)
    return Rotation.from_rotvec(flat).as_matrix().reshape(*rotvec.shape[:-1], 3, 3)


def kabsch(source: FloatArray, target: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Proper rigid transform ``target ~ R source + t`` for batches ``(K, N, 3)``."""
    src_mean = source.mean(axis=-2, keepdims=True)
    dst_mean = target.mean(axis=-2, keepdims=True)
    cov = np.swapaxes(target - dst_mean, -1, -2) @ (source - src_mean)
    u, _, vt = np.linalg.svd(cov)
    det = np.linalg.det(u @ vt)
    fix = np.ones((*cov.shape[:-2], 3))
    fix[..., 2] = np.sign(det) + (det == 0)
    rotation = (u * fix[..., None, :]) @ vt
    translation = dst_mean[..., 0, :] - np.einsum("...ij,...j->...i", rotation, src_mean[..., 0, :])
    return rotation, translation


def joints_in_tetrahedron(geometry: Geometry, lasers: FloatArray) -> FloatArray:
    """Joint centres ``q_i + s_i w_i`` in the tetrahedron frame, ``(K, 3, 3)``."""
    slide = geometry.laser_scale * lasers + geometry.laser_offset
    return geometry.slider_points + slide[..., None] * geometry.slider_directions


def pivots_in_machine(geometry: Geometry, heights: FloatArray) -> FloatArray:
    """Pivot centres ``c_i + e_i H_i v_i`` in the machine frame, ``(K, 3, 3)``."""
    along = geometry.encoder_scale * heights
    return geometry.column_points + along[..., None] * geometry.column_directions


def closure(geometry: Geometry, state: PoseState) -> FloatArray:
    """Closure residuals ``T(joint_i) - pivot_i``, ``(K, 9)`` in mm."""
    joints = joints_in_tetrahedron(geometry, state.lasers)
    moved = np.einsum("kij,kaj->kai", state.rotation, joints) + state.translation[:, None, :]
    return (moved - pivots_in_machine(geometry, state.heights)).reshape(-1, 9)


def kabsch_start(geometry: Geometry, lasers: FloatArray, heights: FloatArray) -> PoseState:
    """Starting pose ``(K,)``: the rigid fit of the joints for ``lasers`` onto the pivots for ``heights``."""
    rotation, translation = kabsch(joints_in_tetrahedron(geometry, lasers), pivots_in_machine(geometry, heights))
    return PoseState(rotation, translation, lasers.copy(), heights.copy(), np.zeros(len(lasers), bool), 0)


def open_equations(geometry: Geometry, state: PoseState, tip_target: FloatArray | None = None) -> FloatArray:
    """Largest residual of the hard equations per sample ``(K,)`` in mm: the three loop closures
    (distance joint-pivot per arm) and, with ``tip_target`` ``(K, 3)``, the tip equation."""
    loops = np.linalg.norm(closure(geometry, state).reshape(-1, 3, 3), axis=-1).max(axis=-1)
    if tip_target is None:
        return loops
    tip = np.einsum("kij,j->ki", state.rotation, geometry.tip_center) + state.translation
    return np.maximum(loops, np.linalg.norm(tip - tip_target, axis=-1))


def solve_pose(
    geometry: Geometry,
    start: PoseState,
    *,
    laser_weight: FloatArray,
    height_weight: FloatArray,
    laser_target: FloatArray,
    height_target: FloatArray,
    tip_target: FloatArray | None = None,
    rcond: float = 1e-15,
) -> PoseState:
    """Run the constrained Gauss-Newton iteration on a batch of ``K`` samples.

    ``laser_weight`` / ``height_weight`` ``(K, 3)`` are ``1/sigma`` of the soft rows pulling
    the readings towards ``laser_target`` / ``height_target``; ``height_weight`` may also be a
    square-root information matrix ``(K, 3, 3)`` (rows ``W (H - target)``, e.g. one row on the
    mean height only).  With ``tip_target``
    ``(K, 3)`` the tip equation is added to the hard constraints (inverse kinematics).
    """
    rotation = start.rotation.copy()
    translation = start.translation.copy()
    lasers = start.lasers.copy()
    heights = start.heights.copy()
    n_samples = rotation.shape[0]
    done = np.zeros(n_samples, dtype=bool)
    lever = max(1.0, float(np.abs(geometry.slider_points).max() + np.abs(geometry.laser_offset).max()))
    iteration = 0
    n_hard = 9 if tip_target is None else 12
    eye = np.eye(3)
    for iteration in range(1, MAX_ITERATIONS + 1):  # noqa: B007 (reported after the loop)
        joints = joints_in_tetrahedron(geometry, lasers)
        rotated = np.einsum("kij,kaj->kai", rotation, joints)
        pivots = pivots_in_machine(geometry, heights)
        hard = np.zeros((n_samples, n_hard, 12))
        value = np.zeros((n_samples, n_hard))
        value[:, :9] = (rotated + translation[:, None, :] - pivots).reshape(-1, 9)
        for arm in range(3):
            rows = slice(3 * arm, 3 * arm + 3)
            hard[:, rows, 0:3] = -skew(rotated[:, arm])
            hard[:, rows, 3:6] = eye
            hard[:, rows, 6 + arm] = geometry.laser_scale[arm] * (rotation @ geometry.slider_directions[arm])
            hard[:, rows, 9 + arm] = -geometry.encoder_scale[arm] * geometry.column_directions[arm]
        if tip_target is not None:
            tip_now = rotation @ geometry.tip_center
            value[:, 9:] = tip_now + translation - tip_target
            hard[:, 9:, 0:3] = -skew(tip_now)
            hard[:, 9:, 3:6] = eye
            step = -np.einsum("kij,kj->ki", np.linalg.pinv(hard, rcond=1e-13), value)
        else:
            soft = np.zeros((n_samples, 6, 12))
            idx = np.arange(3)
            soft[:, idx, 6 + idx] = laser_weight
            if height_weight.ndim == 3:  # full square-root information matrix of the heights
                soft[:, 3:, 9:] = height_weight
                height_misfit = np.einsum("kij,kj->ki", height_weight, heights - height_target)
            else:
                soft[:, 3 + idx, 9 + idx] = height_weight
                height_misfit = height_weight * (heights - height_target)
            soft_value = np.concatenate([laser_weight * (lasers - laser_target), height_misfit], axis=1)
            u, sing, vt = np.linalg.svd(hard, full_matrices=True)
            particular = -np.einsum("kji,kj->ki", vt[:, :9, :], np.einsum("kji,kj->ki", u, value) / sing)
            null = np.swapaxes(vt[:, 9:, :], 1, 2)  # (K, 12, 3)
            reduced = soft @ null
            rhs = -(soft_value + np.einsum("kij,kj->ki", soft, particular))
            coeff = np.einsum("kij,kj->ki", np.linalg.pinv(reduced, rcond=rcond), rhs)
            step = particular + np.einsum("kij,kj->ki", null, coeff)
        step[done] = 0.0
        # trust region: at most MAX_ROTATION_STEP rad and MAX_LINEAR_STEP mm per iteration
        limit = np.maximum(
            np.linalg.norm(step[:, 0:3], axis=1) / MAX_ROTATION_STEP,
            np.abs(step[:, 3:]).max(axis=1) / MAX_LINEAR_STEP,
        )
        step /= np.maximum(limit, 1.0)[:, None]
        rotation = rotvec_to_matrix(step[:, 0:3]) @ rotation
        translation = translation + step[:, 3:6]
        lasers = lasers + step[:, 6:9]
        heights = heights + step[:, 9:12]
        size = np.max(np.abs(np.concatenate([lever * step[:, 0:3], step[:, 3:]], axis=1)), axis=1)
        done |= size < STEP_TOLERANCE * lever
        if done.all():
            break
    return PoseState(rotation, translation, lasers, heights, done, iteration)


def closest_readings(
    geometry: Geometry, rotation: FloatArray, translation: FloatArray, hint: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Readings where each moved slider line comes closest to its column line ``(K, 3)`` each."""
    count = rotation.shape[0]
    lasers = np.empty((count, 3))
    heights = np.empty((count, 3))
    for arm in range(3):
        origin = np.einsum("kij,j->ki", rotation, geometry.slider_points[arm]) + translation
        direction = rotation @ geometry.slider_directions[arm]
        col_dir = geometry.column_directions[arm]
        col_point = geometry.column_points[arm]
        # minimise |origin + s d - (col_point + z v)| over s, z
        cross = direction @ col_dir
        denom = 1.0 - cross**2
        diff = col_point - origin
        s_val = np.where(denom > 1e-12, (diff @ col_dir * -cross + np.einsum("ki,ki->k", diff, direction)) / denom, 0)
        z_val = np.where(
            denom > 1e-12,
            (diff @ col_dir * -1 + cross * np.einsum("ki,ki->k", diff, direction)) / denom,
            hint[:, arm] * geometry.encoder_scale[arm],
        )
        lasers[:, arm] = (s_val - geometry.laser_offset[arm]) / geometry.laser_scale[arm]
        heights[:, arm] = z_val / geometry.encoder_scale[arm]
    return lasers, heights
