"""Shared machinery of the axially symmetric fits (cylinder, cone, torus).

Every axial element is fitted in *standard position*: the data are centred at their
centroid and rotated so that the current axis estimate is the local +z axis.  The
axis is described by local parameters that are regular near the solution:

* ``x0, y0`` (and for the torus ``z0``): a point of the axis in the local frame,
* ``a, b``: the axis direction ``d = (a, b, 1) / |(a, b, 1)|`` (zero at the estimate).

After every accepted Levenberg-Marquardt step the frame is rotated so that the new axis
is +z again (``a = b = 0``), so the analytic Jacobian is always evaluated in a
well-centred frame and no axis direction is singular.  Several starting axes are tried
(principal axes, hints, screened directions) and the converged solution of least cost
is kept.  This module is private; the public functions live in ``cylinder.py``,
``cone.py`` and ``torus.py``.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import AmbiguousFitWarning, ConvergenceError, DegenerateGeometryError, InvalidInputError
from pcmm_geo.fit._kernels import _core
from pcmm_geo.fit._kernels._axial_lm import levenberg_marquardt
from pcmm_geo.fit._kernels._core import SolverOutcome, rotation_to_z

FloatArray = NDArray[np.float64]

#: Residual model in standard position: ``model(local_points, params) -> (residuals, jacobian)``.
LocalModel = Callable[[FloatArray, FloatArray], tuple[FloatArray, FloatArray]]
#: Starting values for data in standard position: ``start(local_points) -> params or None``.
StartRule = Callable[[FloatArray], FloatArray | None]
#: Sum of squared residuals in standard position: ``cost_of(local_points, params) -> float``.
LocalCost = Callable[[FloatArray, FloatArray], float]


#: An rms residual below this fraction of the data extent is an exact interpolation.
_EXACT_FIT = 1e-12


@record
class AxialTerms:
    """Axial height and radial distance of local points, with their parameter derivatives.

    Attributes
    ----------
    height : ndarray, shape (N,)
        ``h = (q - p0) . d``, signed distance along the axis (mm).
    rho : ndarray, shape (N,)
        Distance of each point from the axis (mm).
    radial : ndarray, shape (N, 3)
        ``v = (q - p0) - h d``, the perpendicular from the axis to the point (mm).
    d_height : ndarray, shape (N, 5)
        Derivatives of ``h`` w.r.t. ``(x0, y0, z0, a, b)``.
    d_rho : ndarray, shape (N, 5)
        Derivatives of ``rho`` w.r.t. ``(x0, y0, z0, a, b)``.
    """

    height: FloatArray
    rho: FloatArray
    radial: FloatArray
    d_height: FloatArray
    d_rho: FloatArray


def axial_terms(local: FloatArray, origin: FloatArray, a: float, b: float) -> AxialTerms:
    """Evaluate ``h``, ``rho`` and their analytic derivatives for an axis ``origin + t d``.

    Parameters
    ----------
    local : ndarray, shape (N, 3)
        Points in standard position (mm).
    origin : ndarray, shape (3,)
        Point of the axis ``(x0, y0, z0)`` (mm).
    a, b : float
        Axis tilt parameters, ``d = (a, b, 1) / sqrt(1 + a^2 + b^2)``.

    Returns
    -------
    AxialTerms

    Notes
    -----
    With ``n = |(a, b, 1)|`` one has ``dd/da = (e_x - d d_x) / n`` and, because ``v`` is
    perpendicular to ``d``, ``drho/da = -h v_x / (n rho)``, ``dh/da = v_x / n``;
    ``drho/dx0 = -v_x / rho`` and ``dh/dx0 = -d_x`` (likewise for ``b``/``y0``/``z0``).
    ``rho`` is computed from the perpendicular vector, not from ``|u|^2 - h^2``, so that
    long thin features lose no precision.
    """
    norm = float(np.sqrt(1.0 + a * a + b * b))
    direction = np.array([a, b, 1.0]) / norm
    offset = local - origin
    height = offset @ direction
    radial = offset - height[:, None] * direction
    rho = np.sqrt(np.einsum("ij,ij->i", radial, radial))
    safe_rho = np.where(rho > 0, rho, 1.0)
    d_height = np.empty((local.shape[0], 5))
    d_height[:, 0:3] = -direction
    d_height[:, 3] = radial[:, 0] / norm
    d_height[:, 4] = radial[:, 1] / norm
    d_rho = np.empty((local.shape[0], 5))
    d_rho[:, 0:3] = -radial / safe_rho[:, None]
    d_rho[:, 3] = -height * radial[:, 0] / (norm * safe_rho)
    d_rho[:, 4] = -height * radial[:, 1] / (norm * safe_rho)
    return AxialTerms(height=height, rho=rho, radial=radial, d_height=d_height, d_rho=d_rho)


def local_direction(a: float, b: float) -> FloatArray:
    """Unit axis ``(a, b, 1) / |(a, b, 1)|`` in the local frame."""
    vec = np.array([a, b, 1.0])
    return vec / np.linalg.norm(vec)


def canonical_axis(axis: FloatArray) -> FloatArray:
    """Return the unit axis with its largest-magnitude component positive (sign convention)."""
    axis = axis / np.linalg.norm(axis)
    return axis if axis[int(np.argmax(np.abs(axis)))] > 0 else -axis


def principal_axes(centred: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Singular values (descending) and principal directions (rows) of centred points."""
    _, sing, vt = np.linalg.svd(centred, full_matrices=False)
    return sing, vt


