"""Zones floating in the degrees of freedom a DRF leaves free: the convex minimax over free translations
and free rotations turned exactly (Gauss-Newton on the linearised minimax).

The translation minimax ``min_s max_k |b_k - J_k s|`` is convex: a primal start (SLSQP on the epigraph,
which may stall), polished on its KKT system and certified by Lagrange duality -- for multipliers ``lam``
on the simplex, ``min_s sum_k lam_k |b_k - J_k s|^2`` (weighted least squares, closed form) is a lower
bound of the squared optimum (weak duality), tight at the optimum (:func:`minimax_translation`).
"""

from __future__ import annotations

import heapq
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


def _rotate(v: FloatArray, axis: FloatArray, theta: float) -> FloatArray:
    c, s = np.cos(theta), np.sin(theta)
    return v * c + np.cross(axis, v) * s + axis * (axis @ v) * (1 - c)


def _slsqp_minimax(vectors: FloatArray, jacobians: FloatArray) -> tuple[float, FloatArray]:
    """A primal start for :func:`minimax_translation`: SLSQP on the epigraph in scaled units.

    It may stall (then it returns the least-squares start or a non-optimal point): never use its value alone.
    """
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


def _dual_value(b: FloatArray, jac: FloatArray, lam: FloatArray) -> tuple[float, FloatArray]:
    """``min_s sum_k lam_k |b_k - J_k s|^2`` and its ``s`` (weighted least squares)."""
    p = jac.shape[2]
    root = np.sqrt(np.clip(lam, 0.0, None))[:, None]
    rhs = (b * root).reshape(-1)
    if p == 0:
        return float(rhs @ rhs), np.zeros(0)
    a = (jac * root[:, :, None]).reshape(-1, p)
    s, *_ = np.linalg.lstsq(a, rhs, rcond=None)
    r = rhs - a @ s
    return float(r @ r), np.asarray(s, dtype=np.float64)


def _kkt_polish(b: FloatArray, jac: FloatArray, s: FloatArray,
                support: FloatArray | None = None) -> tuple[FloatArray, FloatArray] | None:
    """Newton on the KKT system of an active set: (s, lam) or None when it does not settle.

    The active set is the targets within 1e-6 (relative) of the largest residual at ``s``, or ``support``
    (the multipliers of a dual solution, (K,), its positive entries) when given.  The system
    (stationarity ``sum lam_k J_k^T r_k = 0``, ``sum lam_k = 1``, ``|r_k|^2 = t`` on the set) is square for any
    set size ``m``; it is solved when ``m <= p + 1`` (more is degenerate: the NNLS multipliers only).
    """
    from scipy.optimize import nnls, root

    p = jac.shape[2]
    r = b - np.einsum("kij,j->ki", jac, s)
    norms = np.einsum("ki,ki->k", r, r)
    scale = max(float(norms.max()), 1e-300)
    if support is None:
        active = np.flatnonzero(norms >= scale * (1 - 1e-6) - 1e-300)
    else:
        active = np.flatnonzero(support > 1e-9 * float(support.max()))
    top = float(norms[active].max())
    grads = np.einsum("kij,ki->jk", jac[active], r[active])  # (p, |A|): sum lam_k J_k^T r_k = 0
    lam0, _ = nnls(np.vstack([grads, np.full((1, len(active)), scale)]), np.r_[np.zeros(p), scale])
    if support is not None:
        lam0 = support[active]
    m = len(active)

    def system(x: FloatArray) -> FloatArray:
        ss, t, lam = x[:p], x[p], x[p + 1:]
        rr = b[active] - np.einsum("kij,j->ki", jac[active], ss)
        return np.r_[np.einsum("kij,ki,k->j", jac[active], rr, lam) / scale, lam.sum() - 1.0,
                     (np.einsum("ki,ki->k", rr, rr) - t) / scale]

    lam = np.zeros(len(b))
    lam[active] = lam0 / max(lam0.sum(), 1e-300)
    if m > p + 1:  # a degenerate set: the multipliers from NNLS only
        return s, lam
    if support is None and np.sqrt(_dual_value(b, jac, lam)[0]) >= np.sqrt(top) * (1 - 1e-12):
        return s, lam  # already certified optimal by these multipliers: no Newton step needed
    sol = root(system, np.r_[s, top, lam0 / max(lam0.sum(), 1e-300)], method="hybr", options={"xtol": 1e-15})
    settled = sol.success or float(np.abs(sol.fun).max()) < 1e-12  # hybr may stop at xtol on a solved system
    newton = np.clip(sol.x[p + 1:], 0.0, None)
    if not settled or np.any(sol.x[p + 1:] < -1e-12) or newton.sum() <= 0:
        return s, lam
    lam = np.zeros(len(b))
    lam[active] = newton / newton.sum()
    return sol.x[:p], lam


