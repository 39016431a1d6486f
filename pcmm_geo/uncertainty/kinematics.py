"""Forward kinematics of the rigid-body model over many trials at once, each with its own geometry.

The virtual CMM evaluates the same few probe contacts (``P``) under ``T`` perturbed machine
geometries and reading sets, ``T x P`` pose problems per batch.  They all lie within
micrometres of one nominal solution per contact, which this solver exploits: it runs the
Gauss-Newton iteration of :meth:`~pcmm_geo.machine.kinematics.model.RigidBodyMachine.forward` (the same
closure equations and weighted least-squares objective over lasers and heights) as a
*chord method*: residuals are evaluated exactly with every trial's geometry and readings,
while the step uses the Jacobian of the nominal solution of each contact, factorised once
(``P`` 9 x 9 inverses instead of ``T x P`` SVDs).  The Jacobian differs from the exact one
by the relative size of the perturbation (about 1e-5), so each iteration reduces the error
by that factor; two to three iterations reach the step tolerance.

Reduction used for the step (all arrays batched): the nine closure equations
``F = R (q_i + (k_i L_i + o_i) w_i) + t - (c_i + e_i H_i v_i)`` are linearised in the pose
increment (rotation vector, translation), the laser readings and the heights.  Heights
alone determine the pose (a square system), so the pose and laser increments follow from the
height increments: ``y = -M^-1 (F + B_H dH)`` with ``M`` the Jacobian w.r.t. pose and lasers.
The three height increments then minimise
``|(L + dL - L_meas) / sigma_L|^2 + |(H + dH - H_meas) / sigma_H|^2`` (3 x 3 normal equations).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError

__all__ = ["BatchForward", "BatchGeometry", "forward_batch", "rotation_from_vector"]

FloatArray = NDArray[np.float64]


@record
class BatchGeometry:
    """Machine geometry per trial (leading axis ``T``; arm order a, b, c; mm).

    Attributes
    ----------
    slider_points, slider_directions : ndarray, shape (T, 3, 3)
    laser_scale, laser_offset : ndarray, shape (T, 3)
    tip_center : ndarray, shape (T, 3)
    column_points, column_directions : ndarray, shape (T, 3, 3)
    encoder_scale : ndarray, shape (T, 3)
    """

    slider_points: FloatArray
    slider_directions: FloatArray
    laser_scale: FloatArray
    laser_offset: FloatArray
    tip_center: FloatArray
    column_points: FloatArray
    column_directions: FloatArray
    encoder_scale: FloatArray

    @classmethod
    def repeat(cls, machine: object, trials: int) -> BatchGeometry:
        """``trials`` copies of a :class:`~pcmm_geo.machine.kinematics.model.RigidBodyMachine`'s geometry."""
        g = machine.geometry  # type: ignore[attr-defined]

        def rep(a: FloatArray) -> FloatArray:
            return np.broadcast_to(np.asarray(a, float), (trials, *np.shape(a))).copy()

        return cls(
            rep(g.slider_points), rep(g.slider_directions), rep(g.laser_scale), rep(g.laser_offset),
            rep(g.tip_center), rep(g.column_points),
            rep(g.column_directions), rep(g.encoder_scale),
        )


@record
class BatchForward:
    """Result of :func:`forward_batch`: ``tip`` (T, P, 3) mm, ``converged`` (T, P), ``iterations``."""

    tip: FloatArray
    converged: NDArray[np.bool_]
    iterations: int


def rotation_from_vector(rotvec: FloatArray) -> FloatArray:
    """Rotation matrices ``(..., 3, 3)`` of rotation vectors ``(..., 3)`` (Rodrigues, exact also at 0).

    Examples
    --------
    >>> r = rotation_from_vector(np.array([0.0, 0.0, np.pi / 2]))
    >>> np.round(r @ [1.0, 0.0, 0.0], 12).tolist()
    [0.0, 1.0, 0.0]
    """
    theta2 = np.sum(rotvec**2, axis=-1)
    if theta2.size and float(theta2.max()) < 1e-4:  # |theta| < 0.01: series, error below theta^6 / 5040
        a = 1.0 - theta2 / 6.0 + theta2**2 / 120.0  # sin(theta)/theta
        b = 0.5 - theta2 / 24.0 + theta2**2 / 720.0  # (1 - cos theta)/theta^2
    else:
        theta = np.sqrt(theta2)
        a = np.sinc(theta / np.pi)
        b = 0.5 * np.sinc(theta / (2.0 * np.pi)) ** 2
    x, y, z = rotvec[..., 0], rotvec[..., 1], rotvec[..., 2]
    k = np.zeros((*rotvec.shape[:-1], 3, 3))
    k[..., 0, 1], k[..., 0, 2], k[..., 1, 2] = -z, y, -x
    k[..., 1, 0], k[..., 2, 0], k[..., 2, 1] = z, -y, x
    return np.eye(3) + a[..., None, None] * k + b[..., None, None] * (k @ k)