def check_spread(centred: FloatArray, *, element: str, forbid_coplanar: bool) -> None:
    """Raise :class:`DegenerateGeometryError` for collinear (or, optionally, coplanar) data."""
    sing, _ = principal_axes(centred)
    if sing[1] <= _core.TOL.degenerate * sing[0]:
        raise DegenerateGeometryError(element, "all points lie on one straight line")
    if forbid_coplanar and sing[2] <= _core.TOL.degenerate * sing[0]:
        raise DegenerateGeometryError(element, "all points lie in one plane; the axis tilt is undetermined")


def as_axis_hint(axis_hint: ArrayLike | None) -> FloatArray | None:
    """Validate an optional axis hint (3 finite numbers, non-zero) and return it as a unit vector."""
    if axis_hint is None:
        return None
    try:
        hint = np.asarray(axis_hint, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInputError("axis_hint", "3 numbers", repr(axis_hint)) from None
    if hint.shape != (3,) or not np.all(np.isfinite(hint)):
        raise InvalidInputError("axis_hint", "3 finite numbers", f"shape {hint.shape} {hint.tolist()}")
    length = float(np.linalg.norm(hint))
    if length == 0.0:
        raise InvalidInputError("axis_hint", "a non-zero vector", "(0, 0, 0)")
    return hint / length


#: Points used by the direction screening (:mod:`pcmm_geo.fit._kernels._screen`), evenly strided.
SCREEN_POINTS = 64
#: Dense data (more points than the screening uses): starting axes within this angle (rad) of
#: an earlier one share its basin and are dropped (each start is a full fit of all points).
_DENSE_MERGE = np.radians(1.0)


def candidate_axes(centred: FloatArray, extra: Sequence[FloatArray | None] = ()) -> list[FloatArray]:
    """Starting axis directions: the given extras first, then the three principal axes.

    Near-duplicates (|cos| > 1 - 1e-9; for data denser than the screening subset, within
    1 degree of an earlier start) are dropped.
    """
    _, vt = principal_axes(centred)
    merge = np.cos(_DENSE_MERGE) if centred.shape[0] > SCREEN_POINTS else 1 - 1e-9
    out: list[FloatArray] = []
    for axis in [*extra, vt[2], vt[0], vt[1]]:
        if axis is None:
            continue
        unit_axis = axis / np.linalg.norm(axis)
        if all(abs(float(unit_axis @ seen)) < merge for seen in out):
            out.append(unit_axis)
    return out


def algebraic_circle(xy: FloatArray) -> tuple[float, float, float]:
    """Algebraic (Kasa) circle ``x^2 + y^2 = 2 x0 x + 2 y0 y + c``: returns ``(x0, y0, radius)``.

    Only a starting value: it minimises an algebraic, not a geometric, error.
    """
    design = np.c_[2 * xy[:, 0], 2 * xy[:, 1], np.ones(len(xy))]
    target = xy[:, 0] ** 2 + xy[:, 1] ** 2
    (x0, y0, c), *_ = np.linalg.lstsq(design, target, rcond=None)
    radius_sq = c + x0 * x0 + y0 * y0
    return float(x0), float(y0), float(np.sqrt(max(radius_sq, 0.0)))


@record
class AxialSolution:
    """Converged fit of an axial element in its final standard position.

    Attributes
    ----------
    centroid : ndarray, shape (3,)
        Data centroid (origin of the local frame), machine frame, mm.
    rotation : ndarray, shape (3, 3)
        ``local = rotation @ (machine - centroid)``; its third row is the fitted axis.
    params : ndarray, shape (P,)
        Final local parameters (``a = b = 0`` up to rounding).
    outcome : SolverOutcome
        Solver result; its (weighted) Jacobian belongs to the final frame.
    cost : float
        Weighted sum of squared residuals.
    others : tuple of AxialSolution
        The other distinct converged local minima whose cost is within ``TOL.ambiguous``
        (relative) of this one; empty when the minimum is clear.
    """

    centroid: FloatArray
    rotation: FloatArray
    params: FloatArray
    outcome: SolverOutcome
    cost: float
    others: tuple[AxialSolution, ...] = ()

    @property
    def iterations(self) -> int:
        """Iterations of the solver for the chosen start."""
        return self.outcome.iterations


class _StandardPosition:
    """Data in standard position around a moving axis estimate (mutable solver state)."""

    def __init__(
        self,
        centred: FloatArray,
        axis: FloatArray,
        model: LocalModel,
        position_slots: Sequence[int],
        tilt_slots: tuple[int, int],
        slide: Callable[[FloatArray, FloatArray, float], FloatArray] | None,
    ) -> None:
        self.centred = centred
        self.slide = slide
        self.rotation = rotation_to_z(axis)
        self.local = centred @ self.rotation.T
        self.model = model
        self.position_slots = list(position_slots)
        self.tilt_slots = tilt_slots

    def residuals(self, params: FloatArray) -> tuple[FloatArray, FloatArray]:
        return self.model(self.local, params)

    def recentre(self, params: FloatArray) -> FloatArray:
        """Rotate the frame so the axis of ``params`` is +z again; return the same element's new parameters.

        For two position slots (cylinder, cone) the axis point is slid along the axis to the
        foot of the perpendicular from the local origin (the centroid); for three (torus)
        the centre is only re-expressed.
        """
        a, b = float(params[self.tilt_slots[0]]), float(params[self.tilt_slots[1]])
        if a == 0.0 and b == 0.0:
            return params
        direction_local = local_direction(a, b)
        origin_local = np.zeros(3)
        origin_local[: len(self.position_slots)] = params[self.position_slots]
        shift = float(origin_local @ direction_local) if len(self.position_slots) == 2 else 0.0
        origin_local = origin_local - shift * direction_local
        new_rotation = rotation_to_z(self.rotation.T @ direction_local)
        new_origin = new_rotation @ (self.rotation.T @ origin_local)
        new_params = np.array(params, dtype=float)
        new_params[self.position_slots] = new_origin[: len(self.position_slots)]
        new_params[list(self.tilt_slots)] = 0.0
        self.rotation = new_rotation
        self.local = self.centred @ new_rotation.T
        if self.slide is not None:
            new_params = self.slide(params, new_params, shift)
        return new_params


def solve_axial(
    points: FloatArray,
    centroid: FloatArray,
    axes: Sequence[FloatArray],
    *,
    start: Callable[[FloatArray], FloatArray | None],
    model: LocalModel,
    position_slots: Sequence[int],
    tilt_slots: tuple[int, int],
    element: str,
    sqrt_weights: FloatArray | None,
    slide: Callable[[FloatArray, FloatArray, float], FloatArray] | None = None,
    max_iterations: int | None = None,
) -> AxialSolution:
    """Fit from each candidate axis and keep the converged solution of least cost.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        Data in the machine frame (mm).
    centroid : ndarray, shape (3,)
        Origin of every local frame (the data centroid).
    axes : sequence of ndarray, shape (3,)
        Candidate axis directions (machine frame).
    start : callable
        ``start(local_points) -> params or None`` builds starting parameters for data in
        standard position around one candidate axis (``None`` skips the candidate).
    model : callable
        ``model(local_points, params) -> (residuals, jacobian)``.
    position_slots : sequence of int
        Indices of the local axis-point coordinates in ``params`` (``x0, y0`` [, ``z0``]).
    tilt_slots : (int, int)
        Indices of ``a`` and ``b`` in ``params``.
    element : str
        Name for error messages.
    sqrt_weights : ndarray, shape (N,), optional
        Square roots of the point weights.
    slide : callable, optional
        ``slide(old_params, new_params, shift) -> params`` corrects shape parameters when the
        axis point is slid by ``shift`` along the old axis during re-centring.
    max_iterations : int, optional
        Iteration budget per start (default ``TOL.max_iterations``).

    Raises
    ------
    ConvergenceError
        No candidate start converged.
    """
    centred = points - centroid
    scale = float(np.max(np.linalg.norm(centred, axis=1)))
    best: AxialSolution | None = None
    failures: list[str] = []
    # most promising start first (least sum of squares of its starting values), so that the
    # later ones can be abandoned early when they head for a worse minimum
    starts: list[tuple[float, int, _StandardPosition, FloatArray]] = []
    for index, axis in enumerate(axes):
        frame = _StandardPosition(centred, axis, model, position_slots, tilt_slots, slide)
        params = start(frame.local)
        if params is None or not np.all(np.isfinite(params)):
            continue
        start_residuals = frame.residuals(params)[0]
        start_cost = (
            float(start_residuals @ start_residuals)
            if sqrt_weights is None
            else float((start_residuals * sqrt_weights) @ (start_residuals * sqrt_weights))
        )
        starts.append((start_cost if np.isfinite(start_cost) else np.inf, index, frame, params))
    starts.sort(key=lambda item: (item[0], item[1]))
    minima: list[AxialSolution] = []
    margin = 1.0 + _core.TOL.ambiguous
    for _, _, frame, params in starts:
        try:
            outcome = levenberg_marquardt(
                frame.residuals,
                params,
                element=element,
                scale=scale,
                sqrt_weights=sqrt_weights,
                recentre=frame.recentre,
                abandon_above=None if best is None else best.cost * margin,
                max_iterations=max_iterations,
            )
        except ConvergenceError as exc:
            failures.append(exc.reason)
            continue
        cost = float(outcome.residuals @ outcome.residuals)
        found = AxialSolution(centroid=centroid, rotation=frame.rotation, params=outcome.x, outcome=outcome, cost=cost)
        minima.append(found)
        if best is None or cost < best.cost * (1 - 1e-12):
            best = found
        if cost <= len(outcome.residuals) * (_EXACT_FIT * scale) ** 2:
            break  # the points are interpolated to rounding level: no other start can do better
    if best is None:
        reason = "; ".join(failures) if failures else "no usable starting value"
        raise ConvergenceError(element, _core.TOL.max_iterations, reason)
    floor = len(best.outcome.residuals) * (_EXACT_FIT * scale) ** 2
    rivals: list[AxialSolution] = []
    for other in sorted(minima, key=lambda item: item.cost):
        if other is best or other.cost > best.cost * margin + floor:
            continue
        if all(_distinct(other, seen, position_slots, tilt_slots, scale) for seen in [best, *rivals]):
            rivals.append(other)
    return dataclasses.replace(best, others=tuple(rivals)) if rivals else best


def _axis_and_point(
    solution: AxialSolution, position_slots: Sequence[int], tilt_slots: tuple[int, int]
) -> tuple[FloatArray, FloatArray]:
    """Machine-frame unit axis and axis point (centre for the torus) of a solution."""
    params = solution.params
    direction = local_direction(float(params[tilt_slots[0]]), float(params[tilt_slots[1]]))
    origin = np.zeros(3)
    origin[: len(position_slots)] = params[list(position_slots)]
    return solution.rotation.T @ direction, solution.centroid + solution.rotation.T @ origin


def _distinct(
    first: AxialSolution,
    second: AxialSolution,
    position_slots: Sequence[int],
    tilt_slots: tuple[int, int],
    scale: float,
) -> bool:
    """Whether two converged solutions are different minima (axes 1e-6 rad or positions 1e-6 scale apart)."""
    axis_1, point_1 = _axis_and_point(first, position_slots, tilt_slots)
    axis_2, point_2 = _axis_and_point(second, position_slots, tilt_slots)
    if float(np.linalg.norm(np.cross(axis_1, axis_2))) > 1e-6:
        return True
    offset = point_2 - point_1
    if len(position_slots) == 2:  # axis points may slide along the axis
        offset = offset - (offset @ axis_1) * axis_1
    return float(np.linalg.norm(offset)) > 1e-6 * max(scale, 1.0)


def warn_if_ambiguous(
    solution: AxialSolution,
    *,
    element: str,
    position_slots: Sequence[int],
    tilt_slots: tuple[int, int],
    sizes: Callable[[FloatArray], dict[str, float]],
) -> None:
    """Emit :class:`~pcmm_geo.errors.AmbiguousFitWarning` when ``solution`` has rivals (``solution.others``).

    ``sizes(params)`` names the element's size parameters (radius, half angle...) of a
    solution's local parameters; the warning lists every competing minimum, best first.
    """
    if not solution.others:
        return
    minima = []
    for candidate in (solution, *solution.others):
        axis, point = _axis_and_point(candidate, position_slots, tilt_slots)
        minima.append(
            {
                "sum_of_squares": candidate.cost,
                "axis": canonical_axis(axis),
                "point": point,
                **sizes(candidate.params),
            }
        )
    warnings.warn(AmbiguousFitWarning(element, tuple(minima), _core.TOL.ambiguous), stacklevel=3)