def _dual_ascent(b: FloatArray, jac: FloatArray, s: FloatArray, lam: FloatArray, g: float, *,
                 fraction: float = 1e-3) -> tuple[float, FloatArray]:
    """Better multipliers: maximise the concave dual ``g(lam) = min_s sum lam_k |b_k - J_k s|^2`` over the simplex
    of the targets within ``fraction`` of the largest residual at ``s`` (SLSQP; the gradient is
    ``|b_k - J_k s(lam)|^2`` by the envelope theorem)."""
    from scipy.optimize import minimize

    r = b - np.einsum("kij,j->ki", jac, s)
    norms = np.sqrt(np.einsum("ki,ki->k", r, r))
    near = np.flatnonzero(norms >= norms.max() * (1 - fraction))
    start = lam[near] if lam[near].sum() > 0 else np.full(len(near), 1.0 / len(near))
    start = start / start.sum()
    scale = max(float(norms.max()) ** 2, 1e-300)

    def full(x: FloatArray) -> FloatArray:
        out = np.zeros(len(b))
        out[near] = np.clip(x, 0.0, None)
        return out

    def negative(x: FloatArray) -> tuple[float, FloatArray]:
        value, ss = _dual_value(b, jac, full(x))
        rr = b[near] - np.einsum("kij,j->ki", jac[near], ss)
        return -value / scale, -np.einsum("ki,ki->k", rr, rr) / scale

    res = minimize(negative, start, jac=True, method="SLSQP", bounds=[(0.0, 1.0)] * len(near),
                   constraints=[{"type": "eq", "fun": lambda x: x.sum() - 1.0, "jac": lambda x: np.ones_like(x)}],
                   options={"ftol": 1e-16, "maxiter": 500})
    x = np.clip(res.x, 0.0, None)
    candidate = full(x / x.sum())
    g2 = _dual_value(b, jac, candidate)[0]
    return (g2, candidate) if g2 > g else (g, lam)


def minimax_translation(b: ArrayLike, jac: ArrayLike) -> tuple[float, float, FloatArray, FloatArray]:
    """``min_s max_k |b_k - J_k s|`` with its dual certificate.

    Parameters
    ----------
    b : array_like, shape (K, 3)
    jac : array_like, shape (K, 3, p)

    Returns
    -------
    value : float
        ``max_k |b_k - J_k s|`` at the returned ``s`` (an upper bound of the optimum).
    bound : float
        ``sqrt(min_s sum_k lam_k |b_k - J_k s|^2)``: a lower bound of the optimum (weak duality).
    s : ndarray, shape (p,)
    lam : ndarray, shape (K,)
        Multipliers: non-negative, sum 1, zero off the active set.
    """
    b = np.asarray(b, dtype=float)
    jac = np.asarray(jac, dtype=float)

    def worst(s: FloatArray) -> float:
        r = b - np.einsum("kij,j->ki", jac, s)
        return float(np.sqrt(np.einsum("ki,ki->k", r, r).max()))

    if jac.shape[2]:  # the translations that move a projected target at all (a basis of them)
        _, sv, vt = np.linalg.svd(jac.reshape(-1, jac.shape[2]), full_matrices=False)
        basis = vt[sv > 1e-12 * max(1.0, float(sv[0]))].T
        if basis.shape[1] < jac.shape[2]:
            value, bound, s, lam = minimax_translation(b, jac @ basis)
            return value, bound, basis @ s, lam
    if jac.shape[2] == 0:
        norms = np.linalg.norm(b, axis=1)
        lam = np.zeros(len(b))
        lam[int(np.argmax(norms))] = 1.0
        return float(norms.max()), float(norms.max()), np.zeros(0), lam
    _, s = _slsqp_minimax(b, jac)
    value = worst(s)
    if value == 0.0:  # every target reached exactly: 0 is optimal (norms are non-negative)
        return 0.0, 0.0, s, np.full(len(b), 1.0 / len(b))
    polished = _kkt_polish(b, jac, s)  # the NNLS multipliers; a Newton step only when they leave a gap
    assert polished is not None
    s2, lam = polished
    if s2 is not s and worst(s2) < value:
        s, value = s2, worst(s2)
    g, s_dual = _dual_value(b, jac, lam)
    if np.sqrt(g) >= value * (1 - 1e-12):  # certified (the common case)
        return value, min(float(np.sqrt(g)) * (1 - 1e-13), value), s, lam
    if np.sqrt(g) < worst(s) * (1 - 1e-12):  # improve the multipliers: maximise the dual on the near-active set
        g, lam = _dual_ascent(b, jac, s, lam, g)
        g, s_dual = _dual_value(b, jac, lam)
    if np.sqrt(g) < worst(s) * (1 - 1e-9):  # the primal solver stalled: the dual over every target
        g, lam = _dual_ascent(b, jac, s, lam, g, fraction=1.0)
        g, s_dual = _dual_value(b, jac, lam)
        if worst(s_dual) < worst(s):
            s = s_dual
        polished = _kkt_polish(b, jac, s)
        if polished is not None and worst(polished[0]) < worst(s):
            s = polished[0]
            g2, _ = _dual_value(b, jac, polished[1])
            if g2 > g:
                g, lam = g2, polished[1]
    if worst(s_dual) < worst(s):
        s = s_dual
    if np.sqrt(g) < worst(s) * (1 - 1e-12):  # the dual's support is the active set: Newton on its KKT system
        polished = _kkt_polish(b, jac, s, lam)
        if polished is not None and worst(polished[0]) < worst(s):
            s = polished[0]
            g2, _ = _dual_value(b, jac, polished[1])
            if g2 > g:
                g, lam = g2, polished[1]
    value = worst(s)
    return value, min(float(np.sqrt(g)) * (1 - 1e-13), value), s, lam


