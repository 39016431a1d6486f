"""Zones floating in the degrees of freedom a DRF leaves free: the convex minimax over free translations
and free rotations turned exactly (Gauss-Newton on the linearised minimax)."""

from __future__ import annotations

import heapq
from typing import Any

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
                   rots: list[FloatArray], pivot: FloatArray,
                   weights: FloatArray | None = None) -> tuple[float, FloatArray]:
    """Largest weighted deviation of ``targets`` (K, 3) from ``nominal`` (projected by ``proj``), minimised over
    the free motions.

    ``nominal`` is (3,) or (K, 3), ``proj`` (3, 3) or (K, 3, 3), ``weights`` (K,) scale each target's deviation
    (a pattern's targets by 2 / their allowed diameter).  Free translations enter linearly (one convex
    minimax); free rotations about ``pivot`` are linearised and the targets turned exactly, repeated until
    the step is below 1e-13 rad (Gauss-Newton on the minimax).  Returns the value (weighted) and the final
    deviations (K, 3), unweighted.
    """
    current = np.asarray(targets, dtype=float)
    k = len(current)
    nominal = np.broadcast_to(np.asarray(nominal, dtype=float), (k, 3))
    proj = np.broadcast_to(np.asarray(proj, dtype=float), (k, 3, 3))
    w = np.ones(k) if weights is None else np.asarray(weights, dtype=float)

    def columns(cloud: FloatArray, rotations: list[FloatArray]) -> list[FloatArray]:
        cols = [np.einsum("kij,j->ki", proj, t) * w[:, None] for t in trans]
        cols += [np.einsum("kij,kj->ki", proj, np.cross(r, cloud - pivot)) * w[:, None] for r in rotations]
        return cols

    # a rotation whose motion of these targets a free translation already gives adds nothing (an axis
    # parallel to the rotation axis): drop it, so the minimax keeps a unique solution
    kept: list[FloatArray] = []
    for r in rots:
        base_cols = [c.reshape(-1) for c in columns(current, kept)]
        new = columns(current, [r])[-1].reshape(-1)
        base = np.column_stack(base_cols) if base_cols else np.zeros((len(new), 0))
        rest = new - base @ np.linalg.lstsq(base, new, rcond=None)[0] if base.shape[1] else new
        if np.linalg.norm(rest) > 1e-6 * max(1.0, float(np.linalg.norm(new))):
            kept.append(r)
    rots = kept
    for _ in range(30 if rots else 1):
        vectors = np.einsum("kij,kj->ki", proj, current - nominal)
        cols = columns(current, rots)
        jac = np.stack(cols, axis=2) if cols else np.zeros((k, 3, 0))
        value, step = float_solve(vectors * w[:, None], jac)
        if not rots:
            return value, _shifted(vectors, proj, trans, step)
        omega = -sum((step[len(trans) + j] * r for j, r in enumerate(rots)), np.zeros(3))
        angle = float(np.linalg.norm(omega))
        if angle > 0:
            axis = omega / angle
            current = pivot + np.array([_rotate(v, axis, angle) for v in current - pivot])
        if angle < 1e-13:
            break
    vectors = np.einsum("kij,kj->ki", proj, current - nominal)
    cols = columns(current, [])
    jac = np.stack(cols, axis=2) if cols else np.zeros((k, 3, 0))
    value, step = float_solve(vectors * w[:, None], jac)
    return value, _shifted(vectors, proj, trans, step)


def _shifted(vectors: FloatArray, proj: FloatArray, trans: list[FloatArray], step: FloatArray) -> FloatArray:
    """The deviations after the free translations of ``step`` (its first ``len(trans)`` entries)."""
    out = vectors.copy()
    for j, t in enumerate(trans):
        out -= step[j] * np.einsum("kij,j->ki", proj, t)
    return out


def minimise_angle(fun: Any, lipschitz: float, *, tol: float = 1e-9, budget: int = 4000) -> tuple[float, float, float]:
    """Branch and bound of ``fun(theta)`` over [-pi, pi]: (best value, proven lower bound, theta)."""
    cells = 64
    h = np.pi / cells
    mids = -np.pi + h * (2 * np.arange(cells) + 1)
    best_val, best_theta = np.inf, 0.0
    heap: list[tuple[float, float, float]] = []
    for m in mids:
        v = float(fun(m))
        if v < best_val:
            best_val, best_theta = v, float(m)
        heapq.heappush(heap, (v - lipschitz * h, float(m), h))
    evaluations = cells
    while heap and evaluations < budget:
        low, m, half = heapq.heappop(heap)
        if best_val - low <= tol:
            heapq.heappush(heap, (low, m, half))
            break
        for child in (m - half / 2, m + half / 2):
            v = float(fun(child))
            evaluations += 1
            if v < best_val:
                best_val, best_theta = v, float(child)
            heapq.heappush(heap, (v - lipschitz * half / 2, child, half / 2))
    bound = min(best_val, heap[0][0]) if heap else best_val
    return best_val, max(bound, 0.0), best_theta
