"""Expanded uncertainty U of every characteristic, propagated from the points' standard uncertainty.

Method (JCGM 101:2008, GUM Supplement 1: propagation of distributions by a Monte Carlo method).  Each
point's coordinates are taken to carry independent normal errors of standard deviation ``point_u_mm``
per axis (one value per feature or per point).  A trial adds a fresh draw of such errors to every
feature's measured points and re-runs the *whole* evaluation -- datum associations (tangent minimax
planes, MIC / MCC, constrained least squares), the datum reference frames, the toleranced features
and each characteristic -- so the uncertainty reaches each value through the datums and the DRF as it
does on the part.  Linearised sensitivities would be exact only for smooth evaluations; the minimax
datums and the zones (a maximum over points) are piecewise, their active points change with the
noise, hence the Monte Carlo.

From the ``M`` trial values ``v_t`` and the value ``v`` of the points as measured:

- ``s``: the standard deviation of the ``v_t`` (the spread the points' errors cause);
- ``b = mean(v_t) - v``: the bias the trials' extra errors add.  The reported value already carries
  such a bias from the real errors: a tangent (minimax) datum plane rests on the outermost noisy
  points, a zone's width is a maximum over noisy points.  For these extremes the bias grows in
  proportion to the noise's standard deviation, and the trials have ``sqrt 2`` times the noise of
  the measurement (the points' own errors plus the trial's), so extrapolating linearly in the noise
  to zero (SIMEX, Cook and Stefanski, JASA 89 (1994) 1314) puts the bias of ``v`` at
  ``b / (sqrt 2 - 1)``.  For a smooth (least-squares) characteristic the bias is of second order and
  ``b`` is small, so this is conservative there;
- ``u = sqrt(s^2 + (b / (sqrt 2 - 1))^2)`` and ``U = 2 u`` (coverage factor k = 2, about 95 %).  The
  value itself is reported uncorrected (the characteristic as defined), its bias counted in U.

The trials are seeded (``seed``): the same plan and points give the same U.  Its relative precision is
about ``1 / sqrt(2 M)`` (7 % at the default ``M = 100``).  Not propagated: the uncertainty of an MMC / LMC
bonus (the size's uncertainty) -- the value's U is compared with the allowance as evaluated.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.errors import FileFormatError, InvalidInputError
from pcmm_geo.gdt.characteristics import CharacteristicResult, FeatureData

__all__ = ["DEFAULT_TRIALS", "PropagatedUncertainty", "perturbed", "plan_point_u", "propagate_plan",
           "propagate_point_uncertainty", "read_point_u", "with_uncertainty"]

FloatArray = NDArray[np.float64]
#: Monte Carlo trials by default
DEFAULT_TRIALS = 100
#: coverage factor of U
COVERAGE_FACTOR = 2.0
#: the trials' noise over the measurement's, minus one: their bias over the measured value's (linear in the noise)
_SIMEX = float(np.sqrt(2.0) - 1.0)


@dataclass(frozen=True)
class PropagatedUncertainty:
    """U of one characteristic from the Monte Carlo over the points' errors.

    Attributes
    ----------
    expanded : float
        U = k u, k = 2 (mm; rad for an angle).
    standard : float
        u = sqrt(spread^2 + (bias / (sqrt 2 - 1))^2).
    spread : float
        Standard deviation of the trial values.
    bias : float
        Mean of the trial values minus the reported value.
    trials : int
    seed : int
    """

    expanded: float
    standard: float
    spread: float
    bias: float
    trials: int
    seed: int

    def to_dict(self, unit: str = "mm") -> dict[str, float | int | str]:
        """JSON-ready (``expanded_uncertainty_{unit}`` ...)."""
        return {f"expanded_uncertainty_{unit}": self.expanded, f"standard_uncertainty_{unit}": self.standard,
                f"trial_spread_{unit}": self.spread, f"trial_bias_{unit}": self.bias,
                "uncertainty_source": f"propagated from the points' uncertainty (Monte Carlo, {self.trials} trials, "
                                      f"seed {self.seed}, k = 2)"}


def read_point_u(path: str | Path, count: int) -> FloatArray:
    """Per-point standard uncertainties (mm) from a text file: one number >= 0 per line, in the points' order.

    Blank lines and ``#`` comments are skipped.

    Raises
    ------
    FileFormatError
        Naming the file and line: not a finite number >= 0, or not ``count`` values.
    FileNotFoundError
    """
    from pcmm_geo.io.text import read_text_lines

    values = []
    for number, text in read_text_lines(path):
        field = text.strip()
        if not field or field.startswith("#"):
            continue
        try:
            value = float(field)
        except ValueError:
            value = float("nan")
        if not 0 <= value < float("inf"):
            raise FileFormatError(str(path), f"expected a standard uncertainty >= 0 in mm, got {field[:40]!r}", number)
        values.append(value)
    if len(values) != count:
        raise FileFormatError(str(path), f"{len(values)} uncertainties for {count} points (one per point, in order)")
    return np.asarray(values, dtype=float)


def plan_point_u(table: Mapping[str, Any], document: Mapping[str, Any], base: Path, count: int,
                 fail: Callable[[str, str], Exception]) -> float | FloatArray | None:
    """A plan feature's ``point_u_mm``: its own (a number, or a file of one value per point relative to ``base``),
    else the plan's (a number), else None.  ``fail(key, reason)`` makes the error naming the plan's line."""
    value = table.get("point_u_mm", document.get("point_u_mm"))
    if value is None:
        return None
    if isinstance(value, str) and "point_u_mm" in table:
        file = (base / value).resolve()
        if not file.is_file():
            raise fail("point_u_mm", f"point_u_mm file {value!r} not found (looked for {file})")
        try:
            return read_point_u(file, count)
        except FileFormatError as exc:
            raise fail("point_u_mm", f"point_u_mm file {value!r}: {exc}") from None
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not 0 <= value < float("inf"):
        raise fail("point_u_mm", f"point_u_mm = {value!r}: expected the points' standard uncertainty >= 0 in mm"
                   + (' (or, in a feature, "FILE" with one per point)' if "point_u_mm" in table else ""))
    return float(value)


def point_u(feature: FeatureData) -> FloatArray | None:
    """Per-point standard uncertainty (N,) of ``feature`` (mm), or None when not known.

    Raises
    ------
    InvalidInputError
        Negative or non-finite values, or a per-point array of the wrong length (named by the feature).
    """
    if feature.point_u_mm is None:
        return None
    u = np.broadcast_to(np.asarray(feature.point_u_mm, dtype=float), (len(feature.points),)) \
        if np.ndim(feature.point_u_mm) == 0 else np.asarray(feature.point_u_mm, dtype=float)
    if u.shape != (len(feature.points),) or not np.all(np.isfinite(u)) or np.any(u < 0):
        raise InvalidInputError(f"{feature.name}: point_u_mm", "a standard uncertainty >= 0 mm (one, or one per "
                                f"point: {len(feature.points)})", repr(feature.point_u_mm)[:80])
    return u


def perturbed(features: Mapping[str, FeatureData], rng: np.random.Generator) -> dict[str, FeatureData]:
    """``features`` with independent normal errors of standard deviation ``point_u_mm`` added to each point's axes.

    Features without ``point_u_mm`` are returned unchanged.  Draws are made feature by feature in the mapping's order.
    """
    out = {}
    for name, feature in features.items():
        u = point_u(feature)
        if u is None:
            out[name] = feature
            continue
        noise = rng.standard_normal(feature.points.shape) * u[:, None]
        out[name] = dataclasses.replace(feature, points=feature.points + noise)
    return out


def propagate_point_uncertainty(
    evaluate: Callable[[dict[str, FeatureData]], Sequence[float]],
    features: Mapping[str, FeatureData],
    values: Sequence[float],
    *,
    trials: int = DEFAULT_TRIALS,
    seed: int = 0,
) -> tuple[PropagatedUncertainty, ...]:
    """U of each value ``evaluate`` returns, by re-evaluating on ``trials`` perturbed copies of ``features``.

    Parameters
    ----------
    evaluate : callable
        ``features -> values`` (one float per characteristic): the whole evaluation, datums included.
    features : mapping of str to FeatureData
        The measured features; those with ``point_u_mm`` are perturbed (:func:`perturbed`).
    values : sequence of float
        The values of the points as measured (what is reported).
    trials : int
        Monte Carlo trials (at least 10).
    seed : int
        Seed of :func:`numpy.random.default_rng`.

    Returns
    -------
    tuple of PropagatedUncertainty
        One per value, in order.

    Raises
    ------
    InvalidInputError
        ``trials`` below 10; a trial returning another number of values.
    """
    if not isinstance(trials, int) or isinstance(trials, bool) or trials < 10:
        raise InvalidInputError("trials", "an integer >= 10", repr(trials))
    rng = np.random.default_rng(seed)
    reference = np.asarray(values, dtype=float)
    samples = np.empty((trials, len(reference)))
    for t in range(trials):
        got = np.asarray(evaluate(perturbed(features, rng)), dtype=float)
        if got.shape != reference.shape:
            raise InvalidInputError("evaluate", f"{len(reference)} values per trial", repr(got.shape))
        samples[t] = got
    spread = np.std(samples, axis=0, ddof=1)
    bias = np.mean(samples, axis=0) - reference
    standard = np.sqrt(spread**2 + (bias / _SIMEX) ** 2)
    return tuple(PropagatedUncertainty(float(COVERAGE_FACTOR * standard[k]), float(standard[k]), float(spread[k]),
                                       float(bias[k]), trials, seed) for k in range(len(reference)))


def with_uncertainty(result: CharacteristicResult, propagated: PropagatedUncertainty) -> CharacteristicResult:
    """``result`` decided with its propagated U (ISO 14253-1, :func:`~pcmm_geo.gdt.characteristics.apply_uncertainty`).

    An angle (``details["unit"] == "rad"``) is decided against its limits in radians.
    """
    from pcmm_geo.gdt.characteristics import apply_uncertainty

    if result.details.get("unit") == "rad":
        from pcmm_geo.uncertainty.conformity import DECISION_RULE_TEXT, decide_conformity

        low, high = (float(np.radians(v)) for v in result.details["limits_deg"])
        verdict = decide_conformity(result.value_mm, propagated.expanded, lower_limit=low, upper_limit=high).verdict
        details = {**result.details, **propagated.to_dict("rad"), "decision_rule": DECISION_RULE_TEXT}
        return dataclasses.replace(result, verdict=verdict, details=details)
    decided = apply_uncertainty(result, propagated.expanded)
    return dataclasses.replace(decided, details={**decided.details, **propagated.to_dict()})


def propagate_plan(plan: Any, results: Sequence[CharacteristicResult],
                   evaluate_all: Callable[[Any], Mapping[int, CharacteristicResult]],
                   ) -> tuple[CharacteristicResult, ...]:
    """An inspection plan's results with U propagated from its features' ``point_u_mm`` (see the module docstring).

    ``plan`` is an :class:`~pcmm_geo.gdt.inspection.InspectionPlan` (its ``point_u_trials`` and ``point_u_seed``),
    ``results`` its characteristics as measured (plan order) and ``evaluate_all(plan)`` the whole evaluation of a
    plan (index -> result).  A characteristic with a stated ``uncertainty_mm`` keeps it (the caller applies it).
    """
    def values(features: dict[str, FeatureData]) -> list[float]:
        trial = evaluate_all(dataclasses.replace(plan, features=features))
        return [trial[i].value_mm for i in range(len(results))]

    propagated = propagate_point_uncertainty(values, plan.features, [r.value_mm for r in results],
                                             trials=plan.point_u_trials, seed=plan.point_u_seed)
    return tuple(r if p.uncertainty_mm is not None else with_uncertainty(r, u)
                 for r, p, u in zip(results, plan.characteristics, propagated, strict=True))
