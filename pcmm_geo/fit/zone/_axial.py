"""Minimum-zone, minimum-circumscribed and maximum-inscribed cylinders; minimum-zone cones.

The axis is ``(x0, y0, 0) + s (a, b, 1) / q`` in the frame of the Gaussian fit (centred
on its axis point, axis along +z), so the four axis parameters start at zero.  The
cylinder zone is two coaxial cylinders ``r_in <= rho_i <= r_out``; the cone zone is two
coaxial cones of the same half angle ``alpha`` bounding ``rho_i cos(alpha) - h_i sin(alpha)``,
whose width is measured normal to the cone surface.
"""

from __future__ import annotations

from typing import Any, TypeVar

import numpy as np

from pcmm_geo.errors import DegenerateGeometryError
from pcmm_geo.fit._kernels._axial import canonical_axis
from pcmm_geo.fit._kernels._core import FitResult, rotation_to_z
from pcmm_geo.fit._kernels._linear import frozen
from pcmm_geo.fit.zone._common import mode_of, shared_fields
from pcmm_geo.fit.zone._models import FloatArray, axis_distance, cone_distance
from pcmm_geo.fit.zone._solver import solve_minimax

_RUNAWAY = 2.0

ResultT = TypeVar("ResultT", bound=FitResult)


def _axis_frame(
    solution_x: FloatArray, frame: FloatArray, origin: FloatArray, centroid: FloatArray
) -> tuple[FloatArray, FloatArray, float]:
    """Machine-frame axis (unit, raw sign), foot point of the data centroid and the foot's local height."""
    x0, y0, a, b = (float(v) for v in solution_x[:4])
    direction_local = np.array([a, b, 1.0]) / np.sqrt(1.0 + a * a + b * b)
    axis_raw = direction_local @ frame
    axis_point = origin + np.array([x0, y0, 0.0]) @ frame
    height = float((centroid - axis_point) @ axis_raw)
    return axis_raw, axis_point + height * axis_raw, height


def cylinder_minimax(points: FloatArray, criterion: str, *, gauss: Any, result_type: type[ResultT]) -> ResultT:
    """Chebyshev / MCC / MIC cylinder of validated ``(N, 3)`` points.

    ``gauss`` is the least-squares cylinder of the points (the start), ``result_type`` the
    ``CylinderFit`` class: both come from :mod:`pcmm_geo.fit.cylinder`, which this module does not import.
    """
    frame = rotation_to_z(gauss.axis)
    local = (points - gauss.point) @ frame.T
    mode = mode_of(criterion)
    size = max(gauss.radius, float(np.ptp(local[:, 2])))

    def diverged(x: FloatArray) -> bool:
        return bool(np.hypot(x[0], x[1]) > _RUNAWAY * gauss.radius or np.hypot(x[2], x[3]) > 1.0)

    solution = solve_minimax(local, np.zeros(4), axis_distance, mode, size=size, diverged=diverged)  # type: ignore[arg-type]
    if solution.message == "diverged":
        reason = (
            "the maximum inscribed cylinder is not bounded: the points do not surround a maximal empty cylinder"
            if criterion == "mic"
            else "the axis runs away from the least-squares axis (points do not determine a cylinder)"
        )
        raise DegenerateGeometryError("cylinder", reason)
    axis_raw, point, _ = _axis_frame(solution.x, frame, gauss.point, points.mean(axis=0))
    axis = canonical_axis(axis_raw)
    d = solution.distances
    if criterion == "chebyshev":
        r_in, r_out = solution.lower, solution.upper
        radius = 0.5 * (r_in + r_out)
    elif criterion == "mcc":
        r_in, r_out = float(d.min()), solution.upper
        radius = r_out
    else:
        r_in, r_out = solution.lower, float(d.max())
        radius = r_in
    residuals = d - radius
    fields = shared_fields(
        residuals,
        solution,
        criterion=criterion,
        parameter_names=gauss.parameter_names,
        parameters=np.concatenate([point, axis, [radius]]),
        form=r_out - r_in,
        n_free=6 if criterion == "chebyshev" else 5,
    )
    return result_type(point=frozen(point), axis=frozen(axis), radius=radius, r_in=r_in, r_out=r_out, **fields)


def cone_minimax(points: FloatArray, criterion: str, *, gauss: Any, result_type: type[ResultT]) -> ResultT:
    """Minimum-zone cone of validated ``(N, 3)`` points.

    ``gauss`` is the least-squares cone of the points (the start), ``result_type`` the
    ``ConeFit`` class: both come from :mod:`pcmm_geo.fit.cone`, which this module does not import.
    """
    frame = rotation_to_z(gauss.axis)
    local = (points - gauss.point) @ frame.T
    size = max(gauss.radius_at_point, float(np.ptp(local[:, 2])))
    x0 = np.array([0.0, 0.0, 0.0, 0.0, gauss.half_angle])

    def diverged(x: FloatArray) -> bool:
        return bool(np.hypot(x[0], x[1]) > _RUNAWAY * size or np.hypot(x[2], x[3]) > 1.0)

    solution = solve_minimax(local, x0, cone_distance, "zone", size=size, diverged=diverged)
    if solution.message == "diverged":
        raise DegenerateGeometryError("cone", "the axis runs away from the least-squares axis")
    alpha = float(solution.x[4])
    axis_raw, point, height = _axis_frame(solution.x, frame, gauss.point, points.mean(axis=0))
    mid = 0.5 * (solution.lower + solution.upper)
    # level m at local height h: rho = (m + h sin(alpha)) / cos(alpha)
    radius_at_point = (mid + height * np.sin(alpha)) / np.cos(alpha)
    if alpha < 0:  # opening toward -axis: flip so that the axis runs from the apex to the opening
        axis_raw, alpha = -axis_raw, -alpha
    apex = point - radius_at_point / np.tan(alpha) * axis_raw if alpha > 0 else np.full(3, np.inf)
    residuals = solution.distances - mid
    fields = shared_fields(
        residuals,
        solution,
        criterion=criterion,
        parameter_names=gauss.parameter_names,
        parameters=np.concatenate([point, axis_raw, [radius_at_point, alpha]]),
        form=solution.upper - solution.lower,
        n_free=7,
    )
    return result_type(
        apex=frozen(apex),
        axis=frozen(axis_raw),
        half_angle=alpha,
        point=frozen(point),
        radius_at_point=float(radius_at_point),
        **fields,
    )
