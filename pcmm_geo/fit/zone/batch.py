"""Form evaluation of many small round features at once: ``(K, N, 2)`` roundness profiles.

2-D profiles are vectorised where the work is: the Gaussian starts come from
:func:`pcmm_geo.fit.fit_circles`, and each sequential-LP iteration solves *one* sparse
block-diagonal linear program for all profiles still iterating (the objective is a sum of
independent per-profile objectives, so its optimum is every profile's optimum); the short
KKT-Newton finish and the certificate then run per profile with the same code as
:func:`pcmm_geo.fit.fit_circle`.  A profile the batch path cannot certify is re-solved alone
(so a batch answer is never weaker than the single fit); 3-D profiles use the single fit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import InvalidInputError, PcmmGeoError

__all__ = ["RoundnessBatch", "roundness_profiles"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class RoundnessBatch:
    """Minimax circles of ``K`` profiles.

    Attributes
    ----------
    criterion : str
        ``"chebyshev"``, ``"mcc"`` or ``"mic"``.
    center : ndarray, shape (K, D)
        Centres (mm), D = 2 or 3.
    radius, r_in, r_out, form : ndarray, shape (K,)
        Reported radius (mid-zone / circumscribed / inscribed), zone radii, zone width (mm);
        NaN for a profile that raised.
    converged : ndarray of bool, shape (K,)
        Certified optimum.
    contacts : tuple of K int arrays
        Support point indices of each profile.
    messages : tuple of K str
        Solver message, or the error of a profile that could not be fitted.
    """

    criterion: str
    center: FloatArray
    radius: FloatArray
    r_in: FloatArray
    r_out: FloatArray
    form: FloatArray
    converged: NDArray[np.bool_]
    contacts: tuple[NDArray[np.intp], ...]
    messages: tuple[str, ...]


def roundness_profiles(profiles: ArrayLike, *, criterion: str = "chebyshev") -> RoundnessBatch:
    """Minimum-zone (or MCC / MIC) circles of a stack of profiles.

    Parameters
    ----------
    profiles : array_like, shape (K, N, 2) or (K, N, 3)
        K profiles of N points each (mm).
    criterion : {"chebyshev", "mcc", "mic"}

    Returns
    -------
    RoundnessBatch
        A profile that cannot be fitted (NaN, collinear, unbounded MIC) gets NaN values,
        ``converged=False`` and the error text in ``messages``; the others are unaffected.

    Raises
    ------
    InvalidInputError
        Wrong shape or criterion.

    Examples
    --------
    >>> angles = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    >>> lobes = np.array([0.001, 0.002, 0.003])[:, None] * np.cos(3 * angles)
    >>> radii = 4.0 + lobes
    >>> stack = np.stack([radii * np.cos(angles), radii * np.sin(angles)], axis=-1)
    >>> batch = roundness_profiles(stack)
    >>> np.round(batch.form, 9).tolist(), batch.converged.tolist()
    ([0.002, 0.004, 0.006], [True, True, True])
    """
    from pcmm_geo.fit.circle import fit_circle

    if criterion not in ("chebyshev", "mcc", "mic"):
        raise InvalidInputError("criterion", "one of 'chebyshev', 'mcc', 'mic'", repr(criterion))
    try:
        stack = np.asarray(profiles, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError("profiles", "an array of numbers", str(exc)) from None
    if stack.ndim != 3 or stack.shape[2] not in (2, 3):
        raise InvalidInputError("profiles", "shape (K, N, 2) or (K, N, 3)", f"shape {stack.shape}")
    count, _, dim = stack.shape
    fast: dict[int, object] = {}
    if dim == 2 and count > 1:
        fast = _batch_2d(stack, criterion)
    center = np.full((count, dim), np.nan)
    radius, r_in, r_out, form = (np.full(count, np.nan) for _ in range(4))
    converged = np.zeros(count, dtype=bool)
    contacts: list[NDArray[np.intp]] = []
    messages: list[str] = []
    for k in range(count):
        try:
            fit = fast.get(k) or fit_circle(stack[k], criterion=criterion)
        except PcmmGeoError as exc:
            contacts.append(np.zeros(0, dtype=np.intp))
            messages.append(f"{type(exc).__name__}: {exc}")
            continue
        center[k] = fit.center
        radius[k], r_in[k], r_out[k], form[k] = fit.radius, fit.r_in, fit.r_out, fit.form
        converged[k] = fit.converged
        contacts.append(fit.contacts)
        messages.append(fit.message)
    return RoundnessBatch(criterion, center, radius, r_in, r_out, form, converged, tuple(contacts), tuple(messages))


def _batch_2d(stack: FloatArray, criterion: str) -> dict[int, object]:
    """Certified CircleFit of each finite, well-posed 2-D profile by the batched SLP; others are left out."""
    from pcmm_geo.fit.batch import fit_circles
    from pcmm_geo.fit.circle import CircleFit
    from pcmm_geo.fit.zone._common import mode_of
    from pcmm_geo.fit.zone._models import center_distance
    from pcmm_geo.fit.zone._round import circle_from_solution
    from pcmm_geo.fit.zone._solver import solve_minimax

    finite = np.flatnonzero(np.isfinite(stack).all(axis=(1, 2)))
    if finite.size == 0:
        return {}
    try:
        gauss = fit_circles(stack[finite])
    except PcmmGeoError:
        return {}
    origins = stack[finite].mean(axis=1)
    local = stack[finite] - origins[:, None, :]
    x0 = gauss.centers - origins
    mode = mode_of(criterion)
    starts = _batch_slp(local, x0, mode)
    out: dict[int, object] = {}
    for j, k in enumerate(finite.tolist()):
        radius0 = float(gauss.radii[j])
        size = max(float(np.sqrt(np.mean(np.sum(local[j] ** 2, axis=1)))), radius0)
        if np.linalg.norm(starts[j][0] - x0[j]) > 2.0 * radius0:
            continue  # running away (e.g. an unbounded MIC): the single fit reports it
        solution = solve_minimax(local[j], x0[j], center_distance, mode, size=size, start=starts[j])  # type: ignore[arg-type]
        if solution.certified:
            out[k] = circle_from_solution(origins[j], solution, criterion, result_type=CircleFit)
    return out


def _batch_slp(local: FloatArray, x0: FloatArray, mode: str) -> list[tuple[FloatArray, dict[int, float], int, str]]:
    """Trust-region sequential LP for K circle-centre problems, one sparse LP per iteration."""
    from pcmm_geo.fit.zone._solver import _objective

    count = local.shape[0]
    use_lower, use_upper = mode in ("zone", "mic"), mode in ("zone", "mcc")

    def evaluate(centres: FloatArray) -> tuple[FloatArray, FloatArray]:
        rel = local - centres[:, None, :]
        dist = np.linalg.norm(rel, axis=2)
        return dist, -rel / np.where(dist > 0, dist, 1.0)[:, :, None]

    def objective(dist: FloatArray) -> FloatArray:
        return np.array([_objective(row, mode) for row in dist])  # type: ignore[arg-type]

    x = x0.copy()
    dist, jac = evaluate(x)
    phi = objective(dist)
    width = np.maximum(np.ptp(dist, axis=1), 1e-9 * np.maximum(1.0, np.abs(dist).max(axis=1)))
    col_scale = width[:, None] / np.maximum(np.abs(jac).max(axis=1), 1e-300)
    radius = np.ones(count)
    running = np.ones(count, dtype=bool)
    iterations = np.zeros(count, dtype=int)
    contacts: list[dict[int, float]] = [{} for _ in range(count)]
    for _ in range(200):
        rows = np.flatnonzero(running)
        if rows.size == 0:
            break
        iterations[rows] += 1
        solved = _block_lp(dist[rows], jac[rows], col_scale[rows], width[rows], radius[rows], use_lower, use_upper)
        steps, lp_values, active = solved
        for j, k in enumerate(rows.tolist()):
            contacts[k] = active[j]
        reference = 0.5 * (dist[rows].max(axis=1) + dist[rows].min(axis=1))
        phi_ref = objective(dist[rows] - reference[:, None]) / width[rows]
        predicted = (phi_ref - lp_values) * width[rows]
        stationary = predicted <= 1e-9 * width[rows] + 1e-15 * np.maximum(1.0, np.abs(phi[rows]))
        trial = x[rows] + steps * col_scale[rows]
        dist_trial, jac_trial = evaluate_subset(local[rows], trial)
        phi_trial = objective(dist_trial)
        ratio = (phi[rows] - phi_trial) / np.where(predicted > 0, predicted, 1.0)
        accept = (ratio >= 0.1) & ~stationary
        take = rows[accept]
        x[take], dist[take], jac[take], phi[take] = (
            trial[accept],
            dist_trial[accept],
            jac_trial[accept],
            phi_trial[accept],
        )
        grow = accept & (ratio > 0.75) & (np.abs(steps).max(axis=1) >= 0.99 * radius[rows])
        radius[rows[grow]] *= 2.0
        shrink = ~accept & ~stationary
        radius[rows[shrink]] *= 0.25
        running[rows[stationary | (radius[rows] < 1e-13)]] = False
    # active sets of an LP whose trust region does not bind at a vertex
    _, _, active = _block_lp(dist, jac, col_scale, width, np.full(count, 1e-2), use_lower, use_upper)
    return [(x[k], active[k] or contacts[k], int(iterations[k]), "sequential LP (batched)") for k in range(count)]


def evaluate_subset(points: FloatArray, centres: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Distances ``(K, N)`` of ``(K, N, 2)`` points from ``(K, 2)`` centres and their gradients."""
    rel = points - centres[:, None, :]
    dist = np.linalg.norm(rel, axis=2)
    return dist, -rel / np.where(dist > 0, dist, 1.0)[:, :, None]


