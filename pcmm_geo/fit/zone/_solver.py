"""Sequential linear programming with a KKT-Newton finish for max-type fitting criteria.

Every non-Gaussian criterion is a minimax problem over the element parameters ``x`` with
the point distances ``d_i(x)`` (distance from the axis, from the centre, signed distance
from the plane ...):

- ``"zone"`` (Chebyshev): minimise ``u - l`` subject to ``l <= d_i(x) <= u``;
- ``"mcc"`` (minimum circumscribed): minimise ``u`` subject to ``d_i(x) <= u``;
- ``"mic"`` (maximum inscribed): maximise ``l`` subject to ``d_i(x) >= l``.

Stage 1 linearises ``d`` at the current ``x`` and solves the resulting linear program
(scipy's HiGHS) inside a trust region on a working set of points (the extreme ones plus
every point that ever became extreme); the step is accepted on the true objective over
all points.  Stage 2 takes the LP's active constraints as the contact set and solves
the KKT system

    d_k(x) = level(k),   sum_k s_k lambda_k grad d_k(x) = 0,   sum_{k in level} lambda_k = 1

by Newton's method (Hessians of the contact distances by central differences of the
analytic gradients: they only steer the iteration, the solution is fixed by the exact
first-order equations), exchanging contacts until every point lies inside the zone and
every multiplier is non-negative.  The multipliers then come from a non-negative least
squares solve of the stationarity equations: a small residual certifies the optimum.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record

FloatArray = NDArray[np.float64]
IndexArray = NDArray[np.intp]
Model = Callable[[FloatArray, FloatArray], tuple[FloatArray, FloatArray]]
Mode = Literal["zone", "mcc", "mic"]

#: Relative stationarity residual below which the KKT conditions count as satisfied.
KKT_TOLERANCE = 1e-8
#: Points outside the zone by less than this times the data size count as inside.
FEASIBILITY_TOLERANCE = 1e-11
_WORKING_BLOCK = 64
_MAX_SLP = 200
_MAX_EXCHANGE = 40


@record
class ZoneSolution:
    """Outcome of :func:`solve_minimax` (parameters in the model's own coordinates)."""

    x: FloatArray
    lower: float
    upper: float
    distances: FloatArray
    contacts: IndexArray
    multipliers: FloatArray
    kkt_residual: float
    feasibility: float
    certified: bool
    iterations: int
    message: str


def _levels(mode: Mode) -> tuple[bool, bool]:
    """(uses lower level, uses upper level)."""
    return mode in ("zone", "mic"), mode in ("zone", "mcc")


def _objective(distances: FloatArray, mode: Mode) -> float:
    if mode == "zone":
        return float(distances.max() - distances.min())
    if mode == "mcc":
        return float(distances.max())
    return float(-distances.min())


def _lp_step(
    d: FloatArray, jac: FloatArray, mode: Mode, radius: float
) -> tuple[FloatArray, float, IndexArray, FloatArray] | None:
    """One trust-region LP on a working set; ``jac`` columns already scaled.

    Returns the step, the linearised objective, the indices (into ``d``) of the
    active constraints and their signs (+1 upper, -1 lower), or None on LP failure.
    """
    from scipy.optimize import linprog

    n_rows, n_par = jac.shape
    use_lower, use_upper = _levels(mode)
    n_var = n_par + use_lower + use_upper
    cost = np.zeros(n_var)
    blocks, rhs, signs = [], [], []
    col = n_par
    if use_lower:
        cost[col] = -1.0
        block = np.zeros((n_rows, n_var))
        block[:, :n_par] = -jac
        block[:, col] = 1.0
        blocks.append(block)
        rhs.append(d)
        signs.append(-np.ones(n_rows))
        col += 1
    if use_upper:
        cost[col] = 1.0
        block = np.zeros((n_rows, n_var))
        block[:, :n_par] = jac
        block[:, col] = -1.0
        blocks.append(block)
        rhs.append(-d)
        signs.append(np.ones(n_rows))
    bounds = [(-radius, radius)] * n_par + [(None, None)] * (n_var - n_par)
    result = linprog(
        cost,
        A_ub=np.vstack(blocks),
        b_ub=np.concatenate(rhs),
        bounds=bounds,
        method="highs",
        options={"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10},
    )
    if result.status != 0:
        return None
    marginals = np.abs(result.ineqlin.marginals)
    active = np.flatnonzero(marginals > 1e-9)
    all_signs = np.concatenate(signs)
    return result.x[:n_par], float(result.fun), active % n_rows, all_signs[active]


def _extremes(d: FloatArray, mode: Mode, count: int) -> IndexArray:
    use_lower, use_upper = _levels(mode)
    if d.size <= 2 * count:
        return np.arange(d.size)
    picks = []
    if use_upper:
        picks.append(np.argpartition(-d, count)[:count])
    if use_lower:
        picks.append(np.argpartition(d, count)[:count])
    return np.unique(np.concatenate(picks))


def _slp(
    points: FloatArray, x0: FloatArray, model: Model, mode: Mode, diverged: Callable[[FloatArray], bool] | None
) -> tuple[FloatArray, dict[int, float], int, str]:
    """Stage 1; returns x, the contact guesses {index: sign}, iterations and a status text."""
    x = np.array(x0, dtype=float)
    d, jac = model(points, x)
    phi = _objective(d, mode)
    # scale of the residuals; exact data (zero width) still need a finite step scale
    width = max(float(d.max() - d.min()), 1e-9 * max(1.0, float(np.abs(d).max())))
    col_scale = width / np.maximum(np.abs(jac).max(axis=0), 1e-300)
    working = _extremes(d, mode, _WORKING_BLOCK)
    radius = 1.0
    contacts: dict[int, float] = {}
    status = "sequential LP: iteration budget exhausted"
    iteration = 0
    for iteration in range(1, _MAX_SLP + 1):  # noqa: B007 (reported after the loop)
        reference = 0.5 * (d.max() + d.min())
        sub_d = (d[working] - reference) / width
        sub_jac = jac[working] * (col_scale / width)
        lp = _lp_step(sub_d, sub_jac, mode, radius)
        if lp is None:
            status = "sequential LP: the linear program failed"
            break
        step_scaled, lp_value, active, signs = lp
        contacts = {int(working[k]): float(s) for k, s in zip(active, signs, strict=True)}
        phi_ref = _objective(d - reference, mode) / width
        predicted = (phi_ref - lp_value) * width
        if predicted <= 1e-9 * width + 1e-15 * max(1.0, abs(phi)):
            status = "sequential LP: stationary"
            break
        trial = x + step_scaled * col_scale
        d_trial, jac_trial = model(points, trial)
        phi_trial = _objective(d_trial, mode)
        ratio = (phi - phi_trial) / predicted
        if ratio >= 0.1:
            x, d, jac, phi = trial, d_trial, jac_trial, phi_trial
            if ratio > 0.75 and np.abs(step_scaled).max() >= 0.99 * radius:
                radius *= 2.0
            if d.max() - d.min() > 2.0 * width:  # keep the LP well scaled as the zone grows
                new_width = float(d.max() - d.min())
                radius *= width / new_width
                col_scale *= new_width / width
                width = new_width
            working = np.union1d(working, _extremes(d, mode, _WORKING_BLOCK))
            if diverged is not None and diverged(x):
                status = "diverged"
                break
        else:
            radius *= 0.25
            working = np.union1d(working, _extremes(d_trial, mode, _WORKING_BLOCK))
        if radius < 1e-13:
            status = "sequential LP: trust region collapsed"
            break
    # the active set of an LP at the final point whose trust region does not bind at a vertex
    reference = 0.5 * (d.max() + d.min())
    working = np.union1d(working, _extremes(d, mode, _WORKING_BLOCK))
    lp = _lp_step((d[working] - reference) / width, jac[working] * (col_scale / width), mode, 1e-2)
    if lp is not None:
        contacts = {int(working[k]): float(s) for k, s in zip(lp[2], lp[3], strict=True)}
    return x, contacts, iteration, status


def _kkt_newton(
    points: FloatArray,
    x: FloatArray,
    contacts: dict[int, float],
    model: Model,
    mode: Mode,
    size: float,
    norms: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray, bool]:
    """Newton on the KKT system of a fixed contact set; returns x, levels, lambdas, converged."""
    use_lower, use_upper = _levels(mode)
    index = np.array(sorted(contacts), dtype=np.intp)
    sign = np.array([contacts[i] for i in index])
    level_slot = np.where(sign > 0, int(use_lower), 0)  # levels ordered (lower, upper)
    n_lev = use_lower + use_upper
    sub = points[index]
    m, p = len(index), x.size
    d, jac = model(sub, x)
    low = d[sign < 0] if np.any(sign < 0) else d
    high = d[sign > 0] if np.any(sign > 0) else d
    levels = np.array(([low.mean()] if use_lower else []) + ([high.mean()] if use_upper else []))
    lam = _nnls_multipliers(jac, sign, level_slot, n_lev, norms)[0]
    one_hot = np.zeros((m, n_lev))
    one_hot[np.arange(m), level_slot] = 1.0
    converged = False
    width = max(float(np.ptp(model(points, x)[0])), 1e-12 * size)
    previous = np.inf
    for _ in range(50):
        d, jac = model(sub, x)
        steps = 1e-6 * size / norms
        hessian = np.zeros((p, p))
        weighted = sign * lam
        for j in range(p):
            shift = np.zeros(p)
            shift[j] = steps[j]
            plus = model(sub, x + shift)[1]
            minus = model(sub, x - shift)[1]
            hessian[:, j] = weighted @ (plus - minus) / (2 * steps[j])
        hessian = 0.5 * (hessian + hessian.T)
        residual = np.concatenate([d - levels[level_slot], jac.T @ weighted, one_hot.T @ lam - 1.0])
        system = np.zeros((m + p + n_lev, p + n_lev + m))
        system[:m, :p] = jac
        system[:m, p : p + n_lev] = -one_hot
        system[m : m + p, :p] = hessian
        system[m : m + p, p + n_lev :] = (jac * sign[:, None]).T
        system[m + p :, p + n_lev :] = one_hot.T
        delta = np.linalg.lstsq(system, -residual, rcond=None)[0]
        if np.abs(delta[:p] * norms).max() > 10.0 * width + 1e-9 * size:
            break  # running away: the contact set is wrong
        x = x + delta[:p]
        levels = levels + delta[p : p + n_lev]
        lam = lam + delta[p + n_lev :]
        moved = float(np.abs(delta[:p] * norms).max())
        # converged: a step at rounding level, or a small step that no longer shrinks
        if moved <= 1e-14 * size or (moved <= 1e-10 * size and moved >= 0.5 * previous):
            converged = True
            break
        previous = moved
    return x, levels, lam, converged


def _reduced_curvature(
    sub: FloatArray,
    x: FloatArray,
    jac: FloatArray,
    sign: FloatArray,
    lam: FloatArray,
    level_slot: IndexArray,
    model: Model,
    mode: Mode,
    size: float,
    norms: FloatArray,
) -> float:
    """Smallest eigenvalue of the Lagrangian's Hessian on the tangent space of the contacts (second-order test).

    At a vertex (as many independent contacts as unknowns) the tangent space is empty and
    the first-order conditions alone prove a strict minimum: returns +inf.  Otherwise the
    Hessian ``sum_k s_k lambda_k H_k`` (central differences of the gradients), reduced to
    the directions ``(dx, dlevels)`` that keep every contact on its level, must be
    positive semi-definite; the value is made dimensionless with the gradient scale.
    """
    use_lower, use_upper = _levels(mode)
    n_lev = use_lower + use_upper
    m, p = jac.shape
    one_hot = np.zeros((m, n_lev))
    one_hot[np.arange(m), level_slot] = 1.0
    # work in parameters scaled to move the distances by about the data size
    scaling = np.concatenate([size / norms, np.ones(n_lev)])
    constraint = np.hstack([jac, -one_hot]) * scaling
    _, singular, vt = np.linalg.svd(constraint)
    rank = int(np.sum(singular > 1e-10 * max(singular[0], 1e-300))) if singular.size else 0
    tangent = vt[rank:].T
    if tangent.shape[1] == 0:
        return float("inf")
    steps = 1e-6 * size / norms
    hessian = np.zeros((p + n_lev, p + n_lev))
    weighted = sign * lam
    for j in range(p):
        shift = np.zeros(p)
        shift[j] = steps[j]
        hessian[:p, j] = weighted @ (model(sub, x + shift)[1] - model(sub, x - shift)[1]) / (2 * steps[j])
    hessian = 0.5 * (hessian + hessian.T)
    reduced = tangent.T @ (hessian * np.outer(scaling, scaling)) @ tangent / size
    return float(np.linalg.eigvalsh(0.5 * (reduced + reduced.T)).min())


def _nnls_multipliers(
    jac: FloatArray, sign: FloatArray, level_slot: IndexArray, n_lev: int, norms: FloatArray
) -> tuple[FloatArray, float]:
    """Non-negative multipliers of the stationarity equations and the relative residual."""
    from scipy.optimize import nnls

    rows = (jac / norms * sign[:, None]).T
    groups = np.zeros((n_lev, len(sign)))
    groups[level_slot, np.arange(len(sign))] = 1.0
    matrix = np.vstack([rows, groups])
    target = np.concatenate([np.zeros(rows.shape[0]), np.ones(n_lev)])
    lam, residual = nnls(matrix, target, maxiter=50 * matrix.shape[1])
    return lam, float(residual)


def solve_minimax(
    points: FloatArray,
    x0: FloatArray,
    model: Model,
    mode: Mode,
    *,
    size: float,
    diverged: Callable[[FloatArray], bool] | None = None,
    start: tuple[FloatArray, dict[int, float], int, str] | None = None,
) -> ZoneSolution:
    """Solve a zone / MCC / MIC problem for ``model(points, x) -> (d (N,), dd/dx (N, P))``.

    ``size`` is the extent of the data (mm) for the tolerances; ``diverged(x)`` flags a
    run-away (unbounded) problem, reported as ``message == "diverged"``.  ``start``
    (x, contacts {index: +1 upper / -1 lower}, iterations, status) replaces the
    sequential-LP stage, e.g. by one solved for many problems at once.
    """
    use_lower, use_upper = _levels(mode)
    # gradient scale of each parameter over all points (contacts alone may have a zero column)
    norms = np.abs(model(points, x0)[1]).max(axis=0)
    norms = np.maximum(norms, 1e-12 * max(float(norms.max()), 1e-300))
    x, contacts, iterations, status = _slp(points, x0, model, mode, diverged) if start is None else start
    if status == "diverged":
        d = model(points, x)[0]
        return _failed(x, d, iterations, "diverged")
    feasibility_tol = FEASIBILITY_TOLERANCE * size
    message = status
    converged = False
    levels = np.zeros(2)
    for _ in range(_MAX_EXCHANGE):
        if not contacts:
            d = model(points, x)[0]
            contacts = {int(np.argmax(d)): 1.0} if use_upper else {}
            if use_lower:
                contacts[int(np.argmin(d))] = -1.0
        x_new, levels, lam, converged = _kkt_newton(points, x, contacts, model, mode, size, norms)
        if not converged:
            # exchange: add the point nearest to a boundary that is not yet a contact
            d = model(points, x)[0]
            gap = np.minimum(d.max() - d if use_upper else np.inf, d - d.min() if use_lower else np.inf)
            gap[list(contacts)] = np.inf
            nearest = int(np.argmin(gap))
            if not np.isfinite(gap[nearest]):
                break
            nearer_upper = not use_lower or d.max() - d[nearest] <= d[nearest] - d.min()
            contacts[nearest] = 1.0 if use_upper and nearer_upper else -1.0
            continue
        if diverged is not None and diverged(x_new):
            return _failed(x_new, model(points, x_new)[0], iterations, "diverged")
        d = model(points, x_new)[0]
        lower = levels[0] if use_lower else -np.inf
        upper = levels[-1] if use_upper else np.inf
        outside = np.maximum(d - upper, lower - d)
        worst = int(np.argmax(outside))
        index = np.array(sorted(contacts), dtype=np.intp)
        off_level = np.abs(d[index] - np.where(np.array([contacts[i] for i in index]) > 0, upper, lower))
        if off_level.max() > feasibility_tol:
            # the contact equations are inconsistent: drop the contact of least multiplier
            del contacts[int(index[int(np.argmin(lam))])]
            x = x_new
            continue
        if outside[worst] > feasibility_tol:
            x = x_new
            contacts[worst] = 1.0 if d[worst] > upper else -1.0
            continue
        if lam.size and lam.min() < -KKT_TOLERANCE:
            del contacts[int(index[int(np.argmin(lam))])]
            x = x_new
            continue
        x = x_new
        break
    else:
        message = "contact exchange did not settle"
    d = model(points, x)[0]
    lower = float(levels[0]) if use_lower else float(d.min())
    upper = float(levels[-1]) if use_upper else float(d.max())
    return assess(points, x, contacts, model, mode, size=size, levels=(lower, upper), converged=converged,
                  iterations=iterations, message=message, norms=norms)


def assess(
    points: FloatArray,
    x: FloatArray,
    contacts: dict[int, float],
    model: Model,
    mode: Mode,
    *,
    size: float,
    levels: tuple[float, float] | None = None,
    converged: bool = True,
    iterations: int = 0,
    message: str = "",
    norms: FloatArray | None = None,
) -> ZoneSolution:
    """Multipliers, KKT residual, feasibility and second-order test of ``x`` with the given contacts.

    ``levels`` (lower, upper) default to the extreme distances at ``x`` (every point inside).
    """
    use_lower, use_upper = _levels(mode)
    d, jac = model(points, x)
    if norms is None:
        norms = np.abs(jac).max(axis=0)
        norms = np.maximum(norms, 1e-12 * max(float(norms.max()), 1e-300))
    lower, upper = (float(d.min()), float(d.max())) if levels is None else levels
    index = np.array(sorted(contacts), dtype=np.intp)
    sign = np.array([contacts[i] for i in index])
    level_slot = np.where(sign > 0, int(use_lower), 0)
    lam, kkt_residual = _nnls_multipliers(jac[index], sign, level_slot, use_lower + use_upper, norms)
    feasibility = float(max(0.0, (d - upper).max() if use_upper else 0.0, (lower - d).max() if use_lower else 0.0))
    curvature = _reduced_curvature(points[index], x, jac[index], sign, lam, level_slot, model, mode, size, norms)
    feasibility_tol = FEASIBILITY_TOLERANCE * size
    certified = bool(
        converged and kkt_residual <= KKT_TOLERANCE and feasibility <= feasibility_tol and curvature >= -KKT_TOLERANCE
    )
    if certified:
        message = "certified: KKT conditions hold on the contact set, every point inside the zone"
    elif not converged:
        message = f"not certified: Newton iteration on the contact set did not converge ({message})"
    elif kkt_residual > KKT_TOLERANCE:
        message = f"not certified: KKT stationarity residual {kkt_residual:.3g} (no non-negative multipliers)"
    elif feasibility > feasibility_tol:
        message = f"not certified: a point lies {feasibility:.3g} mm outside the zone"
    else:
        message = f"not certified: a saddle point (curvature {curvature:.3g} along the contact set), not a minimum"
    return ZoneSolution(
        x=x,
        lower=lower,
        upper=upper,
        distances=d,
        contacts=index,
        multipliers=lam,
        kkt_residual=kkt_residual,
        feasibility=feasibility,
        certified=certified,
        iterations=iterations,
        message=message,
    )


def _failed(x: FloatArray, d: FloatArray, iterations: int, message: str) -> ZoneSolution:
    return ZoneSolution(
        x=x,
        lower=float(d.min()),
        upper=float(d.max()),
        distances=d,
        contacts=np.zeros(0, dtype=np.intp),
        multipliers=np.zeros(0),
        kkt_residual=float("inf"),
        feasibility=float("nan"),
        certified=False,
        iterations=iterations,
        message=message,
    )
