"""Minimum-zone (Chebyshev), minimum-circumscribed and maximum-inscribed fits.

The ``fit_*`` functions of :mod:`pcmm_geo.fit` take ``criterion="chebyshev" | "mcc" |
"mic"`` and return the same result types as their Gaussian fits, with ``criterion``,
``contacts`` (indices of the support points) and an optimality ``certificate``.

What the certificate says
-------------------------
``certificate.scope == "global"``: the value is the optimum over ``certificate.domain`` (all
planes, all circles, ...), proven by ``certificate.bound_mm`` -- a lower bound of the zone width
or enclosing radius, an upper bound of the inscribed radius -- with ``gap_mm = |value - bound|``
at most 1e-9 mm.  ``scope == "local"``: the KKT conditions (and a second-order test) prove a local
optimum only; ``bound_mm`` holds whatever bound was proven (NaN when none).  ``certified`` (and
``converged`` on the result) is True for a global answer, or for a local one whose KKT conditions
hold.  Exact data (three points on a circle, coplanar points) are certified global with form 0.

========================  ======  ==========================================================
element, criterion        scope   domain the scope refers to
========================  ======  ==========================================================
plane, chebyshev          global  all planes
line 2-D, chebyshev       global  all straight lines in the plane
circle, chebyshev / mcc   global  all circles (3-D points: in their least-squares plane)
sphere, chebyshev / mcc   global  all spheres
circle / sphere, mic      global  empty circles / spheres centred in the points' convex hull
line 3-D, chebyshev       global  all straight lines (every axis direction) [*]
cylinder, chebyshev/mcc   global  the axis region (default: within 45 deg of the least-squares
                                  axis, crossing within 2R of it) [*]
cylinder, mic             global  the axes of that region that the points surround [*]
cone, chebyshev           local   cones near the least-squares cone
========================  ======  ==========================================================

[*] branch and bound over axis cells (:mod:`pcmm_geo.fit.zone.axial`): "global" when the proven
bound closes to 1e-9 mm within the search budget, else "local" with the bound proven so far.

Methods (``docs/minimum-zone.md`` has the details and the proofs):

- the narrowest slab / strip is an antipodal pair of the convex hull (Qhull): facet-vertex or
  edge-edge in 3-D (the facets of the difference body ``K - K``), edge-vertex in 2-D;
- zone and enclosing circle / sphere: the exact optimum of a small subset, found by enumerating
  every candidate centre (vertices of the nearest- and farthest-point Voronoi diagrams and the
  crossings of their edges; the straight zone at infinity), is a proven bound for all points; the
  farthest and nearest points join the subset until the subset's optimum holds every point;
- maximum inscribed: the largest empty circle / sphere with its centre in the convex hull is at a
  Voronoi vertex inside the hull or where a Voronoi edge crosses the hull; it is the MIC when its
  contact points surround it, else the data (a partial arc or cap) have no MIC and the fit raises.

- 3-D line and cylinder: a branch and bound over boxes of axes with rigorous bounds of the point
  distances over each box (first order per point, second order for weighted sums of the contacts'
  distances), the region's edge constraints included; see :mod:`pcmm_geo.fit.zone.axial`.

The exact answer is then refined by Newton's method on the KKT system of its contacts (sequential
linear programs, scipy's HiGHS, plus that Newton finish are the local method of the cone).

Duplicated points and the independent check
-------------------------------------------
Coincident points (exact duplicates, or within ``1e-13 x extent + 8 eps x max|coordinate|``) are merged
before every fit (:func:`merge_duplicates`), so no answer depends on how often a point was given; the
contacts are the caller's indices, the first of each merged group.  Every answer is then checked on all
input points by :func:`check_answer` (feasibility, contacts on their levels, distinct support,
non-negative multipliers summing to 1 per level, stationarity); one that fails is not certified
(``certificate.check`` says why).

Also here: :func:`evaluate_form` (ISO straightness, flatness, roundness, sphericity,
cylindricity with a PASS / FAIL / NOT PROVEN verdict, :func:`~pcmm_geo.fit.zone.form.decide_form`),
:mod:`pcmm_geo.fit.zone.reference` (data sets with a known minimax solution) and
:func:`roundness_profiles` (batches of roundness profiles, by the same exact method).

Examples
--------
>>> import numpy as np
>>> from pcmm_geo.fit import fit_circle
>>> angles = np.radians([0, 45, 90, 135, 180, 225, 270, 315])
>>> radii = 10 + np.array([0.01, -0.01] * 4)
>>> pts = np.c_[500 + radii * np.cos(angles), 200 + radii * np.sin(angles)]
>>> zone = fit_circle(pts, criterion="chebyshev")
>>> round(zone.form, 12), round(zone.radius, 12), zone.converged, zone.certificate.scope
(0.02, 10.0, True, 'global')
>>> (np.round(zone.center, 9) + 0.0).tolist()
[500.0, 200.0]
"""

from __future__ import annotations

from pcmm_geo._lazy import attach

_LAZY = {
    "evaluate_form": "form",
    "decide_form": "form",
    "FormEvaluation": "form",
    "roundness_profiles": "batch",
    "RoundnessBatch": "batch",
    "reference": "reference",
    "CRITERIA": "_common",
    "check_answer": "_check",
    "CheckOutcome": "_check",
    "merge_duplicates": "_distinct",
}

__getattr__, __dir__, __all__ = attach(__name__, _LAZY)
