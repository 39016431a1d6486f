"""Minimum-zone, minimum-circumscribed and maximum-inscribed cylinders; 3-D line zones; minimum-zone cones.

Cylinders and 3-D lines are solved *globally* by a branch and bound over the axes
(:mod:`pcmm_geo.fit.zone.axial`): over the axes of a stated region for cylinders
(:class:`~pcmm_geo.fit.zone.axial.region.AxisRegion`, default within 45 deg of the
least-squares axis and crossing within 2R of it), over all directions for the smallest
cylinder enclosing a 3-D line.  The certificate says ``scope == "global"`` when the proven
bound is within 1e-9 mm of the value, ``"local"`` with the bound proven so far when the
search budget ran out first.

Cones are local this round: the axis is ``(x0, y0, 0) + s (a, b, 1) / q`` in the frame of
the Gaussian fit; the cone zone is two coaxial cones of the same half angle ``alpha``
bounding ``rho_i cos(alpha) - h_i sin(alpha)``, whose width is measured normal to the cone
surface; the sequential-LP / KKT solver proves a local optimum near the least-squares cone.
"""

from __future__ import annotations

import dataclasses
from typing import Any, TypeVar

import numpy as np

from pcmm_geo.elements import Criterion
from pcmm_geo.errors import DegenerateGeometryError
from pcmm_geo.fit._kernels._axial import canonical_axis
from pcmm_geo.fit._kernels._core import FitResult, rotation_to_z
from pcmm_geo.fit._kernels._linear import frozen, sign_convention
from pcmm_geo.fit.zone._common import Proof, mode_of, shared_fields
from pcmm_geo.fit.zone._models import FloatArray, cone_distance
from pcmm_geo.fit.zone._solver import solve_minimax
from pcmm_geo.fit.zone.axial.region import AxisRegion, SearchBudget, as_budget, resolve_region
from pcmm_geo.fit.zone.axial.solve import AxialOptimum, cylinder_search, line_search
from pcmm_geo.fit.zone.axial.surround import EDGE_REASON

_RUNAWAY = 2.0
METHOD = "branch-and-bound+kkt-polish"
#: what a cone's certificate refers to (no global search this round)
CONE_DOMAIN = (
    "cones near the least-squares cone (local: the axis is not searched globally, and for a fixed axis the "
    "cone zone would still not be exact, its half angle and apex being free)"
)

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


def _axial_fields(
    fields: dict[str, Any], optimum: AxialOptimum, *, what: str, bound: float, value: float
) -> dict[str, Any]:
    """The search's method, effort and (for a local answer) why it stopped, in the result's fields."""
    effort = f"branch and bound: {optimum.cells} cells, {optimum.generations} generations"
    message = f"{fields['message']} ({effort})"
    if fields["certificate"].scope != "global":
        relation = "<=" if what == "inscribed radius" else ">="
        message = (f"local: {optimum.stop_reason} before the proof closed; the {what} is proven {relation} "
                   f"{bound:.12g} mm (value {value:.12g} mm); {message}")
    if optimum.on_boundary:
        message += "; the optimum lies on the edge of the searched axis region: a better one may lie outside it"
    fields["message"] = message
    fields["method"] = METHOD
    return fields


def cylinder_minimax(
    points: FloatArray,
    criterion: Criterion,
    *,
    gauss: Any,
    result_type: type[ResultT],
    axis_region: AxisRegion | None = None,
    search_budget: SearchBudget | None = None,
) -> ResultT:
    """Chebyshev / MCC / MIC cylinder of validated ``(N, 3)`` points, global over the axis region.

    ``gauss`` is the least-squares cylinder of the points (the default reference axis and
    the start), ``result_type`` the ``CylinderFit`` class: both come from
    :mod:`pcmm_geo.fit.cylinder`, which this module does not import.

    Raises
    ------
    DegenerateGeometryError
        MIC of points that surround no axis of the region (no inscribed cylinder exists).
    """
    mode = mode_of(criterion)
    centroid = points.mean(axis=0)
    region = resolve_region(axis_region, centroid, gauss.axis, gauss.point, gauss.radius)
    budget = as_budget(search_budget)
    optimum = cylinder_search(points, mode, region, gauss.point, gauss.axis, budget)
    effort = f" (branch and bound: {optimum.cells} cells, {optimum.generations} generations)"
    if not np.isfinite(optimum.value):
        reason = (
            "the points surround no axis of the region: there is no inscribed cylinder"
            if optimum.finished
            else f"no axis of the region that the points surround was found ({optimum.stop_reason})"
        )
        raise DegenerateGeometryError("cylinder", reason + effort)
    if mode == "mic" and optimum.stop_reason == EDGE_REASON:
        raise DegenerateGeometryError(
            "cylinder",
            f"the largest empty cylinders found run onto the edge of the points' projection (radius "
            f"{-optimum.value:.9g} mm, proven <= {-optimum.bound:.9g} mm, their axes ever closer to that edge): the "
            "points surround no empty cylinder whose maximum could be proven" + effort,
        )
    if mode == "mic":
        from pcmm_geo.fit.zone.axial.surround import Surround

        local = (points - region.origin) @ region.frame.T
        x = _region_coordinates(optimum, region)
        depth = Surround(local, np.zeros(0, dtype=np.intp)).depth(x)
        if depth <= 1e-9 * max(float(optimum.distances.min()), 1e-300):
            raise DegenerateGeometryError(
                "cylinder",
                "the points do not surround an empty cylinder: the largest empty cylinder of the region "
                "has its axis on the edge of the points' projection" + effort,
            )
    axis = canonical_axis(optimum.direction)
    point = optimum.point + float((centroid - optimum.point) @ axis) * axis
    d = optimum.distances
    if criterion == "chebyshev":
        r_in, r_out = float(d.min()), float(d.max())
        radius = 0.5 * (r_in + r_out)
        value, bound, what = r_out - r_in, optimum.bound, "zone width"
    elif criterion == "mcc":
        r_in, r_out = float(d.min()), float(d.max())
        radius = r_out
        value, bound, what = r_out, optimum.bound, "circumscribed radius"
    else:
        r_in, r_out = float(d.min()), float(d.max())
        radius = r_in
        value, bound, what = r_in, -optimum.bound, "inscribed radius"
    assert optimum.solution is not None
    residuals = d - radius
    proof = Proof(bound, value, region.domain, "branch and bound over the axis region", optimum.on_boundary)
    fields = shared_fields(
        residuals,
        optimum.solution,
        criterion=criterion,
        parameter_names=gauss.parameter_names,
        parameters=np.concatenate([point, axis, [radius]]),
        form=r_out - r_in,
        n_free=6 if criterion == "chebyshev" else 5,
        proof=proof,
    )
    fields = _axial_fields(fields, optimum, what=what, bound=bound, value=value)
    return result_type(point=frozen(point), axis=frozen(axis), radius=radius, r_in=r_in, r_out=r_out, **fields)


