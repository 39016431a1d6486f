"""A second opinion on a CMM's results: refit every measured feature from its points and compare.

For each feature measurement of a results file (:class:`~pcmm_geo.io.cmm.CmmDocument`) that has
points, :func:`~pcmm_geo.cmm.refit.refit_feature` refits the surface element (file's criterion,
else Gaussian; probe compensation; common frame), and the refit is compared with what the CMM
reported, quantity by quantity, as a metrologist reads them:

=========  ===================================================================================
type       compared
=========  ===================================================================================
circle     diameter; centre (within the circle's plane when the CMM reported the circle in its
           nominal plane -- its working plane, as QIF_PTS_SAMPLE does -- else in 3-D); normal
           (unless it is the nominal one)
cylinder   diameter; distance of the reported axis point from the refitted axis; axis direction
cone       diameter at the reported locating point; distance of that point from the axis; axis
           direction; half-angle
sphere     diameter; centre
plane      distance of the reported location from the refitted plane; normal
line       distance of the reported location from the refitted line; direction
point      location
=========  ===================================================================================

Lengths agree within ``tolerance_mm``; angles (directions, half-angles) within
``tolerance_mm / size``, where ``size`` is the length over which a tilt shows: a circle's
diameter, the extent of a plane's points, the axial extent of a line's, cylinder's or cone's
points.  Directions are compared as lines (the sign of a normal or axis is a convention).

Examples
--------
>>> check = FeatureCheck(id=7, type="sphere", name="S1", n_points=0, agrees=None, reason="no points")
>>> check.to_dict()["agrees"] is None
True
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.cmm.compensation import Compensation
from pcmm_geo.cmm.refit import Refit, refit_feature
from pcmm_geo.elements import SIZED_FEATURES, SPECS, Criterion
from pcmm_geo.errors import InvalidInputError, NotRefittedError
from pcmm_geo.io.cmm import SpellSetting, python_setting

if TYPE_CHECKING:
    from pcmm_geo.io.cmm import CmmDocument, FeatureGeometry, MeasuredFeature

__all__ = ["DEFAULT_TOLERANCE_MM", "FeatureCheck", "Verification", "verify_document", "verify_qif"]

FloatArray = NDArray[np.float64]

#: default agreement tolerance (mm): 0.1 um, the order of the size and location errors ISO 10360-6
#: accepts from CMM software on its reference data sets; files written with fewer digits need more
DEFAULT_TOLERANCE_MM = 1e-4
#: a circle whose reported normal and height equal the nominal ones to this (rad, mm) lies in its
#: nominal (projection) plane
_SAME_PLANE = 1e-9


@dataclass(frozen=True, eq=False)
class FeatureCheck:
    """One feature's refit beside the CMM's report (see the module table for what is compared).

    Attributes
    ----------
    id : int
        QIF id of the feature measurement.
    type, name : str
    n_points : int
    agrees : bool or None
        True / False when compared; None when not refitted (``reason`` says why).
    reason : str
    method, method_source, circle_plane : str or None
        Fit criterion and where it came from; the plane of a 3-D circle.
    compensation : Compensation or None
    reported, refit, difference : dict
        JSON-ready quantities (mm, rad); a quantity the feature lacks is absent.
    compared : tuple of str
        The ``difference`` keys that decided ``agrees``.
    tolerance_mm, angle_tolerance_rad, size_mm : float or None
    refit_result : Refit or None
        The refit itself (None when not refitted), e.g. to write it as QIF
        (:func:`~pcmm_geo.cmm.export.verification_document`).
    """

    id: int
    type: str
    name: str | None
    n_points: int
    agrees: bool | None
    reason: str
    method: str | None = None
    method_source: str | None = None
    circle_plane: str | None = None
    compensation: Compensation | None = None
    reported: dict[str, Any] = field(default_factory=dict)
    refit: dict[str, Any] = field(default_factory=dict)
    difference: dict[str, Any] = field(default_factory=dict)
    compared: tuple[str, ...] = ()
    tolerance_mm: float | None = None
    angle_tolerance_rad: float | None = None
    size_mm: float | None = None
    refit_result: Refit | None = field(default=None, repr=False)

    def to_dict(self) -> dict[str, Any]:
        """The JSON object of the ``pcmm qif verify`` contract (DESIGN.md), plus what was compared."""
        out: dict[str, Any] = {"id": self.id, "type": self.type, "name": self.name, "n_points": self.n_points,
                               "method": self.method}
        if self.method_source is not None:
            out["method_source"] = self.method_source
        if self.circle_plane is not None:
            out["circle_plane"] = self.circle_plane
        out["compensation"] = None if self.compensation is None else self.compensation.to_dict()
        out.update(reported=self.reported, refit=self.refit, difference=self.difference, agrees=self.agrees,
                   reason=self.reason)
        if self.agrees is not None:
            out["compared"] = list(self.compared)
            out["tolerance_mm"] = self.tolerance_mm
            if self.angle_tolerance_rad is not None:
                out["angle_tolerance_rad"] = self.angle_tolerance_rad
                out["size_mm"] = self.size_mm
        return out


@dataclass(frozen=True, eq=False)
class Verification:
    """Result of :func:`verify_document`: one :class:`FeatureCheck` per feature measurement."""

    source: str
    features: tuple[FeatureCheck, ...]
    tolerance_mm: float
    problems: tuple[str, ...] = ()

    @property
    def disagreeing(self) -> tuple[FeatureCheck, ...]:
        """Features whose refit disagrees with the report."""
        return tuple(f for f in self.features if f.agrees is False)

    @property
    def verified(self) -> int:
        """How many features were compared (agree or disagree); the others were not checked."""
        return sum(f.agrees is not None for f in self.features)

    @property
    def agrees(self) -> bool | None:
        """True when at least one feature was compared and none disagrees; False when one disagrees;
        None when nothing could be compared (an unverified file is not a file that agrees)."""
        if self.disagreeing:
            return False
        return True if self.verified else None

    def summary(self) -> dict[str, int]:
        """Counts of agreeing, disagreeing and unchecked features."""
        return {"agree": sum(f.agrees is True for f in self.features), "disagree": len(self.disagreeing),
                "not_checked": sum(f.agrees is None for f in self.features)}

    def to_dict(self) -> dict[str, Any]:
        """``{"file", "features": [...]}`` of the JSON contract, with the tolerance, the number of
        features compared (``verified``), the overall ``agrees`` (null: nothing verified), counts and
        file problems."""
        return {"file": self.source, "tolerance_mm": self.tolerance_mm, "verified": self.verified,
                "agrees": self.agrees, "features": [f.to_dict() for f in self.features], "summary": self.summary(),
                "problems": list(self.problems)}


def verify_qif(path: str | Path, **options: Any) -> Verification:
    """Read a QIF results file and :func:`verify_document` it (keyword options as there)."""
    from pcmm_geo.io.cmm import read_qif

    return verify_document(read_qif(path), **options)


def verify_document(
    document: CmmDocument,
    *,
    tolerance_mm: float = DEFAULT_TOLERANCE_MM,
    criterion: Criterion | None = None,
    circle_plane: str = "least-squares",
    compensated: bool | None = None,
    probe_radius: float | None = None,
    material_side: str | None = None,
    spell_setting: SpellSetting = python_setting,
) -> Verification:
    """Refit every measured feature that has points and compare it with the CMM's actuals.

    Parameters
    ----------
    document : CmmDocument
        A results file read by :mod:`pcmm_geo.io.cmm`.
    tolerance_mm : float
        Largest length difference that agrees (mm); angles by ``tolerance_mm / size``.
    criterion : {"gaussian", "chebyshev", "mcc", "mic"}, optional
        Refit with this criterion instead of the file's.
    circle_plane : {"least-squares", "reported"}
        Plane of a 3-D circle (see :func:`~pcmm_geo.cmm.refit.refit_feature`).
    compensated : bool, optional
        Whether the points are surface points, for formats that do not say.
    probe_radius : float, optional
        Probe radius (mm) overriding the file's; a positive finite length.
    material_side : {"internal", "external"}, optional
        Material side of the features of size whose file states none (others keep the file's; see
        :func:`~pcmm_geo.cmm.refit.refit_feature`); without it, a circle, cylinder or sphere of
        unknown side has its centre and axis compared and its diameter not.
    spell_setting : callable
        How errors and reasons name these parameters (:mod:`pcmm_geo.io.cmm.settings`; the
        command line passes its option names).

    Returns
    -------
    Verification

    Raises
    ------
    InvalidInputError
        A tolerance that is not a positive finite number, an unknown criterion or plane.
    """
    tolerance = float(tolerance_mm)
    if not (np.isfinite(tolerance) and tolerance > 0):
        raise InvalidInputError(spell_setting("tolerance_mm"), "a positive finite length (mm)", repr(tolerance_mm))
    if probe_radius is not None and not (np.isfinite(probe_radius) and probe_radius > 0):
        raise InvalidInputError(spell_setting("probe_radius"), "a positive finite probe radius (mm)",
                                repr(probe_radius))
    if material_side not in (None, "internal", "external"):
        raise InvalidInputError(spell_setting("material_side"), "'internal' or 'external'", repr(material_side))
    if criterion is not None and criterion not in ("gaussian", "chebyshev", "mcc", "mic"):
        raise InvalidInputError(spell_setting("criterion"), "'gaussian', 'chebyshev', 'mcc' or 'mic'", repr(criterion))
    checks = []
    for feature in document.measured_features:
        try:
            refit = refit_feature(document, feature, criterion=criterion, circle_plane=circle_plane,
                                  compensated=compensated, probe_radius=probe_radius,
                                  material_side=material_side if feature.material_side is None else None,
                                  spell_setting=spell_setting)
        except NotRefittedError as exc:
            points = _count_points(document, feature)
            checks.append(FeatureCheck(feature.id, feature.type, feature.name, points, None, str(exc),
                                       reported=_reported(feature.type, feature.actual)))
            continue
        checks.append(_compare(document, feature, refit, tolerance))
    return Verification(document.source, tuple(checks), tolerance, tuple(document.problems))


def _count_points(document: CmmDocument, feature: MeasuredFeature) -> int:
    from pcmm_geo.errors import PcmmGeoError

    try:
        points = document.points_of(feature, frame="stored")
    except PcmmGeoError:  # a reference the reader could not resolve: no usable points
        return 0
    return 0 if points is None else len(points)


def _vector(value: Any) -> FloatArray | None:
    return None if value is None else np.asarray(value, dtype=float)


def _reported(kind: str, actual: FeatureGeometry) -> dict[str, Any]:
    out: dict[str, Any] = {}
    if kind in SIZED_FEATURES and actual.diameter is not None:
        out["diameter_mm"] = float(actual.diameter)
    if actual.location is not None:
        out["location_mm"] = np.asarray(actual.location, dtype=float).tolist()
    row = SPECS.get(kind)  # a circle and a plane by their normal, axes and lines by their direction
    orientation = "direction" if row is None else row.orientation
    direction = None if orientation is None else getattr(actual, orientation)
    if direction is not None:
        out["direction"] = np.asarray(direction, dtype=float).tolist()
    if kind == "cone" and actual.half_angle is not None:
        out["half_angle_rad"] = float(actual.half_angle)
    return out


def _line_angle(first: FloatArray, second: FloatArray) -> float:
    """Angle between two lines (directions of either sign), rad, in [0, pi/2]."""
    from pcmm_geo.fit.skew import angle_between

    angle = float(angle_between(first, second))
    return min(angle, np.pi - angle)


def _oriented(direction: FloatArray, like: FloatArray | None) -> FloatArray:
    return -direction if like is not None and float(direction @ like) < 0 else direction


def _size(refit: Refit) -> float | None:
    """Length over which a tilt of the refitted element shows (mm); None for elements without a direction."""
    points = refit.points
    if refit.type == "circle":
        return refit.diameter
    if refit.type == "plane":
        centred = points - points.mean(axis=0)
        in_plane = centred - np.outer(centred @ refit.direction, refit.direction)
        return float(2.0 * np.max(np.linalg.norm(in_plane, axis=1)))
    if SPECS[refit.type].orientation == "direction":  # line, cylinder, cone
        extent = float(np.ptp(points @ refit.direction))
        return extent if extent > 0 else refit.diameter
    return None


def _compare(document: CmmDocument, feature: MeasuredFeature, refit: Refit, tolerance: float) -> FeatureCheck:
    actual = feature.actual
    kind = refit.type
    reported = _reported(kind, actual)
    nominal = document.nominal_of(feature)
    size = _size(refit)
    angle_tolerance = None if size is None or size <= 0 else tolerance / size
    refit_values: dict[str, Any] = {}
    difference: dict[str, Any] = {}
    compared: list[str] = []
    notes: list[str] = []
    reported_location = _vector(actual.location)
    reported_direction = _vector(reported.get("direction"))
    location = refit.location
    direction = None if refit.direction is None else _oriented(refit.direction, reported_direction)
    diameter = refit.diameter
    if SPECS[kind].orientation == "direction" and reported_location is not None:
        # the refitted axis point nearest the reported one (an axis point is any point on the axis)
        location = refit.location + float((reported_location - refit.location) @ refit.direction) * refit.direction
        if kind == "cone":
            along = float((location - refit.location) @ refit.direction)
            diameter = refit.diameter + 2.0 * along * np.tan(refit.half_angle)
    elif kind == "cone":
        diameter = None  # a cone's diameter is only defined at a stated locating point
    elif kind == "plane" and reported_location is not None:
        location = reported_location - float((reported_location - refit.location) @ refit.direction) * refit.direction
    if diameter is not None:
        refit_values["diameter_mm"] = float(diameter)
    if location is not None:
        refit_values["location_mm"] = np.asarray(location, dtype=float).tolist()
    if direction is not None:
        refit_values["direction"] = direction.tolist()
    if refit.half_angle is not None:
        refit_values["half_angle_rad"] = float(refit.half_angle)

    if diameter is not None and "diameter_mm" in reported:
        difference["diameter_mm"] = float(diameter - reported["diameter_mm"])
        compared.append("diameter_mm")
    if location is not None and reported_location is not None:
        delta = np.asarray(location, dtype=float) - reported_location
        difference["location_mm"] = delta.tolist()
        distance = float(np.linalg.norm(delta))
        if kind == "circle":
            normal = reported_direction if reported_direction is not None else refit.direction
            axial = float(delta @ normal)
            difference["location_axial_mm"] = axial
            in_plane = float(np.linalg.norm(delta - axial * normal))
            if refit.circle_plane == "reported" or _in_nominal_plane(actual, nominal):
                distance = in_plane
                notes.append("circle reported in its plane, not measured: centre compared within the plane"
                             if refit.circle_plane == "reported" else
                             "the CMM reported the circle in its nominal plane (normal and height are the nominal "
                             "ones): centre compared within that plane, normal not compared")
        difference["location_distance_mm"] = distance
        compared.append("location_distance_mm")
    if direction is not None and reported_direction is not None:
        difference["direction_angle_rad"] = _line_angle(direction, reported_direction)
        skip = kind == "circle" and (refit.circle_plane == "reported" or _in_nominal_plane(actual, nominal))
        if angle_tolerance is not None and not skip:
            compared.append("direction_angle_rad")
    if refit.half_angle is not None and "half_angle_rad" in reported:
        difference["half_angle_rad"] = float(refit.half_angle - reported["half_angle_rad"])
        if angle_tolerance is not None:
            compared.append("half_angle_rad")

    failed = [name for name in compared
              if abs(difference[name]) > (angle_tolerance if name.endswith("_rad") else tolerance)]
    if not compared:
        agrees = None
        reason = "the CMM reported no quantity the refit can be compared with"
    elif failed:
        agrees = False
        reason = "; ".join(_describe(name, difference[name]) for name in failed) + \
            f" (tolerance {tolerance:g} mm" + (f", {angle_tolerance:.3g} rad" if angle_tolerance else "") + ")"
        diagnosis = _diagnose(refit, difference, tolerance)
        if diagnosis:
            reason += ": " + diagnosis
    else:
        agrees = True
        reason = f"{', '.join(_words(name) for name in compared)} within {tolerance:g} mm" + \
            (f" ({angle_tolerance:.3g} rad)" if angle_tolerance is not None and
             any(n.endswith("_rad") for n in compared) else "")
    if notes:
        reason += "; " + "; ".join(notes)
    if feature.problems:
        reason += "; file: " + "; ".join(feature.problems)
    return FeatureCheck(feature.id, kind, feature.name, refit.n_points, agrees, reason, refit.method,
                        refit.method_source, refit.circle_plane, refit.compensation, reported, refit_values,
                        difference, tuple(compared), tolerance, angle_tolerance, size, refit_result=refit)


def _in_nominal_plane(actual: FeatureGeometry, nominal: Any) -> bool:
    """The reported circle's normal and height are the nominal ones (the CMM's projection plane)."""
    geometry = None if nominal is None else nominal.geometry
    if geometry is None or geometry.normal is None or actual.normal is None or actual.location is None \
            or geometry.location is None:
        return False
    normal = np.asarray(actual.normal, dtype=float)
    same_normal = _line_angle(normal, np.asarray(geometry.normal, dtype=float)) <= _SAME_PLANE
    height = abs(float((np.asarray(actual.location) - np.asarray(geometry.location)) @ normal))
    return same_normal and height <= _SAME_PLANE


_WORDS = {"diameter_mm": "diameter", "location_distance_mm": "location", "direction_angle_rad": "direction",
          "half_angle_rad": "half-angle"}


def _words(name: str) -> str:
    return _WORDS.get(name, name)


def _describe(name: str, value: float) -> str:
    unit = "rad" if name.endswith("_rad") else "mm"
    return f"{_words(name)} differs by {value:.6g} {unit}"


def _diagnose(refit: Refit, difference: dict[str, Any], tolerance: float) -> str:
    """A plain reading of a disagreement that matches a compensation mistake."""
    radius = refit.compensation.probe_radius_mm
    if radius <= 0:
        return ""
    k = 1.0 / np.cos(refit.half_angle) if refit.half_angle is not None else 1.0
    diameter = difference.get("diameter_mm")
    if diameter is not None:
        if abs(abs(diameter) - 2 * radius * k) <= tolerance:
            return "the reported diameter is the probe centres' (not compensated by the CMM)"
        if abs(abs(diameter) - 4 * radius * k) <= tolerance:
            return "the reported diameter is compensated toward the other material side"
    distance = difference.get("location_distance_mm")
    if distance is not None and SPECS[refit.type].size is None and abs(distance - radius) <= tolerance:
        return "the reported location is the probe centre's (not compensated by the CMM)"
    return ""
