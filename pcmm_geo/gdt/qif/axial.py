"""Runout, concentricity, coaxiality and surface / line profile of a QIF feature, from its actuals and points.

The datum is the primary datum feature's actual as the CMM reported it (its axis: point ``c``
and unit direction ``u``; a point datum: its centre).  Lengths in mm.

- **concentricity, coaxiality** (ISO 1101:2017 §18.13; ASME Y14.5-2018 removed concentricity,
  and its 2009 definition -- median points of diametrically opposed elements -- needs points
  in opposed pairs, which the files do not give: the ISO definition is used, and said so):
  a circle, sphere or point gives ``2 |c_f - axis|``, twice its centre's distance from the
  datum axis (or point); an axis (cylinder, cone) gives twice the largest distance from the
  datum axis of the refitted axis' two ends over its points' extent (from the actuals alone
  the axis' extent is unknown: QIF's location is any point on it).
- **circular and total runout** (ISO 1101 §18.15, §18.16), radial, of a circle or cylinder
  about a datum axis, from the compensated surface points: total runout ``range(r_i)`` of the
  points' distances from the datum axis; circular runout the largest such range within one
  cross-section (points grouped into sections by their position along ``u``: a new section
  where consecutive positions differ by more than ``_SECTION_GAP_MM``; a circle is one
  section).  Axial runout of a plane perpendicular to the datum axis: total ``range(p . u)``;
  circular axial runout needs the points grouped by radius and is not evaluated.  Without
  points, runout is not computable (it includes the form); the reason gives ``2 e``, the part
  due to the actual axis' eccentricity, as a lower bound.
- **surface and line profile** with datums, of a feature whose nominal is a plane, a cylinder
  or a sphere (no CAD surface is read): the compensated points carried into part coordinates by
  the frame of the datum actuals, their signed distances ``d_i`` from the nominal surface, and
  the value ``2 max |d_i|`` (the zone centred on the nominal, ISO 1101 §18.6 / ASME Y14.5 §11).
  A line profile only for a feature whose points are one section (a circle, a line).  Without
  datums the zone floats in six degrees of freedom (a locally solvable L-infinity fit): not
  computable, by name.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from pcmm_geo.gdt.qif.frames import AXIS_TYPES, PLANE_TYPES, POINT_TYPES, frame_map
from pcmm_geo.gdt.qif.measures import NotComputable, Recomputation, datum_substitutes

if TYPE_CHECKING:
    from pcmm_geo.io.cmm import Characteristic, CmmDocument, MeasuredFeature
    from pcmm_geo.io.cmm.qif.characteristic_definitions import QifDefinitions

__all__ = ["coaxiality", "profile", "runout", "sections", "surface_points"]

#: consecutive axial positions further apart than this start a new cross-section (mm)
_SECTION_GAP_MM = 0.5
_CENTRES = POINT_TYPES | {"circle", "circular_arc", "elongated_circle"}


def _datum_axis(document: CmmDocument, definitions: QifDefinitions | None,
                characteristic: Characteristic) -> tuple[np.ndarray, np.ndarray | None, str]:
    """The primary datum's actual point and direction (None: a point datum), and its label."""
    _, actual, labels, _ = datum_substitutes(document, definitions, characteristic)
    if not actual:
        raise NotComputable(f"a {characteristic.type.replace('_', ' ')} needs a datum axis; the file names none")
    datum = actual[0]
    if datum.kind == "plane":
        if characteristic.type in ("circular_runout", "total_runout"):
            raise NotComputable(f"a runout needs a datum axis; datum {labels[0]} is a plane")
        raise NotComputable(f"datum {labels[0]} is a plane: it gives no axis or centre for a "
                            f"{characteristic.type}")
    direction = None if datum.direction is None else np.asarray(datum.direction, dtype=float)
    if direction is not None:
        direction = direction / float(np.linalg.norm(direction))
    return np.asarray(datum.location, dtype=float), direction, labels[0]


def _distance(points: np.ndarray, origin: np.ndarray, direction: np.ndarray | None) -> np.ndarray:
    delta = np.atleast_2d(points) - origin
    if direction is None:
        return np.linalg.norm(delta, axis=1)
    return np.linalg.norm(delta - np.outer(delta @ direction, direction), axis=1)