def _region_coordinates(optimum: AxialOptimum, region: Any) -> FloatArray:
    """``(x0, y0, a, b)`` of the optimum's axis in the region frame."""
    direction = region.frame @ optimum.direction
    if direction[2] < 0:
        direction = -direction
    local = region.frame @ (optimum.point - region.origin)
    crossing = local - local[2] / direction[2] * direction
    return np.array([crossing[0], crossing[1], direction[0] / direction[2], direction[1] / direction[2]])


def line3d_minimax(
    points: FloatArray,
    criterion: Criterion,
    *,
    gauss: Any,
    result_type: type[ResultT],
    search_budget: SearchBudget | None = None,
) -> ResultT:
    """Minimum zone of a 3-D line: the smallest cylinder enclosing the points over all directions.

    ``form`` is the cylinder's diameter; ``certificate.bound_mm`` bounds that diameter.
    ``gauss`` is the least-squares line (the start; None when the points have none, e.g. the
    corners of a regular tetrahedron), ``result_type`` the ``LineFit`` class.
    """
    budget = as_budget(search_budget)
    if gauss is None:  # no unique least-squares line (isotropic points): start on a principal axis
        centroid0 = points.mean(axis=0)
        start_point, start_direction = centroid0, np.linalg.svd(points - centroid0, full_matrices=False)[2][0]
        names = ("point_x", "point_y", "point_z", "direction_x", "direction_y", "direction_z")
    else:
        start_point, start_direction, names = gauss.point, gauss.direction, gauss.parameter_names
    optimum = line_search(points, start_point, start_direction, budget)
    direction = sign_convention(optimum.direction)
    centroid = points.mean(axis=0)
    point = optimum.point + float((centroid - optimum.point) @ direction) * direction
    rel = points - point
    perpendicular = rel - np.outer(rel @ direction, direction)
    helper = rotation_to_z(direction)
    components = perpendicular @ helper[:2].T
    residuals = optimum.distances
    assert optimum.solution is not None
    form = 2.0 * float(residuals.max())
    bound = 2.0 * optimum.bound
    proof = Proof(bound, form, "all straight lines (every axis direction)", "branch and bound over all directions")
    fields = shared_fields(
        residuals,
        optimum.solution,
        criterion=criterion,
        parameter_names=names,
        parameters=np.concatenate([point, direction]),
        form=form,
        n_free=5,
        n_residuals=len(points) * 2,
        proof=proof,
    )
    fields = _axial_fields(fields, optimum, what="enclosing diameter", bound=bound, value=form)
    fields["extra"] = {"residual_components": frozen(components)}
    return result_type(point=frozen(point), direction=frozen(direction), **fields)


def cone_minimax(points: FloatArray, criterion: Criterion, *, gauss: Any, result_type: type[ResultT]) -> ResultT:
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
    fields["certificate"] = dataclasses.replace(fields["certificate"], scope="local", domain=CONE_DOMAIN)
    fields["message"] = f"{fields['message']}; scope local over {CONE_DOMAIN}"
    return result_type(
        apex=frozen(apex),
        axis=frozen(axis_raw),
        half_angle=alpha,
        point=frozen(point),
        radius_at_point=float(radius_at_point),
        **fields,
    )
