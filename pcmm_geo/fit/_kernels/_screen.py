"""Direction screening for the axial fits: where can the global least-squares minimum be?

With the axis *direction* fixed, a cylinder, cone or torus fit is a small problem in the
remaining parameters (axis position, radii, half angle).  Its converged sum of squares as a
function of the direction, the *reduced cost*, has one local minimum per basin of the full
problem, so scanning it over the hemisphere finds every basin, including the narrow ones
of sparse data that the principal axes miss.  One implementation serves all three elements:

1. evaluate the reduced cost on a Fibonacci lattice of directions (vectorised: every
   direction's small fit runs as one batched Levenberg-Marquardt),
2. keep the lattice's local minima (no lower neighbour), best first,
3. polish each by a shrinking 3 x 3 pattern search of tilts, again on the reduced cost.

The polished directions start the full fit; :func:`pcmm_geo.fit._axial.solve_axial` then
compares the minima it converges to and warns when two are practically equally good.

The wrong minima the screening exists for come from sparse or partial data.  A cylinder of
many points that surround its fitted axis (:func:`surrounds_axis`: more than
:data:`DENSE_POINTS` points, no gap in azimuth wider than :data:`FULL_COVERAGE_GAP`) is
fitted from the principal axes alone; the screening runs when the data are sparse, or when
that fit leaves a wider gap (a partial surface), and the fit is then repeated from the
screened directions too.  Private to :mod:`pcmm_geo.fit`.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.fit._kernels._axial import SCREEN_POINTS

FloatArray = NDArray[np.float64]

#: Vectorised reduced cost: local points ``(D, n, 3)`` (z = trial axis) -> sum of squares ``(D,)``.
ReducedCost = Callable[[FloatArray], FloatArray]

#: Lattice size on the hemisphere (spacing about sqrt(2 pi / count) rad = 8 degrees).
LATTICE = 240
#: Nearest lattice neighbours that a local minimum must not exceed.
_NEIGHBOURS = 6
_BATCH_ITERATIONS = 12
#: Torus: axis-position grid (ticks per side) and how many of its best cells start a refinement.
_TORUS_GRID = 13
_TORUS_GRID_STARTS = 2


@lru_cache(maxsize=4)
def lattice(count: int) -> tuple[FloatArray, NDArray[np.int64], FloatArray]:
    """Fibonacci lattice on the upper hemisphere, each point's nearest neighbours (axes: ``d ~ -d``), its frames."""
    index = np.arange(count) + 0.5
    z = 1.0 - index / count
    azimuth = np.pi * (3.0 - np.sqrt(5.0)) * index
    ring = np.sqrt(1.0 - z * z)
    directions = np.c_[ring * np.cos(azimuth), ring * np.sin(azimuth), z]
    closeness = np.abs(directions @ directions.T)
    np.fill_diagonal(closeness, -1.0)
    neighbours = np.argsort(-closeness, axis=1)[:, :_NEIGHBOURS]
    rotations = frames(directions)
    for array in (directions, neighbours, rotations):
        array.setflags(write=False)
    return directions, neighbours, rotations


def screen_subset(centred: FloatArray) -> FloatArray:
    """At most :data:`SCREEN_POINTS` points, evenly strided through the data (deterministic)."""
    if centred.shape[0] <= SCREEN_POINTS:
        return centred
    index = np.linspace(0, centred.shape[0] - 1, SCREEN_POINTS).round().astype(int)
    return centred[index]


def frames(directions: FloatArray) -> FloatArray:
    """Rotations ``(D, 3, 3)`` taking each unit direction to +z (rows: two across, the direction; vectorised
    :func:`~pcmm_geo.fit._core.rotation_to_z`)."""
    helper = np.zeros_like(directions)
    helper[np.arange(len(directions)), np.argmin(np.abs(directions), axis=1)] = 1.0
    across = np.cross(helper, directions)
    across /= np.linalg.norm(across, axis=1, keepdims=True)
    return np.stack([across, np.cross(directions, across), directions], axis=1)


def _tilted(directions: FloatArray, step: float) -> FloatArray:
    """Each direction's 3 x 3 grid of tilts of size ``step`` (rad), shape (K, 9, 3), centre included."""
    ta, tb = np.meshgrid([-step, 0.0, step], [-step, 0.0, step])
    local = np.c_[ta.ravel(), tb.ravel(), np.ones(9)]
    local /= np.linalg.norm(local, axis=1, keepdims=True)
    return np.einsum("ti,kij->ktj", local, frames(directions))


