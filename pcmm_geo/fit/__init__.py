"""Gaussian (least-squares, orthogonal-distance) fits of geometric elements.

Every ``fit_*`` function takes points of shape ``(N, 3)`` (``(N, 2)`` for the planar
line and circle), in millimetres, and returns one frozen result dataclass per
element type that subclasses :class:`FitResult`: element geometry, signed residuals,
``rms``, ``form``, parameter covariance with names, degrees of freedom and
convergence information.  Algebraic fits are used only as starting values.

This sub-package knows nothing of machines or files: pure numpy/scipy.

Two helpers of every fit are public for the layers above (artefacts, cmm, calibration) that take
points the same way: :func:`as_points` (an ``(N, 3)`` float64 array from user input, with the
typed errors of the fits) and :func:`rotation_to_z` (the rotation taking a direction to +z).

Examples
--------
>>> import numpy as np
>>> from pcmm_geo.fit import fit_sphere
>>> angles = np.linspace(0, 2 * np.pi, 7, endpoint=False)
>>> pts = np.c_[10 * np.cos(angles), 10 * np.sin(angles), np.zeros(7)]
>>> pts = np.vstack([pts, [0, 0, 10], [0, 0, -10]]) + 1000.0
>>> result = fit_sphere(pts)
>>> round(result.radius, 9), np.round(result.center, 9).tolist()
(10.0, [1000.0, 1000.0, 1000.0])
"""

from __future__ import annotations

from pcmm_geo._lazy import attach
from pcmm_geo.elements import ELEMENTS
from pcmm_geo.fit._kernels._core import TOL, FitResult, Tolerances, as_points, rotation_to_z

# public name -> submodule that defines it; loaded on first access (PEP 562) so that
# ``import pcmm_geo.fit`` stays fast and independent of scipy until a fit runs.
_LAZY = {
    "fit_line": "line",
    "LineFit": "line",
    "fit_plane": "plane",
    "PlaneFit": "plane",
    "fit_circle": "circle",
    "CircleFit": "circle",
    "fit_sphere": "sphere",
    "SphereFit": "sphere",
    "fit_cylinder": "cylinder",
    "CylinderFit": "cylinder",
    "fit_cone": "cone",
    "ConeFit": "cone",
    "fit_torus": "torus",
    "TorusFit": "torus",
    "closest_points": "skew",
    "angle_between": "skew",
    "LinePair": "skew",
    "nearest_point_to_lines": "skew",
    "LinesNearestPoint": "skew",
    "pairwise_closest_points": "skew",
    "mean_pairwise_midpoint": "skew",
    "fit_spheres": "batch",
    "fit_circles": "batch",
    "fit_planes": "batch",
    "fit_lines": "batch",
    "BatchFit": "batch",
    "SphereBatchFit": "batch",
    "CircleBatchFit": "batch",
    "PlaneBatchFit": "batch",
    "LineBatchFit": "batch",
    "reference": "reference",
    "compensate_probe": "probe",
    "compensate_points": "probe",
    "ProbeCompensation": "probe",
    "material_side_from_normals": "probe",
    "material_side_from_nominal": "probe",
    "AxisRegion": "zone.axial.region",
    "SearchBudget": "zone.axial.region",
}

__getattr__, __dir__, _LAZY_ALL = attach(__name__, _LAZY)

__all__ = ["ELEMENTS", "FitResult", "Tolerances", "TOL", "as_points", "rotation_to_z", *_LAZY_ALL]