def _refit(document: CmmDocument, feature: MeasuredFeature, options: Mapping[str, Any]) -> Any:
    from pcmm_geo.cmm.refit import refit_feature
    from pcmm_geo.errors import NotRefittedError

    try:
        return refit_feature(document, feature, **options)
    except NotRefittedError as exc:
        raise NotComputable(f"the points could not be refitted: {exc}") from None


def surface_points(refit: Any) -> np.ndarray:
    """The refit's points on the touched surface (mm, ``(N, 3)``): probe-ball centres moved by the probe radius.

    :class:`~pcmm_geo.cmm.refit.Refit` keeps the points as read when the radius was applied to
    the fitted element (``"element offset"``): a plane's or line's are moved against its outward
    normal, a circle's, cylinder's or sphere's along their distance from the refitted axis or
    centre (outward for a hole, inward for a boss).
    """
    compensation = refit.compensation
    points = np.asarray(refit.points, dtype=float)
    radius = float(compensation.probe_radius_mm)
    if compensation.method != "element offset" or radius == 0.0:
        return points
    if compensation.outward is not None:
        return points - radius * np.asarray(compensation.outward, dtype=float)
    if compensation.side not in ("internal", "external") or refit.location is None:
        raise NotComputable("the side the probe touched is not known, so its points are not surface points")
    delta = points - refit.location
    if refit.direction is not None and refit.type != "sphere":
        delta = delta - np.outer(delta @ refit.direction, refit.direction)
    unit = delta / np.linalg.norm(delta, axis=1)[:, None]
    return points + (radius if compensation.side == "internal" else -radius) * unit


def coaxiality(document: CmmDocument, definitions: QifDefinitions | None, characteristic: Characteristic,
               feature: MeasuredFeature, use_points: bool, options: Mapping[str, Any]) -> Recomputation:
    """Concentricity or coaxiality by ISO 1101 (see the module docstring)."""
    origin, direction, label = _datum_axis(document, definitions, characteristic)
    standard = "ISO 1101 §18.13 (ASME Y14.5-2018 has no concentricity; its 2009 median-point definition is not used)"
    if feature.type in _CENTRES:
        location = feature.actual.location
        source, what = "actuals", "the actual centre"
        if use_points and feature.point_set_refs and feature.type in ("circle", "sphere"):
            refit = _refit(document, feature, options)
            if refit.location is not None:
                location, source, what = refit.location, "points", "the centre refitted from its points"
        if location is None:
            raise NotComputable(f"feature {feature.name or feature.id} has no actual centre")
        value = 2.0 * float(_distance(location, origin, direction)[0])
        return Recomputation(value, f"2 x the distance of {what} from datum {label}'s actual "
                             f"{'axis' if direction is not None else 'centre'}, by {standard}", source)
    if feature.type not in AXIS_TYPES:
        raise NotComputable(f"a {characteristic.type} of a {feature.type} feature is not evaluated")
    if not (use_points and feature.point_set_refs):
        raise NotComputable(f"a {characteristic.type} of an axis needs its extent: the file holds no points for "
                            "it (QIF's actual location is any point on the axis)")
    refit = _refit(document, feature, options)
    if refit.location is None or refit.direction is None:
        raise NotComputable("the refit has no axis")
    along = (refit.points - refit.location) @ refit.direction
    ends = np.array([refit.location + t * refit.direction for t in (along.min(), along.max())])
    value = 2.0 * float(_distance(ends, origin, direction).max())
    return Recomputation(value, f"2 x the largest distance of the refitted axis' ends (over its points' extent) "
                         f"from datum {label}'s actual axis, by {standard}", "points")


def sections(along: np.ndarray, gap: float = _SECTION_GAP_MM) -> list[np.ndarray]:
    """Indices of ``along`` (positions, mm) grouped into sections: sorted, split where a step exceeds ``gap``."""
    order = np.argsort(along)
    breaks = np.nonzero(np.diff(along[order]) > gap)[0] + 1
    return [np.sort(part) for part in np.split(order, breaks)]


