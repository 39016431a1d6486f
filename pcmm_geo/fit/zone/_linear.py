"""Minimum-zone straight lines (2-D strip, 3-D enclosing cylinder) and planes (slab).

The minimum zone of a 2-D line or a plane is the narrowest strip / slab holding the points:
an antipodal pair of their convex hull (edge-vertex in 2-D; facet-vertex or edge-edge in 3-D),
found exactly and globally by :mod:`pcmm_geo.fit.zone._exact.slab` (rotating calipers; the
nearest facet of the hull's difference body) and refined by the KKT system of its contacts.
A 3-D line's minimum zone is the smallest cylinder enclosing the points (started from the
least-squares axis; a local optimum); ``form`` is its diameter.
"""

from __future__ import annotations

from typing import Any, TypeVar

import numpy as np

from pcmm_geo.fit._kernels._core import FitResult, rotation_to_z
from pcmm_geo.fit._kernels._linear import frozen, sign_convention
from pcmm_geo.fit.zone._common import Proof, shared_fields
from pcmm_geo.fit.zone._models import FloatArray, axis_distance, line2d_offset, plane_offset
from pcmm_geo.fit.zone._solver import solve_minimax

ResultT = TypeVar("ResultT", bound=FitResult)


def _size(local: FloatArray) -> float:
    return max(float(np.sqrt(np.mean(np.einsum("ij,ij->i", local, local)))), 1e-300)


def plane_minimax(points: FloatArray, criterion: str, *, gauss: Any, result_type: type[ResultT]) -> ResultT:
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


def line_minimax(points: FloatArray, criterion: str, *, gauss: Any, result_type: type[ResultT]) -> ResultT:
    """Minimum-zone line: narrowest strip (2-D) or smallest enclosing cylinder (3-D).

    ``gauss`` is the least-squares line of the points (the start), ``result_type`` the
    ``LineFit`` class: both come from :mod:`pcmm_geo.fit.line`, which this module does not import.
    """
    proof = None
    if points.shape[1] == 2:
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
        components = residuals[:, None]
        form = solution.upper - solution.lower
        n_free = 3
    else:
        frame = rotation_to_z(gauss.direction)
        local = (points - gauss.point) @ frame.T
        solution = solve_minimax(local, np.zeros(4), axis_distance, "mcc", size=_size(local))
        x0, y0, a, b = solution.x
        direction_local = np.array([a, b, 1.0]) / np.sqrt(1.0 + a * a + b * b)
        origin_local = np.array([x0, y0, 0.0])
        foot_local = origin_local - (origin_local @ direction_local) * direction_local
        direction = sign_convention(direction_local @ frame)
        point = gauss.point + foot_local @ frame
        residuals = solution.distances
        rel = points - point
        perpendicular = rel - np.outer(rel @ direction, direction)
        helper = rotation_to_z(direction)
        components = perpendicular @ helper[:2].T
        form = 2.0 * solution.upper
        n_free = 5
    dim = points.shape[1]
    fields = shared_fields(
        residuals,
        solution,
        criterion=criterion,
        parameter_names=gauss.parameter_names,
        parameters=np.concatenate([point, direction]),
        form=form,
        n_free=n_free,
        n_residuals=len(points) * (dim - 1),
        proof=proof,
    )
    fields["extra"] = {"residual_components": frozen(components)}
    return result_type(point=frozen(point), direction=frozen(direction), **fields)