def _skew(v: FloatArray) -> FloatArray:
    out = np.zeros((*v.shape[:-1], 3, 3))
    out[..., 0, 1], out[..., 0, 2], out[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    out[..., 1, 0], out[..., 2, 0], out[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    return out


def _apply(rotation: FloatArray, vectors: FloatArray) -> FloatArray:
    """``rotation @ vectors[k]`` for rotations ``(..., 3, 3)`` and vectors ``(..., K, 3)`` (elementwise sums: fast)."""
    return (
        rotation[..., None, :, 0] * vectors[..., :, None, 0]
        + rotation[..., None, :, 1] * vectors[..., :, None, 1]
        + rotation[..., None, :, 2] * vectors[..., :, None, 2]
    )


def _compose(left: FloatArray, right: FloatArray) -> FloatArray:
    """``left @ right`` for stacks of 3 x 3 matrices (elementwise sums)."""
    return (
        left[..., :, 0, None] * right[..., None, 0, :]
        + left[..., :, 1, None] * right[..., None, 1, :]
        + left[..., :, 2, None] * right[..., None, 2, :]
    )


def _times(vectors: FloatArray, matrices: FloatArray) -> FloatArray:
    """``vectors[p, t] @ matrices[p]`` for ``(P, T, n)`` and ``(P, n, m)``: one BLAS product per contact."""
    out = np.empty((*vectors.shape[:2], matrices.shape[2]))
    for p in range(vectors.shape[0]):
        np.matmul(vectors[p], matrices[p], out=out[p])
    return out


def _closure(geometry: BatchGeometry, rotation: FloatArray, translation: FloatArray, lasers: FloatArray,
             heights: FloatArray) -> FloatArray:
    """Closure residuals ``(P, T, 9)`` for contact-major arrays ``(P, T, ...)``."""
    slide = geometry.laser_scale * lasers + geometry.laser_offset
    joints = geometry.slider_points + slide[..., None] * geometry.slider_directions
    moved = _apply(rotation, joints) + translation[..., None, :]
    pivots = geometry.column_points + (geometry.encoder_scale * heights)[..., None] * geometry.column_directions
    return (moved - pivots).reshape(*lasers.shape[:2], 9)


def forward_batch(
    machine: object,
    geometry: BatchGeometry,
    lasers: FloatArray,
    heights: FloatArray,
    *,
    laser_sigma: float,
    height_sigma: float,
    nominal_lasers: FloatArray,
    nominal_heights: FloatArray,
    tolerance: float = 1e-10,
    max_iterations: int = 10,
) -> BatchForward:
    """Probe-tip centers for ``T`` trials x ``P`` contacts, each trial with its own geometry.

    Parameters
    ----------
    machine : RigidBodyMachine
        The nominal machine (linearisation point).
    geometry : BatchGeometry
        Per-trial geometry, close to ``machine``'s (within micrometres).
    lasers, heights : ndarray, shape (T, P, 3)
        Measured readings (mm).
    laser_sigma, height_sigma : float
        Standard uncertainties of the readings: the weights of
        :meth:`~pcmm_geo.machine.kinematics.model.RigidBodyMachine.forward`.
    nominal_lasers, nominal_heights : ndarray, shape (P, 3)
        Consistent readings of ``machine`` at the contacts (its inverse kinematics).
    tolerance : float
        Largest step (mm; rotations times the lever arm) at convergence.
    max_iterations : int

    Returns
    -------
    BatchForward

    Raises
    ------
    InvalidInputError
        Shapes that do not match, non-positive sigmas.

    Notes
    -----
    Agrees with :meth:`RigidBodyMachine.forward` of each trial's machine to the solver
    tolerance (tested at 1e-9 mm).
    """
    if not (laser_sigma > 0 and height_sigma > 0):
        raise InvalidInputError("sigma", "positive reading uncertainties", f"{laser_sigma}, {height_sigma}")
    trials, points = lasers.shape[:2]
    if lasers.shape != (trials, points, 3) or heights.shape != lasers.shape:
        raise InvalidInputError("readings", "lasers and heights of shape (T, P, 3)", f"{lasers.shape}, {heights.shape}")
    if geometry.laser_scale.shape != (trials, 3):
        raise InvalidInputError("geometry", f"{trials} trials", f"{geometry.laser_scale.shape[0]}")
    start = machine.forward(nominal_lasers, nominal_heights)  # type: ignore[attr-defined]
    g0 = machine.geometry  # type: ignore[attr-defined]
    # nominal Jacobian per contact: columns (dphi 3, dt 3, dL 3 | dH 3)
    joints0 = g0.slider_points + (g0.laser_scale * nominal_lasers + g0.laser_offset)[..., None] * g0.slider_directions
    rotated0 = np.einsum("pij,paj->pai", start.rotation, joints0)
    jac = np.zeros((points, 9, 12))
    for arm in range(3):
        rows = slice(3 * arm, 3 * arm + 3)
        jac[:, rows, 0:3] = -_skew(rotated0[:, arm])
        jac[:, rows, 3:6] = np.eye(3)
        jac[:, rows, 6 + arm] = g0.laser_scale[arm] * (start.rotation @ g0.slider_directions[arm])
        jac[:, rows, 9 + arm] = -g0.encoder_scale[arm] * g0.column_directions[arm]
    m_inv = np.linalg.inv(jac[:, :, :9])  # (P, 9, 9)
    y_h = -m_inv @ jac[:, :, 9:]  # (P, 9, 3): d(pose, lasers)/dH
    y_l = y_h[:, 6:9, :]
    w_l, w_h = 1.0 / laser_sigma**2, 1.0 / height_sigma**2
    normal = np.linalg.inv(w_l * np.swapaxes(y_l, 1, 2) @ y_l + w_h * np.eye(3))  # (P, 3, 3)
    lever = max(1.0, float(np.abs(g0.slider_points).max() + np.abs(g0.laser_offset).max()))

    # contact-major layout (P, T, ...): the per-contact matrices then multiply by BLAS
    rotation = np.broadcast_to(start.rotation[:, None], (points, trials, 3, 3)).copy()
    translation = np.broadcast_to(start.translation[:, None], (points, trials, 3)).copy()
    meas_l = np.ascontiguousarray(np.swapaxes(lasers, 0, 1))
    meas_h = np.ascontiguousarray(np.swapaxes(heights, 0, 1))
    cur_l = np.broadcast_to(nominal_lasers[:, None], meas_l.shape).copy()
    cur_h = np.broadcast_to(nominal_heights[:, None], meas_h.shape).copy()
    m_inv_t = np.swapaxes(m_inv, 1, 2)
    y_h_t = np.swapaxes(y_h, 1, 2)
    normal_t = np.swapaxes(normal, 1, 2)
    done = np.zeros((points, trials), dtype=bool)
    previous = None
    iteration = 0
    for iteration in range(1, max_iterations + 1):  # noqa: B007 (reported)
        value = _closure(geometry, rotation, translation, cur_l, cur_h)
        y0 = -_times(value, m_inv_t)
        rhs = -(w_l * _times(cur_l + y0[..., 6:9] - meas_l, y_l) + w_h * (cur_h - meas_h))
        d_h = _times(rhs, normal_t)
        step = y0 + _times(d_h, y_h_t)
        rotation = _compose(rotation_from_vector(step[..., 0:3]), rotation)
        translation += step[..., 3:6]
        cur_l += step[..., 6:9]
        cur_h += d_h
        size = np.maximum(lever * np.abs(step[..., 0:3]).max(axis=-1),
                          np.maximum(np.abs(step[..., 3:9]).max(axis=-1), np.abs(d_h).max(axis=-1)))
        # chord method: linear convergence with ratio rho; the error left after this step is
        # about rho * size / (1 - rho), rho estimated from the last two steps
        if previous is None:
            done = size < tolerance
        else:
            rho = np.minimum(size / np.maximum(previous, 1e-300), 0.5)
            done = (size < tolerance) | (rho * size / (1.0 - rho) < tolerance)
        previous = size
        if done.all():
            break
    tip = _apply(rotation, geometry.tip_center[:, None, :])[..., 0, :] + translation
    return BatchForward(tip=np.swapaxes(tip, 0, 1), converged=done.T, iterations=iteration)
