"""Lagrangian bounds over axis cells: weighted sums of the point distances.

For weights ``w >= 0`` summing to 1 on each level (outer points ``s = +1``, inner points
``s = -1``), the objective of an axis is at least ``F = sum s w rho`` (``max rho``, ``max rho
- min rho`` and ``-min rho`` all dominate such a sum), and inside the axis region at least
``F + c (cos(cone) - d . e_z) + r (|X| - offset)`` for ``c, r >= 0`` (both edge terms are
``<= 0`` there).  Over a cell, each distance obeys the linear inequalities of
:mod:`~pcmm_geo.fit.zone.axial.bounds` (outer points from below, inner points from above
with a second-order term), so

    F >= sum s w rho_c + (d - d_c) . A - (X - X_c) . B - (sum w) eps delta - sum_inner w D^2 / (2 rho)

with ``A = sum s w (rho d_c - h beta) - c e_z`` and ``B = sum s w beta - r n``, bounded over
the cell by ``|A_perp| sin(phi) + max(A . d_c, 0) (1 - cos(phi)) + |B_x| hx + |B_y| hy``.
Near a configuration whose weighted gradients cancel (a KKT point, or a flat valley of
near-optimal axes) ``A_perp`` and ``B`` nearly vanish and the bound is accurate to second
order in the cell size, where the per-point bound is only first-order.

Weights come from the local solver's multipliers at its optima (:class:`Multipliers`) and,
per cell, from a least-squares balance of the most extreme points at the cell's centre axis
(:func:`balanced_bound`): any non-negative weights give a valid bound, good weights a tight one.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.fit.zone.axial.bounds import CellShape, CellTerms

FloatArray = NDArray[np.float64]


@record
class Multipliers:
    """Weights of contact points and of the region's active edges.

    ``signs`` +1 (outer level) / -1 (inner level); ``weights`` >= 0 summing to 1 per level;
    ``cone`` (>= 0) weights the tilt constraint ``cos(cone) - d . e_z <= 0``, ``ring`` (>= 0)
    the crossing constraint ``|X| - offset <= 0``.
    """

    contacts: NDArray[np.intp]
    signs: FloatArray
    weights: FloatArray
    cone: float = 0.0
    ring: float = 0.0


def _weighted_bound(
    rho: FloatArray,
    height: FloatArray,
    radial: FloatArray,
    signs: FloatArray,
    weights: FloatArray,
    terms: CellTerms,
    mode: str,
    *,
    cone: float = 0.0,
    ring: float = 0.0,
    cone_cos: float = 0.0,
    offset: float = np.inf,
) -> FloatArray:
    """The Lagrangian bound (K,) for per-cell points ``rho``/``height`` (K, M), ``radial`` (K, M, 3), weights (K, M)."""
    signed = signs * weights
    value = np.einsum("km,km->k", rho, signed)
    tilt_vec = -np.einsum("km,kmj->kj", signed * height, radial) + value[:, None] * terms.axis
    position = np.einsum("km,kmj->kj", signed, radial)
    edges = np.zeros(len(value))
    if cone > 0.0:
        tilt_vec[:, 2] -= cone
        edges += cone * (cone_cos - terms.axis[:, 2])
    if ring > 0.0:
        length = np.hypot(terms.foot[:, 0], terms.foot[:, 1])
        normal = terms.foot[:, :2] / np.where(length > 0, length, 1.0)[:, None]
        position[:, :2] -= ring * normal
        edges += ring * (length - offset)
    along = np.einsum("kj,kj->k", tilt_vec, terms.axis)
    across = np.linalg.norm(tilt_vec - along[:, None] * terms.axis, axis=1)
    first_order = (
        across * terms.sin_phi
        + np.maximum(along, 0.0) * terms.one_minus_cos
        + np.abs(position[:, 0]) * terms.half[:, 0]
        + np.abs(position[:, 1]) * terms.half[:, 1]
    )
    total_weight = weights.sum(axis=1)
    correction = np.zeros(len(value))
    inner = signs < 0
    if inner.any():
        spread = (
            np.abs(height) * terms.sin_phi[:, None]
            + rho * terms.chord[:, None]
            + (terms.eps * (1.0 + terms.chord))[:, None]
        )
        with np.errstate(divide="ignore", invalid="ignore"):
            curvature = np.where(rho > 0, spread**2 / (2.0 * rho), np.inf)
        correction = np.where(inner & (weights > 0), np.minimum(curvature, 1e300) * weights, 0.0).sum(axis=1)
    bound = value + edges - first_order - total_weight * terms.eps * terms.chord - correction
    bound = bound - terms.slack * (1.0 + total_weight)
    return np.maximum(bound, 0.0) if mode in ("mcc", "zone") else bound


def multiplier_bound(
    terms: CellTerms, multipliers: Multipliers, mode: str, *, cone_cos: float = 0.0, offset: float = np.inf
) -> FloatArray:
    """Lower bound (K,) of the objective over each cell from fixed weights (``terms`` of the contacts, with radial)."""
    assert terms.radial is not None
    k = terms.rho.shape[0]
    signs = np.broadcast_to(multipliers.signs, terms.rho.shape)
    weights = np.broadcast_to(multipliers.weights, (k, len(multipliers.weights)))
    return _weighted_bound(
        terms.rho, terms.height, terms.radial, signs, weights, terms, mode,
        cone=multipliers.cone, ring=multipliers.ring, cone_cos=cone_cos, offset=offset,
    )


#: points per level tried for the balanced weights (each gives a valid bound; the best is kept)
BALANCE_COUNTS = {"zone": (2, 3, 4), "mcc": (3, 4, 6), "mic": (3, 4, 6)}


def balanced_bound(points: FloatArray, shape: CellShape, terms: CellTerms, mode: str) -> FloatArray:
    """Lower bound (K,) of the objective over each cell with weights balanced at the cell's own centre axis.

    The most extreme points of each level at the centre axis (``terms`` are those of
    ``points``) get the weights minimising, per cell, the squared first-order terms of the
    bound plus the squared value loss ``sum w |level - rho|`` under the level sums (a batched
    equality-constrained least-squares solve; negative weights clipped).  A least-squares
    balance is not the best weighting, and fewer points sometimes do better: the best bound
    over the point counts of :data:`BALANCE_COUNTS` is kept.
    """
    k, n = terms.rho.shape
    largest = min(max(BALANCE_COUNTS[mode]), n)
    ranked = []
    if mode in ("mcc", "zone"):
        top = np.argpartition(-terms.rho, largest - 1, axis=1)[:, :largest]
        ranked.append(np.take_along_axis(top, np.argsort(-np.take_along_axis(terms.rho, top, axis=1), axis=1), axis=1))
    if mode in ("zone", "mic"):
        low = np.argpartition(terms.rho, largest - 1, axis=1)[:, :largest]
        ranked.append(np.take_along_axis(low, np.argsort(np.take_along_axis(terms.rho, low, axis=1), axis=1), axis=1))
    best = np.full(k, -np.inf)
    for count in sorted({min(c, n) for c in BALANCE_COUNTS[mode]}):
        best = np.maximum(best, _balanced_weights_bound(points, shape, terms, mode, [r[:, :count] for r in ranked]))
    return best


def _balanced_weights_bound(
    points: FloatArray, shape: CellShape, terms: CellTerms, mode: str, picks: list[NDArray[np.intp]]
) -> FloatArray:
    """The Lagrangian bound (K,) with least-squares balanced weights on the picked points of each level."""
    k = terms.rho.shape[0]
    signs = []
    if mode in ("mcc", "zone"):
        signs.append(np.ones(picks[0].shape[1]))
    if mode in ("zone", "mic"):
        signs.append(-np.ones(picks[-1].shape[1]))
    index = np.concatenate(picks, axis=1)
    sign = np.concatenate(signs)
    m_total = index.shape[1]
    rel = points[index] - shape.foot[:, None, :]
    height = np.einsum("kmj,kj->km", rel, shape.axis)
    u = np.einsum("kmj,kj->km", rel, shape.first)
    v = np.einsum("kmj,kj->km", rel, shape.second)
    rho = np.hypot(u, v)
    safe = np.where(rho > 0, rho, 1.0)
    radial = (u[..., None] * shape.first[:, None, :] + v[..., None] * shape.second[:, None, :]) / safe[..., None]
    radial = np.where((rho > 0)[..., None], radial, shape.first[:, None, :])
    level = np.where(sign > 0, terms.rho.max(axis=1, keepdims=True), terms.rho.min(axis=1, keepdims=True))
    loss = np.abs(level - rho)
    # rows of the first-order terms (tilt across the axis, position x, y) and the value loss, per weight
    tilt = (-height[..., None] * radial) * terms.sin_phi[:, None, None]
    design = np.concatenate(
        [
            np.transpose(tilt * sign[None, :, None], (0, 2, 1)),
            (radial[..., 0] * sign * terms.half[:, 0:1])[:, None, :],
            (radial[..., 1] * sign * terms.half[:, 1:2])[:, None, :],
            loss[:, None, :],
        ],
        axis=1,
    )
    levels = [value for value in (1.0, -1.0) if np.any(sign == value)]
    gram = np.einsum("krm,krn->kmn", design, design)
    scale = np.maximum(np.einsum("kmm->k", gram) / m_total, 1e-300)
    gram += (1e-9 * scale)[:, None, None] * np.eye(m_total)
    n_lev = len(levels)
    system = np.zeros((k, m_total + n_lev, m_total + n_lev))
    system[:, :m_total, :m_total] = gram
    for row, value in enumerate(levels):
        system[:, m_total + row, :m_total] = sign == value
        system[:, :m_total, m_total + row] = (sign == value) * scale[:, None]
    rhs = np.zeros((k, m_total + n_lev))
    rhs[:, m_total:] = 1.0
    try:
        solution = np.linalg.solve(system, rhs[..., None])[..., 0]
    except np.linalg.LinAlgError:
        return np.full(k, -np.inf)
    weights = np.clip(solution[:, :m_total], 0.0, None)
    for value in levels:
        group = sign == value
        total = weights[:, group].sum(axis=1, keepdims=True)
        extreme = np.argmin(loss[:, group], axis=1)
        fallback_rows = np.zeros((k, int(group.sum())))
        fallback_rows[np.arange(k), extreme] = 1.0
        weights[:, group] = np.where(total > 0, weights[:, group] / np.where(total > 0, total, 1.0), fallback_rows)
    signs_k = np.broadcast_to(sign, rho.shape)
    return _weighted_bound(rho, height, radial, signs_k, weights, terms, mode)
