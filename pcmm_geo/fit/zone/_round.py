"""Minimum-zone, minimum-circumscribed and maximum-inscribed circles (2-D, 3-D) and spheres.

The distance of a point from the centre ``c`` is ``d_i = |p_i - c|``; the zone is the
annulus (spherical shell) ``r_in <= d_i <= r_out`` about a common centre.  A 3-D circle is
evaluated in the least-squares plane of its points: the points are projected orthogonally
onto that plane and the 2-D problem is solved there (ISO 12181 roundness is a property of
one cross-section; the out-of-plane offsets are reported as ``residual_components[:, 1]``).

The optimum is found by the exact global methods of :mod:`pcmm_geo.fit.zone._exact` (subset
enumeration grown by violators for the zone and the enclosing ball, Voronoi vertices for the
empty ball) and refined by the KKT system of its contacts; the certificate states the domain
it is global over and the proven bound.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np

from pcmm_geo.elements import Criterion, Element
from pcmm_geo.errors import DegenerateGeometryError
from pcmm_geo.fit._kernels._core import FitResult
from pcmm_geo.fit._kernels._linear import frozen, sign_convention
from pcmm_geo.fit.zone._common import Proof, mode_of, shared_fields
from pcmm_geo.fit.zone._models import FloatArray, center_distance
from pcmm_geo.fit.zone._solver import ZoneSolution

ResultT = TypeVar("ResultT", bound=FitResult)


def domain_of(criterion: Criterion, element: Element, *, in_plane: bool = False) -> str:
    """The set of elements a round optimum is global over, in words."""
    shape = "circle" if element == "circle" else "sphere"
    where = " in the least-squares plane of the points" if in_plane else ""
    if criterion == "mic":
        return f"empty {shape}s{where} centred inside the convex hull of the points"
    return f"all {shape}s{where}"


def solve_round(
    points: FloatArray, criterion: Criterion, *, element: Element
) -> tuple[FloatArray, ZoneSolution, Proof]:
    """Solve the minimax problem of a circle (2-D points) or sphere (3-D points), globally.

    Returns the centre (machine frame), the solver outcome (distances, levels, contacts) and
    the proof (bound and domain).

    Raises
    ------
    DegenerateGeometryError
        Collinear (coplanar) points; a maximum-inscribed element the points do not surround
        (a partial arc or cap); or a zone narrower as a straight strip / slab than as any
        circle / sphere (an infinite radius).
    """
    from pcmm_geo.fit._kernels._round import algebraic_nsphere
    from pcmm_geo.fit.zone._exact.annulus import enclosing_sphere, zone_annulus
    from pcmm_geo.fit.zone._exact.empty import largest_empty_ball
    from pcmm_geo.fit.zone._exact.polish import polish

    origin = points.mean(axis=0)
    local = points - origin
    centre0, radius0 = algebraic_nsphere(local, None, element=element)
    size = max(float(np.sqrt(np.mean(np.einsum("ij,ij->i", local, local)))), radius0)
    mode = mode_of(criterion)
    if criterion == "chebyshev":
        exact = zone_annulus(local, centre0, element=element)
    elif criterion == "mcc":
        exact = enclosing_sphere(local, centre0)
    else:
        exact = largest_empty_ball(local, element=element)
    solution = polish(local, exact, exact.x, center_distance, mode, size=size)  # type: ignore[arg-type]
    radius, _, _, form = _radii(solution, criterion)
    proof = Proof(
        bound_mm=exact.bound,
        value_mm=form if criterion == "chebyshev" else radius,
        domain=domain_of(criterion, element),
        method=exact.method,
    )
    return origin + solution.x, solution, proof


def _radii(solution: ZoneSolution, criterion: Criterion) -> tuple[float, float, float, float]:
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
    origin: FloatArray,
    solution: ZoneSolution,
    criterion: Criterion,
    *,
    result_type: type[ResultT],
    proof: Proof | None = None,
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
        proof=proof,
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
    points: FloatArray, criterion: Criterion, *, result_type: type[ResultT], fit_plane: Callable[[FloatArray], Any]
) -> ResultT:
    """Chebyshev / MCC / MIC circle of validated ``(N, 2)`` or ``(N, 3)`` points.

    ``result_type`` is the ``CircleFit`` class and ``fit_plane`` the least-squares plane fit (the
    plane of 3-D points), passed in by :mod:`pcmm_geo.fit.circle`: this module imports no element module.
    """
    if points.shape[1] == 2:
        origin = points.mean(axis=0)
        _, solution, proof = solve_round(points, criterion, element="circle")
        return circle_from_solution(origin, solution, criterion, result_type=result_type, proof=proof)
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
    centre2, solution, proof = solve_round(in_plane, criterion, element="circle")
    proof = Proof(proof.bound_mm, proof.value_mm, domain_of(criterion, "circle", in_plane=True), proof.method)
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
        proof=proof,
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


def sphere_minimax(points: FloatArray, criterion: Criterion, *, result_type: type[ResultT]) -> ResultT:
    """Chebyshev / MCC / MIC sphere of validated ``(N, 3)`` points (``result_type``: the ``SphereFit`` class)."""
    centre, solution, proof = solve_round(points, criterion, element="sphere")
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
        proof=proof,
    )
    return result_type(center=frozen(centre), radius=radius, r_in=r_in, r_out=r_out, **fields)
