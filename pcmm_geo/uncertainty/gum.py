"""Linear propagation of uncertainty (JCGM 100:2008, the GUM, §5 and Annex G).

For a measurement model ``y = f(x)`` with input estimates ``x`` (n) and their covariance
``U_x`` (n, n), the first-order law of propagation gives

* scalar output: ``u^2(y) = c^T U_x c`` with the sensitivity coefficients ``c = df/dx``
  (GUM eq 13);
* vector output ``y`` (m): ``U_y = J U_x J^T`` with the Jacobian ``J`` (m, n) (JCGM 102 eq 3).

The coverage factor for 95 % is the Student-t quantile for the effective degrees of freedom
of Welch-Satterthwaite (GUM eq G.2b), computed from the uncorrelated inputs' ``dof``
(``inf`` for Type B inputs and for the default).  ``k = 1.96`` when every ``dof`` is
infinite: this library states the 95 % coverage factor of the normal distribution, not the
conventional ``k = 2``.

Jacobians are analytic where the caller passes one, otherwise central finite differences
(:func:`jacobian`) of the *whole* computation -- which is how the fits' SVD/least-squares
and the kinematics' Gauss-Newton solvers are propagated: those run inside numpy/LAPACK, out
of reach of the operator-overloading propagators GTC and ``uncertainties`` (they follow
Python arithmetic on their own number types).  The test suite uses both of them as
independent references for this module.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.uncertainty.result import BudgetEntry, UncertaintyResult

__all__ = ["coverage_factor", "jacobian", "propagate", "propagate_covariance", "welch_satterthwaite"]

FloatArray = NDArray[np.float64]


def _as_covariance(x: FloatArray, uncertainty: ArrayLike) -> FloatArray:
    """``U_x`` from standard uncertainties (n,) or a covariance (n, n); checked symmetric PSD."""
    u = np.asarray(uncertainty, dtype=float)
    n = len(x)
    if u.shape == (n,):
        if not np.all(np.isfinite(u)) or np.any(u < 0):
            raise InvalidInputError("uncertainty", "finite standard uncertainties >= 0", str(u.tolist()))
        return np.diag(u**2)
    if u.shape != (n, n):
        raise InvalidInputError("uncertainty", f"shape ({n},) or ({n}, {n})", f"shape {u.shape}")
    if not np.all(np.isfinite(u)):
        raise InvalidInputError("covariance", "finite values", "NaN or inf")
    scale = max(float(np.abs(u).max()), 1e-300)
    if not np.allclose(u, u.T, rtol=0, atol=1e-10 * scale):
        raise InvalidInputError("covariance", "a symmetric matrix", "an asymmetric one")
    if np.linalg.eigvalsh(0.5 * (u + u.T)).min() < -1e-9 * scale:
        raise InvalidInputError("covariance", "a positive semi-definite matrix", "a negative eigenvalue")
    return 0.5 * (u + u.T)


def jacobian(
    func: Callable[[FloatArray], ArrayLike], x: ArrayLike, steps: ArrayLike | None = None
) -> tuple[FloatArray, FloatArray]:
    """Central-difference Jacobian of ``func`` at ``x``.

    Parameters
    ----------
    func : callable
        ``func(x) -> y``, ``x`` shape (n,), ``y`` scalar or shape (m,).
    x : array_like, shape (n,)
    steps : array_like, shape (n,), optional
        Difference steps ``h_i`` (default ``1e-6 max(1, |x_i|)``); choose about a tenth of
        ``u(x_i)`` or less so that curvature over ``+-u`` does not enter.

    Returns
    -------
    y : ndarray, shape (m,) (m = 1 for a scalar)
    jac : ndarray, shape (m, n)
        ``(f(x + h e_i) - f(x - h e_i)) / 2h`` (error ``O(h^2 f''')``).

    Examples
    --------
    >>> y, jac = jacobian(lambda v: v[0] * v[1] ** 2, [2.0, 3.0])
    >>> np.round(jac, 6).tolist()
    [[9.0, 12.0]]
    """
    x0 = np.asarray(x, dtype=float).ravel()
    h = 1e-6 * np.maximum(1.0, np.abs(x0)) if steps is None else np.broadcast_to(np.asarray(steps, float), x0.shape)
    if np.any(~np.isfinite(h)) or np.any(h <= 0):
        raise InvalidInputError("steps", "positive finite difference steps", str(np.asarray(h).tolist()))
    y0 = np.atleast_1d(np.asarray(func(x0), dtype=float)).ravel()
    jac = np.empty((len(y0), len(x0)))
    for i, step in enumerate(h):
        up, down = x0.copy(), x0.copy()
        up[i] += step
        down[i] -= step
        diff = np.atleast_1d(np.asarray(func(up), float)).ravel() - np.atleast_1d(np.asarray(func(down), float)).ravel()
        jac[:, i] = diff / (2.0 * step)
    return y0, jac


def welch_satterthwaite(contributions: ArrayLike, dof: ArrayLike) -> float:
    """Effective degrees of freedom ``u^4(y) / sum(u_i^4(y) / nu_i)`` (GUM eq G.2b).

    Examples
    --------
    >>> round(welch_satterthwaite([0.3, 0.4], [4, np.inf]), 1)
    30.9
    """
    u_i = np.asarray(contributions, dtype=float)
    nu = np.broadcast_to(np.asarray(dof, dtype=float), u_i.shape)
    total = float(np.sum(u_i**2)) ** 2
    finite = np.isfinite(nu) & (u_i > 0)
    if not finite.any():
        return math.inf
    if np.any(nu[finite] <= 0):
        raise InvalidInputError("dof", "degrees of freedom > 0", str(nu.tolist()))
    return total / float(np.sum(u_i[finite] ** 4 / nu[finite]))


def coverage_factor(dof: float, probability: float = 0.95) -> float:
    """Two-sided Student-t quantile ``k_p`` (1.96 for infinite ``dof`` and p = 0.95).

    Examples
    --------
    >>> round(coverage_factor(math.inf), 3), round(coverage_factor(10), 3)
    (1.96, 2.228)
    """
    from scipy import stats

    if not 0 < probability < 1:
        raise InvalidInputError("probability", "a coverage probability in (0, 1)", str(probability))
    q = 0.5 * (1.0 + probability)
    return float(stats.norm.ppf(q) if math.isinf(dof) else stats.t.ppf(q, dof))


def propagate(
    func: Callable[[FloatArray], float],
    x: ArrayLike,
    uncertainty: ArrayLike,
    *,
    names: Sequence[str] | None = None,
    dof: ArrayLike | None = None,
    sensitivities: ArrayLike | None = None,
    steps: ArrayLike | None = None,
    probability: float = 0.95,
    quantity: str = "y",
    unit: str = "",
) -> UncertaintyResult:
    r"""Standard and expanded uncertainty of a scalar ``y = func(x)`` by the GUM's linear law.

    Parameters
    ----------
    func : callable
        ``func(x) -> float`` with ``x`` shape (n,).
    x : array_like, shape (n,)
        Input estimates.
    uncertainty : array_like, shape (n,) or (n, n)
        Standard uncertainties ``u(x_i)`` (uncorrelated) or the covariance ``U_x``.
    names : sequence of str, optional
        Input names for the budget (default ``x0, x1, ...``).
    dof : array_like, shape (n,), optional
        Degrees of freedom of each ``u(x_i)`` (default ``inf``); Welch-Satterthwaite is used
        (it assumes uncorrelated inputs: with a full covariance give ``dof`` only if the
        finite-dof inputs are uncorrelated with the others).
    sensitivities : array_like, shape (n,), optional
        Analytic ``c_i = df/dx_i``; default central differences with ``steps``.
    steps : array_like, shape (n,), optional
        Finite-difference steps (default ``u(x_i) / 100``, or the :func:`jacobian` default
        where ``u(x_i) = 0``).
    probability : float
        Coverage probability ``p``.
    quantity, unit : str
        Labels of the result.

    Returns
    -------
    UncertaintyResult
        ``method = "GUM linear"``; the budget has one line per input with ``c_i``,
        ``u_i(y) = |c_i| u(x_i)`` and the share ``c_i (U_x c)_i / u^2(y)`` (which sums to 1
        and reduces to ``u_i^2(y)/u^2(y)`` for uncorrelated inputs).

    Raises
    ------
    InvalidInputError
        Mismatched shapes, negative uncertainties, a covariance that is not symmetric PSD.

    See Also
    --------
    propagate_covariance : vector outputs
    pcmm_geo.uncertainty.montecarlo.adaptive_monte_carlo : the Monte Carlo evaluation (JCGM 101)
    welch_satterthwaite
    coverage_factor

    Notes
    -----
    The law of propagation of uncertainty (GUM eq. (13) [1]_):

    .. math::

        u_c^2(y) = \sum_{i,j} \frac{\partial f}{\partial x_i} \frac{\partial f}{\partial x_j}
                   u(x_i, x_j) ,

    the expanded uncertainty :math:`U = k \, u_c(y)` with :math:`k` the Student-t quantile for the
    Welch-Satterthwaite effective degrees of freedom (GUM annex G, eq. (G.2b)).

    References
    ----------
    .. [1] JCGM 100:2008, *Evaluation of measurement data -- Guide to the expression of uncertainty in
           measurement* (GUM).

    Examples
    --------
    Area of a 20 mm x 10 mm rectangle with u = 0.01 mm and 0.02 mm:

    >>> r = propagate(lambda v: v[0] * v[1], [20.0, 10.0], [0.01, 0.02], names=["a", "b"], unit="mm2")
    >>> round(r.value, 6), round(r.standard_uncertainty, 6), round(r.coverage_factor, 2)
    (200.0, 0.412311, 1.96)
    >>> [(e.name, round(e.sensitivity, 6), round(e.share, 4)) for e in r.budget]
    [('a', 10.0, 0.0588), ('b', 20.0, 0.9412)]
    """
    x0 = np.asarray(x, dtype=float).ravel()
    if not np.all(np.isfinite(x0)):
        raise InvalidInputError("x", "finite input estimates", "NaN or inf")
    cov = _as_covariance(x0, uncertainty)
    u_x = np.sqrt(np.diag(cov))
    labels = list(names) if names is not None else [f"x{i}" for i in range(len(x0))]
    if len(labels) != len(x0):
        raise InvalidInputError("names", f"{len(x0)} names", f"{len(labels)}")
    nu = np.full(len(x0), math.inf) if dof is None else np.broadcast_to(np.asarray(dof, float), x0.shape)
    if sensitivities is None:
        h = np.where(u_x > 0, u_x / 100.0, 1e-6 * np.maximum(1.0, np.abs(x0))) if steps is None else steps
        y_arr, jac = jacobian(lambda v: float(func(v)), x0, h)
        value, c = float(y_arr[0]), jac[0]
    else:
        value = float(func(x0))
        c = np.asarray(sensitivities, dtype=float).ravel()
        if c.shape != x0.shape:
            raise InvalidInputError("sensitivities", f"shape {x0.shape}", f"shape {c.shape}")
    variance = float(c @ cov @ c)
    u_y = math.sqrt(max(variance, 0.0))
    contributions = np.abs(c) * u_x
    shares = c * (cov @ c) / variance if variance > 0 else np.zeros_like(c)
    nu_eff = welch_satterthwaite(contributions, nu)
    k = coverage_factor(nu_eff, probability)
    budget = tuple(
        BudgetEntry(
            name=labels[i],
            contribution=float(contributions[i]),
            share=float(shares[i]),
            sensitivity=float(c[i]),
            input_value=float(x0[i]),
            input_uncertainty=float(u_x[i]),
            dof=float(nu[i]),
        )
        for i in range(len(x0))
    )
    return UncertaintyResult(
        quantity=quantity,
        unit=unit,
        method="GUM linear",
        value=value,
        standard_uncertainty=u_y,
        coverage_probability=probability,
        coverage_interval=(value - k * u_y, value + k * u_y),
        interval_kind="symmetric",
        expanded_uncertainty=k * u_y,
        coverage_factor=k,
        dof=nu_eff,
        budget=budget,
    )


def propagate_covariance(
    func: Callable[[FloatArray], ArrayLike],
    x: ArrayLike,
    uncertainty: ArrayLike,
    *,
    steps: ArrayLike | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Covariance of a vector output ``y = func(x)``: ``U_y = J U_x J^T`` (JCGM 102 §6.2).

    Parameters
    ----------
    func : callable
        ``func(x) -> y`` with ``x`` shape (n,), ``y`` shape (m,).
    x : array_like, shape (n,)
    uncertainty : array_like, shape (n,) or (n, n)
    steps : array_like, shape (n,), optional
        Finite-difference steps (default ``u(x_i) / 100``).

    Returns
    -------
    y : ndarray, shape (m,)
    covariance : ndarray, shape (m, m)
    jac : ndarray, shape (m, n)

    Examples
    --------
    Polar to Cartesian, r = 10 mm +- 0.01 mm, phi = 0 rad +- 0.001 rad:

    >>> y, cov, _ = propagate_covariance(lambda v: [v[0] * np.cos(v[1]), v[0] * np.sin(v[1])],
    ...                                  [10.0, 0.0], [0.01, 0.001])
    >>> np.round(np.sqrt(np.diag(cov)), 6).tolist()
    [0.01, 0.01]
    """
    x0 = np.asarray(x, dtype=float).ravel()
    cov = _as_covariance(x0, uncertainty)
    u_x = np.sqrt(np.diag(cov))
    h = np.where(u_x > 0, u_x / 100.0, 1e-6 * np.maximum(1.0, np.abs(x0))) if steps is None else steps
    y0, jac = jacobian(func, x0, h)
    out = jac @ cov @ jac.T
    return y0, 0.5 * (out + out.T), jac
