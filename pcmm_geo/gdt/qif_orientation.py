"""Perpendicularity and parallelism of a QIF feature to its primary datum, from its points (ISO 1101 §18.9, §18.10).

The datum is the primary datum feature's actual as the CMM reported it (a plane's normal, an
axis' direction ``u``); the toleranced feature is refitted from its compensated points
(:func:`pcmm_geo.cmm.refit.refit_feature`, the file's criterion):

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

Without points, an axis whose actual states its length uses that length and the reported
direction; anything else is not computable.  Only the primary datum orients the zone: a frame
with more datums is refused by name (the secondary's clocking of the zone is not evaluated).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from pcmm_geo.gdt.qif_frames import AXIS_TYPES, PLANE_TYPES
from pcmm_geo.gdt.qif_measures import NotComputable, Recomputation, datum_substitutes

if TYPE_CHECKING:
    from pcmm_geo.io.cmm import Characteristic, CmmDocument, MeasuredFeature
    from pcmm_geo.io.cmm.qif.characteristic_definitions import QifDefinitions

__all__ = ["orientation", "thinnest_width_perpendicular_to"]


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


def orientation(document: CmmDocument, definitions: QifDefinitions | None, characteristic: Characteristic,
                feature: MeasuredFeature, use_points: bool, options: Mapping[str, Any]) -> Recomputation:
    """Perpendicularity or parallelism of ``feature`` to the primary datum (see the module docstring)."""
    _, actual, labels, _ = datum_substitutes(document, definitions, characteristic)
    if not actual:
        raise NotComputable(f"a {characteristic.type} needs a datum; the file names none")
    if len(actual) > 1:
        raise NotComputable(f"a {characteristic.type} to {' | '.join(labels)} (the secondary datum's orientation "
                            "of the zone) is not evaluated")
    datum = actual[0]
    if datum.kind == "point" or datum.direction is None:
        raise NotComputable(f"datum {labels[0]} is a point: it orients nothing")
    u = np.asarray(datum.direction, dtype=float)
    # the zone is "about u" (a cylinder or planes parallel to u) or "across u" (planes perpendicular to u)
    about_u = (characteristic.type == "perpendicularity") == (datum.kind == "plane")
    kind = feature.type
    if kind not in AXIS_TYPES and kind not in PLANE_TYPES:
        raise NotComputable(f"{characteristic.type} of a {kind} feature is not evaluated")
    if use_points and feature.point_set_refs:
        from pcmm_geo.cmm.refit import refit_feature
        from pcmm_geo.errors import NotRefittedError

        try:
            refit = refit_feature(document, feature, **options)
        except NotRefittedError as exc:
            raise NotComputable(f"the points could not be refitted: {exc}") from None
        points = refit.points
        if kind in PLANE_TYPES:
            value = thinnest_width_perpendicular_to(points, u) if about_u else float(np.ptp(points @ u))
            return Recomputation(value, f"the thinnest zone {'parallel' if about_u else 'perpendicular'} to datum "
                                 f"{labels[0]}'s actual direction holding the feature's {len(points)} compensated "
                                 "points", "points")
        if refit.direction is None or refit.location is None:
            raise NotComputable("the refit has no axis")
        along = (points - refit.location) @ refit.direction
        length = float(along.max() - along.min())
        axis = refit.direction
        words = f"the refitted axis over its points' extent {length:.6g} mm"
    else:
        if kind not in AXIS_TYPES or feature.actual.length is None:
            raise NotComputable(f"a {characteristic.type} needs the feature's extent: the file holds no points "
                                "for it" + ("" if kind in PLANE_TYPES else " and no actual length"))
        axis = feature.actual.direction if feature.actual.direction is not None else feature.actual.normal
        if axis is None:
            raise NotComputable("the feature actual has no direction")
        length = float(feature.actual.length)
        words = f"the actual axis over its reported length {length:.6g} mm"
    tilt = float(np.linalg.norm(np.cross(axis, u))) if about_u else abs(float(axis @ u))
    return Recomputation(length * tilt, f"{words} against datum {labels[0]}'s actual direction",
                         "points" if use_points and feature.point_set_refs else "actuals")