@record
class ScreenedAxis:
    """A polished local minimum of the reduced cost: its direction and cost (on the screening subset)."""

    direction: FloatArray
    cost: float


def screen(
    centred: FloatArray,
    reduced_cost: ReducedCost,
    *,
    count: int = LATTICE,
    keep: int = 5,
    levels: int = 4,
) -> list[ScreenedAxis]:
    """Local minima of the reduced cost over axis directions, polished, best first.

    Parameters
    ----------
    centred : ndarray, shape (N, 3)
        Data centred at their centroid, mm.
    reduced_cost : callable
        Vectorised reduced cost (see :data:`ReducedCost`).
    count : int
        Lattice size on the hemisphere.
    keep : int
        Number of lattice minima polished and returned.
    levels : int
        Pattern-search levels; the tilt step starts at half the lattice spacing and halves
        each level.

    Returns
    -------
    list of ScreenedAxis
    """
    data = screen_subset(centred)
    directions, neighbours, lattice_frames = lattice(count)
    costs = reduced_cost(np.einsum("dij,nj->dni", lattice_frames, data))
    costs = np.where(np.isfinite(costs), costs, np.inf)
    is_minimum = np.all(costs[:, None] <= costs[neighbours], axis=1) & np.isfinite(costs)
    order = [int(i) for i in np.argsort(costs) if is_minimum[i]][:keep]
    if not order:
        return []
    current = np.array([directions[i] for i in order])
    best = costs[order].copy()
    step = 0.5 * np.sqrt(2.0 * np.pi / count)
    for _ in range(levels):
        trials = _tilted(current, step).reshape(-1, 3)
        trial_costs = reduced_cost(np.einsum("dij,nj->dni", frames(trials), data)).reshape(len(current), 9)
        trial_costs = np.where(np.isfinite(trial_costs), trial_costs, np.inf)
        pick = np.argmin(trial_costs, axis=1)
        for k, index in enumerate(pick):
            if trial_costs[k, index] < best[k]:
                best[k] = trial_costs[k, index]
                current[k] = trials[9 * k + index]
        step *= 0.5
    ranked = np.argsort(best)
    return [ScreenedAxis(direction=current[k], cost=float(best[k])) for k in ranked if np.isfinite(best[k])]


def batched_lm(
    model: Callable[[FloatArray], tuple[FloatArray, FloatArray]],
    params: FloatArray,
    *,
    iterations: int = _BATCH_ITERATIONS,
) -> tuple[FloatArray, FloatArray]:
    """A few Levenberg-Marquardt steps of D independent small problems at once.

    Parameters
    ----------
    model : callable
        ``model(params (D, P)) -> (residuals (D, n), jacobian (D, n, P))``.
    params : ndarray, shape (D, P)
        Starting parameters.

    Returns
    -------
    params : ndarray, shape (D, P)
    costs : ndarray, shape (D,)
        Sums of squared residuals (inf where not finite).
    """
    params = np.array(params, dtype=float)
    residuals, jac = model(params)
    cost = np.einsum("dn,dn->d", residuals, residuals)
    damping = np.full(len(params), 1e-6)
    eye = np.eye(params.shape[1])
    for _ in range(iterations):
        ok = np.isfinite(cost)
        if not ok.any():
            break
        jac = np.where(ok[:, None, None], jac, 0.0)
        residuals = np.where(ok[:, None], residuals, 0.0)
        jac_t = np.swapaxes(jac, 1, 2)
        normal = jac_t @ jac
        gradient = (jac_t @ residuals[..., None])[..., 0]
        diagonal = np.einsum("dii->di", normal)
        scale = np.where(diagonal > 0, diagonal, 1.0)
        system = normal + damping[:, None, None] * scale[:, :, None] * eye
        system = np.where(ok[:, None, None], system, eye)
        try:
            step = np.linalg.solve(system, -gradient[..., None])[..., 0]
        except np.linalg.LinAlgError:
            step = np.zeros_like(params)
            for k in range(len(params)):
                step[k] = np.linalg.lstsq(system[k], -gradient[k], rcond=None)[0]
        trial = params + step
        trial_residuals, trial_jac = model(trial)
        trial_cost = np.einsum("dn,dn->d", trial_residuals, trial_residuals)
        better = np.isfinite(trial_cost) & (trial_cost <= cost)
        params = np.where(better[:, None], trial, params)
        residuals = np.where(better[:, None], trial_residuals, residuals)
        jac = np.where(better[:, None, None], trial_jac, jac)
        cost = np.where(better, trial_cost, cost)
        damping = np.where(better, np.maximum(damping * 0.1, 1e-12), damping * 10.0)
    return params, np.where(np.isfinite(cost), cost, np.inf)


