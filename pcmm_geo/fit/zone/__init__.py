"""Minimum-zone (Chebyshev), minimum-circumscribed and maximum-inscribed fits.

The ``fit_*`` functions of :mod:`pcmm_geo.fit` take ``criterion="chebyshev" | "mcc" |
"mic"`` and return the same result types as their Gaussian fits, with ``criterion``,
``contacts`` (indices of the support points) and an optimality ``certificate``.

Method (exact, no random search): sequential linear programs (scipy's HiGHS) on the
linearised distances inside a trust region, started from the Gaussian fit, then Newton's
method on the Karush-Kuhn-Tucker system of the contact set; contacts are exchanged until
every point lies in the zone and every multiplier is non-negative.  The certificate holds
the multipliers and the stationarity residual; a result that cannot be certified has
``converged=False`` and says why in ``message``.

What the certificate proves: the first-order (KKT) optimality conditions of the minimax
problem, plus a second-order test (the Lagrangian's Hessian on the tangent space of the
contacts) when there are fewer contacts than unknowns.  For the minimum circumscribed
circle / sphere (a convex problem) this is global optimality, and the 2-D line zone is
started from the narrowest hull-edge strip, which is the global optimum.  For the other
zones and the MIC (non-convex problems) it proves a strict local optimum near the
least-squares element (for planes: near the better of the least-squares and the best
hull-facet normal), which is the ISO minimum zone for form errors small against the
element size.

Also here: :func:`evaluate_form` (ISO straightness, flatness, roundness, sphericity,
cylindricity with a verdict), :mod:`pcmm_geo.fit.zone.reference` (data sets with a known
minimax solution) and :func:`roundness_profiles` (batches of roundness profiles).

Examples
--------
>>> import numpy as np
>>> from pcmm_geo.fit import fit_circle
>>> angles = np.radians([0, 45, 90, 135, 180, 225, 270, 315])
>>> radii = 10 + np.array([0.01, -0.01] * 4)
>>> pts = np.c_[500 + radii * np.cos(angles), 200 + radii * np.sin(angles)]
>>> zone = fit_circle(pts, criterion="chebyshev")
>>> round(zone.form, 12), round(zone.radius, 12), zone.converged
(0.02, 10.0, True)
>>> (np.round(zone.center, 9) + 0.0).tolist()
[500.0, 200.0]
"""

from __future__ import annotations

import importlib
from typing import Any

_LAZY = {
    "evaluate_form": "form",
    "FormEvaluation": "form",
    "roundness_profiles": "batch",
    "RoundnessBatch": "batch",
    "reference": "reference",
    "CRITERIA": "_common",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    module_name = _LAZY.get(name)
    if module_name is None:
        raise AttributeError(f"module 'pcmm_geo.fit.zone' has no attribute {name!r}")
    module = importlib.import_module(f"pcmm_geo.fit.zone.{module_name}")
    value = module if name == module_name else getattr(module, name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
