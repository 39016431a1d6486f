"""Local polish of an axis inside the region: the minimax solver on the axis parameters.

The branch and bound proves the bound; the incumbent it compares against should be the
exact local optimum (to rounding), with its contact points and multipliers.  This module
runs :func:`~pcmm_geo.fit.zone._solver.solve_minimax` on ``(x0, y0, a, b)`` from a cell's
axis; when the local optimum leaves the region, the solve is repeated on the region's
edge: the tilt on the cone (``(a, b) = t (cos psi, sin psi)``, ``t = tan(cone)``), the
crossing on the offset circle (``(x0, y0) = r (cos omega, sin omega)``), or both.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.fit.zone._models import axis_distance
from pcmm_geo.fit.zone._solver import ZoneSolution, solve_minimax
from pcmm_geo.fit.zone.axial.bounds import cell_terms
from pcmm_geo.fit.zone.axial.lagrange import Multipliers
from pcmm_geo.fit.zone.axial.search import Domain, Incumbent

FloatArray = NDArray[np.float64]
Model = Callable[[FloatArray, FloatArray], tuple[FloatArray, FloatArray]]

#: relative slack of the region test (an axis this close outside still counts as inside)
EDGE = 1e-12


def objective(distances: FloatArray, mode: str) -> float:
    """``max``, ``max - min`` or ``-min`` of the distances."""
    if mode == "mcc":
        return float(distances.max())
    if mode == "zone":
        return float(distances.max() - distances.min())
    return float(-distances.min())


def inside_region(x: FloatArray, domain: Domain) -> bool:
    """Whether the axis ``x = (x0, y0, a, b)`` lies in the region (to rounding)."""
    return bool(
        np.hypot(x[0], x[1]) <= domain.offset * (1 + EDGE) and np.hypot(x[2], x[3]) <= domain.tan_max * (1 + EDGE)
    )


def on_edge(x: FloatArray, domain: Domain, *, relative: float = 1e-9) -> bool:
    """Whether the axis lies on the region's boundary (within ``relative`` of either limit)."""
    return bool(
        np.hypot(x[0], x[1]) >= domain.offset * (1 - relative)
        or np.hypot(x[2], x[3]) >= domain.tan_max * (1 - relative)
    )


def _edge_models(
    domain: Domain, x: FloatArray, *, near: float = 1.0
) -> list[tuple[FloatArray, Model, Callable[[FloatArray], FloatArray]]]:
    """Start, model and map back to ``(x0, y0, a, b)`` for each edge within ``near`` (relative) of ``x``."""
    cone, ring = domain.tan_max, domain.offset
    out: list[tuple[FloatArray, Model, Callable[[FloatArray], FloatArray]]] = []

    def on_cone(p: FloatArray) -> FloatArray:
        return np.array([p[0], p[1], cone * np.cos(p[2]), cone * np.sin(p[2])])

    def on_ring(p: FloatArray) -> FloatArray:
        return np.array([ring * np.cos(p[0]), ring * np.sin(p[0]), p[1], p[2]])

    def on_both(p: FloatArray) -> FloatArray:
        return np.array([ring * np.cos(p[0]), ring * np.sin(p[0]), cone * np.cos(p[1]), cone * np.sin(p[1])])

    def cone_model(points: FloatArray, p: FloatArray) -> tuple[FloatArray, FloatArray]:
        d, jac = axis_distance(points, on_cone(p))
        turn = -jac[:, 2] * cone * np.sin(p[2]) + jac[:, 3] * cone * np.cos(p[2])
        return d, np.column_stack([jac[:, 0], jac[:, 1], turn])

    def ring_model(points: FloatArray, p: FloatArray) -> tuple[FloatArray, FloatArray]:
        d, jac = axis_distance(points, on_ring(p))
        turn = -jac[:, 0] * ring * np.sin(p[0]) + jac[:, 1] * ring * np.cos(p[0])
        return d, np.column_stack([turn, jac[:, 2], jac[:, 3]])

    def both_model(points: FloatArray, p: FloatArray) -> tuple[FloatArray, FloatArray]:
        d, jac = axis_distance(points, on_both(p))
        turn_ring = -jac[:, 0] * ring * np.sin(p[0]) + jac[:, 1] * ring * np.cos(p[0])
        turn_cone = -jac[:, 2] * cone * np.sin(p[1]) + jac[:, 3] * cone * np.cos(p[1])
        return d, np.column_stack([turn_ring, turn_cone])

    omega, psi = float(np.arctan2(x[1], x[0])), float(np.arctan2(x[3], x[2]))
    near_cone = np.isfinite(cone) and np.hypot(x[2], x[3]) >= cone * (1.0 - near)
    near_ring = np.isfinite(ring) and np.hypot(x[0], x[1]) >= ring * (1.0 - near)
    if near_cone:
        out.append((np.array([x[0], x[1], psi]), cone_model, on_cone))
    if near_ring:
        out.append((np.array([omega, x[2], x[3]]), ring_model, on_ring))
    if near_cone and near_ring:
        out.append((np.array([omega, psi]), both_model, on_both))
    return out


