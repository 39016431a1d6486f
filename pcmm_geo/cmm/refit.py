"""Refitting a feature a CMM measured, from the points its file holds, onto the touched surface.

The refit follows what a CMM does with the same points, so that a disagreement means something:

* the points are put in the document's common frame (the frame of the reported actuals: a point
  set's ``TranformId`` / ``CoordinateSystemId`` transform is applied by
  :meth:`~pcmm_geo.io.cmm.CmmDocument.points_of`);
* the criterion is the one the file states (``SubstituteFeatureAlgorithm``: least squares,
  minimum zone, minimum circumscribed, maximum inscribed), else Gaussian least squares;
* a circle measured in 3-D is fitted in the least-squares plane of its points (the points are
  projected onto it), or, on request, in the plane the CMM reported (its working plane);
* probe-ball centres are compensated by the element offset of
  :func:`pcmm_geo.fit.probe.compensate_probe` (sphere, circle, cylinder, cone, plane: exact
  parallel surfaces) or point by point along normals (points, lines, and points whose radii or
  compensation flags differ), with the material side from the file's ``InternalExternal``, the
  point normals, or inferred from the nominal size (flagged), else refused.

A feature that cannot be refitted raises :class:`~pcmm_geo.errors.NotRefittedError` with the reason in plain
words.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.cmm.compensation import FILE_COMPENSATED, Compensation, plan_compensation, side_arguments
from pcmm_geo.elements import FEATURE_TYPES, Criterion, FeatureType
from pcmm_geo.errors import InvalidInputError, NotRefittedError
from pcmm_geo.io.cmm import SpellSetting, python_setting

if TYPE_CHECKING:
    from pcmm_geo.fit import FitResult
    from pcmm_geo.io.cmm import CmmDocument, FeatureGeometry, MeasuredFeature

__all__ = ["CRITERIA_BY_ALGORITHM", "Compensation", "Refit", "refit_feature"]

FloatArray = NDArray[np.float64]

#: QIF SubstituteFeatureAlgorithmEnum -> fit criterion
CRITERIA_BY_ALGORITHM: dict[str, Criterion] = {
    "LEASTSQUARES": "gaussian",
    "MINMAX": "chebyshev",
    "MINCIRCUMSCRIBED": "mcc",
    "MAXINSCRIBED": "mic",
}
#: algorithms that name no particular criterion: the default (Gaussian) applies
_DEFAULT_ALGORITHMS = ("DEFAULT", "UNDEFINED", "")
REFITTED_TYPES = FEATURE_TYPES  # every feature type of pcmm_geo.elements the QIF writer knows
CIRCLE_PLANES = ("least-squares", "reported")


NO_COMPENSATION_NEEDED = FILE_COMPENSATED


@record
class Refit:
    """A refitted feature (surface element, in the document's common frame).

    Attributes
    ----------
    type : str
    n_points : int
    method : str
        Fit criterion: ``"gaussian"``, ``"chebyshev"``, ``"mcc"`` or ``"mic"``.
    method_source : str
        ``"file (LEASTSQUARES)"``, ``"default"`` or ``"requested"``.
    circle_plane : str or None
        Circles: ``"least-squares"`` or ``"reported"``.
    location, direction : ndarray (3,) or None
        Centre / point on the element; unit normal or axis.
    diameter : float or None
        mm (a cone: at ``location``).
    half_angle : float or None
        Cone half-angle, rad.
    fit : FitResult or None
        The surface element (None for points).
    compensation : Compensation
    points : ndarray (N, 3)
        The points used (surface points for point features; as read otherwise), common frame.
    """

    type: FeatureType
    n_points: int
    method: Criterion
    method_source: str
    compensation: Compensation
    points: FloatArray
    location: FloatArray | None = None
    direction: FloatArray | None = None
    diameter: float | None = None
    half_angle: float | None = None
    circle_plane: str | None = None
    fit: FitResult | None = None


def _criterion(feature: MeasuredFeature, requested: Criterion | None, spell: SpellSetting) -> tuple[Criterion, str]:
    if requested is not None:
        return requested, "requested"
    algorithm = (feature.substitute_algorithm or "").strip().upper()
    if algorithm in CRITERIA_BY_ALGORITHM:
        return CRITERIA_BY_ALGORITHM[algorithm], f"file ({algorithm})"
    if algorithm in _DEFAULT_ALGORITHMS:
        return "gaussian", "default"
    raise NotRefittedError(f"the file's fitting algorithm {feature.substitute_algorithm!r} is not one pcmm_geo offers "
                           f"(least squares, minimum zone, MCC, MIC): give {spell('criterion')} to refit anyway")


def _unit(vector: Any) -> FloatArray | None:
    if vector is None:
        return None
    arr = np.asarray(vector, dtype=float)
    norm = float(np.linalg.norm(arr))
    return None if not np.isfinite(norm) or norm == 0 else arr / norm


@dataclass(frozen=True)
class _Context:
    """What the document says about a feature besides its points."""

    actual: FeatureGeometry
    nominal: FeatureGeometry | None
    nominal_diameter: float | None
    nominal_half_angle: float | None
    side: str | None  # from InternalExternal
    internal_external: str | None


def _context(document: CmmDocument, feature: MeasuredFeature) -> _Context:
    nominal = document.nominal_of(feature)
    definition = document.definition_of(feature)
    geometry = None if nominal is None else nominal.geometry
    diameter = None if definition is None else definition.diameter
    if diameter is None and geometry is not None:
        diameter = geometry.diameter
    half_angle = None if definition is None else definition.half_angle
    if half_angle is None and geometry is not None:
        half_angle = geometry.half_angle
    return _Context(feature.actual, geometry, diameter, half_angle, feature.material_side, feature.internal_external)


def _first(*vectors: Any) -> FloatArray | None:
    for vector in vectors:
        unit = _unit(vector)
        if unit is not None:
            return unit
    return None


def refit_feature(
    document: CmmDocument,
    feature: MeasuredFeature,
    *,
    criterion: Criterion | None = None,
    circle_plane: str = "least-squares",
    compensated: bool | None = None,
    probe_radius: float | None = None,
    material_side: str | None = None,
    spell_setting: SpellSetting = python_setting,
) -> Refit:
    """Refit one measured feature from its points, compensated, in the document's common frame.

    Parameters
    ----------
    document : CmmDocument
    feature : MeasuredFeature
        One of ``document.measured_features``.
    criterion : {"gaussian", "chebyshev", "mcc", "mic"}, optional
        Overrides the file's fitting algorithm.
    circle_plane : {"least-squares", "reported"}
        Plane a 3-D circle is fitted in: the least-squares plane of its points (default) or the
        plane through the reported centre with the reported (else nominal) normal.
    compensated : bool, optional
        For formats that do not say (DMIS, PC-DMIS): whether the points are surface points.
    probe_radius : float, optional
        Overrides the file's probe radius (mm).
    material_side : {"internal", "external"}, optional
        The side of a feature of size where the file does not state it; a side that contradicts
        the file's ``InternalExternal`` or the point normals is refused (NotRefittedError).
    spell_setting : callable
        How reasons name these parameters (:mod:`pcmm_geo.io.cmm.settings`; the command line
        passes its option names).

    Returns
    -------
    Refit

    Notes
    -----
    The probe radius and the material side are decided by :mod:`pcmm_geo.cmm.compensation`
    (:func:`~pcmm_geo.cmm.compensation.plan_compensation`,
    :func:`~pcmm_geo.cmm.compensation.side_arguments`), as for ``pcmm fit FILE`` and the
    calibration balls of a QIF file.

    Raises
    ------
    NotRefittedError
        No points, a type not refitted, unknown compensation or material side, a fit that fails
        (its message).
    """
    from pcmm_geo.errors import PcmmGeoError

    if circle_plane not in CIRCLE_PLANES:
        raise InvalidInputError("circle_plane", "'least-squares' or 'reported'", repr(circle_plane))
    if feature.type not in REFITTED_TYPES:
        raise NotRefittedError(f"features of type {feature.type} are not refitted")
    try:
        point_set = document.points_of(feature, frame="common")
    except PcmmGeoError as exc:  # e.g. a point set whose frame cannot be put into the common one
        raise NotRefittedError(" ".join(str(exc).split())) from None
    if point_set is None or len(point_set) == 0:
        why = "; ".join(feature.problems)
        raise NotRefittedError("the file holds no measured points for this feature" + (f" ({why})" if why else ""))
    method, method_source = _criterion(feature, criterion, spell_setting)
    context = _context(document, feature)
    try:
        plan = plan_compensation(point_set, compensated=compensated, probe_radius=probe_radius,
                                 spell_setting=spell_setting)
        return _REFITTERS[feature.type](plan.points, plan.normals, plan.radius, plan.radius_source, context, method,
                                        method_source, circle_plane=circle_plane, material_side=material_side,
                                        spell_setting=spell_setting)
    except PcmmGeoError as exc:
        raise NotRefittedError(" ".join(str(exc).split())) from None


def _round_compensation(fit: FitResult, radius: float, radius_source: str, context: _Context,
                        material_side: str | None, normals: FloatArray | None, points: FloatArray,
                        nominal_diameter: float | None = None, *, spell_setting: SpellSetting = python_setting,
                        side_free: bool = False) -> tuple[FitResult, Compensation]:
    from pcmm_geo.fit.probe import compensate_probe

    if radius == 0:
        return fit, Compensation(0.0, "none", False, radius_source, "none", radius_source=radius_source)
    kwargs, side_source = side_arguments(material_side, file_side=context.side,
                                         internal_external=context.internal_external, normals=normals, points=points,
                                         nominal_diameter=context.nominal_diameter, required=not side_free,
                                         spell_setting=spell_setting)
    if not kwargs:  # an element offset moves the surface along its normals: centre and axis stay put
        return fit, Compensation(radius, "unknown", False, f"{radius_source}; side unknown: centre and axis do not "
                                 "depend on it, the size does and is not refitted", "none")
    if "nominal_diameter" in kwargs and nominal_diameter is not None:
        kwargs["nominal_diameter"] = nominal_diameter
    try:
        result = compensate_probe(fit, radius, **kwargs)
    except InvalidInputError as exc:
        raise NotRefittedError(" ".join(str(exc).split())) from None
    return result.surface, Compensation.from_probe(result, radius_source, side_source)


def _sphere(points: FloatArray, normals: FloatArray | None, radius: float, radius_source: str, context: _Context,
            method: Criterion, method_source: str, **options: Any) -> Refit:
    from pcmm_geo.fit import fit_sphere

    fit, comp = _round_compensation(fit_sphere(points, criterion=method), radius, radius_source, context,
                                    options["material_side"], normals, points, spell_setting=options["spell_setting"],
                                    side_free=True)
    return Refit("sphere", len(points), method, method_source, comp, points, location=fit.center,
                 diameter=None if comp.side == "unknown" else 2.0 * fit.radius, fit=fit)


def _cylinder(points: FloatArray, normals: FloatArray | None, radius: float, radius_source: str, context: _Context,
              method: Criterion, method_source: str, **options: Any) -> Refit:
    from pcmm_geo.fit import fit_cylinder

    hint = _first(context.actual.direction, None if context.nominal is None else context.nominal.direction)
    hinted = {"axis_hint": hint} if method == "gaussian" else {}  # the minimax fits search their own axes
    fit, comp = _round_compensation(fit_cylinder(points, criterion=method, **hinted), radius, radius_source,
                                    context, options["material_side"], normals, points,
                                    spell_setting=options["spell_setting"], side_free=True)
    return Refit("cylinder", len(points), method, method_source, comp, points, location=fit.point,
                 direction=fit.axis, diameter=None if comp.side == "unknown" else 2.0 * fit.radius, fit=fit)


def _cone(points: FloatArray, normals: FloatArray | None, radius: float, radius_source: str, context: _Context,
          method: Criterion, method_source: str, **options: Any) -> Refit:
    from pcmm_geo.fit import fit_cone

    nominal = context.nominal
    hint = _first(context.actual.direction, None if nominal is None else nominal.direction)
    fit = fit_cone(points, criterion=method, **({"axis_hint": hint} if method == "gaussian" else {}))
    nominal_diameter = None
    if nominal is not None and nominal.location is not None and context.nominal_diameter is not None \
            and context.nominal_half_angle is not None:
        axis = _first(nominal.direction, fit.axis)
        along = float((fit.point - nominal.location) @ axis)  # nominal axis: locating point -> expanding end
        nominal_diameter = context.nominal_diameter + 2.0 * along * np.tan(context.nominal_half_angle)
    elif context.nominal_diameter is not None:
        context = _Context(context.actual, nominal, None, None, context.side, context.internal_external)
    fit, comp = _round_compensation(fit, radius, radius_source, context, options["material_side"], normals, points,
                                    nominal_diameter, spell_setting=options["spell_setting"])
    return Refit("cone", len(points), method, method_source, comp, points, location=fit.point, direction=fit.axis,
                 diameter=2.0 * fit.radius_at_point, half_angle=fit.half_angle, fit=fit)


def _circle(points: FloatArray, normals: FloatArray | None, radius: float, radius_source: str, context: _Context,
            method: Criterion, method_source: str, **options: Any) -> Refit:
    from pcmm_geo.fit import fit_circle

    plane = options["circle_plane"]
    if plane == "reported":
        normal = _first(context.actual.normal, None if context.nominal is None else context.nominal.normal)
        origin = context.actual.location if context.actual.location is not None else \
            (None if context.nominal is None else context.nominal.location)
        if normal is None or origin is None:
            spell = options["spell_setting"]
            raise NotRefittedError(f"{spell('circle_plane', 'reported')} needs the circle's reported (or nominal) "
                                   "normal and centre")
        frame = _plane_frame(normal)
        in_plane = (points - origin) @ frame[:2].T
        normals_2d = None if normals is None else normals @ frame[:2].T
        fit = fit_circle(in_plane, criterion=method)
        fit, comp = _round_compensation(fit, radius, radius_source, context, options["material_side"], normals_2d,
                                        in_plane, spell_setting=options["spell_setting"])
        centre = origin + fit.center @ frame[:2]
        return Refit("circle", len(points), method, method_source, comp, points, location=centre, direction=normal,
                     diameter=2.0 * fit.radius, circle_plane="reported", fit=fit)
    fit = fit_circle(points, method="projected") if method == "gaussian" else fit_circle(points, criterion=method)
    fit, comp = _round_compensation(fit, radius, radius_source, context, options["material_side"], normals, points,
                                    spell_setting=options["spell_setting"], side_free=True)
    return Refit("circle", len(points), method, method_source, comp, points, location=fit.center,
                 direction=fit.normal, diameter=None if comp.side == "unknown" else 2.0 * fit.radius,
                 circle_plane="least-squares", fit=fit)


def _plane_frame(normal: FloatArray) -> FloatArray:
    """Rows ``(e1, e2, normal)``: an orthonormal frame whose third axis is ``normal``."""
    from pcmm_geo.fit import rotation_to_z

    return rotation_to_z(normal)


def _outward(context: _Context, normals: FloatArray | None, kind: str) -> tuple[FloatArray | None, str]:
    """Outward normal(s) of a plane, line or point: point normals, else the reported, else the nominal one."""
    if normals is not None:
        return normals, "point normals"
    nominal = context.nominal
    reported = context.actual.normal
    if reported is not None:
        return np.asarray(reported, dtype=float), f"the {kind}'s reported normal"
    if nominal is not None and nominal.normal is not None:
        return np.asarray(nominal.normal, dtype=float), f"the {kind}'s nominal normal"
    return None, ""


def _flat_compensation(fit: FitResult, kind: str, radius: float, radius_source: str, context: _Context,
                       normals: FloatArray | None) -> tuple[FitResult, Compensation]:
    from pcmm_geo.fit.probe import compensate_probe

    if radius == 0:
        return fit, Compensation(0.0, "none", False, radius_source, "none", radius_source=radius_source)
    outward, source = _outward(context, normals, kind)
    if outward is None:
        raise NotRefittedError(f"the {kind}'s points are probe centres but neither the points nor the {kind} carry a "
                               "normal saying where the material is")
    try:
        result = compensate_probe(fit, radius, outward=outward)
    except InvalidInputError as exc:
        raise NotRefittedError(f"{' '.join(str(exc).split())} (from {source})") from None
    method = "element offset" if kind == "plane" else "points along normals"
    return result.surface, Compensation(radius, "external", False, f"{radius_source}; outward normal from {source}",
                                        method, result.outward, radius_source, source)


def _plane(points: FloatArray, normals: FloatArray | None, radius: float, radius_source: str, context: _Context,
           method: Criterion, method_source: str, **options: Any) -> Refit:
    from pcmm_geo.fit import fit_plane

    fit, comp = _flat_compensation(fit_plane(points, criterion=method), "plane", radius, radius_source, context,
                                   normals)
    return Refit("plane", len(points), method, method_source, comp, points, location=fit.point, direction=fit.normal,
                 fit=fit)


def _line(points: FloatArray, normals: FloatArray | None, radius: float, radius_source: str, context: _Context,
          method: Criterion, method_source: str, **options: Any) -> Refit:
    from pcmm_geo.fit import fit_line

    fit, comp = _flat_compensation(fit_line(points, criterion=method), "line", radius, radius_source, context,
                                   normals)
    return Refit("line", len(points), method, method_source, comp, points, location=fit.point,
                 direction=fit.direction, fit=fit)


def _point(points: FloatArray, normals: FloatArray | None, radius: float, radius_source: str, context: _Context,
           method: Criterion, method_source: str, **options: Any) -> Refit:
    from pcmm_geo.fit.probe import compensate_points

    if method != "gaussian":
        raise NotRefittedError(f"a point feature is the mean of its points; criterion {method} does not apply")
    comp = Compensation(0.0, "none", False, radius_source, "none", radius_source=radius_source)
    surface = points
    if radius > 0:
        outward, source = _outward(context, normals, "point")
        if outward is None:
            raise NotRefittedError("the point is a probe centre but neither the point set nor the feature (reported or "
                                   "nominal) gives the surface normal to compensate it along")
        surface = compensate_points(points, outward, radius)
        mean_normal = np.mean(np.atleast_2d(outward) / np.linalg.norm(np.atleast_2d(outward), axis=1, keepdims=True),
                              axis=0)
        comp = Compensation(radius, "external", False, f"{radius_source}; outward normal from {source}",
                            "points along normals", mean_normal / np.linalg.norm(mean_normal), radius_source, source)
    return Refit("point", len(points), method, method_source, comp, surface, location=surface.mean(axis=0))


_REFITTERS = {"sphere": _sphere, "cylinder": _cylinder, "cone": _cone, "circle": _circle, "plane": _plane,
              "line": _line, "point": _point}