def runout(document: CmmDocument, definitions: QifDefinitions | None, characteristic: Characteristic,
           feature: MeasuredFeature, use_points: bool, options: Mapping[str, Any]) -> Recomputation:
    """Circular or total runout to the primary datum axis (see the module docstring)."""
    origin, direction, label = _datum_axis(document, definitions, characteristic)
    if direction is None:
        raise NotComputable(f"a runout needs a datum axis; datum {label} is a point")
    total = characteristic.type == "total_runout"
    radial = feature.type in ("circle", "cylinder", "cone", "sphere")
    if not radial and feature.type not in PLANE_TYPES:
        raise NotComputable(f"runout of a {feature.type} feature is not evaluated")
    if not (use_points and feature.point_set_refs):
        eccentric = ""
        if radial and feature.actual.location is not None:
            eccentric = (f"; the actual axis' eccentricity alone gives at least "
                         f"{2.0 * float(_distance(feature.actual.location, origin, direction)[0]):.6g} mm")
        raise NotComputable("a runout includes the surface's form and needs its points: the file holds none for it"
                            + eccentric)
    points = surface_points(_refit(document, feature, options))
    if not radial:
        if not total:
            raise NotComputable("circular axial runout needs the face's points grouped by radius: not evaluated")
        return Recomputation(float(np.ptp((points - origin) @ direction)),
                             f"the range of the face's {len(points)} compensated points along datum {label}'s actual "
                             "axis (total axial runout)", "points")
    radii = _distance(points, origin, direction)
    if total or feature.type == "circle":
        return Recomputation(float(np.ptp(radii)), f"the range of the {len(points)} compensated points' distances "
                             f"from datum {label}'s actual axis", "points")
    groups = sections((points - origin) @ direction)
    if len(groups) < 2 and feature.type != "circle":
        raise NotComputable("circular runout needs the points in cross-sections: they are not grouped along the "
                            f"datum axis (no gap over {_SECTION_GAP_MM} mm)")
    value = max(float(np.ptp(radii[group])) for group in groups if len(group) >= 3)
    return Recomputation(value, f"the largest range of the compensated points' distances from datum {label}'s "
                         f"actual axis within one of {len(groups)} cross-sections", "points")


def profile(document: CmmDocument, definitions: QifDefinitions | None, characteristic: Characteristic,
            feature: MeasuredFeature, use_points: bool, options: Mapping[str, Any]) -> Recomputation:
    """Surface or line profile of a plane, cylinder or sphere nominal to datums (see the module docstring)."""
    nominal_feature = document.nominal_of(feature)
    if nominal_feature is None:
        raise NotComputable(f"feature {feature.name or feature.id} has no nominal")
    nominal = nominal_feature.geometry
    if characteristic.type == "line_profile" and feature.type not in ("circle", "line", "circular_arc"):
        raise NotComputable("a line profile is evaluated section by section; the file gives the feature's points "
                            "as one set, not in sections")
    substitutes, actual, labels, _ = datum_substitutes(document, definitions, characteristic)
    if not actual:
        raise NotComputable("a profile without datums floats in six degrees of freedom (a locally solvable "
                            "L-infinity fit): not evaluated")
    if not (use_points and feature.point_set_refs):
        raise NotComputable("a profile needs the surface's points: the file holds none for it (the actual's "
                            "location and direction do not give the largest deviation)")
    frame = frame_map(substitutes, actual)
    points = np.array([frame.apply(p) for p in surface_points(_refit(document, feature, options))])
    if nominal.location is None:
        raise NotComputable("the nominal has no location")
    direction = nominal.direction if nominal.direction is not None else nominal.normal
    definition = document.definition_of(feature)
    diameter = nominal.diameter if nominal.diameter is not None else (
        None if definition is None else getattr(definition, "diameter", None))
    kind = feature.type
    if kind in PLANE_TYPES and nominal.normal is not None:
        normal = np.asarray(nominal.normal, dtype=float)
        deviations = (points - nominal.location) @ (normal / float(np.linalg.norm(normal)))
    elif kind in ("cylinder", "circle") and direction is not None and diameter is not None:
        axis = np.asarray(direction, dtype=float) / float(np.linalg.norm(direction))
        deviations = _distance(points, nominal.location, axis) - diameter / 2.0
    elif kind == "sphere" and diameter is not None:
        deviations = _distance(points, nominal.location, None) - diameter / 2.0
    else:
        raise NotComputable(f"a profile of a {kind} nominal is not evaluated (planes, and cylinders, circles and "
                            "spheres of stated diameter, are; no CAD surface is read)")
    return Recomputation(2.0 * float(np.abs(deviations).max()),
                         f"2 x the largest distance of the {len(points)} compensated points from the nominal "
                         f"{kind} in the frame {' | '.join(labels)} of the datum features' actuals", "points")