def _block_lp(
    dist: FloatArray,
    jac: FloatArray,
    col_scale: FloatArray,
    width: FloatArray,
    radius: FloatArray,
    use_lower: bool,
    use_upper: bool,
) -> tuple[FloatArray, FloatArray, list[dict[int, float]]]:
    """One block-diagonal LP (scaled like the single solver's) for the rows' profiles."""
    from scipy.optimize import linprog
    from scipy.sparse import coo_matrix

    count, n_points, n_par = jac.shape
    n_lev = int(use_lower) + int(use_upper)
    n_var = n_par + n_lev
    reference = 0.5 * (dist.max(axis=1) + dist.min(axis=1))
    scaled_d = (dist - reference[:, None]) / width[:, None]
    scaled_j = jac * (col_scale / width[:, None])[:, None, :]
    cost = np.zeros((count, n_var))
    blocks_row, blocks_col, blocks_val, rhs, signs = [], [], [], [], []
    row0 = np.arange(count)[:, None] * (n_lev * n_points) + np.arange(n_points)[None, :]
    col0 = np.arange(count)[:, None] * n_var
    level = n_par
    for sign, used in ((-1.0, use_lower), (1.0, use_upper)):
        if not used:
            continue
        cost[:, level] = sign
        rows = row0 + (level - n_par) * n_points
        for p in range(n_par):
            blocks_row.append(rows.ravel())
            blocks_col.append(np.broadcast_to(col0 + p, rows.shape).ravel())
            blocks_val.append((sign * scaled_j[:, :, p]).ravel())
        blocks_row.append(rows.ravel())
        blocks_col.append(np.broadcast_to(col0 + level, rows.shape).ravel())
        blocks_val.append(np.full(rows.size, -sign))
        rhs.append((rows.ravel(), (-sign * scaled_d).ravel()))
        signs.append((rows.ravel(), np.full(rows.size, sign)))
        level += 1
    n_rows = count * n_lev * n_points
    matrix = coo_matrix(
        (np.concatenate(blocks_val), (np.concatenate(blocks_row), np.concatenate(blocks_col))),
        shape=(n_rows, count * n_var),
    ).tocsr()
    b_ub = np.zeros(n_rows)
    row_sign = np.zeros(n_rows)
    for (index, values), (_, sgn) in zip(rhs, signs, strict=True):
        b_ub[index] = values
        row_sign[index] = sgn
    bounds = np.tile(np.array([[-1.0, 1.0]] * n_par + [[-np.inf, np.inf]] * n_lev), (count, 1))
    bounds[:, 0] = np.where(np.isinf(bounds[:, 0]), -np.inf, bounds[:, 0] * np.repeat(radius, n_var))
    bounds[:, 1] = np.where(np.isinf(bounds[:, 1]), np.inf, bounds[:, 1] * np.repeat(radius, n_var))
    result = linprog(
        cost.ravel(),
        A_ub=matrix,
        b_ub=b_ub,
        bounds=[(lo if np.isfinite(lo) else None, hi if np.isfinite(hi) else None) for lo, hi in bounds],
        method="highs",
        options={"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10},
    )
    if result.status != 0:
        return np.zeros((count, n_par)), np.full(count, np.inf), [{} for _ in range(count)]
    solution = result.x.reshape(count, n_var)
    values = (cost * solution).sum(axis=1)
    marginal_rows = np.flatnonzero(np.abs(result.ineqlin.marginals) > 1e-9)
    active: list[dict[int, float]] = [{} for _ in range(count)]
    for row in marginal_rows.tolist():
        profile, within = divmod(row, n_lev * n_points)
        active[profile][within % n_points] = float(row_sign[row])
    return solution[:, :n_par], values, active
