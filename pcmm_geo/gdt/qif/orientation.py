"""Perpendicularity, parallelism and angularity of a QIF feature to its datums (ISO 1101 §18.9-18.11).

The datums are the datum features' actuals as the CMM reported them (a plane's normal, an
axis' direction ``u``); the toleranced feature is refitted from its compensated points
(:func:`pcmm_geo.cmm.refit.refit_feature`, the file's criterion).

**Two or more datums that fix every rotation** (``A|B``, ``A|B|C`` with B not parallel to A):
the zone's orientation is the feature's nominal direction ``m`` (a plane's normal, an axis),
carried from part into measured coordinates by the frame of the datum actuals
(:func:`~pcmm_geo.gdt.qif.frames.frame_map`), for all three characteristics alike: a plane
gives ``range(p . m)``, an axis in a cylindrical zone ``L |a x m|``.  An axis in a planar zone
to two datums is not computable (the zone's normal is the drawing's view, which QIF does not
carry).

**One datum** (or datums that leave the rotation about the primary free), the zone is oriented
by the primary's direction ``u`` only:

- an axis (cylinder, cone, line): its refitted straight axis over the axial extent ``L`` of its
  points.  A zone that is a cylinder (diametrical) or a pair of planes containing the axis gives
  ``L |a x u|`` when the zone's axis is ``u`` (perpendicular to a datum plane, parallel to a
  datum axis) and ``L |a . u|`` when the zone's planes are perpendicular to ``u`` (parallel to a
  datum plane, perpendicular to a datum axis).  The axis is the refitted line, not the extracted
  median line: its form is not included;
- a plane: the width of the thinnest pair of planes in the zone's orientation that holds the
  points: parallel to a datum plane (or perpendicular to a datum axis) ``range(p . u)``;
  perpendicular to a datum plane (or parallel to a datum axis) the smallest ``range(p . m)`` over
  unit ``m`` perpendicular to ``u`` (exact: the edges of the convex hull of the projected points).

- angularity (the nominal angle ``alpha`` between the feature's and the datum's nominal
  directions): an axis in a cylindrical zone whose axis lies on the cone of half-angle
  ``alpha`` about ``u`` gives ``L sin|theta - alpha|`` with ``theta`` the angle between the
  refitted axis and ``u`` (the nearest generator of the cone is in their common plane); a plane
  gives the smallest ``range(p . m)`` over normals ``m`` on that cone (a one-dimensional search:
  a grid of 0.25 degree, then a bounded refinement about the best step to 1e-12 rad).

Without points, an axis whose actual states its length uses that length and the reported
direction; a plane, or an axis without length, is not computable.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from pcmm_geo.gdt.qif.frames import AXIS_TYPES, PLANE_TYPES, frame_map
from pcmm_geo.gdt.qif.measures import NotComputable, Recomputation, datum_substitutes

if TYPE_CHECKING:
    from pcmm_geo.io.cmm import Characteristic, CmmDocument, MeasuredFeature
    from pcmm_geo.io.cmm.qif.characteristic_definitions import QifDefinitions

__all__ = ["orientation", "thinnest_width_on_cone", "thinnest_width_perpendicular_to"]


def thinnest_width_perpendicular_to(points: np.ndarray, direction: np.ndarray) -> float:
    """Width of the thinnest pair of planes parallel to ``direction`` that holds the points (mm).

    The smallest ``max(p @ m) - min(p @ m)`` over unit ``m`` perpendicular to ``direction``.

    The points are projected onto the plane perpendicular to ``direction``; the thinnest strip
    holding a planar point set has one side along an edge of its convex hull (rotating calipers),
    so every hull edge's normal is tried: exact, no search.

    Parameters
    ----------
    points : (N, 3) ndarray, mm
    direction : (3,) ndarray, unit

    Returns
    -------
    float
    """
    from scipy.spatial import ConvexHull, QhullError

    direction = np.asarray(direction, dtype=float)
    first = np.linalg.svd(np.eye(3) - np.outer(direction, direction))[0][:, 0]
    second = np.cross(direction, first)
    flat = np.column_stack([points @ first, points @ second])
    try:
        hull = flat[ConvexHull(flat).vertices]
    except QhullError:  # collinear (or fewer than three) projections: a strip of width 0
        return 0.0
    edges = np.roll(hull, -1, axis=0) - hull
    normals = np.column_stack([-edges[:, 1], edges[:, 0]]) / np.linalg.norm(edges, axis=1)[:, None]
    spans = hull @ normals.T
    return float((spans.max(axis=0) - spans.min(axis=0)).min())


def thinnest_width_on_cone(points: np.ndarray, axis: np.ndarray, half_angle: float) -> float:
    """Smallest ``max(p @ m) - min(p @ m)`` over unit ``m`` at ``half_angle`` (rad) to the unit ``axis`` (mm).

    The width of the thinnest pair of parallel planes holding the points whose normal makes the
    angle ``half_angle`` with ``axis``: the zone of an angularity of a plane to one datum, free to
    turn about the datum's direction.  A grid over the cone's angle ``phi`` (1440 steps), then a
    bounded scalar minimisation about the best step (to 1e-12 rad).  ``points`` ``(N, 3)``.
    """
    from scipy.optimize import minimize_scalar

    axis = np.asarray(axis, dtype=float)
    first = np.linalg.svd(np.eye(3) - np.outer(axis, axis))[0][:, 0]
    second = np.cross(axis, first)
    along, c1, c2 = points @ axis, points @ first, points @ second
    cos_a, sin_a = np.cos(half_angle), np.sin(half_angle)

    def width(phi: float) -> float:
        values = cos_a * along + sin_a * (np.cos(phi) * c1 + np.sin(phi) * c2)
        return float(values.max() - values.min())

    grid = np.linspace(0.0, 2.0 * np.pi, 1441)[:-1]
    step = grid[1] - grid[0]
    best = float(grid[int(np.argmin([width(phi) for phi in grid]))])
    # searched as an offset from the best step, so that the tolerance is absolute (not relative to phi)
    refined = minimize_scalar(lambda t: width(best + t), bounds=(-step, step), method="bounded",
                              options={"xatol": 1e-12})
    return min(float(refined.fun), width(best))


def _feature_data(document: CmmDocument, characteristic: Characteristic, feature: MeasuredFeature,
                  use_points: bool, options: Mapping[str, Any]) -> tuple[np.ndarray | None, np.ndarray | None,
                                                                         float | None, str, str]:
    """``(points, axis, length, words, source)``: the refitted points (a plane) or axis over its extent."""
    kind = feature.type
    if use_points and feature.point_set_refs:
        from pcmm_geo.cmm.refit import refit_feature
        from pcmm_geo.errors import NotRefittedError

        try:
            refit = refit_feature(document, feature, **options)
        except NotRefittedError as exc:
            raise NotComputable(f"the points could not be refitted: {exc}") from None
        if kind in PLANE_TYPES:
            return refit.points, None, None, f"the feature's {len(refit.points)} compensated points", "points"
        if refit.direction is None or refit.location is None:
            raise NotComputable("the refit has no axis")
        along = (refit.points - refit.location) @ refit.direction
        length = float(along.max() - along.min())
        return None, refit.direction, length, f"the refitted axis over its points' extent {length:.6g} mm", "points"
    if kind not in AXIS_TYPES or feature.actual.length is None:
        article = "an" if characteristic.type[0] in "aeiou" else "a"
        raise NotComputable(f"{article} {characteristic.type} needs the feature's extent: the file holds no points "
                            "for it" + ("" if kind in PLANE_TYPES else " and no actual length"))
    axis = feature.actual.direction if feature.actual.direction is not None else feature.actual.normal
    if axis is None:
        raise NotComputable("the feature actual has no direction")
    length = float(feature.actual.length)
    return None, np.asarray(axis, dtype=float), length, f"the actual axis over its reported length {length:.6g} mm", \
        "actuals"


def _nominal_direction(document: CmmDocument, feature: MeasuredFeature) -> np.ndarray:
    nominal = document.nominal_of(feature)
    geometry = None if nominal is None else nominal.geometry
    direction = None if geometry is None else (
        geometry.direction if geometry.direction is not None else geometry.normal)
    if direction is None:
        raise NotComputable(f"feature {feature.name or feature.id} has no nominal direction to orient the zone")
    return np.asarray(direction, dtype=float) / float(np.linalg.norm(direction))


def orientation(document: CmmDocument, definitions: QifDefinitions | None, characteristic: Characteristic,
                feature: MeasuredFeature, use_points: bool, options: Mapping[str, Any]) -> Recomputation:
    """Perpendicularity, parallelism or angularity of ``feature`` to its datums (see the module docstring)."""
    nominal, actual, labels, _ = datum_substitutes(document, definitions, characteristic)
    if not actual:
        raise NotComputable(f"a {characteristic.type} needs a datum; the file names none")
    kind = feature.type
    if kind not in AXIS_TYPES and kind not in PLANE_TYPES:
        raise NotComputable(f"{characteristic.type} of a {kind} feature is not evaluated")
    zone = characteristic.zone_shape
    if zone is None and definitions is not None:
        definition = definitions.definition_of(characteristic.definition_id)
        zone = None if definition is None else definition.zone_shape
    frame = frame_map(nominal, actual) if len(actual) > 1 else None
    if frame is not None and frame.nominal.z_defined and not frame.rotation_free:
        return _fully_oriented(document, characteristic, feature, use_points, options, frame, labels, zone)
    datum = actual[0]
    if datum.kind == "point" or datum.direction is None:
        raise NotComputable(f"datum {labels[0]} is a point: it orients nothing")
    u = np.asarray(datum.direction, dtype=float)
    u = u / float(np.linalg.norm(u))
    points, axis, length, words, source = _feature_data(document, characteristic, feature, use_points, options)
    against = f"against datum {labels[0]}'s actual direction" + (
        f" (datums {' | '.join(labels)} leave the rotation about it free)" if len(labels) > 1 else "")
    if characteristic.type == "angularity":
        datum_nominal = np.asarray(nominal[0].direction, dtype=float)
        if float(u @ datum_nominal) < 0.0:
            u = -u
        feature_nominal = _nominal_direction(document, feature)
        alpha = float(np.arccos(np.clip(float(feature_nominal @ datum_nominal) / float(np.linalg.norm(datum_nominal)),
                                        -1.0, 1.0)))
        if points is not None:
            return Recomputation(thinnest_width_on_cone(points, u, alpha),
                                 f"the thinnest zone whose normal is at the nominal {np.degrees(alpha):.6g} degrees to "
                                 f"datum {labels[0]}'s actual direction, holding {words}", source)
        if zone not in (None, "diametrical"):
            raise NotComputable(f"an angularity of an axis in a {zone} zone to one datum is not evaluated (the "
                                "zone's planes are the drawing's view)")
        theta = float(np.arccos(np.clip(abs(float(axis @ u)), 0.0, 1.0)))  # type: ignore[operator]
        alpha = min(alpha, np.pi - alpha)
        return Recomputation(length * abs(np.sin(theta - alpha)),  # type: ignore[operator]
                             f"{words}, its tilt from the cone at the nominal {np.degrees(alpha):.6g} degrees "
                             f"{against}", source)
    # the zone is "about u" (a cylinder or planes parallel to u) or "across u" (planes perpendicular to u)
    about_u = (characteristic.type == "perpendicularity") == (datum.kind == "plane")
    if points is not None:
        value = thinnest_width_perpendicular_to(points, u) if about_u else float(np.ptp(points @ u))
        return Recomputation(value, f"the thinnest zone {'parallel' if about_u else 'perpendicular'} to datum "
                             f"{labels[0]}'s actual direction holding {words}", source)
    tilt = float(np.linalg.norm(np.cross(axis, u))) if about_u else abs(float(axis @ u))  # type: ignore[arg-type]
    return Recomputation(length * tilt, f"{words} {against}", source)  # type: ignore[operator]


def _fully_oriented(document: CmmDocument, characteristic: Characteristic, feature: MeasuredFeature,
                    use_points: bool, options: Mapping[str, Any], frame: Any, labels: list[str],
                    zone: str | None) -> Recomputation:
    """Orientation to datums that fix every rotation: the zone along the nominal direction carried by the frame."""
    measured = frame.actual.rotation @ (frame.nominal.rotation.T @ _nominal_direction(document, feature))
    points, axis, length, words, source = _feature_data(document, characteristic, feature, use_points, options)
    where = f"the nominal direction carried by the frame {' | '.join(labels)} of the datum features' actuals"
    if points is not None:
        return Recomputation(float(np.ptp(points @ measured)),
                             f"the width along {where} of {words}", source)
    if zone not in (None, "diametrical"):
        raise NotComputable(f"a {characteristic.type} of an axis in a {zone} zone to {' | '.join(labels)} is not "
                            "evaluated (the zone's planes are the drawing's view, which QIF does not carry)")
    tilt = float(np.linalg.norm(np.cross(axis, measured)))  # type: ignore[arg-type]
    return Recomputation(length * tilt, f"{words}, its tilt from {where}", source)  # type: ignore[operator]
