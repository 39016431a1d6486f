"""Shared machinery of the Gaussian fits: input checks, the result base class and the solver.

Nothing here knows about a particular element; the element modules supply a
function returning residuals and their analytic Jacobian in *standard position*
(data centred, and for axial elements rotated so the estimated axis is +z).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import SummaryRow, record
from pcmm_geo.elements import Criterion
from pcmm_geo.errors import (
    ConvergenceError,
    DegenerateGeometryError,
    IllConditionedWarning,
    InvalidInputError,
)
from pcmm_geo.fit._kernels._inputs import check_magnitude, check_point_values, point_array, real_array
from pcmm_geo.fit._kernels._tall import tall_lstsq, tall_svd

__all__ = [
    "Certificate",
    "FitResult",
    "Tolerances",
    "TOL",
    "as_points",
    "check_points",
    "as_weights",
    "solve_least_squares",
    "SolverOutcome",
    "rotation_to_z",
    "unit",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Tolerances:
    """Numerical tolerances used by every fit (one documented object, like ``trimesh.tol``).

    Attributes
    ----------
    step : float
        Convergence: the Gauss-Newton step is below ``step * (scale + |x|)`` where
        ``scale`` is the size of the data (mm).  Default 1e-14, well below the 1e-9 mm
        accuracy target.
    max_iterations : int
        Iteration budget of the Levenberg-Marquardt loop.
    identical : float
        Points closer than ``identical * scale`` to each other count as the same point.
    degenerate : float
        Relative singular value below which data are called collinear / coplanar.
    ill_conditioned : float
        Condition number of the weighted Jacobian above which :class:`IllConditionedWarning`
        is emitted.
    ambiguous : float
        Two distinct local minima of an axial fit (cylinder, cone, torus) whose sums of
        squares differ by less than this fraction are indistinguishable:
        :class:`~pcmm_geo.errors.AmbiguousFitWarning` is emitted with both.
    rounding_floor : float
        A Gauss-Newton step below ``rounding_floor * (scale + |x|)`` that is no longer at
        least halving from one iteration to the next is rounding noise: the iteration stops
        as converged (ill-conditioned data never reach ``step``).
    """

    step: float = 1e-14
    max_iterations: int = 200
    identical: float = 1e-12
    degenerate: float = 1e-10
    ill_conditioned: float = 1e10
    rounding_floor: float = 1e-11
    ambiguous: float = 0.01


TOL = Tolerances()


def unit(vector: ArrayLike) -> FloatArray:
    """Return ``vector / |vector|`` along the last axis."""
    arr = np.asarray(vector, dtype=float)
    return arr / np.linalg.norm(arr, axis=-1, keepdims=True)


def as_points(
    points: ArrayLike,
    *,
    element: str,
    dims: tuple[int, ...] = (3,),
    min_points: int = 1,
    name: str = "points",
) -> FloatArray:
    """Validate a point array and return it as a C-contiguous float64 ``(N, D)`` array.

    Public as :func:`pcmm_geo.fit.as_points`: the layers above the fits take points the same
    way, with the same typed errors.

    Parameters
    ----------
    points : array_like, shape (N, D)
        Coordinates (mm).
    element : str
        What the points are for, named in the errors (``"sphere"``, ``"gauge block"``).
    dims : tuple of int
        Accepted numbers of columns ``D`` (default 3).
    min_points : int
        Fewest rows accepted.
    name : str
        The parameter named in the errors.

    Returns
    -------
    ndarray, shape (N, D)

    Raises
    ------
    InvalidInputError
        Wrong shape, non-numeric values, NaN or inf.
    TooFewPointsError
        Fewer than ``min_points`` rows.
    DegenerateGeometryError
        All points identical (when ``min_points > 1``).
    """
    arr = point_array(points, element=element, dims=dims, min_points=min_points, name=name)
    check_points(arr, element=element, min_points=min_points, name=name)
    return arr


def check_points(arr: FloatArray, *, element: str, min_points: int, name: str = "points") -> None:
    """The value checks of :func:`as_points` on an array from :func:`~pcmm_geo.fit._kernels._inputs.point_array`.

    A fit that reads every point in a pass of its own (the chunked fits of many points)
    skips this and checks the extremes of that pass instead
    (:func:`~pcmm_geo.fit._kernels._inputs.check_point_extremes`).

    Raises
    ------
    InvalidInputError
        NaN or inf (row named), coordinates beyond ``MAX_COORDINATE``.
    DegenerateGeometryError
        All points identical (when ``min_points > 1``).
    """
    check_point_values(arr, element=element, min_points=min_points, identical=TOL.identical, name=name)


def as_weights(weights: ArrayLike | None, n: int, *, element: str) -> FloatArray | None:
    """Validate per-point weights (``(N,)``, real, finite, non-negative, not all zero).

    Raises
    ------
    InvalidInputError
        Strings, complex numbers, a wrong shape, NaN/inf, a negative weight or all weights zero.
    """
    if weights is None:
        return None
    arr = real_array(weights, "weights")
    if arr.shape != (n,):
        raise InvalidInputError("weights", f"shape ({n},)", f"shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        row = int(np.argmax(~np.isfinite(arr)))
        raise InvalidInputError("weights", "finite values", f"{arr[row]} at index {row}")
    if np.any(arr < 0):
        row = int(np.argmax(arr < 0))
        raise InvalidInputError("weights", "non-negative values", f"{arr[row]} at index {row}")
    if not np.any(arr > 0):
        raise InvalidInputError("weights", "at least one positive weight", f"all {n} weights zero")
    check_magnitude(arr, "weights")
    return arr


def rotation_to_z(direction: ArrayLike) -> FloatArray:
    """Proper rotation matrix ``R`` with ``R @ direction_unit = (0, 0, 1)``.

    Built with a Householder-free two-step construction that is exact for
    ``direction = ±z`` (no singular axis).  Public as :func:`pcmm_geo.fit.rotation_to_z`.

    Parameters
    ----------
    direction : array_like, shape (3,)
        Any non-zero direction (normalised here).

    Returns
    -------
    ndarray, shape (3, 3)
        Rows: two unit vectors perpendicular to ``direction``, then its unit vector.

    Examples
    --------
    >>> import numpy as np
    >>> r = rotation_to_z([0.0, 3.0, 4.0])
    >>> bool(np.allclose(r @ [0.0, 0.6, 0.8], [0.0, 0.0, 1.0])), bool(np.isclose(np.linalg.det(r), 1.0))
    (True, True)
    """
    d = unit(direction)
    # pick the coordinate axis least aligned with d to build an orthonormal frame
    helper = np.zeros(3)
    helper[int(np.argmin(np.abs(d)))] = 1.0
    e1 = unit(np.cross(helper, d))
    e2 = np.cross(d, e1)
    return np.vstack([e1, e2, d])


@record
class SolverOutcome:
    """What :func:`solve_least_squares` found (internal, in standard position)."""

    x: FloatArray
    residuals: FloatArray
    jacobian: FloatArray
    converged: bool
    iterations: int
    message: str


def solve_least_squares(
    fun: Callable[[FloatArray], tuple[FloatArray, FloatArray]],
    x0: ArrayLike,
    *,
    element: str,
    scale: float = 1.0,
    sqrt_weights: FloatArray | None = None,
    normalize: Callable[[FloatArray], FloatArray] | None = None,
    raise_on_failure: bool = True,
) -> SolverOutcome:
    """Levenberg-Marquardt with analytic Jacobian and QR-based (not normal-equation) steps.

    Parameters
    ----------
    fun : callable
        ``fun(x) -> (r, J)`` with residuals ``(M,)`` and Jacobian ``(M, P)``.
    x0 : array_like, shape (P,)
        Starting parameters.
    element : str
        Name used in error messages.
    scale : float
        Size of the problem (mm) for the relative step test.
    sqrt_weights : ndarray, shape (M,), optional
        Square roots of residual weights.
    normalize : callable, optional
        Applied to the parameters after each accepted step (e.g. renormalise a direction).
    raise_on_failure : bool
        Raise :class:`ConvergenceError` when the budget is exhausted (default); otherwise
        return ``converged=False``.

    Notes
    -----
    Convergence is declared when an undamped Gauss-Newton step is smaller than
    ``TOL.step * (scale + |x|)``, or when it has reached the rounding floor (below
    ``TOL.rounding_floor * (scale + |x|)`` and no longer shrinking): the first-order
    optimality of the exact least-squares problem then holds far below the 1e-9 mm target.
    """
    x = np.array(x0, dtype=float)

    def evaluate(params: FloatArray) -> tuple[FloatArray, FloatArray]:
        r, jac = fun(params)
        if sqrt_weights is not None:
            r = r * sqrt_weights
            jac = jac * sqrt_weights[:, None]
        return r, jac

    r, jac = evaluate(x)
    cost = float(r @ r)
    lam = 0.0
    n_param = x.size
    message = "iteration budget exhausted"
    converged = False
    iteration = 0
    previous_gn = np.inf
    stalled = False
    for iteration in range(1, TOL.max_iterations + 1):  # noqa: B007 (reported after the loop)
        if not np.all(np.isfinite(jac)) or not np.all(np.isfinite(r)):
            message = "non-finite residuals or Jacobian"
            break
        gauss_newton = tall_lstsq(jac, -r)
        gn_norm = float(np.linalg.norm(gauss_newton))
        size = scale + float(np.linalg.norm(x))
        if gn_norm <= TOL.step * size or (
            # rounding floor: a tiny Gauss-Newton step that no longer shrinks (or that no
            # damping can turn into a decrease of the cost) is rounding noise
            gn_norm <= TOL.rounding_floor * size and (gn_norm >= 0.5 * previous_gn or stalled)
        ):
            x = x + gauss_newton
            if normalize is not None:
                x = normalize(x)
            r, jac = evaluate(x)
            converged, message = True, "converged: Gauss-Newton step below tolerance"
            break
        previous_gn = gn_norm
        if lam > 0:
            col_norm = np.linalg.norm(jac, axis=0)
            col_norm[col_norm == 0] = 1.0
            aug = np.vstack([jac, np.diag(np.sqrt(lam) * col_norm)])
            step = tall_lstsq(aug, np.concatenate([-r, np.zeros(n_param)]))
        else:
            step = gauss_newton
        trial = x + step
        if normalize is not None:
            trial = normalize(trial)
        r_trial, jac_trial = evaluate(trial)
        cost_trial = float(r_trial @ r_trial)
        # undamped steps are accepted within rounding of the cost; damped ones must decrease it
        if cost_trial < cost or (lam == 0.0 and cost_trial <= cost * (1 + 1e-12) + 1e-300):
            x, r, jac, cost = trial, r_trial, jac_trial, cost_trial
            lam = 0.0 if lam <= 1e-8 else lam / 10.0
            stalled = False
        else:
            lam = 1e-6 if lam == 0.0 else lam * 10.0
            stalled = True
            if lam > 1e12:
                message = "damping exhausted without decrease of the sum of squares"
                break
    if not converged and raise_on_failure:
        raise ConvergenceError(element, iteration, message)
    return SolverOutcome(x=x, residuals=r, jacobian=jac, converged=converged, iterations=iteration, message=message)


def covariance_from_jacobian(
    jacobian: FloatArray,
    residuals: FloatArray,
    dof: int,
    *,
    element: str,
) -> tuple[FloatArray, float]:
    """Parameter covariance ``s^2 (J^T J)^-1`` with ``s^2 = r.r / dof`` and the Jacobian's condition number.

    Both ``jacobian`` and ``residuals`` are already weighted.  Emits
    :class:`IllConditionedWarning` when the condition number exceeds ``TOL.ill_conditioned``.
    """
    sing, vt = tall_svd(jacobian)
    if sing.size == 0 or sing[0] == 0:
        raise DegenerateGeometryError(element, "Jacobian is zero")
    cond = float(sing[0] / sing[-1]) if sing[-1] > 0 else float("inf")
    if cond > TOL.ill_conditioned:
        warnings.warn(
            f"{element}: ill-conditioned fit (condition number {cond:.3g}); parameters are poorly determined",
            IllConditionedWarning,
            stacklevel=3,
        )
    variance = float(residuals @ residuals) / dof if dof > 0 else float("nan")
    with np.errstate(divide="ignore"):
        inv = np.where(sing > 0, 1.0 / sing**2, np.inf)
    cov = (vt.T * inv) @ vt * variance
    return cov, cond


@record
class Certificate:
    """Optimality certificate of a minimum-zone, minimum-circumscribed or maximum-inscribed fit.

    The fits minimise a max-type objective over the element parameters ``x``; at the optimum the
    contact (support) points satisfy the Karush-Kuhn-Tucker conditions ``sum_k s_k lambda_k grad d_k(x) = 0``
    with ``lambda_k >= 0`` (``s_k = +1`` outer, ``-1`` inner level), each level's multipliers summing to 1.

    Attributes
    ----------
    multipliers : ndarray, shape (M,)
        KKT multipliers of the contacts (same order as the result's ``contacts``).
    kkt_residual, feasibility : float
        Stationarity residual relative to the gradient scale; largest distance of a point outside the zone (mm).
    certified : bool
        The optimum is proven: globally (``scope == "global"``), or locally with multipliers
        non-negative, ``kkt_residual`` and ``feasibility`` within tolerance.
    method : str
        How the optimum was found and proven (e.g. ``"slp+kkt-newton"``, or the exact method
        followed by ``" + KKT polish"``).
    scope : {"global", "local"}
        ``"global"``: the value is proven optimal over the stated domain (all elements of
        that type, or for axial elements the stated axis region), to ``gap_mm``.
        ``"local"``: only local optimality (KKT, second order) is proven; ``bound_mm`` then
        holds the best proven bound, if any.
    bound_mm : float
        Proven bound of the optimum over the domain (mm): a lower bound of the zone width
        (Chebyshev) or of the radius (MCC), an upper bound of the radius (MIC).  NaN when
        nothing is proven beyond the local conditions.
    gap_mm : float
        ``|value - bound_mm|`` (mm; NaN when ``bound_mm`` is NaN).
    on_region_boundary : bool
        Axial elements only: the optimum found lies on the boundary of the searched axis
        region, so a better element may exist outside it.
    domain : str
        Plain-language statement of the domain the scope refers to (e.g. ``"all planes"``,
        ``"axes within 45 deg of the least-squares axis and within 2R of it"``).
    check : str
        The independent check of the answer on every input point (:mod:`pcmm_geo.fit.zone._check`).
    """

    multipliers: FloatArray
    kkt_residual: float
    feasibility: float
    certified: bool
    method: str
    scope: str = "local"
    bound_mm: float = float("nan")
    gap_mm: float = float("nan")
    on_region_boundary: bool = False
    domain: str = ""
    check: str = ""


@record(kw_only=True)
class FitResult:
    """Fields shared by every fit result (element parameters are added by subclasses).

    Attributes
    ----------
    residuals : ndarray, shape (N,)
        Signed orthogonal distances of the points from the fitted element (mm),
        positive outside / along the normal.
    rms : float
        Root mean square of ``residuals`` (unweighted), mm.
    form : float
        Form error, ``max(residuals) - min(residuals)``, mm.
    n : int
        Number of points.
    dof : int
        Degrees of freedom, residual count minus number of parameters.
    parameter_names : tuple of str
        Names of the entries of ``parameters`` and of the rows/columns of ``covariance``.
    parameters : ndarray, shape (P,)
        The fitted parameters in that order (machine frame, mm / rad).
    covariance : ndarray, shape (P, P)
        Parameter covariance ``s^2 (J^T J)^-1`` from the (weighted) Jacobian at the solution,
        ``s^2`` = weighted sum of squares / dof.  Zero for exact data, NaN when dof = 0.
    condition_number : float
        Condition number of the weighted Jacobian.
    converged : bool
    iterations : int
    message : str
    method : str
        ``"gaussian"`` (orthogonal-distance least squares) or a named variant.
    criterion : {"gaussian", "chebyshev", "mcc", "mic"}
        :data:`pcmm_geo.elements.Criterion`: ``"gaussian"`` (least squares, default),
        ``"chebyshev"`` (minimum zone), ``"mcc"`` (minimum circumscribed) or ``"mic"`` (maximum
        inscribed).
    contacts : ndarray of int, shape (M,)
        Indices of the support points of a non-Gaussian fit (empty for Gaussian fits).
    certificate : Certificate or None
        Optimality certificate of a non-Gaussian fit (``None`` for Gaussian fits).
    """

    residuals: FloatArray
    rms: float
    form: float
    n: int
    dof: int
    parameter_names: tuple[str, ...]
    parameters: FloatArray
    covariance: FloatArray
    condition_number: float
    converged: bool
    iterations: int
    message: str
    method: str = "gaussian"
    extra: dict[str, Any] = field(default_factory=dict)
    criterion: Criterion = "gaussian"
    contacts: NDArray[np.intp] = field(default_factory=lambda: np.zeros(0, dtype=np.intp))
    certificate: Certificate | None = None

    @property
    def std_errors(self) -> FloatArray:
        """Standard uncertainties (P,), mm / rad, ordered like ``parameters`` (a dict until 0.1, see NamedValues)."""
        from pcmm_geo._deprecation import NamedValues

        diag = np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))
        return NamedValues(diag, self.parameter_names, f"{type(self).__name__}.std_errors")

    @property
    def sum_of_squares(self) -> float:
        """Sum of squared residuals (unweighted), mm^2."""
        return float(self.residuals @ self.residuals)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (arrays as lists, residuals included)."""
        out: dict[str, Any] = {"element": type(self).__name__}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            out[f.name] = _jsonable(value)
        out["std_errors"] = np.asarray(self.std_errors).tolist()
        return out

    def summary(self, *, complete: bool = False) -> tuple[SummaryRow, ...]:
        """The displayed parameters, one :class:`~pcmm_geo._records.SummaryRow` per row (name, value, u, unit).

        The element spec (:data:`pcmm_geo.elements.SPECS`, the row of this result's class) says
        what the parameters are; this renders them, in the order: the positions (the spec's
        ``location_field`` first; unit ``"mm"``) and the directions (unit ``"1"``) by component,
        then the lengths (mm) and angles (rad), the size parameter followed by the zone radii
        ``r_in`` / ``r_out`` of a minimax fit; then, derived for reading, the ``diameter``
        ``d = 2 r`` of the size parameter with ``u(d) = 2 u(r)`` and a ``half_angle``'s
        ``apex_angle_deg``.  A vector the result leaves ``None`` (the normal of a 2-D circle) has
        no rows.  ``u`` is the standard uncertainty from :attr:`std_errors` (NaN where the row is
        not a fitted parameter).  ``pcmm fit`` prints these rows, the repr shows them and the
        QIF export (:func:`pcmm_geo.cmm.export.feature_report`) takes its location, orientation,
        diameter, angles and their uncertainties from ``summary(complete=True)``, selected by the
        spec's fields.

        Parameters
        ----------
        complete : bool
            Also the rows of the spec's parameters not displayed (:attr:`Parameter.shown
            <pcmm_geo.elements.Parameter.shown>`: a cone's ``radius_at_point`` and, from it, its
            ``diameter``).

        Returns
        -------
        tuple of SummaryRow
            Empty for a result class that is no element of the spec.
        """
        from pcmm_geo.elements import SPECS, element_of

        element = element_of(self)
        if element is None:
            return ()
        spec = SPECS[element]
        u = dict(zip(self.parameter_names, np.asarray(self.std_errors).tolist(), strict=True))
        shown = [p for p in spec.parameters if complete or p.shown]
        shown.sort(key=lambda p: (_KIND_ORDER[p.kind], p.name != spec.location_field))  # stable: else spec order
        rows = []
        for parameter in shown:
            name, unit = parameter.name, parameter.unit
            value = getattr(self, name)
            if parameter.kind in ("position", "direction"):
                if value is not None:
                    rows += [SummaryRow(f"{name}_{axis}", float(v), u.get(f"{name}_{axis}", math.nan), unit, name)
                             for axis, v in zip("xyz", np.asarray(value, dtype=float), strict=False)]
                continue
            rows.append(SummaryRow(name, float(value), u.get(name, math.nan), unit, name))
            if name == spec.size:
                for zone in ("r_in", "r_out"):  # the zone radii of a minimax fit (NaN for a Gaussian fit)
                    radius = float(getattr(self, zone, math.nan))
                    if not math.isnan(radius):
                        rows.append(SummaryRow(zone, radius, math.nan, "mm", zone))
        if spec.size is not None and any(p.name == spec.size for p in shown):
            radius = float(getattr(self, spec.size))
            rows.append(SummaryRow("diameter", 2.0 * radius, 2.0 * u.get(spec.size, math.nan), "mm", "diameter", True))
        if any(p.name == "half_angle" for p in shown):
            angle = math.degrees(2.0 * float(self.half_angle))  # type: ignore[attr-defined]
            rows.append(SummaryRow("apex_angle_deg", angle, math.nan, "deg", "apex_angle_deg", True))
        return tuple(rows)

    def __repr__(self) -> str:
        """Compact: the :meth:`summary` quantities (not derived ones), the criterion unless Gaussian, statistics."""
        quantities: dict[str, list[float]] = {}
        for row in self.summary():
            if not row.derived:
                quantities.setdefault(row.quantity, []).append(row.value)
        shown = [f"{name}={_short(values)}" for name, values in quantities.items()]
        shown += [f"criterion={self.criterion!r}"] if self.criterion != "gaussian" else []
        return (
            f"{type(self).__name__}({', '.join(shown)}, n={self.n}, rms={self.rms:.6g}, form={self.form:.6g}, "
            f"converged={self.converged})"
        )


#: summary rows: positions, directions, lengths, angles (pcmm_geo.elements parameter kinds)
_KIND_ORDER = {"position": 0, "direction": 1, "length": 2, "angle": 3}


def _short(values: list[float]) -> str:
    if len(values) == 1 and values[0] is not None:
        return f"{values[0]:.12g}"
    return "[" + ", ".join(f"{v:.10g}" for v in values) + "]"


def _jsonable(value: Any) -> Any:
    if isinstance(value, Certificate):
        return {f.name: _jsonable(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    return value


def residual_stats(residuals: FloatArray) -> tuple[float, float]:
    """Return ``(rms, form)`` of a residual vector."""
    if residuals.size == 0:
        return 0.0, 0.0
    return float(np.sqrt(np.mean(residuals**2))), float(residuals.max() - residuals.min())
