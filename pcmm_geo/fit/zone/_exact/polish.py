"""The last digits of an exact optimum: Newton's method on the KKT system of its contacts."""

from __future__ import annotations

import numpy as np

from pcmm_geo.fit.zone._exact._optimum import ExactOptimum, FloatArray
from pcmm_geo.fit.zone._solver import Mode, Model, ZoneSolution, assess, solve_minimax

#: a polished optimum may exceed the exact one by at most this times the data size (rounding)
_ROUNDING = 1e-13


def objective(solution: ZoneSolution, mode: Mode) -> float:
    """The minimised quantity: zone width, enclosing radius, or minus the empty radius (mm)."""
    if mode == "zone":
        return solution.upper - solution.lower
    return solution.upper if mode == "mcc" else -solution.lower


def polish(
    points: FloatArray, exact: ExactOptimum, x0: FloatArray, model: Model, mode: Mode, *, size: float
) -> ZoneSolution:
    """The exact optimum ``x0`` (model parameters) refined on its contact set, never worse than it.

    The KKT-Newton finish of :func:`~pcmm_geo.fit.zone._solver.solve_minimax` starts from the exact
    optimum and its contacts (a circumcentre of nearly collinear contacts, for instance, is exact only
    to a few digits); its answer is kept when it is certified and not worse (to rounding), else the
    exact optimum itself is returned with its multipliers (exact data, whose contact system is
    degenerate, end here), its contacts being the exact support's points that lie on their level (to
    rounding: 1e-13 times the size), or every point on an extreme level when those are not stationary.
    """
    refined = solve_minimax(points, x0, model, mode, size=size, start=(x0, dict(exact.contacts), exact.iterations,
                                                                         exact.method))
    exact_value = exact.upper - exact.lower if mode == "zone" else (exact.upper if mode == "mcc" else -exact.lower)
    if refined.certified and objective(refined, mode) <= exact_value + _ROUNDING * size:
        return refined
    # a contact is a point on its level: the exact method's support may hold near-ties off it (clusters of
    # points closer than the exact method's tie tolerance) and may miss contacts of a symmetric optimum (a
    # 3-lobed profile's zone touches three outer and three inner points)
    extremes = _extreme_contacts(model(points, x0)[0], mode, _ROUNDING * size)
    on_level = {k: s for k, s in exact.contacts.items() if extremes.get(k) == s} or extremes
    found = assess(points, x0, on_level, model, mode, size=size, iterations=exact.iterations, message=exact.method)
    if found.certified or on_level == extremes:
        return found
    wide = assess(points, x0, extremes, model, mode, size=size, iterations=exact.iterations, message=exact.method)
    return wide if wide.certified else found


def _extreme_contacts(distances: FloatArray, mode: Mode, tolerance: float) -> dict[int, float]:
    """The points within ``tolerance`` of the levels the criterion uses, +1 outer, -1 inner."""
    contacts: dict[int, float] = {}
    if mode in ("zone", "mcc"):
        contacts.update({int(i): 1.0 for i in np.flatnonzero(distances >= distances.max() - tolerance)})
    if mode in ("zone", "mic"):
        contacts.update({int(i): -1.0 for i in np.flatnonzero(distances <= distances.min() + tolerance)})
    return contacts
