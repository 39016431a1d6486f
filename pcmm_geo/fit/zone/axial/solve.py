"""Set up and run the global axis search for a cylinder (over a region) or a 3-D line (all directions)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.fit.zone._common import GLOBAL_GAP_MM
from pcmm_geo.fit.zone._models import axis_distance
from pcmm_geo.fit.zone._solver import ZoneSolution, assess
from pcmm_geo.fit.zone.axial.bounds import axis_distances, center_values
from pcmm_geo.fit.zone.axial.polish import balanced_multipliers, make_polisher, on_edge
from pcmm_geo.fit.zone.axial.region import ResolvedRegion, SearchBudget
from pcmm_geo.fit.zone.axial.search import Domain, Hooks, Incumbent, branch_and_bound, clip_to_region
from pcmm_geo.fit.zone.axial.surround import Surround

FloatArray = NDArray[np.float64]



@record
class AxialOptimum:
    """Best axis of an axial minimax search, in the machine frame, with its proof.

    Attributes
    ----------
    point, direction : ndarray, shape (3,)
        A point of the axis (its crossing of the chart's reference plane) and the unit direction.
    distances : ndarray, shape (N,)
        Distances of the points from the axis (mm).
    value, bound : float
        Objective (``max rho``, ``max rho - min rho`` or ``-min rho``) and its proven lower bound.
    finished : bool
        Every cell was discarded: the gap is within the tolerance.
    on_boundary : bool
        The axis lies on the edge of the searched region.
    solution : ZoneSolution or None
        The local solver's solution at this axis (contacts, multipliers, KKT residual), if any.
    cells, generations, seconds, stop_reason :
        Effort and why the search stopped.
    """

    point: FloatArray
    direction: FloatArray
    distances: FloatArray
    value: float
    bound: float
    finished: bool
    on_boundary: bool
    solution: ZoneSolution | None
    cells: int
    generations: int
    seconds: float
    stop_reason: str


def _extreme_contacts(distances: FloatArray, mode: str) -> dict[int, float]:
    """The points at the extreme levels (to rounding) as contacts, +1 outer, -1 inner."""
    scale = 1e-9 * max(float(distances.max()), 1e-300)
    contacts: dict[int, float] = {}
    if mode in ("mcc", "zone"):
        contacts.update({int(i): 1.0 for i in np.flatnonzero(distances >= distances.max() - scale)})
    if mode in ("zone", "mic"):
        contacts.update({int(i): -1.0 for i in np.flatnonzero(distances <= distances.min() + scale)})
    return contacts


def _hull_vertices(points: FloatArray) -> NDArray[np.intp]:
    from scipy.spatial import ConvexHull, QhullError

    try:
        return np.asarray(ConvexHull(points).vertices, dtype=np.intp)
    except (QhullError, ValueError):  # flat or tiny data: every point may be extreme
        return np.arange(len(points), dtype=np.intp)


def _run(
    points_by_chart: list[FloatArray],
    frames: list[FloatArray],
    origin: FloatArray,
    domain: Domain,
    mode: str,
    start: tuple[int, FloatArray],
    budget: SearchBudget,
    tolerance: float,
    size: float,
    surround: Surround | None,
) -> AxialOptimum:
    def evaluate(chart: int, x: FloatArray) -> FloatArray:
        return center_values(axis_distances(points_by_chart[chart], x), mode)

    local_polish = make_polisher(domain, mode, size)

    def polish(chart: int, x: FloatArray, margin: float | None = None) -> Incumbent | None:
        found = local_polish(chart, x, margin)
        if found is not None and surround is not None and not surround.surrounded(found.x[None, :])[0]:
            return None
        return found

    chart0, x0 = start
    x0 = clip_to_region(np.asarray(x0, dtype=float)[None, :], domain)[0]
    value0 = float(evaluate(chart0, x0[None, :])[0])
    if surround is not None and not surround.surrounded(x0[None, :])[0]:
        value0 = np.inf  # not in the MIC's domain: no incumbent yet
    incumbent = Incumbent(value0, chart0, x0)
    polished = polish(chart0, x0)
    if polished is not None and polished.value <= incumbent.value:
        incumbent = polished
    hooks = Hooks(
        evaluate=evaluate,
        polish=polish,
        balance=lambda chart, x: balanced_multipliers(domain, chart, x, mode),
        surround=surround,
    )
    outcome = branch_and_bound(
        domain, mode, incumbent, hooks, tolerance=tolerance, max_cells=budget.max_cells, max_seconds=budget.max_seconds
    )
    best = outcome.incumbent
    if best.polished is None and np.isfinite(best.value):
        # the best axis is a cell centre: a local solve from it gives the contacts and multipliers
        spread = float(np.ptp(axis_distances(points_by_chart[best.chart], best.x[None, :])))
        again = polish(best.chart, best.x, 1e-6 * max(spread, size))
        if again is None or again.polished is None or not again.polished.certified:
            again = polish(best.chart, best.x)
        if again is not None and again.value <= best.value:
            best = again
    frame = frames[best.chart]
    x = best.x
    direction_local = np.array([x[2], x[3], 1.0]) / np.sqrt(1.0 + x[2] ** 2 + x[3] ** 2)
    distances = axis_distances(points_by_chart[best.chart], x[None, :])[0]
    value = float(center_values(distances[None, :], mode)[0]) if np.isfinite(best.value) else np.inf
    bound = min(outcome.bound, value)
    solution = best.polished
    if solution is None and np.isfinite(value):
        # no local solution at this axis (exact data: a degenerate contact system): assess its extreme points
        solution = assess(points_by_chart[best.chart], x, _extreme_contacts(distances, mode), axis_distance, mode,
                          size=size, message="the search's axis, not a local solver's")
    return AxialOptimum(
        point=origin + np.array([x[0], x[1], 0.0]) @ frame,
        direction=direction_local @ frame,
        distances=distances,
        value=value,
        bound=bound,
        finished=outcome.finished,
        on_boundary=on_edge(x, domain),
        solution=solution,
        cells=outcome.cells,
        generations=outcome.generations,
        seconds=outcome.seconds,
        stop_reason=outcome.stop_reason,
    )


def cylinder_search(
    points: FloatArray,
    mode: str,
    region: ResolvedRegion,
    start_point: FloatArray,
    start_axis: FloatArray,
    budget: SearchBudget,
) -> AxialOptimum:
    """Global search of the cylinder zone / MCC / MIC over the axes of ``region``.

    The search starts from the axis through ``start_point`` along ``start_axis`` (the
    least-squares cylinder), moved into the region if it lies outside.
    """
    local = (points - region.origin) @ region.frame.T
    size = max(float(np.sqrt(np.einsum("ij,ij->i", local, local).max())), 1e-300)
    direction = region.frame @ start_axis
    if direction[2] < 0:
        direction = -direction
    start_local = region.frame @ (start_point - region.origin)
    if abs(direction[2]) > 1e-12:
        crossing = start_local - start_local[2] / direction[2] * direction
        x0 = np.array([crossing[0], crossing[1], direction[0] / direction[2], direction[1] / direction[2]])
    else:
        x0 = np.zeros(4)
    root_half = np.array([region.offset, region.offset, region.tan_max, region.tan_max])
    hull = _hull_vertices(local)
    domain = Domain(charts=[local], roots=[(0, np.zeros(4), root_half)], tan_max=region.tan_max,
                    offset=region.offset, hull=hull)
    surround = Surround(local, hull) if mode == "mic" else None
    return _run([local], [region.frame], region.origin, domain, mode, (0, x0), budget, GLOBAL_GAP_MM, size, surround)


def line_search(
    points: FloatArray, ls_point: FloatArray, ls_direction: FloatArray, budget: SearchBudget
) -> AxialOptimum:
    """Smallest cylinder enclosing ``points`` over all axis directions (3-D line minimum zone).

    The directions are covered by three gnomonic charts (cube faces around the
    least-squares direction and two normals to it); in each chart the axis crosses the
    plane through the centroid normal to the chart's pole within ``sqrt(2) R_max`` of the
    centroid (``R_max`` the largest distance of a point from it): the optimal axis meets
    the convex hull of the points, which this box contains.
    """
    from pcmm_geo.fit._kernels._core import rotation_to_z

    centroid = points.mean(axis=0)
    base = rotation_to_z(ls_direction)
    frames = [base, base[[1, 2, 0]], base[[2, 0, 1]]]
    charts = [(points - centroid) @ frame.T for frame in frames]
    extent = max(float(np.sqrt(np.einsum("ij,ij->i", charts[0], charts[0]).max())), 1e-300)
    box = np.sqrt(2.0) * extent * (1.0 + 1e-9)
    half = np.array([box, box, 1.0, 1.0])
    domain = Domain(charts=charts, roots=[(k, np.zeros(4), half) for k in range(3)], hull=_hull_vertices(charts[0]))
    start_local = base @ (ls_point - centroid)
    x0 = np.array([start_local[0], start_local[1], 0.0, 0.0])
    # the form of a 3-D line is a diameter: the radius tolerance is half the diameter's
    return _run(charts, frames, centroid, domain, "mcc", (0, x0), budget, GLOBAL_GAP_MM / 2, extent, None)
