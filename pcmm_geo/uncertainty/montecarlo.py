"""Propagation of distributions by Monte Carlo (JCGM 101:2008), adaptive, seeded, vectorised.

A *simulation* is a callable ``simulate(rng, size) -> (size,)`` that draws ``size``
independent trials of the measurement (inputs sampled from their distributions with the
``numpy.random.Generator`` it is given, the model evaluated on whole arrays) and returns the
output values.  :func:`adaptive_monte_carlo` runs it in batches of ``M`` trials (JCGM 101
§7.9.4: ``M = max(100 / (1 - p), 10^4)``) until the batch means, standard deviations and
coverage-interval endpoints are stable: twice the standard deviation of each of these
batch statistics divided by ``sqrt(h)`` must be below the numerical tolerance
``delta = 10^l / 2`` of ``u(y)`` written with ``significant_digits`` digits, ``c x 10^l``
(JCGM 101 §7.9.2).  The reported estimate, uncertainty and interval use all ``h M``
trials.

Coverage intervals (JCGM 101 §7.7): *probabilistically symmetric* (2.5 % and 97.5 %
quantiles for p = 95 %) and *shortest* (the narrowest window of the sorted values holding
a fraction p of them); they coincide for symmetric distributions.  The expanded uncertainty
reported is the half-width of the interval and ``k = U / u``.

A budget with Monte Carlo is obtained by re-running the simulation with one input group
varied at a time (``groups``); its lines are the standard deviations so obtained.  Their
squares add up to ``u^2(y)`` only for a model linear in the groups; the difference is part
of the report.

:func:`validate_gum` is the JCGM 101 §8 comparison: the GUM interval ``y -/+ U`` is
validated when both its endpoints lie within ``delta`` of the Monte Carlo ones.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import ConvergenceError, InvalidInputError
from pcmm_geo.uncertainty.result import BudgetEntry, UncertaintyResult

__all__ = [
    "adaptive_monte_carlo",
    "coverage_interval",
    "monte_carlo_propagate",
    "numerical_tolerance",
    "sample_normal",
    "validate_gum",
]

FloatArray = NDArray[np.float64]
#: ``simulate(rng, size) -> (size,)`` output values
Simulation = Callable[[np.random.Generator, int], ArrayLike]


def coverage_interval(values: ArrayLike, probability: float = 0.95, kind: str = "shortest") -> tuple[float, float]:
    """Coverage interval from Monte Carlo values (JCGM 101 §7.7).

    Parameters
    ----------
    values : array_like, shape (M,)
    probability : float
    kind : {"shortest", "symmetric"}

    Returns
    -------
    (low, high) : tuple of float

    Examples
    --------
    >>> v = np.arange(1000.0)
    >>> coverage_interval(v, 0.9, "symmetric")
    (50.0, 950.0)
    >>> skewed = np.r_[np.zeros(900), np.arange(1.0, 101.0)]
    >>> coverage_interval(skewed, 0.9, "shortest")
    (0.0, 1.0)
    """
    ordered = np.sort(np.asarray(values, dtype=float).ravel())
    count = len(ordered)
    if count < 2 or not np.all(np.isfinite(ordered)):
        raise InvalidInputError("values", "at least 2 finite Monte Carlo values", f"{count} values (or NaN)")
    q = min(count - 1, int(probability * count + 0.5))
    if kind == "symmetric":
        low = (count - q) // 2
        return float(ordered[low]), float(ordered[min(low + q, count - 1)])
    if kind == "shortest":
        widths = ordered[q:] - ordered[: count - q]
        low = int(np.argmin(widths))
        return float(ordered[low]), float(ordered[low + q])
    raise InvalidInputError("kind", "'shortest' or 'symmetric'", repr(kind))


def numerical_tolerance(standard_uncertainty: float, significant_digits: int = 2) -> float:
    """JCGM 101 §7.9.2: ``delta = 10^l / 2`` where ``u = c x 10^l`` with ``c`` of ``n_dig`` digits.

    Examples
    --------
    >>> numerical_tolerance(0.000412)
    5e-06
    """
    if not (math.isfinite(standard_uncertainty) and standard_uncertainty > 0):
        return 0.0
    exponent = math.floor(math.log10(standard_uncertainty)) - significant_digits + 1
    return 0.5 * 10.0**exponent


def sample_normal(rng: np.random.Generator, mean: ArrayLike, covariance: ArrayLike, size: int) -> FloatArray:
    """Draws ``(size, n)`` from ``N(mean, covariance)`` for a symmetric PSD (possibly singular) covariance.

    Uses the eigen-decomposition (negative rounding eigenvalues clipped to 0), so
    over-parametrised covariances -- such as a unit direction's -- are sampled correctly.
    """
    mu = np.asarray(mean, dtype=float).ravel()
    cov = np.asarray(covariance, dtype=float)
    values, vectors = np.linalg.eigh(0.5 * (cov + cov.T))
    root = vectors * np.sqrt(np.clip(values, 0.0, None))
    return mu + rng.standard_normal((size, len(mu))) @ root.T


def _batch_stats(values: FloatArray, probability: float, kind: str) -> tuple[float, float, float, float]:
    low, high = coverage_interval(values, probability, kind)
    return float(values.mean()), float(values.std(ddof=1)), low, high


def _simulate(simulate: Simulation, rng: np.random.Generator, size: int) -> FloatArray:
    out = np.asarray(simulate(rng, size), dtype=float).ravel()
    if out.shape != (size,):
        raise InvalidInputError("simulate", f"{size} output values", f"shape {out.shape}")
    bad = int(np.count_nonzero(~np.isfinite(out)))
    if bad:
        raise ConvergenceError("Monte Carlo model", 0, f"{bad} of {size} trials gave a non-finite value")
    return out


def adaptive_monte_carlo(
    simulate: Simulation,
    *,
    seed: int | np.random.Generator = 0,
    probability: float = 0.95,
    significant_digits: int = 2,
    batch_size: int | None = None,
    max_trials: int = 2_000_000,
    trials: int | None = None,
    interval: str = "shortest",
    groups: Mapping[str, Simulation] | None = None,
    group_trials: int | None = None,
    quantity: str = "y",
    unit: str = "",
    progress: Callable[..., None] | None = None,
    keep_values: bool = False,
) -> UncertaintyResult:
    r"""Monte Carlo evaluation of ``y`` with the adaptive procedure of JCGM 101 §7.9.

    Parameters
    ----------
    simulate : callable
        ``simulate(rng, size) -> (size,)`` trials of the output.
    seed : int or numpy.random.Generator
        Seed of the generator (results are reproducible for a given seed and batch size).
    probability : float
        Coverage probability ``p``.
    significant_digits : int
        ``n_dig``: the digits of ``u(y)`` that must be stable (JCGM 101 §7.9.2).
    batch_size : int, optional
        ``M`` (default ``max(100/(1 - p), 10^4)``).
    max_trials : int
        Stop (``converged = False``) after this many trials.
    trials : int, optional
        Run exactly this many trials in one go instead (non-adaptive; ``converged`` then
        says whether the split-half statistics happen to meet the tolerance).
    interval : {"shortest", "symmetric"}
        The coverage interval reported.
    groups : mapping str -> callable, optional
        Simulations with one input group varied each; they give the budget.
    group_trials : int, optional
        Trials per group (default: those of the main run, at most 10^5).
    quantity, unit : str
    progress : callable, optional
        ``progress(trials_done, total_or_None, text)`` (no total while the adaptive run goes on).
    keep_values : bool
        Keep the output values in ``result.values`` (for histograms).

    Returns
    -------
    UncertaintyResult
        ``method = "Monte Carlo"``; ``extra`` holds both intervals
        (``symmetric_low``/``_high``, ``shortest_low``/``_high``) and the batch count.

    Raises
    ------
    ConvergenceError
        The model returned non-finite values.
    InvalidInputError
        Bad settings.

    See Also
    --------
    validate_gum : compare a GUM result with this one (JCGM 101 section 8)
    coverage_interval
    pcmm_geo.uncertainty.gum.propagate : the GUM linear evaluation

    Notes
    -----
    JCGM 101 [1]_, section 7.9: batches of trials are drawn until twice the standard deviation
    :math:`s` of the batch averages of :math:`y`, of :math:`u(y)` and of both ends of the
    coverage interval is below the numerical tolerance :math:`\delta` of :math:`u(y)` stated to
    ``significant_digits`` significant digits (:math:`2 s < \delta` for all four).  The coverage
    interval is the shortest or the probabilistically symmetric one (section 7.7).

    References
    ----------
    .. [1] JCGM 101:2008, *Evaluation of measurement data -- Supplement 1 to the GUM -- Propagation of
           distributions using a Monte Carlo method*.

    Examples
    --------
    ``y = x1 + x2`` with ``x1 ~ N(0, 1)`` and ``x2`` rectangular on ``[-sqrt 3, sqrt 3]`` (u = 1):

    >>> def sim(rng, size):
    ...     return rng.normal(0.0, 1.0, size) + rng.uniform(-3**0.5, 3**0.5, size)
    >>> r = adaptive_monte_carlo(sim, seed=1)
    >>> r.converged, round(r.standard_uncertainty, 2), round(r.expanded_uncertainty, 1)
    (True, 1.41, 2.7)
    """
    if not 0 < probability < 1:
        raise InvalidInputError("probability", "a value in (0, 1)", str(probability))
    if interval not in ("shortest", "symmetric"):
        raise InvalidInputError("interval", "'shortest' or 'symmetric'", repr(interval))
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    size = batch_size or max(math.ceil(100.0 / (1.0 - probability)), 10_000)
    if trials is not None:
        if trials < 4:
            raise InvalidInputError("trials", "at least 4 trials", str(trials))
        size, max_trials = trials, trials
    if size < 2:
        raise InvalidInputError("batch_size", "at least 2 trials per batch", str(size))
    batches: list[FloatArray] = []
    stats: list[tuple[float, float, float, float]] = []
    converged = False
    delta = math.nan
    while True:
        if progress is not None:  # the adaptive run's length is not known in advance: no total
            progress(len(batches) * size, trials, f"Monte Carlo: {len(batches) * size} trials")
        batch = _simulate(simulate, rng, size)
        batches.append(batch)
        if trials is not None:  # one fixed run: judge stability on its two halves
            half = size // 2
            stats = [_batch_stats(part, probability, interval) for part in (batch[:half], batch[half:])]
        else:
            stats.append(_batch_stats(batch, probability, interval))
        everything = np.concatenate(batches)
        delta = numerical_tolerance(float(everything.std(ddof=1)), significant_digits)
        if len(stats) >= 2:
            spread = np.std(np.array(stats), axis=0, ddof=1) / math.sqrt(len(stats))
            converged = bool(np.all(2.0 * spread <= delta))
        if converged or trials is not None or len(everything) + size > max_trials:
            break
    result = _summarise(everything, probability, interval, quantity, unit)
    budget: tuple[BudgetEntry, ...] = ()
    if groups:
        n_group = group_trials or min(len(everything), 100_000)
        spreads = {}
        for done, (name, group_sim) in enumerate(groups.items()):
            if progress is not None:
                progress(len(everything) + done * n_group, len(everything) + len(groups) * n_group,
                         f"budget {done + 1}/{len(groups)}: {name}")
            spreads[name] = float(_simulate(group_sim, rng, n_group).std(ddof=1))
        total = sum(s**2 for s in spreads.values())
        budget = tuple(
            BudgetEntry(name=name, contribution=s, share=(s**2 / total) if total > 0 else 0.0)
            for name, s in spreads.items()
        )
    if progress is not None:
        progress(len(everything), len(everything), "done")
    message = (
        f"stable to delta = {delta:.3g} {unit} after {len(everything)} trials"
        if converged
        else f"not stable to delta = {delta:.3g} {unit} after {len(everything)} trials"
    )
    out = _with(result, budget, len(everything), converged, delta, message, len(batches), size)
    return dataclasses.replace(out, values=everything) if keep_values else out


def _summarise(values: FloatArray, probability: float, interval: str, quantity: str, unit: str) -> dict:
    mean = float(values.mean())
    u = float(values.std(ddof=1))
    sym = coverage_interval(values, probability, "symmetric")
    short = coverage_interval(values, probability, "shortest")
    low, high = short if interval == "shortest" else sym
    expanded = 0.5 * (high - low)
    return {
        "quantity": quantity,
        "unit": unit,
        "method": "Monte Carlo",
        "value": mean,
        "standard_uncertainty": u,
        "coverage_probability": probability,
        "coverage_interval": (low, high),
        "interval_kind": interval,
        "expanded_uncertainty": expanded,
        "coverage_factor": expanded / u if u > 0 else math.nan,
        "dof": math.inf,
        "extra": {
            "symmetric_low": sym[0],
            "symmetric_high": sym[1],
            "shortest_low": short[0],
            "shortest_high": short[1],
            "median": float(np.median(values)),
        },
    }


def _with(
    summary: dict, budget: tuple[BudgetEntry, ...], n: int, converged: bool, delta: float, message: str,
    batches: int, size: int,
) -> UncertaintyResult:
    extra = {**summary.pop("extra"), "batches": batches, "batch_size": size}
    return UncertaintyResult(
        **summary, budget=budget, n_trials=n, converged=converged, numerical_tolerance=delta, message=message,
        extra=extra,
    )


def monte_carlo_propagate(
    func: Callable[[FloatArray], ArrayLike],
    x: ArrayLike,
    covariance: ArrayLike,
    *,
    names: Sequence[str] | None = None,
    seed: int | np.random.Generator = 0,
    quantity: str = "y",
    unit: str = "",
    **options: object,
) -> UncertaintyResult:
    """Monte Carlo for ``y = func(X)`` with ``X ~ N(x, U_x)``; ``func`` takes ``(M, n)`` and returns ``(M,)``.

    The budget has one line per input (only that input varied, with its marginal
    ``N(x_i, U_x[i, i])``).  ``options`` go to :func:`adaptive_monte_carlo`.

    Examples
    --------
    >>> r = monte_carlo_propagate(lambda v: v[:, 0] * v[:, 1], [20.0, 10.0], np.diag([0.01, 0.02]) ** 2,
    ...                           names=["a", "b"], seed=3)
    >>> round(r.standard_uncertainty, 3), [round(e.share, 2) for e in r.budget]
    (0.412, [0.06, 0.94])
    """
    mean = np.asarray(x, dtype=float).ravel()
    cov = np.asarray(covariance, dtype=float)
    if cov.shape == mean.shape:
        cov = np.diag(cov**2)
    if cov.shape != (len(mean), len(mean)):
        raise InvalidInputError("covariance", f"shape ({len(mean)}, {len(mean)})", f"shape {cov.shape}")
    labels = list(names) if names is not None else [f"x{i}" for i in range(len(mean))]

    def simulate(rng: np.random.Generator, size: int) -> ArrayLike:
        return func(sample_normal(rng, mean, cov, size))

    def one(i: int) -> Simulation:
        def simulate_one(rng: np.random.Generator, size: int) -> ArrayLike:
            draws = np.tile(mean, (size, 1))
            draws[:, i] += rng.standard_normal(size) * math.sqrt(max(cov[i, i], 0.0))
            return func(draws)

        return simulate_one

    return adaptive_monte_carlo(
        simulate, seed=seed, groups={label: one(i) for i, label in enumerate(labels)}, quantity=quantity,
        unit=unit, **options,  # type: ignore[arg-type]
    )


def validate_gum(gum: UncertaintyResult, monte_carlo: UncertaintyResult, significant_digits: int = 2) -> dict:
    """JCGM 101 §8.2: is the GUM interval ``y -/+ U`` within ``delta`` of the Monte Carlo one?

    Returns
    -------
    dict
        ``d_low = |y - U - y_low|``, ``d_high = |y + U - y_high|``, ``delta`` (of the GUM
        ``u(y)`` with ``significant_digits``) and ``validated`` (both ``<= delta``).
    """
    low, high = gum.coverage_interval
    mc_low, mc_high = monte_carlo.coverage_interval
    delta = numerical_tolerance(gum.standard_uncertainty, significant_digits)
    d_low, d_high = abs(low - mc_low), abs(high - mc_high)
    return {"d_low": d_low, "d_high": d_high, "delta": delta, "validated": bool(max(d_low, d_high) <= delta)}