def _incumbent(chart: int, x: FloatArray, solution: ZoneSolution, mode: str, domain: Domain) -> Incumbent:
    """Incumbent with the solution's contacts, levels, multipliers (normalised per level) and edge weights."""
    d = solution.distances
    contacts = np.asarray(solution.contacts, dtype=np.intp)
    weights = np.clip(np.asarray(solution.multipliers, dtype=float), 0.0, None)
    if mode == "mcc":
        signs = np.ones(len(contacts))
    elif mode == "mic":
        signs = -np.ones(len(contacts))
    else:
        signs = np.where(np.abs(d[contacts] - d.max()) <= np.abs(d[contacts] - d.min()), 1.0, -1.0)
    usable = len(contacts) == len(weights) and len(contacts) > 0
    for level in {"mcc": (1.0,), "mic": (-1.0,), "zone": (1.0, -1.0)}[mode]:
        group = signs == level
        total = float(weights[group].sum()) if usable else 0.0
        if total <= 0.0:
            usable = False
            break
        weights[group] /= total
    value = objective(d, mode)
    if not usable:
        return Incumbent(value, chart, np.array(x, dtype=float), None, solution)
    multipliers = _edge_weights(Multipliers(contacts, signs, weights), domain.charts[chart], x, domain)
    return Incumbent(value, chart, np.array(x, dtype=float), multipliers, solution)


def _edge_weights(multipliers: Multipliers, points: FloatArray, x: FloatArray, domain: Domain) -> Multipliers:
    """Weights of the region's edges that cancel the contacts' gradient at an axis near an edge (least squares, >= 0).

    (Any non-negative edge weights give a valid bound inside the region; they help near the edge.)
    """
    if not on_edge(x, domain, relative=1e-2):
        return multipliers
    terms = cell_terms(points[multipliers.contacts], x[None, :], np.zeros((1, 4)), radial=True)
    signed = multipliers.signs * multipliers.weights
    axis = terms.axis[0]
    tilt_vec = -(signed * terms.height[0]) @ terms.radial[0]  # sum s w alpha, normal to the axis
    position = signed @ terms.radial[0]
    cone = ring = 0.0
    if np.hypot(x[2], x[3]) >= domain.tan_max * (1 - 1e-2):
        e_normal = np.array([0.0, 0.0, 1.0]) - axis[2] * axis
        cone = max(0.0, float(tilt_vec @ e_normal) / max(float(e_normal @ e_normal), 1e-300))
    if np.hypot(x[0], x[1]) >= domain.offset * (1 - 1e-2):
        normal = np.array([x[0], x[1]]) / np.hypot(x[0], x[1])
        ring = max(0.0, float(position[:2] @ normal))
    return dataclasses.replace(multipliers, cone=cone, ring=ring)


def _contact_guess(distances: FloatArray, mode: str, n_params: int, margin: float) -> dict[int, float] | None:
    """The points within ``margin`` of the extreme levels as the contact set (None when too many to be a guess)."""
    guess: dict[int, float] = {}
    if mode in ("mcc", "zone"):
        guess.update({int(i): 1.0 for i in np.flatnonzero(distances >= distances.max() - margin)})
    if mode in ("mic", "zone"):
        inner = np.flatnonzero(distances <= distances.min() + margin)
        guess.update({int(i): -1.0 for i in inner if int(i) not in guess})
    if len(guess) > n_params + 3:  # not yet a contact set: the margin is too wide
        return None
    return guess


