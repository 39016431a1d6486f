"""Minimum-zone, minimum-circumscribed and maximum-inscribed circles (2-D, 3-D) and spheres.

The distance of a point from the centre ``c`` is ``d_i = |p_i - c|``; the zone is the
annulus (spherical shell) ``r_in <= d_i <= r_out`` about a common centre.  A 3-D circle is
evaluated in the least-squares plane of its points: the points are projected orthogonally
onto that plane and the 2-D problem is solved there (ISO 12181 roundness is a property of
one cross-section; the out-of-plane offsets are reported as ``residual_components[:, 1]``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np

from pcmm_geo.errors import DegenerateGeometryError
from pcmm_geo.fit._kernels._core import FitResult
from pcmm_geo.fit._kernels._linear import frozen, sign_convention
from pcmm_geo.fit.zone._common import mode_of, shared_fields
from pcmm_geo.fit.zone._models import FloatArray, center_distance
from pcmm_geo.fit.zone._solver import ZoneSolution, solve_minimax

#: a maximum-inscribed centre this many radii away from the Gaussian centre is running away
_RUNAWAY = 2.0

ResultT = TypeVar("ResultT", bound=FitResult)


def solve_round(points: FloatArray, criterion: str, *, element: str) -> tuple[FloatArray, ZoneSolution]:
    """Solve the minimax problem of a circle (2-D points) or sphere (3-D points).

    Returns the centre (machine frame) and the solver outcome (distances, levels, contacts).

    Raises
    ------
    DegenerateGeometryError
        Collinear (coplanar) points; or an unbounded maximum-inscribed element (the points
        do not surround a maximal empty circle / sphere), or a zone that runs off to an
        infinite radius.
    """
    from pcmm_geo.fit._kernels._round import fit_nsphere

    origin = points.mean(axis=0)
    local = points - origin
    centre0, radius0, *_ = fit_nsphere(local, None, element=element)
    size = float(np.sqrt(np.mean(np.einsum("ij,ij->i", local, local))))
    mode = mode_of(criterion)

    def diverged(centre: FloatArray) -> bool:
        return bool(np.linalg.norm(centre - centre0) > _RUNAWAY * radius0)

    solution = solve_minimax(local, centre0, center_distance, mode, size=max(size, radius0), diverged=diverged)  # type: ignore[arg-type]
    if solution.message == "diverged":
        shape = "circle" if points.shape[1] == 2 else "sphere"
        if criterion == "mic":
            reason = (
                f"the maximum inscribed {shape} is not bounded: the points do not surround a maximal empty "
                f"{shape} (a partial arc or cap has no inscribed {shape})"
            )
        else:
            reason = f"the minimum-zone {shape} runs off to an infinite radius (points nearly on a line/plane)"
        raise DegenerateGeometryError(element, reason)
    return origin + solution.x, solution


def _radii(solution: ZoneSolution, criterion: str) -> tuple[float, float, float, float]:
    """(reported radius, r_in, r_out, form)."""
    d = solution.distances
    if criterion == "chebyshev":
        r_in, r_out = solution.lower, solution.upper
        return 0.5 * (r_in + r_out), r_in, r_out, r_out - r_in
    if criterion == "mcc":
        r_in, r_out = float(d.min()), solution.upper
        radius = r_out
    else:
        r_in, r_out = solution.lower, float(d.max())
        radius = r_in
    return radius, r_in, r_out, r_out - r_in


def circle_from_solution(
    origin: FloatArray, solution: ZoneSolution, criterion: str, *, result_type: type[ResultT]
) -> ResultT:
    """The 2-D circle of a solved minimax problem in coordinates centred at ``origin``.

    ``result_type`` is the ``CircleFit`` class (passed in: this module imports no element module).
    """
    centre = origin + solution.x
    radius, r_in, r_out, form = _radii(solution, criterion)
    residuals = solution.distances - radius
    fields = shared_fields(
        residuals,
        solution,
        criterion=criterion,
        parameter_names=("center_x", "center_y", "radius"),
        parameters=np.append(centre, radius),
        form=form,
        n_free=4 if criterion == "chebyshev" else 3,
    )
    return result_type(
        center=frozen(centre),
        radius=radius,
        normal=None,
        residual_components=frozen(residuals[:, None]),
        r_in=r_in,
        r_out=r_out,
        **fields,
    )


def circle_minimax(
    points: FloatArray, criterion: str, *, result_type: type[ResultT], fit_plane: Callable[[FloatArray], Any]
) -> ResultT:
    """Chebyshev / MCC / MIC circle of validated ``(N, 2)`` or ``(N, 3)`` points.

    ``result_type`` is the ``CircleFit`` class and ``fit_plane`` the least-squares plane fit (the
    plane of 3-D points), passed in by :mod:`pcmm_geo.fit.circle`: this module imports no element module.
    """
    if points.shape[1] == 2:
        origin = points.mean(axis=0)
        _, solution = solve_round(points, criterion, element="circle")
        return circle_from_solution(origin, solution, criterion, result_type=result_type)
    try:
        plane = fit_plane(points)
    except DegenerateGeometryError:
        raise DegenerateGeometryError("circle", "points are collinear; no unique circle passes through them") from None
    normal = sign_convention(plane.normal)
    helper = np.zeros(3)
    helper[int(np.argmin(np.abs(normal)))] = 1.0
    e1 = np.cross(helper, normal)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(normal, e1)
    rel = points - plane.point
    in_plane = np.column_stack([rel @ e1, rel @ e2])
    centre2, solution = solve_round(in_plane, criterion, element="circle")
    radius, r_in, r_out, form = _radii(solution, criterion)
    centre = plane.point + centre2[0] * e1 + centre2[1] * e2
    residuals = solution.distances - radius
    fields = shared_fields(
        residuals,
        solution,
        criterion=criterion,
        parameter_names=("center_x", "center_y", "center_z", "normal_x", "normal_y", "normal_z", "radius"),
        parameters=np.concatenate([centre, normal, [radius]]),
        form=form,
        n_free=4 if criterion == "chebyshev" else 3,
    )
    return result_type(
        center=frozen(centre),
        radius=radius,
        normal=frozen(normal),
        residual_components=frozen(np.column_stack([residuals, rel @ normal])),
        r_in=r_in,
        r_out=r_out,
        **fields,
    )


def sphere_minimax(points: FloatArray, criterion: str, *, result_type: type[ResultT]) -> ResultT:
    """Chebyshev / MCC / MIC sphere of validated ``(N, 3)`` points (``result_type``: the ``SphereFit`` class)."""
    centre, solution = solve_round(points, criterion, element="sphere")
    radius, r_in, r_out, form = _radii(solution, criterion)
    residuals = solution.distances - radius
    fields = shared_fields(
        residuals,
        solution,
        criterion=criterion,
        parameter_names=("center_x", "center_y", "center_z", "radius"),
        parameters=np.append(centre, radius),
        form=form,
        n_free=5 if criterion == "chebyshev" else 4,
    )
    return result_type(center=frozen(centre), radius=radius, r_in=r_in, r_out=r_out, **fields)