def _kasa(xy: FloatArray) -> FloatArray:
    """Batched algebraic circle ``(x0, y0, r)`` of ``xy`` (D, n, 2)."""
    design = np.concatenate([2.0 * xy, np.ones((*xy.shape[:2], 1))], axis=2)
    target = np.einsum("dni,dni->dn", xy, xy)
    normal = np.einsum("dni,dnj->dij", design, design) + 1e-300 * np.eye(3)
    solution = _solve(normal, np.einsum("dni,dn->di", design, target))
    radius = np.sqrt(np.maximum(solution[:, 2] + solution[:, 0] ** 2 + solution[:, 1] ** 2, 0.0))
    return np.c_[solution[:, :2], radius]


def _solve(normal: FloatArray, rhs: FloatArray) -> FloatArray:
    try:
        return np.linalg.solve(normal, rhs[..., None])[..., 0]
    except np.linalg.LinAlgError:
        return np.stack([np.linalg.lstsq(a, b, rcond=None)[0] for a, b in zip(normal, rhs, strict=True)])


def cylinder_reduced(fixed_radius: float | None) -> ReducedCost:
    """Reduced cylinder cost: the geometric circle of the points projected along each trial axis."""

    def costs(local: FloatArray) -> FloatArray:
        xy = local[..., :2]
        start = _kasa(xy)
        if fixed_radius is not None:
            start = start[:, :2]

        def model(params: FloatArray) -> tuple[FloatArray, FloatArray]:
            rel = xy - params[:, None, :2]
            rho = np.sqrt(np.einsum("dni,dni->dn", rel, rel))
            safe = np.where(rho > 0, rho, 1.0)
            radius = fixed_radius if fixed_radius is not None else params[:, 2:3]
            jac = np.empty((*rho.shape, params.shape[1]))
            jac[..., :2] = -rel / safe[..., None]
            if fixed_radius is None:
                jac[..., 2] = -1.0
            return rho - radius, jac

        return batched_lm(model, start)[1]

    return costs


def cone_reduced(local: FloatArray) -> FloatArray:
    """Reduced cone cost: per trial axis, an algebraic cone refined geometrically (x0, y0, r, alpha)."""
    x, y, z = local[..., 0], local[..., 1], local[..., 2]
    design = np.stack([2 * x, 2 * y, np.ones_like(x), z, z * z], axis=2)
    target = x * x + y * y
    normal = np.einsum("dni,dnj->dij", design, design)
    x0, y0, c, e, f = _solve(normal, np.einsum("dni,dn->di", design, target)).T
    positive = f > 0
    slope = np.where(positive, np.copysign(np.sqrt(np.abs(f)), e), 0.0)
    radius = np.where(
        positive, np.abs(e) / (2 * np.sqrt(np.where(positive, f, 1.0))), np.sqrt(np.maximum(c + x0**2 + y0**2, 0.0))
    )
    start = np.c_[x0, y0, radius, np.arctan(slope)]

    def model(params: FloatArray) -> tuple[FloatArray, FloatArray]:
        dx, dy = x - params[:, 0:1], y - params[:, 1:2]
        rho = np.hypot(dx, dy)
        safe = np.where(rho > 0, rho, 1.0)
        cos_a, sin_a = np.cos(params[:, 3:4]), np.sin(params[:, 3:4])
        gap = rho - params[:, 2:3]
        jac = np.stack([-dx / safe * cos_a, -dy / safe * cos_a, -cos_a + 0 * rho, -gap * sin_a - z * cos_a], axis=2)
        return gap * cos_a - z * sin_a, jac

    return batched_lm(model, start)[1]


