"""Minimum-zone 2-D straight lines (strip) and planes (slab).

The minimum zone of a 2-D line or a plane is the narrowest strip / slab holding the points:
an antipodal pair of their convex hull (edge-vertex in 2-D; facet-vertex or edge-edge in 3-D),
found exactly and globally by :mod:`pcmm_geo.fit.zone._exact.slab` (rotating calipers; the
nearest facet of the hull's difference body) and refined by the KKT system of its contacts.
(A 3-D line's minimum zone, the smallest enclosing cylinder, is an axial search:
:mod:`pcmm_geo.fit.zone._axial`.)
"""

from __future__ import annotations

from typing import Any, TypeVar

import numpy as np

from pcmm_geo.elements import Criterion
from pcmm_geo.fit._kernels._core import FitResult, rotation_to_z
from pcmm_geo.fit._kernels._linear import frozen, sign_convention
from pcmm_geo.fit.zone._common import Proof, shared_fields
from pcmm_geo.fit.zone._models import FloatArray, line2d_offset, plane_offset

ResultT = TypeVar("ResultT", bound=FitResult)


def _size(local: FloatArray) -> float:
    return max(float(np.sqrt(np.mean(np.einsum("ij,ij->i", local, local)))), 1e-300)


def plane_minimax(points: FloatArray, criterion: Criterion, *, gauss: Any, result_type: type[ResultT]) -> ResultT:
    """Minimum-zone plane (narrowest slab) of validated ``(N, 3)`` points.

    ``gauss`` is the least-squares plane of the points (the start), ``result_type`` the
    ``PlaneFit`` class: both come from :mod:`pcmm_geo.fit.plane`, which this module does not import.
    """
    from pcmm_geo.fit.zone._exact.polish import polish
    from pcmm_geo.fit.zone._exact.slab import narrowest_slab

    centred = points - gauss.point
    exact = narrowest_slab(centred, gauss.normal)
    frame = rotation_to_z(exact.x)
    local = centred @ frame.T
    solution = polish(local, exact, np.zeros(2), plane_offset, "zone", size=_size(local))
    proof = Proof(exact.bound, solution.upper - solution.lower, "all planes", exact.method)
    a, b = solution.x
    normal_raw = np.array([-a, -b, 1.0]) @ frame / np.sqrt(1.0 + a * a + b * b)
    normal = sign_convention(normal_raw)
    flip = float(normal @ normal_raw)
    mid = 0.5 * (solution.lower + solution.upper)
    point = gauss.point + mid * normal_raw
    residuals = flip * (solution.distances - mid)
    fields = shared_fields(
        residuals,
        solution,
        criterion=criterion,
        parameter_names=gauss.parameter_names,
        parameters=np.concatenate([point, normal]),
        form=solution.upper - solution.lower,
        n_free=4,
        proof=proof,
    )
    return result_type(point=frozen(point), normal=frozen(normal), **fields)


def line_minimax(points: FloatArray, criterion: Criterion, *, gauss: Any, result_type: type[ResultT]) -> ResultT:
    """Minimum-zone 2-D line: the narrowest strip (a 3-D line is :func:`pcmm_geo.fit.zone._axial.line3d_minimax`).

    ``gauss`` is the least-squares line of the points (the start), ``result_type`` the
    ``LineFit`` class: both come from :mod:`pcmm_geo.fit.line`, which this module does not import.
    """
    from pcmm_geo.fit.zone._exact.polish import polish
    from pcmm_geo.fit.zone._exact.slab import narrowest_strip

    exact = narrowest_strip(points - gauss.point)
    normal0 = exact.x
    frame = np.array([[normal0[1], -normal0[0]], normal0])
    local = (points - gauss.point) @ frame.T
    solution = polish(local, exact, np.zeros(1), line2d_offset, "zone", size=_size(local))
    proof = Proof(exact.bound, solution.upper - solution.lower, "all straight lines in the plane", exact.method)
    a = float(solution.x[0])
    q = np.sqrt(1.0 + a * a)
    direction_raw = np.array([1.0, a]) @ frame / q
    normal_raw = np.array([-a, 1.0]) @ frame / q
    direction = sign_convention(direction_raw)
    flip = float(direction @ direction_raw)
    mid = 0.5 * (solution.lower + solution.upper)
    point = gauss.point + mid * normal_raw
    residuals = flip * (solution.distances - mid)
    fields = shared_fields(
        residuals,
        solution,
        criterion=criterion,
        parameter_names=gauss.parameter_names,
        parameters=np.concatenate([point, direction]),
        form=solution.upper - solution.lower,
        n_free=3,
        n_residuals=len(points),
        proof=proof,
    )
    fields["extra"] = {"residual_components": frozen(residuals[:, None])}
    return result_type(point=frozen(point), direction=frozen(direction), **fields)
