"""Branch and bound over axis cells: the global search of the axial minimax fits.

The objective ``f`` (minimised) of an axis is ``max rho`` (``mcc``), ``max rho - min rho``
(``zone``) or ``-min rho`` (``mic``) over the point distances ``rho`` from the axis.  The
axes are cut into cells (boxes of ``(x0, y0, a, b)`` in a chart, see
:mod:`~pcmm_geo.fit.zone.axial.bounds`); each generation bounds ``f`` from below on every
live cell, evaluates ``f`` exactly at the most promising cell centres (the incumbent is
the best axis found; the search starts from a local solver's optimum), discards the cells whose bound
is within ``tolerance`` of the incumbent and halves the others along their widest
dimensions.  When no cell is left, the incumbent is within ``tolerance`` of the optimum
over the whole domain: a *global* result.  When the budget runs out first, the smallest
bound over the live cells is the proven bound of a *local* result.

Bounds over a subset of the points are valid bounds (a maximum over fewer points is not
larger): the search bounds the cells on a *working set* of the points that can still be
extreme in some live cell, and evaluates candidate axes on all points.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.fit.zone._solver import ZoneSolution
from pcmm_geo.fit.zone.axial.bounds import CellShape, CellTerms, axis_distances, cell_terms, center_values, point_bounds
from pcmm_geo.fit.zone.axial.lagrange import Multipliers, balanced_bound, multiplier_bound
from pcmm_geo.fit.zone.axial.surround import EDGE_REASON, EdgeWatch, Surround

FloatArray = NDArray[np.float64]
IndexArray = NDArray[np.intp]

_TIER_POINTS = 48  # points per level in the first-tier bound of large working sets
_NET_POINTS = 400  # points of the second-tier (covering) subset
_CANDIDATES = 4  # cell centres evaluated on all points per generation
_CHUNK = 1_500_000  # cells x points per vectorised block
_MAX_LIVE = 2_000_000  # cells of one generation kept in memory at most
_MAX_POLISH = 12  # local solves from improved incumbents per search
_EXPLORE_LIVE = 32  # more live cells than this: polish from the lowest-bound one (another basin?)
_MAX_KNOWN = 12  # local solutions whose multipliers bound the cells


@record
class Incumbent:
    """A feasible axis and its objective value (on all points).

    ``multipliers``: support points with their levels and KKT multipliers (and the
    region edges' multipliers) when the axis comes from the local solver; ``polished``:
    that solver's solution.
    """

    value: float
    chart: int
    x: FloatArray
    multipliers: Multipliers | None = None
    polished: ZoneSolution | None = None


@record
class Domain:
    """Where the search runs.

    ``charts[k]``: the points in chart ``k``'s frame (N, 3); ``roots``: (chart, centre,
    half) of the starting cells; ``tan_max``/``offset``: the region's tilt and crossing
    discs (``inf`` for none).
    """

    charts: list[FloatArray]
    roots: list[tuple[int, FloatArray, FloatArray]]
    tan_max: float = np.inf
    offset: float = np.inf
    hull: IndexArray | None = None  # convex-hull vertices (suffice for maxima of convex distances)


@record
class Cells:
    """A batch of axis cells: ``chart`` (K,), ``centre`` / ``half`` (K, 4) as ``(x0, y0, a, b)``;
    ``inside`` (K,): every axis of the cell is surrounded by the data (MIC)."""

    chart: IndexArray
    center: FloatArray
    half: FloatArray
    inside: NDArray[np.bool_]

    def __len__(self) -> int:
        return len(self.chart)

    def take(self, rows: IndexArray | NDArray[np.bool_]) -> Cells:
        """The cells selected by an index or mask."""
        return Cells(self.chart[rows], self.center[rows], self.half[rows], self.inside[rows])


@dataclass(frozen=True)
class SearchOutcome:
    """Result of :func:`branch_and_bound`: the incumbent, the proven bound of ``f`` and the effort."""

    incumbent: Incumbent
    bound: float
    finished: bool
    cells: int
    generations: int
    seconds: float
    stop_reason: str


def clip_to_region(x: FloatArray, domain: Domain) -> FloatArray:
    """The nearest axis of the region in each disc (x (K, 4) -> (K, 4))."""
    out = np.array(x, dtype=float)
    for slots, limit in (((0, 1), domain.offset), ((2, 3), domain.tan_max)):
        if not np.isfinite(limit):
            continue
        length = np.hypot(out[:, slots[0]], out[:, slots[1]])
        scale = np.where(length > limit, limit / np.where(length > 0, length, 1.0), 1.0)
        out[:, slots[0]] *= scale
        out[:, slots[1]] *= scale
    return out


def _rows(item: CellShape | CellTerms, rows: NDArray[np.bool_]) -> CellShape | CellTerms:
    """The cells ``rows`` of a shape or of terms (every per-cell array sliced)."""
    sliced = {}
    for f in dataclasses.fields(item):
        value = getattr(item, f.name)
        sliced[f.name] = value[rows] if isinstance(value, np.ndarray) and value.ndim >= 1 else value
    return dataclasses.replace(item, **sliced)


def _touches_region(cells: Cells, domain: Domain) -> NDArray[np.bool_]:
    """Cells that hold at least one axis of the region (nearest box point inside both discs)."""
    gap = np.maximum(np.abs(cells.center) - cells.half, 0.0)
    return (np.hypot(gap[:, 0], gap[:, 1]) <= domain.offset) & (np.hypot(gap[:, 2], gap[:, 3]) <= domain.tan_max)


@dataclass(frozen=True)
class Hooks:
    """What the search calls on the problem.

    ``evaluate(chart, x (M, 4)) -> f (M,)`` on all points; ``polish(chart, x, margin)`` a local
    solve from ``x`` with the points within ``margin`` of the levels as contacts (or None);
    ``balance(chart, x)`` weights of the extreme points at ``x`` for the Lagrangian bound (or
    None); ``surround`` (MIC, one chart) restricts the search to axes the data surround.
    """

    evaluate: Callable[[int, FloatArray], FloatArray]
    polish: Callable[[int, FloatArray, float | None], Incumbent | None]
    balance: Callable[[int, FloatArray], Multipliers | None]
    surround: Surround | None = None


class _Search:
    def __init__(self, domain: Domain, mode: str, incumbent: Incumbent, hooks: Hooks, tolerance: float) -> None:
        self.domain = domain
        self.mode = mode
        self.incumbent = incumbent
        self.evaluate = hooks.evaluate
        self.balance = hooks.balance
        self.polish = hooks.polish
        self.surround = hooks.surround
        self.polishes = 0
        self.polished_at = np.inf  # the margin at the last local solve
        self.margin = np.inf  # largest per-point margin of the live cells (mm)
        self.tolerance = tolerance
        self._margins: list[float] = []
        self.n_points = domain.charts[0].shape[0]
        self.working = self._initial_working_set()
        self.proven = np.inf
        self.known: list[tuple[int, FloatArray, Multipliers]] = []
        self._remember(incumbent)
        self._tier: IndexArray | None = None
        self._net: tuple[IndexArray, float] | None = None
        self._net_of = -1
        self.cone_cos = float(1.0 / np.sqrt(1.0 + domain.tan_max**2)) if np.isfinite(domain.tan_max) else 0.0
        charts0 = domain.charts[0]
        self.extent = float(np.sqrt(np.einsum("ij,ij->i", charts0, charts0).max()))

    def _initial_working_set(self) -> IndexArray:
        if self.mode == "mcc" and self.domain.hull is not None:
            return np.array(self.domain.hull, dtype=np.intp)
        return np.arange(self.n_points)

    # -- incumbent ---------------------------------------------------------------------
    def offer(self, chart: int, x: FloatArray) -> None:
        """Evaluate axes ``x`` (M, 4) of one chart on all points; the best becomes the incumbent if better.

        A clear gain is polished by the local solver, with the points within the live
        cells' margin of the levels as its contacts.
        """
        values = self.evaluate(chart, x)
        best = int(np.argmin(values))
        if values[best] < self.incumbent.value:
            gain = self.incumbent.value - float(values[best])
            self._accept(Incumbent(float(values[best]), chart, np.array(x[best], dtype=float)))
            if (gain > self.tolerance and self.polishes < _MAX_POLISH and np.isfinite(self.margin)
                    and self.margin <= 0.1 * self.polished_at):
                self.polishes += 1
                self.polished_at = self.margin
                found = self.polish(chart, self.incumbent.x, 2.0 * self.margin)
                if found is not None:
                    self._remember(found)
                    if found.value <= self.incumbent.value:
                        self._accept(found)

    def _remember(self, solution: Incumbent) -> None:
        if solution.multipliers is not None:
            self.known = [*self.known, (solution.chart, solution.x, solution.multipliers)][-_MAX_KNOWN:]

    def _accept(self, incumbent: Incumbent) -> None:
        self.incumbent = incumbent
        self._tier = None
        if incumbent.multipliers is None:
            found = self.balance(incumbent.chart, incumbent.x)
            if found is not None:
                self.known = [*self.known, (incumbent.chart, incumbent.x, found)][-_MAX_KNOWN:]

    def tier_points(self) -> IndexArray:
        """A few of the most extreme points about the incumbent axis (first-tier bounds)."""
        if self._tier is None:
            rho = axis_distances(self.domain.charts[self.incumbent.chart], self.incumbent.x[None, :])[0]
            multipliers = self.incumbent.multipliers
            picks = [np.zeros(0, dtype=np.intp) if multipliers is None else multipliers.contacts]
            count = min(_TIER_POINTS, len(rho))
            if self.mode in ("mcc", "zone"):
                picks.append(np.argpartition(-rho, count - 1)[:count])
            if self.mode in ("zone", "mic"):
                picks.append(np.argpartition(rho, count - 1)[:count])
            self._tier = np.unique(np.concatenate(picks).astype(np.intp))
        return self._tier

    # -- bounds --------------------------------------------------------------------------
    def bounds(
        self, chart: int, center: FloatArray, half: FloatArray, subset: IndexArray
    ) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
        """Lower bounds, centre values on ``subset`` and the per-point activity of ``subset`` (chunked)."""
        points = self.domain.charts[chart][subset]
        step = max(1, _CHUNK // max(len(subset), 1))
        lower = np.empty(len(center))
        values = np.empty(len(center))
        active = np.zeros(len(subset), dtype=bool)
        inc = self.incumbent
        known = [multipliers for k, _, multipliers in self.known if k == chart]
        if known:
            contact_index, slots = np.unique(np.concatenate([m.contacts for m in known]), return_inverse=True)
            contact_points = self.domain.charts[chart][contact_index]
            bounds_of = np.cumsum([0] + [len(m.contacts) for m in known])
        for start in range(0, len(center), step):
            block = slice(start, start + step)
            shape = CellShape.of(center[block], half[block])
            terms = cell_terms(points, shape)
            bound, low, high = point_bounds(terms, self.mode)
            if known:
                contact_terms = cell_terms(contact_points, shape, radial=True)
                for j, multipliers in enumerate(known):
                    own = contact_terms.select(slots[bounds_of[j] : bounds_of[j + 1]])
                    bound = np.maximum(bound, multiplier_bound(own, multipliers, self.mode,
                                                               cone_cos=self.cone_cos, offset=self.domain.offset))
            live = bound < inc.value - self.tolerance
            if live.any():
                # balanced weights among the incumbent's extreme points when the subset is large (any subset is valid)
                pool, pool_terms = points, _rows(terms, live)
                if len(subset) > 4 * _TIER_POINTS:
                    pool = self.domain.charts[chart][self.tier_points()]
                    pool_terms = cell_terms(pool, _rows(shape, live))
                balanced = balanced_bound(pool, _rows(shape, live), pool_terms, self.mode)
                bound[live] = np.maximum(bound[live], balanced)
            lower[block] = bound
            values[block] = center_values(terms.rho, self.mode)
            self._margins.append(float(np.median(terms.eps + self.extent * terms.sin_phi)))
            live = bound < inc.value - self.tolerance
            if live.any():
                active |= self._activity(terms, low, high, live)
        return lower, values, active

    def _activity(
        self, terms: CellTerms, low: FloatArray | None, high: FloatArray | None, live: NDArray[np.bool_]
    ) -> NDArray[np.bool_]:
        """Points that may still decide the bound in some live cell (a heuristic: any subset is valid)."""
        rho = terms.rho[live]
        active = np.zeros(rho.shape[1], dtype=bool)
        if low is not None:
            low_live = low[live]
            reach = rho + 2.0 * (rho - low_live)
            active |= (reach >= low_live.max(axis=1, keepdims=True)).any(axis=0)
        if high is not None:
            high_live = high[live]
            reach = rho - 2.0 * (high_live - rho)
            active |= (reach <= high_live.min(axis=1, keepdims=True)).any(axis=0)
        return active

    def net(self) -> tuple[IndexArray, float]:
        """A strided subset of the working set and its covering radius (every point lies within it of the subset)."""
        if self._net is None or self._net_of != len(self.working):
            from scipy.spatial import cKDTree

            stride = max(1, len(self.working) // _NET_POINTS)
            subset = self.working[::stride]
            points = self.domain.charts[0]
            radius = float(cKDTree(points[subset]).query(points[self.working])[0].max())
            self._net, self._net_of = (subset, radius), len(self.working)
        return self._net

    # -- one generation -------------------------------------------------------------------
    def generation(self, cells: Cells) -> tuple[Cells, FloatArray]:
        """Bound the cells, update the incumbent, drop what is proven; return the live cells and their bounds."""
        cells = cells.take(_touches_region(cells, self.domain))
        if self.surround is not None:
            cells = self._surround(cells)
        lower = np.full(len(cells), -np.inf)
        values = np.full(len(cells), np.inf)
        active = np.zeros(len(self.working), dtype=bool)
        coarse_live = False
        self._margins = []
        for k in np.unique(cells.chart):
            rows = np.flatnonzero(cells.chart == k)
            tiers: list[tuple[IndexArray, float]] = []
            if len(self.working) > 4 * _TIER_POINTS and len(rows) > 8:
                tiers.append((self.tier_points(), np.inf))
            if len(self.working) > 2 * _NET_POINTS:
                tiers.append(self.net())
            for subset, cover in tiers:
                bound, value, _ = self.bounds(int(k), cells.center[rows], cells.half[rows], subset)
                lower[rows] = np.maximum(lower[rows], bound)
                values[rows] = value
                rows = rows[lower[rows] < self.incumbent.value - self.tolerance]
                if np.isfinite(cover) and len(rows):
                    # cells much wider than the subset's covering radius keep the subset's bound
                    half = cells.half[rows]
                    scale = np.hypot(half[:, 0], half[:, 1]) + self.extent * np.hypot(half[:, 2], half[:, 3])
                    coarse = scale > 4.0 * cover
                    coarse_live = coarse_live or bool(coarse.any())
                    rows = rows[~coarse]
                if len(rows) == 0:
                    break
            if len(rows) == 0:
                continue
            bound, value, act = self.bounds(int(k), cells.center[rows], cells.half[rows], self.working)
            lower[rows] = np.maximum(lower[rows], bound)
            values[rows] = value
            active |= act
        if self._margins:
            self.margin = max(self._margins)
        self._candidates(cells, values)
        live = lower < self.incumbent.value - self.tolerance
        if (~live).any():
            self.proven = min(self.proven, float(lower[~live].min()))
        if active.any() and live.any() and not coarse_live:
            self.working = self.working[active]
            self._tier = None
        if live.sum() > _EXPLORE_LIVE:
            self._explore_lowest(cells.take(live), lower[live])
        return cells.take(live), lower[live]

    def _explore_lowest(self, cells: Cells, lower: FloatArray) -> None:
        """Weights that balance the extreme points at the live cell of least bound, unless known there already."""
        row = int(np.argmin(lower))
        chart, center, half = int(cells.chart[row]), cells.center[row], cells.half[row]
        for k, x, _ in self.known:
            if k == chart and np.all(np.abs(x - center) <= 2.0 * half):
                return
        x = clip_to_region(center[None, :], self.domain)[0]
        found = self.balance(chart, x)
        if found is not None:
            self.known = [*self.known, (chart, x, found)][-_MAX_KNOWN:]

    def _surround(self, cells: Cells) -> Cells:
        """MIC: drop cells whose axes the data cannot surround; mark cells whose axes they all surround."""
        assert self.surround is not None
        keep = np.ones(len(cells), dtype=bool)
        inside = cells.inside.copy()
        rows = np.flatnonzero(~inside)
        if len(rows):
            upper, lower = self.surround.cell_depth(cells.center[rows], cells.half[rows])
            keep[rows[upper < 0]] = False
            inside[rows[lower > 0]] = True
        return Cells(cells.chart, cells.center, cells.half, inside).take(keep)

    def _candidates(self, cells: Cells, values: FloatArray) -> None:
        """Evaluate the most promising cell centres (moved into the region) on all points.

        ``values`` are the centre values on a subset of the points: lower estimates of
        the true values, so a centre whose estimate is not below the incumbent is skipped.
        """
        order = np.argsort(values)
        order = order[values[order] < self.incumbent.value]
        for k in np.unique(cells.chart[order]):
            rows = order[cells.chart[order] == k]
            if self.surround is None:
                rows = rows[:_CANDIDATES]
                x = clip_to_region(cells.center[rows], self.domain)
            else:
                # MIC: the lowest values are mostly axes the data do not surround (their empty
                # cylinder is unbounded); take the best cells known to be surrounded as well
                rows = np.concatenate([rows[cells.inside[rows]][:_CANDIDATES], rows[~cells.inside[rows]][:_CANDIDATES]])
                x = clip_to_region(cells.center[rows], self.domain)
                within = np.all(np.abs(x - cells.center[rows]) <= cells.half[rows], axis=1)
                sure = cells.inside[rows] & within
                unsure = np.flatnonzero(~sure)
                if len(unsure):
                    sure[unsure] = self.surround.surrounded(x[unsure])
                x = x[sure]
            if len(x):
                self.offer(int(k), x)

    def split(self, cells: Cells) -> Cells:
        """Halve each cell along the dimensions whose width moves the distances most.

        A tilt half width turns into a distance through the largest distance of a
        working-set point from the chart origin.
        """
        points = self.domain.charts[0][self.working]
        reach = max(float(np.sqrt(np.einsum("ij,ij->i", points, points).max(initial=0.0))), 1e-300)
        center, half, chart, inside = cells.center, cells.half, cells.chart, cells.inside
        q2 = 1.0 + center[:, 2] ** 2 + center[:, 3] ** 2
        effect = np.column_stack([
            half[:, 0],
            half[:, 1],
            reach * half[:, 2] * np.sqrt(1.0 + center[:, 3] ** 2) / q2,
            reach * half[:, 3] * np.sqrt(1.0 + center[:, 2] ** 2) / q2,
        ])
        cut = effect >= 0.5 * effect.max(axis=1, keepdims=True)
        for dim in range(4):
            rows = np.flatnonzero(cut[:, dim])
            if len(rows) == 0:
                continue
            half = half.copy()
            half[rows, dim] *= 0.5
            twin = center[rows].copy()
            twin[:, dim] += half[rows, dim]
            center = center.copy()
            center[rows, dim] -= half[rows, dim]
            chart = np.concatenate([chart, chart[rows]])
            center = np.vstack([center, twin])
            half = np.vstack([half, half[rows]])
            inside = np.concatenate([inside, inside[rows]])
            cut = np.vstack([cut, cut[rows]])
        return Cells(chart, center, half, inside)


def branch_and_bound(
    domain: Domain,
    mode: str,
    incumbent: Incumbent,
    hooks: Hooks,
    *,
    tolerance: float,
    max_cells: int,
    max_seconds: float | None,
) -> SearchOutcome:
    """Minimise the objective of ``mode`` over the axes of ``domain`` to within ``tolerance``, from ``incumbent``."""
    started = time.perf_counter()
    search = _Search(domain, mode, incumbent, hooks, tolerance)
    cells = Cells(
        chart=np.array([root[0] for root in domain.roots], dtype=np.intp),
        center=np.array([root[1] for root in domain.roots], dtype=float),
        half=np.array([root[2] for root in domain.roots], dtype=float),
        inside=np.zeros(len(domain.roots), dtype=bool),
    )
    evaluated = 0
    generation = 0
    reason = "proof complete"
    lower = np.zeros(0)
    edge = EdgeWatch()
    while True:
        generation += 1
        evaluated += len(cells)
        cells, lower = search.generation(cells)
        if len(cells) == 0:
            break
        if search.surround is not None and edge.runs_onto_edge(search.surround, search.incumbent.value,
                                                               search.incumbent.x):
            reason = EDGE_REASON
            break
        if evaluated >= max_cells:
            reason = f"cell budget of {max_cells} cells exhausted"
            break
        if max_seconds is not None and time.perf_counter() - started > max_seconds:
            reason = f"time budget of {max_seconds:g} s exhausted"
            break
        if len(cells) * 16 > _MAX_LIVE:
            reason = f"more than {_MAX_LIVE} live cells"
            break
        cells = search.split(cells)
    bound = min(search.proven, float(lower.min()) if len(lower) else np.inf, search.incumbent.value)
    return SearchOutcome(
        incumbent=search.incumbent,
        bound=bound,
        finished=len(cells) == 0,
        cells=evaluated,
        generations=generation,
        seconds=time.perf_counter() - started,
        stop_reason=reason,
    )
