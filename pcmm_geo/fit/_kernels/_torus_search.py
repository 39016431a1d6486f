"""Starting-value searches for the torus by variable projection.

With the axis direction and the axis position ``(x0, y0)`` given, every point of a torus
lies on one circle in the ``(rho, z)`` half-plane (``rho`` = distance from the axis): the
tube's cross-section.  The remaining parameters ``z0, R, r`` then follow from a linear
(algebraic) circle fit, so for a given axis direction the non-convex part of the problem
has two dimensions.  Sparse data have narrow basins there: the axis position is searched
on a grid refined round its best cells (vectorised over many trial frames), and an
approximate axis direction is refined by a shrinking tilt pattern search.
"""

from __future__ import annotations

import numpy as np

from pcmm_geo.fit._kernels._axial import FloatArray, local_direction, rotation_to_z

__all__ = ["best_axis_position", "refined_axis", "varpro_costs"]

_SCREEN_POINTS = 48  # points used for the screening; the fit itself always uses all of them
_GRID_TICKS = 15


def varpro_costs(local: FloatArray, centres: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Torus cost for many axis positions at once, the other parameters projected out.

    Parameters
    ----------
    local : ndarray, shape (..., N, 3)
        Points in frames whose z axis is the trial torus axis, mm.
    centres : ndarray, shape (G, 2) or (..., G, 2)
        Trial axis positions ``(x0, y0)`` in those frames (shared or one set per frame), mm.

    Returns
    -------
    costs : ndarray, shape (..., G)
        Sum of squared orthogonal residuals of the torus built from each centre (inf where
        the algebraic circle is not a valid tube).
    params : ndarray, shape (..., G, 7)
        The corresponding local parameters ``(x0, y0, z0, a=0, b=0, R, r)``.
    """
    x = local[..., None, :, 0]
    y = local[..., None, :, 1]
    rho = np.hypot(x - centres[..., :, 0, None], y - centres[..., :, 1, None])
    z = np.broadcast_to(local[..., None, :, 2], rho.shape)
    design = np.stack([2.0 * rho, 2.0 * z, np.ones_like(rho)], axis=-1)
    target = rho * rho + z * z
    design_t = np.swapaxes(design, -1, -2)
    normal = design_t @ design  # stacked 3 x 3 products: matmul is about 3x faster than einsum here
    rhs = (design_t @ target[..., None])[..., 0]
    # degenerate samples (all rho equal, say) get an identity system here and score inf below
    size = np.trace(normal, axis1=-2, axis2=-1)
    singular = ~(np.abs(np.linalg.det(normal)) > 1e-12 * size**3)
    normal = np.where(singular[..., None, None], np.eye(3), normal)
    solution = np.linalg.solve(normal, rhs[..., None])[..., 0]
    major, z0, constant = solution[..., 0], solution[..., 1], solution[..., 2]
    minor_sq = constant + major * major + z0 * z0
    minor = np.sqrt(np.maximum(minor_sq, 0.0))
    residuals = np.hypot(rho - major[..., None], z - z0[..., None]) - minor[..., None]
    costs = np.einsum("...n,...n->...", residuals, residuals)
    valid = ~singular & (major > 0) & (minor_sq > 0) & np.isfinite(costs)
    costs = np.where(valid, costs, np.inf)
    centre_xy = np.broadcast_to(centres, (*major.shape, 2))
    zeros = np.zeros_like(major)
    params = np.stack([centre_xy[..., 0], centre_xy[..., 1], z0, zeros, zeros, major, minor], axis=-1)
    return costs, params


def _screen_subset(centred: FloatArray) -> FloatArray:
    """At most ``_SCREEN_POINTS`` points, evenly strided through the data (deterministic)."""
    if centred.shape[-2] <= _SCREEN_POINTS:
        return centred
    index = np.linspace(0, centred.shape[-2] - 1, _SCREEN_POINTS).round().astype(int)
    return centred[..., index, :]


def _grid(extent: float, ticks: int) -> FloatArray:
    axis_ticks = np.linspace(-extent, extent, ticks)
    gx, gy = np.meshgrid(axis_ticks, axis_ticks)
    return np.c_[gx.ravel(), gy.ravel()]


def _costs_of_directions(centred: FloatArray, directions: FloatArray, **search: int) -> FloatArray:
    """Least torus cost over the axis position for each direction, shape (D,)."""
    frames = np.stack([rotation_to_z(direction) for direction in directions])
    local = np.einsum("dij,nj->dni", frames, centred)
    return best_axis_position(local, **search)[0]


def _refined(centred: FloatArray, direction: FloatArray, step: float, levels: int) -> tuple[float, FloatArray]:
    """Pattern search on a 3 x 3 grid of tilts around ``direction``, the step shrinking each level."""
    tilts = _grid(1.0, 3)
    cost = float(_costs_of_directions(centred, direction[None, :])[0])
    for _ in range(levels):
        frame = rotation_to_z(direction)
        trial = np.stack([frame.T @ local_direction(step * ta, step * tb) for ta, tb in tilts])
        costs = _costs_of_directions(centred, trial)
        index = int(np.argmin(costs))
        if costs[index] < cost:
            cost, direction = float(costs[index]), trial[index]
        step *= 0.4
    return cost, direction


def refined_axis(centred: FloatArray, direction: FloatArray, *, step: float = 0.05, levels: int = 8) -> FloatArray:
    """Refine an approximate torus axis (a nominal one, say) by a shrinking 3 x 3 tilt pattern search.

    The objective is the torus cost with the axis position searched coarse-to-fine and the
    other parameters projected out, so the refined axis comes with a starting position in
    the right basin.

    Parameters
    ----------
    centred : ndarray, shape (N, 3)
        Data centred at their centroid, mm.
    direction : ndarray, shape (3,)
        Approximate unit axis (machine frame).
    step : float
        First tilt step, rad (shrinks by 0.4 per level).
    levels : int
        Number of pattern levels.

    Returns
    -------
    ndarray, shape (3,)
        Refined unit axis.
    """
    return _refined(_screen_subset(centred), direction / np.linalg.norm(direction), step, levels)[1]


def best_axis_position(
    local: FloatArray, *, ticks: int = 41, keep: int = 8, levels: int = 5
) -> tuple[FloatArray, FloatArray]:
    """Axis position ``(x0, y0)`` of least torus cost for points whose z axis is the trial torus axis.

    A ``ticks`` x ``ticks`` grid over 1.5 times the data's extent, then ``levels`` rounds of
    an 11 x 11 grid around each of the ``keep`` best positions so far, each round three times
    finer.  The basin of the true position can be much narrower than any affordable single
    grid's spacing (sparse data round a whole torus), hence the coarse-to-fine search.

    Parameters
    ----------
    local : ndarray, shape (..., N, 3)
        Points in frames whose z axes are the trial torus axes, mm.

    Returns
    -------
    cost : ndarray, shape (...)
        Sum of squared residuals at the best position (inf if none gives a valid tube).
    params : ndarray, shape (..., 7)
        Local parameters ``(x0, y0, z0, 0, 0, R, r)``.
    """
    subset = _screen_subset(local)
    batch = subset.shape[:-2]
    extent = 1.5 * np.max(np.hypot(subset[..., 0], subset[..., 1]), axis=-1)
    unit_grid = _grid(1.0, ticks)
    centres = extent[..., None, None] * unit_grid
    spacing = 2.0 * extent / (ticks - 1)
    costs = varpro_costs(subset, centres)[0]
    for _ in range(levels):
        order = np.argsort(costs, axis=-1)[..., :keep]
        best = np.take_along_axis(centres, order[..., None], axis=-2)
        spacing = spacing * 0.3
        patch = (5.0 * spacing)[..., None, None] * _grid(1.0, 11)
        centres = (best[..., :, None, :] + patch[..., None, :, :]).reshape(*batch, -1, 2)
        costs = varpro_costs(subset, centres)[0]
    order = np.argsort(costs, axis=-1)[..., :keep]
    best = np.take_along_axis(centres, order[..., None], axis=-2)
    costs, params = varpro_costs(local, best)
    index = np.argmin(costs, axis=-1)[..., None]
    best_params = np.take_along_axis(params, index[..., None], axis=-2)[..., 0, :]
    return np.take_along_axis(costs, index, axis=-1)[..., 0], best_params