def vertex_solution(
    points: FloatArray, start: FloatArray, model: Model, mode: str, contacts: dict[int, float], size: float
) -> ZoneSolution | None:
    """Newton's method on ``d_k(x) = level_k`` for a vertex contact set (as many contacts as unknowns).

    The unknowns are the parameters and the levels; at the solution the multipliers follow
    from the square stationarity system.  Returns a certified solution only when every
    multiplier is non-negative and every point lies inside the levels (a strict local
    optimum: a non-degenerate vertex of the minimax problem), else None.
    """
    index = np.array(sorted(contacts), dtype=np.intp)
    sign = np.array([contacts[i] for i in index])
    levels_used = {"mcc": (1.0,), "mic": (-1.0,), "zone": (-1.0, 1.0)}[mode]
    p, n_levels = len(start), len(levels_used)
    if len(index) != p + n_levels or not all(np.any(sign == level) for level in levels_used):
        return None
    slot = np.array([levels_used.index(value) for value in sign])
    one_hot = np.zeros((len(index), n_levels))
    one_hot[np.arange(len(index)), slot] = 1.0
    x = np.array(start, dtype=float)
    d = model(points[index], x)[0]
    levels = np.array([d[sign == level].mean() for level in levels_used])
    converged = False
    for _ in range(40):
        d, jac = model(points[index], x)
        residual = d - levels[slot]
        try:
            step = np.linalg.solve(np.hstack([jac, -one_hot]), -residual)
        except np.linalg.LinAlgError:
            return None
        if not np.all(np.isfinite(step)):
            return None
        x = x + step[:p]
        levels = levels + step[p:]
        if np.abs(residual).max() <= 1e-13 * size and np.abs(step[p:]).max() <= 1e-13 * size:
            converged = True
            break
    if not converged:
        return None
    d_all, jac_all = model(points, x)
    jac = jac_all[index]
    system = np.vstack([(jac * sign[:, None]).T, one_hot.T])
    target = np.concatenate([np.zeros(p), np.ones(n_levels)])
    try:
        lam = np.linalg.solve(system, target)
    except np.linalg.LinAlgError:
        return None
    tolerance = 1e-11 * size
    lower = float(levels[levels_used.index(-1.0)]) if -1.0 in levels_used else float(d_all.min())
    upper = float(levels[levels_used.index(1.0)]) if 1.0 in levels_used else float(d_all.max())
    outside = max(0.0, float((d_all - upper).max()) if 1.0 in levels_used else 0.0,
                  float((lower - d_all).max()) if -1.0 in levels_used else 0.0)
    if lam.min() < -1e-10 or outside > tolerance:
        return None
    norms = np.maximum(np.abs(jac_all).max(axis=0), 1e-300)
    kkt = float(np.linalg.norm(((jac / norms) * sign[:, None]).T @ lam))
    return ZoneSolution(
        x=x, lower=lower, upper=upper, distances=d_all, contacts=index, multipliers=np.clip(lam, 0.0, None),
        kkt_residual=kkt, feasibility=outside, certified=True, iterations=0,
        message="certified: a vertex of the minimax problem (non-negative multipliers, every point inside the zone)",
    )


def balanced_multipliers(domain: Domain, chart: int, x: FloatArray, mode: str) -> Multipliers | None:
    """Weights of the most extreme points at the axis ``x`` whose gradients nearly cancel (non-negative LS).

    Any non-negative weights summing to 1 per level give a valid Lagrangian bound; these
    make it second-order accurate around ``x`` when the points near the levels there hold
    a (near) stationary configuration -- an optimum, or a flat valley of near-optimal axes.
    Near an edge of the region the edge's constraint joins with its own weight.
    """
    from scipy.optimize import nnls

    points = domain.charts[chart]
    d, jac = axis_distance(points, x)
    extra = 2
    if mode == "zone":
        upper, lower = np.argsort(-d)[: 3 + extra], np.argsort(d)[: 3 + extra]
        lower = lower[~np.isin(lower, upper)]
        contacts = np.concatenate([upper, lower])
        signs = np.concatenate([np.ones(len(upper)), -np.ones(len(lower))])
    else:
        contacts = (np.argsort(-d) if mode == "mcc" else np.argsort(d))[: 5 + extra]
        signs = np.full(len(contacts), 1.0 if mode == "mcc" else -1.0)
    levels = (1.0,) if mode == "mcc" else (-1.0,) if mode == "mic" else (1.0, -1.0)
    columns = [jac[contacts].T * signs]  # (4, m): sum s w grad rho
    tilt, crossing = float(np.hypot(x[2], x[3])), float(np.hypot(x[0], x[1]))
    near_cone = np.isfinite(domain.tan_max) and tilt >= domain.tan_max * (1 - 1e-2)
    near_ring = np.isfinite(domain.offset) and crossing >= domain.offset * (1 - 1e-2) and crossing > 0
    if near_cone:  # gradient of cos(cone) - d . e_z = cos(cone) - 1 / q
        q3 = (1.0 + x[2] ** 2 + x[3] ** 2) ** 1.5
        columns.append(np.array([[0.0], [0.0], [x[2] / q3], [x[3] / q3]]))
    if near_ring:  # gradient of |X| - offset
        columns.append(np.array([[x[0] / crossing], [x[1] / crossing], [0.0], [0.0]]))
    gradient = np.hstack(columns)
    row_scale = np.maximum(np.abs(gradient).max(axis=1, keepdims=True), 1e-300)
    n_points = len(contacts)
    level_rows = np.zeros((len(levels), gradient.shape[1]))
    for row, level in enumerate(levels):
        level_rows[row, :n_points] = signs == level
    level_of = {1.0: float(d.max()), -1.0: float(d.min())}
    loss = np.zeros((1, gradient.shape[1]))
    loss[0, :n_points] = [abs(level_of[sign] - d[i]) for i, sign in zip(contacts, signs, strict=True)]
    loss /= max(float(np.ptp(d)), 1e-300)
    matrix = np.vstack([gradient / row_scale, 10.0 * level_rows, loss])
    target = np.concatenate([np.zeros(4), 10.0 * np.ones(len(levels)), np.zeros(1)])
    solution, _ = nnls(matrix, target, maxiter=50 * matrix.shape[1])
    weights = solution[:n_points]
    edge = list(solution[n_points:])
    for level in levels:
        group = signs == level
        total = float(weights[group].sum())
        if total <= 0.0:
            return None
        weights[group] /= total
        if mode != "zone":
            edge = [value / total for value in edge]
    cone = float(edge.pop(0)) if near_cone else 0.0
    ring = float(edge.pop(0)) if near_ring else 0.0
    if mode == "zone":  # the edge weights were solved against unnormalised levels: rescale by their mean
        scale = 0.5 * sum(float(solution[:n_points][signs == level].sum()) for level in levels)
        cone, ring = cone / max(scale, 1e-300), ring / max(scale, 1e-300)
    keep = weights > 0
    return Multipliers(contacts[keep].astype(np.intp), signs[keep], weights[keep], cone=cone, ring=ring)