def torus_reduced(local: FloatArray) -> FloatArray:
    """Reduced torus cost: per trial axis, the best of three algebraic axis positions (circles through all,
    the highest and the lowest points) refined geometrically."""
    x, y, z = local[..., 0], local[..., 1], local[..., 2]
    order = np.argsort(z, axis=1)
    size = max(5, local.shape[1] // 8)
    candidates = []
    top = np.take_along_axis(local, order[:, -size:, None], axis=1)
    bottom = np.take_along_axis(local, order[:, :size, None], axis=1)
    for subset in (local, top, bottom):
        centre = _kasa(subset[..., :2])[:, :2]
        rho = np.hypot(x - centre[:, 0:1], y - centre[:, 1:2])
        section = _kasa(np.stack([rho, z], axis=2))  # (R, z0, r) of the tube section
        candidates.append(np.c_[centre, section[:, 1], section[:, 0], section[:, 2]])

    # sparse data have narrow basins in the axis position: also start from the best cells of a
    # coarse grid of positions, the tube section projected out (variable projection)
    from pcmm_geo.fit._kernels._torus_search import varpro_costs  # torus-only helper

    extent = 1.5 * np.max(np.hypot(x, y), axis=1)
    ticks = np.linspace(-1.0, 1.0, _TORUS_GRID)
    gx, gy = np.meshgrid(ticks, ticks)
    centres = extent[:, None, None] * np.c_[gx.ravel(), gy.ravel()][None]
    grid_costs, grid_params = varpro_costs(local, centres)
    for rank in range(_TORUS_GRID_STARTS):
        pick = np.argsort(grid_costs, axis=1)[:, rank]
        chosen = grid_params[np.arange(len(local)), pick]
        candidates.append(np.c_[chosen[:, 0:3], chosen[:, 5:7]])

    def model(params: FloatArray) -> tuple[FloatArray, FloatArray]:
        dx, dy, dz = x - params[:, 0:1], y - params[:, 1:2], z - params[:, 2:3]
        rho = np.hypot(dx, dy)
        safe_rho = np.where(rho > 0, rho, 1.0)
        gap = rho - params[:, 3:4]
        tube = np.hypot(gap, dz)
        safe = np.where(tube > 0, tube, 1.0)
        jac = np.stack(
            [-gap / safe * dx / safe_rho, -gap / safe * dy / safe_rho, -dz / safe, -gap / safe, -np.ones_like(rho)],
            axis=2,
        )
        return tube - params[:, 4:5], jac

    return np.min([batched_lm(model, start)[1] for start in candidates], axis=0)


#: Screened minima whose reduced cost exceeds the best one's by more than this factor are not
#: worth a full fit (their basins end far above the best; near-ties are what matters).
_WORTH_FITTING = 2.0


#: Above this many points the data determine the element well (the failures the screening
#: exists for are sparse sets): a coarser screening (60 directions, 2 polish levels) suffices.
DENSE_POINTS = 200


#: Largest gap in azimuth about the fitted axis (rad) for which dense data count as surrounding
#: it (a full surface): 45 degrees, i.e. at least 7/8 of the circumference covered without a hole.
FULL_COVERAGE_GAP = np.radians(45.0)


def largest_azimuth_gap(across: FloatArray) -> float:
    """Largest angle (rad) between consecutive azimuths of points about an axis, wrapping round.

    ``across`` (N, 2) are the points' coordinates across the axis, relative to it (the axis
    through the origin).  2 pi for a single direction.

    Examples
    --------
    >>> angles = np.radians([0.0, 90.0, 180.0, 200.0])
    >>> round(float(np.degrees(largest_azimuth_gap(np.c_[np.cos(angles), np.sin(angles)]))), 6)
    160.0
    """
    azimuth = np.sort(np.arctan2(across[:, 1], across[:, 0]))
    if azimuth.size == 0:
        return 2.0 * np.pi
    gaps = np.diff(azimuth, append=azimuth[0] + 2.0 * np.pi)
    return float(gaps.max())


def surrounds_axis(count: int, across: FloatArray) -> bool:
    """True for dense data surrounding the fitted axis: no direction screening needed.

    ``count`` points (more than :data:`DENSE_POINTS`), ``across`` their coordinates across the
    fitted axis relative to it; the largest gap in azimuth must not exceed
    :data:`FULL_COVERAGE_GAP`.  The robustness scan (``benchmarks/fit_robustness.py``,
    ``docs/fit-robustness.md``) checks that dense full cylinders fitted without screening reach
    the global minimum and that dense partial ones are screened.
    """
    return count > DENSE_POINTS and largest_azimuth_gap(across) <= FULL_COVERAGE_GAP


def screened_directions(centred: FloatArray, reduced_cost: ReducedCost) -> list[FloatArray]:
    """Directions from :func:`screen` worth a full fit: within a factor 2 of the best reduced cost.

    Sparse data (at most :data:`DENSE_POINTS` points) get the full screening; denser data a
    coarse one, which still catches a principal-axis start in the wrong basin.
    """
    dense = centred.shape[0] > DENSE_POINTS
    found = screen(centred, reduced_cost, count=60, keep=3, levels=2) if dense else screen(centred, reduced_cost)
    if not found:
        return []
    limit = _WORTH_FITTING * found[0].cost + 1e-24 * float(np.sum(centred * centred))
    return [item.direction for item in found if item.cost <= limit]
