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
from pcmm_geo.fit.zone.axial.bounds import Multipliers, cell_terms
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


def _edge_models(domain: Domain, x: FloatArray) -> list[tuple[FloatArray, Model, Callable[[FloatArray], FloatArray]]]:
    """Start, model and map back to ``(x0, y0, a, b)`` for each active edge of the region."""
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
    if np.isfinite(cone):
        out.append((np.array([x[0], x[1], psi]), cone_model, on_cone))
    if np.isfinite(ring):
        out.append((np.array([omega, x[2], x[3]]), ring_model, on_ring))
    if np.isfinite(cone) and np.isfinite(ring):
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
    """Weights of the region's edges that cancel the contacts' gradient at an axis on an edge (least squares, >= 0)."""
    if not on_edge(x, domain):
        return multipliers
    terms = cell_terms(points[multipliers.contacts], x[None, :], np.zeros((1, 4)), radial=True)
    signed = multipliers.signs * multipliers.weights
    axis = terms.axis[0]
    tilt_vec = -(signed * terms.height[0]) @ terms.radial[0]  # sum s w alpha, normal to the axis
    position = signed @ terms.radial[0]
    cone = ring = 0.0
    if np.hypot(x[2], x[3]) >= domain.tan_max * (1 - 1e-9):
        e_normal = np.array([0.0, 0.0, 1.0]) - axis[2] * axis
        cone = max(0.0, float(tilt_vec @ e_normal) / max(float(e_normal @ e_normal), 1e-300))
    if np.hypot(x[0], x[1]) >= domain.offset * (1 - 1e-9):
        normal = np.array([x[0], x[1]]) / np.hypot(x[0], x[1])
        ring = max(0.0, float(position[:2] @ normal))
    return dataclasses.replace(multipliers, cone=cone, ring=ring)


def make_polisher(domain: Domain, mode: str, size: float) -> Callable[[int, FloatArray], Incumbent | None]:
    """A function ``polish(chart, x)``: the best local optimum in the region reached from ``x`` (or None)."""

    def solve(points: FloatArray, start: FloatArray, model: Model) -> ZoneSolution | None:
        try:
            solution = solve_minimax(points, start, model, mode, size=size)  # type: ignore[arg-type]
        except (ValueError, np.linalg.LinAlgError, FloatingPointError):
            return None
        if solution.message == "diverged" or not np.all(np.isfinite(solution.x)):
            return None
        return solution

    def polish(chart: int, x: FloatArray) -> Incumbent | None:
        points = domain.charts[chart]
        found: list[Incumbent] = []
        solution = solve(points, np.asarray(x, dtype=float), axis_distance)
        if solution is not None and inside_region(solution.x, domain):
            found.append(_incumbent(chart, solution.x, solution, mode, domain))
        else:
            for start, model, back in _edge_models(domain, np.asarray(x, dtype=float)):
                edge_solution = solve(points, start, model)
                if edge_solution is None:
                    continue
                axis = back(edge_solution.x)
                if inside_region(axis, domain):
                    found.append(_incumbent(chart, axis, edge_solution, mode, domain))
        if not found:
            return None
        return min(found, key=lambda inc: inc.value)

    return polish