def make_polisher(
    domain: Domain, mode: str, size: float
) -> Callable[[int, FloatArray, float | None], Incumbent | None]:
    """A function ``polish(chart, x, margin)``: the best local optimum in the region reached from ``x`` (or None).

    With a ``margin`` (mm) the contact set is the points within it of the extreme levels at
    ``x`` (a small cell near an optimum picks its contacts), refined by the KKT-Newton
    exchange alone; without, the sequential linear programs start from ``x``.  When the
    local optimum leaves the region, or ``x`` lies near an edge, the solve is repeated on
    the edge(s).
    """

    def far(x: FloatArray) -> bool:
        return bool(np.hypot(x[0], x[1]) > 2.0 * domain.offset or np.hypot(x[2], x[3]) > 2.0 * domain.tan_max)

    def solve(points: FloatArray, start: FloatArray, model: Model, margin: float | None) -> ZoneSolution | None:
        try:
            if margin is None:
                diverged = far if model is axis_distance else None
                solution = solve_minimax(points, start, model, mode, size=size, diverged=diverged)  # type: ignore[arg-type]
            else:
                guess = _contact_guess(model(points, start)[0], mode, len(start), margin)
                if not guess:
                    return None
                vertex = vertex_solution(points, start, model, mode, guess, size)
                if vertex is not None:
                    return vertex
                solution = solve_minimax(points, start, model, mode, size=size,  # type: ignore[arg-type]
                                         start=(start, guess, 0, "contacts from the search"))
        except (ValueError, np.linalg.LinAlgError, FloatingPointError):
            return None
        if solution.message == "diverged" or not np.all(np.isfinite(solution.x)):
            return None
        return solution

    def polish(chart: int, x: FloatArray, margin: float | None = None) -> Incumbent | None:
        points = domain.charts[chart]
        x = np.asarray(x, dtype=float)
        found: list[Incumbent] = []
        solution = solve(points, x, axis_distance, margin)
        if solution is not None and inside_region(solution.x, domain):
            found.append(_incumbent(chart, solution.x, solution, mode, domain))
        if solution is None or not inside_region(solution.x, domain) or on_edge(x, domain, relative=1e-3):
            for start, model, back in _edge_models(domain, x, near=1e-3 if margin is not None else 1.0):
                edge_solution = solve(points, start, model, margin)
                if edge_solution is None:
                    continue
                axis = back(edge_solution.x)
                if inside_region(axis, domain):
                    found.append(_incumbent(chart, axis, edge_solution, mode, domain))
        if not found:
            return None
        return min(found, key=lambda inc: inc.value)

    return polish
