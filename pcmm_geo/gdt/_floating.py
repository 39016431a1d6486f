"""Zones floating in the degrees of freedom a DRF leaves free: the convex minimax over free translations
and free rotations turned exactly (Gauss-Newton on the linearised minimax)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def _rotate(v: FloatArray, axis: FloatArray, theta: float) -> FloatArray:
    c, s = np.cos(theta), np.sin(theta)
    return v * c + np.cross(axis, v) * s + axis * (axis @ v) * (1 - c)


def float_solve(vectors: FloatArray, jacobians: FloatArray) -> tuple[float, FloatArray]:
    """``min_s max_k |v_k - J_k s|`` and its ``s`` (convex; SLSQP on the epigraph in scaled units)."""
    from scipy.optimize import minimize

    p = jacobians.shape[2]
    if p == 0:
        return float(np.linalg.norm(vectors, axis=1).max()), np.zeros(0)
    flat = jacobians.reshape(-1, p)
    s0, *_ = np.linalg.lstsq(flat, vectors.reshape(-1), rcond=None)
    start = vectors - np.einsum("kij,j->ki", jacobians, s0)
    sigma = float(np.linalg.norm(start, axis=1).max())
    if sigma == 0.0:
        return 0.0, s0
    scaled = start / sigma  # the problem in units of the least-squares start's largest residual

    def resid(s: FloatArray) -> FloatArray:
        return scaled - np.einsum("kij,j->ki", jacobians, s)

    def con(x: FloatArray) -> FloatArray:
        r = resid(x[:-1])
        return x[-1] ** 2 - np.einsum("ki,ki->k", r, r)

    def con_jac(x: FloatArray) -> FloatArray:
        r = resid(x[:-1])
        return np.c_[2.0 * np.einsum("kij,ki->kj", jacobians, r), np.full(len(r), 2.0 * x[-1])]

    objective_jac = np.r_[np.zeros(p), 1.0]
    res = minimize(lambda x: x[-1], np.r_[np.zeros(p), 1.0], jac=lambda x: objective_jac, method="SLSQP",
                   constraints=[{"type": "ineq", "fun": con, "jac": con_jac}],
                   options={"ftol": 1e-15, "maxiter": 200})
    best = float(np.linalg.norm(resid(res.x[:-1]), axis=1).max())
    if best > 1.0:
        return sigma, s0
    return sigma * best, s0 + sigma * res.x[:-1]


def float_position(targets: FloatArray, nominal: FloatArray, proj: FloatArray, trans: list[FloatArray],
                    rots: list[FloatArray], pivot: FloatArray) -> tuple[float, FloatArray]:
    """Largest deviation of ``targets`` from ``nominal`` (projected by ``proj``), minimised over the free motions.

    Free translations enter linearly (one convex minimax); free rotations about ``pivot`` are linearised
    and the targets turned exactly, repeated until the step is below 1e-13 rad (Gauss-Newton on the
    minimax).  Returns the value and the final deviations (K, 3).
    """
    current = np.asarray(targets, dtype=float)
    # a rotation whose motion of these targets a free translation already gives adds nothing (an axis
    # parallel to the rotation axis): drop it, so the minimax keeps a unique solution
    kept: list[FloatArray] = []
    for r in rots:
        cols = [np.repeat((proj @ t)[None, :], len(current), axis=0).reshape(-1) for t in trans]
        cols += [(np.cross(k, current - pivot) @ proj.T).reshape(-1) for k in kept]
        new = (np.cross(r, current - pivot) @ proj.T).reshape(-1)
        base = np.column_stack(cols) if cols else np.zeros((len(new), 0))
        rest = new - base @ np.linalg.lstsq(base, new, rcond=None)[0] if base.shape[1] else new
        if np.linalg.norm(rest) > 1e-6 * max(1.0, float(np.linalg.norm(new))):
            kept.append(r)
    rots = kept
    for _ in range(30 if rots else 1):
        vectors = (current - nominal) @ proj.T
        cols = [np.repeat((proj @ t)[None, :], len(current), axis=0) for t in trans]
        cols += [np.cross(r, current - pivot) @ proj.T for r in rots]
        jac = np.stack(cols, axis=2) if cols else np.zeros((len(current), 3, 0))
        value, step = float_solve(vectors, jac)
        if not rots:
            return value, vectors
        omega = -sum((step[len(trans) + k] * r for k, r in enumerate(rots)), np.zeros(3))
        angle = float(np.linalg.norm(omega))
        if angle > 0:
            axis = omega / angle
            rel = current - pivot
            current = pivot + np.array([_rotate(v, axis, angle) for v in rel])
        if angle < 1e-13:
            break
    vectors = (current - nominal) @ proj.T
    cols = [np.repeat((proj @ t)[None, :], len(current), axis=0) for t in trans]
    jac = np.stack(cols, axis=2) if cols else np.zeros((len(current), 3, 0))
    return float_solve(vectors, jac)[0], vectors
