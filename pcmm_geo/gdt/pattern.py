"""Patterns of positions as one simultaneous requirement (ASME Y14.5-2018 7.19; ISO 5458:2018 ``SIM``).

With a complete DRF nothing floats and the requirement adds nothing; with free degrees of freedom the
zones of the pattern float together, by one motion.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.gdt._sizes import allowed_zone
from pcmm_geo.gdt.characteristics import (
    CharacteristicResult,
    FeatureData,
    _free_axes,
    _position_targets,
)
from pcmm_geo.gdt.reference._floating import float_position
from pcmm_geo.gdt.reference.frame import DatumReferenceFrame

__all__ = ["evaluate_position_pattern"]


def evaluate_position_pattern(
    features: list[FeatureData],
    drf: DatumReferenceFrame,
    tolerances_mm: list[float],
    *,
    names: list[str] | None = None,
    modifiers: list[str] | None = None,
    pattern: str = "pattern",
) -> tuple[CharacteristicResult, ...]:
    """Positions of a pattern as one simultaneous requirement (ASME Y14.5-2018 7.19; ISO 5458 ``SIM``).

    One motion in the degrees of freedom the DRF leaves free places every zone at once: the pattern
    conforms when ``max_k value_k / allowed_k <= 1`` at some common placement (``allowed_k`` = tolerance plus
    proven bonus).  With a complete DRF nothing floats and each result equals :func:`evaluate_position`'s.

    Returns
    -------
    tuple of CharacteristicResult
        One per feature, its value at the common placement; ``details["pattern"]`` and
        ``details["pattern_ratio"]`` (the least achievable largest value / allowance).  When no placement
        holds every zone: FAIL if only translations float (a convex problem, proven), NOT PROVEN when
        rotations float (turned to first order, then exactly: a local optimum).  A size outside its limits
        is FAIL for that feature.
    """
    names = names or [f.name for f in features]
    modifiers = modifiers or ["RFS"] * len(features)
    trans, rots = _free_axes(drf)
    targets, nominals, projs, owner, details_list = [], [], [], [], []
    allowed_low, allowed_high, bonuses, size_ok = [], [], [], []
    for k, (feature, tolerance, modifier) in enumerate(zip(features, tolerances_mm, modifiers, strict=True)):
        if feature.element not in ("cylinder", "sphere", "point"):
            raise InvalidInputError(f"{names[k]}: element", "an axis, a centre or a point in a pattern",
                                    feature.element)
        pts, proj = _position_targets(feature, drf, names[k], "dia")
        targets.append(pts)
        nominals.append(np.repeat(feature.point[None, :], len(pts), axis=0))
        projs.append(np.repeat(proj[None], len(pts), axis=0))
        owner += [k] * len(pts)
        details: dict[str, Any] = {"pattern": pattern}
        low, high, ok, bonus = allowed_zone(feature, tolerance, modifier, details)
        details_list.append(details)
        allowed_low.append(low)
        allowed_high.append(high)
        bonuses.append(bonus)
        size_ok.append(ok)
    stacked = np.vstack(targets)
    owner_arr = np.array(owner)
    weights = 2.0 / np.array(allowed_low)[owner_arr]
    from pcmm_geo.gdt.composite import float_group

    if rots:
        ratio, _, vectors = float_position(stacked, np.vstack(nominals), np.vstack(projs), trans, rots, drf.pivot,
                                        weights)
    else:  # translations only: the certified minimax (Lagrange dual) of gdt.composite
        cert = float_group(stacked, np.vstack(nominals), np.vstack(projs), weights, trans, [], drf.pivot)
        ratio, vectors = cert.value, cert.deviations
    if ratio <= 1.0:
        group = "PASS"
    elif not rots:  # FAIL needs a proven lower bound
        high = float_group(stacked, np.vstack(nominals), np.vstack(projs), 2.0 / np.array(allowed_high)[owner_arr],
                           trans, [], drf.pivot)
        group = "FAIL" if high.bound > 1.0 else "NOT PROVEN"
    else:
        group = "NOT PROVEN"
    results = []
    for k in range(len(features)):
        value = 2.0 * float(np.linalg.norm(vectors[owner_arr == k], axis=1).max())
        details = details_list[k]
        details.update({"pattern_ratio": ratio, "deviations_mm": vectors[owner_arr == k].tolist()})
        verdict, bonus = group, bonuses[k]
        if not size_ok[k]:
            verdict, bonus = "FAIL", 0.0
            details["reason"] = "size outside its limits"
        results.append(CharacteristicResult(names[k], "position", value, value, tolerances_mm[k], bonus, verdict,
                                            drf.datums, drf.standard, details))
    return tuple(results)