def float_solve(vectors: FloatArray, jacobians: FloatArray) -> tuple[float, float, FloatArray]:
    """``min_s max_k |v_k - J_k s|``: (value, proven lower bound, ``s``), see :func:`minimax_translation`.

    ``vectors`` (K, 3), ``jacobians`` (K, 3, p).  The value is the largest residual at the returned ``s`` (an
    upper bound of the optimum, attained); the bound is the dual certificate.  They agree to about 1e-12
    relative when the solver closed the gap; callers report a FAIL only on the bound.
    """
    value, bound, s, _ = minimax_translation(vectors, jacobians)
    return value, bound, s


def float_position(targets: FloatArray, nominal: FloatArray, proj: FloatArray, trans: list[FloatArray],
                   rots: list[FloatArray], pivot: FloatArray,
                   weights: FloatArray | None = None) -> tuple[float, float, FloatArray]:
    """Largest weighted deviation of ``targets`` (K, 3) from ``nominal`` (projected by ``proj``), minimised over
    the free motions.

    ``nominal`` is (3,) or (K, 3), ``proj`` (3, 3) or (K, 3, 3), ``weights`` (K,) scale each target's deviation
    (a pattern's targets by 2 / their allowed diameter).  Free translations enter linearly (one convex
    minimax); free rotations about ``pivot`` are linearised and the targets turned exactly, repeated until
    the step is below 1e-13 rad (Gauss-Newton on the minimax).  Returns the value (weighted), its lower
    bound and the final deviations (K, 3), unweighted.  Without free rotations the bound is proven (the dual
    certificate of the convex minimax); with a free rotation that moves the targets the turn found is a
    local optimum and no lower bound is proven: the bound is then 0 (a FAIL cannot be decided on it).
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
    scale = max(1.0, float(np.abs(nominal - pivot).max()))
    for r in rots:
        # a turn about an axis along every zone's own axis and through every nominal changes no distance to
        # its zone (coaxiality about its datum axis): it moves nothing the minimax sees
        if np.abs(proj @ r).max() < 1e-12 and np.abs(np.cross(nominal - pivot, r)).max() < 1e-12 * scale:
            continue
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
        value, bound, step = float_solve(vectors * w[:, None], jac)
        if not rots:
            return value, bound, _shifted(vectors, proj, trans, step)
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
    value, _, step = float_solve(vectors * w[:, None], jac)
    return value, 0.0, _shifted(vectors, proj, trans, step)


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
