"""A second opinion on the characteristics of a QIF results file, each recomputed from the CMM's own feature actuals.

A CMM's QIF results file reports characteristic values (a hole's diameter, its position to
A|B|C, a point's profile deviation, a distance) next to the substitute features (actuals) they
were computed from.  :func:`verify_characteristics` recomputes every characteristic whose
inputs the file holds and says, per characteristic measurement, whether it ``agrees``,
``disagrees`` or is ``not computable`` (and why).

Definitions (mm and rad; ISO 1101 / ASME Y14.5 where a zone is involved):

- diameter, spherical diameter: the actual's diameter; radius, spherical radius: half of it;
  width: the actual's width;
- position (ISO 1101 §18.12, ASME Y14.5 §10): the actual location is put into the part's
  coordinates by the datum reference frame built from the datum features' actuals
  (:mod:`pcmm_geo.gdt.qif.frames`); a diametrical zone of an axis (cylinder, circle, cone) gives
  ``2 |d_perp|``, the deviation perpendicular to the nominal axis; a spherical zone or a point,
  sphere ``2 |d|``; a planar zone of a plane-like feature ``2 |d . n|``.  With points, ``d`` is
  taken at the refitted centre, or at both ends of the refitted axis over its points' extent
  (the largest counts: the whole axis must lie in the zone).  MMC / LMC changes the
  tolerance (bonus), not the value, and is reported in the reason where the size is known;
- point profile (QIF ``PointProfileCharacteristic``): the signed deviation ``d . n`` of the
  actual point from the nominal along the nominal's normal (the sign the files use: + outside);
- linear coordinate: the component (``XAXIS``, ``YAXIS``, ``ZAXIS``) of the actual location in
  the part's coordinates (the frame's map; none named: the file's coordinates);
- distance between: two points (centres) 3-D; a point and a plane (or two planes) along the
  (first) plane's normal; two axes: the distance of one axis' point from the other axis;
- angle between: the angle between the two features' directions (the one of ``theta`` and
  ``pi - theta`` nearer the nominal);
- form (flatness, circularity, cylindricity, straightness, sphericity): the actual's ``Form``
  where the file reports one; else, with points, the range of the compensated points about the
  refit (:func:`pcmm_geo.cmm.refit.refit_feature`) by minimum zone and by the file's criterion;
- perpendicularity, parallelism, angularity to one datum or to datums that fix every rotation
  (:mod:`pcmm_geo.gdt.qif.orientation`); concentricity and coaxiality (ISO 1101's
  definition), circular and total runout, surface and line profile of plane, cylinder, circle
  and sphere nominals to datums (:mod:`pcmm_geo.gdt.qif.axial`);
- a position to datums at MMB / LMB: with the datums fixed at their actual features, the datum
  shift bounding how far it may come down (:mod:`pcmm_geo.gdt.qif.shift`).

Agreement rule: ``|reported - recomputed| <= max(floor, fraction * tolerance width)`` with the
tolerance width the zone (``ToleranceValue``) or the limits' span, ``fraction`` 1 % by default
and ``floor`` 1 µm (1 µrad for angles).  1 % of the tolerance changes no conformance decision
except within 1 % of a limit, and 1 µm covers a value printed to 3 decimals; a file whose values
were computed from more digits of the actuals than it prints needs a larger bound, which
``tolerance_mm`` sets (the public samples do not: their values agree to 1e-11 mm with the
printed actuals, e.g. the sheet-metal point profiles).  A file's value that matches another
convention (the deviation in the file's coordinates without the datums) still disagrees; the
reason names the convention it matches.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from pcmm_geo.errors import InvalidInputError, PcmmGeoError
from pcmm_geo.gdt.qif.axial import coaxiality, profile, runout
from pcmm_geo.gdt.qif.measures import Recomputation, recompute
from pcmm_geo.gdt.qif.orientation import orientation

if TYPE_CHECKING:
    from pcmm_geo.io.cmm import Characteristic, CmmDocument
    from pcmm_geo.io.cmm.qif.characteristic_definitions import QifDefinitions

__all__ = ["AGREES", "DISAGREES", "NOT_COMPUTABLE", "CharacteristicCheck", "CharacteristicVerification",
           "verify_characteristics"]

AGREES, DISAGREES, NOT_COMPUTABLE = "agrees", "disagrees", "not computable"
#: default fraction of the tolerance width within which a recomputed value agrees
DEFAULT_FRACTION = 0.01
#: default smallest bound (mm; rad for angles)
DEFAULT_FLOOR_MM = 1e-3
DEFAULT_FLOOR_RAD = 1e-6
#: the characteristic types recomputed beyond sizes, positions, point profiles, coordinates, distances, angles, form
HANDLERS = {"perpendicularity": orientation, "parallelism": orientation, "angularity": orientation,
            "concentricity": coaxiality, "coaxiality": coaxiality, "circular_runout": runout,
            "total_runout": runout, "surface_profile": profile, "line_profile": profile}


@dataclass(frozen=True)
class CharacteristicCheck:
    """The second opinion on one characteristic measurement.

    Attributes
    ----------
    id : int
        QIF id of the ``<Type>CharacteristicMeasurement``.
    name : str or None
    type : str
        snake_case characteristic type.
    unit : str
        ``"mm"`` or ``"rad"`` (or ``"-"``).
    reported, recomputed : float or None
    status : str
        ``"agrees"``, ``"disagrees"`` or ``"not computable"``.
    reason : str
        How it was recomputed, or why it could not be, in plain words.
    bound : float or None
        The agreement bound applied (mm or rad).
    source : str or None
        ``"actuals"`` or ``"points"``.
    """

    id: int
    name: str | None
    type: str
    unit: str
    reported: float | None
    recomputed: float | None
    status: str
    reason: str
    bound: float | None = None
    source: str | None = None

    @property
    def difference(self) -> float | None:
        if self.reported is None or self.recomputed is None:
            return None
        return self.reported - self.recomputed

    def to_dict(self) -> dict[str, Any]:
        return {"id": self.id, "name": self.name, "type": self.type, "unit": self.unit, "reported": self.reported,
                "recomputed": self.recomputed, "status": self.status, "reason": self.reason,
                "difference": self.difference, "bound": self.bound, "source": self.source}


@dataclass(frozen=True)
class CharacteristicVerification:
    """Every characteristic measurement of a file with its second opinion."""

    source: str
    checks: tuple[CharacteristicCheck, ...]
    rule: str

    def summary(self) -> dict[str, int]:
        """Counts: ``{"agrees", "disagrees", "not_computable"}``."""
        return {"agrees": sum(c.status == AGREES for c in self.checks),
                "disagrees": sum(c.status == DISAGREES for c in self.checks),
                "not_computable": sum(c.status == NOT_COMPUTABLE for c in self.checks)}

    @property
    def agrees(self) -> bool | None:
        """False when one disagrees; None when none could be computed; else True."""
        counts = self.summary()
        if counts["disagrees"]:
            return False
        return True if counts["agrees"] else None

    def to_dict(self) -> dict[str, Any]:
        return {"file": self.source, "rule": self.rule, "summary": self.summary(),
                "characteristics": [check.to_dict() for check in self.checks]}


def _width(characteristic: Characteristic) -> float | None:
    tolerance = characteristic.tolerance
    if tolerance is None:
        return None
    if tolerance.value is not None:
        return abs(tolerance.value)
    if tolerance.max_value is not None and tolerance.min_value is not None:
        return abs(tolerance.max_value - tolerance.min_value)
    return None


def _bound(characteristic: Characteristic, fraction: float, tolerance_mm: float | None) -> float:
    angular = characteristic.quantity == "angular"
    if tolerance_mm is not None and not angular:
        return tolerance_mm
    floor = DEFAULT_FLOOR_RAD if angular else DEFAULT_FLOOR_MM
    width = _width(characteristic)
    return floor if width is None else max(floor, fraction * width)


def _unit(characteristic: Characteristic) -> str:
    return {"linear": "mm", "angular": "rad"}.get(characteristic.quantity, "-")


def _duplicates(document: CmmDocument) -> dict[int, int]:
    """Measurements that repeat an earlier one's item and features (files write a second value): id -> first id."""
    first: dict[tuple[Any, ...], int] = {}
    repeats: dict[int, int] = {}
    for characteristic in document.characteristics:
        if characteristic.item_id is None or not characteristic.feature_measurement_ids:
            continue
        key = (characteristic.results_id, characteristic.item_id, characteristic.feature_measurement_ids)
        if key in first:
            repeats[characteristic.id] = first[key]
        else:
            first[key] = characteristic.id
    return repeats


def verify_characteristics(
    document: CmmDocument,
    definitions: QifDefinitions | None = None,
    *,
    fraction: float = DEFAULT_FRACTION,
    tolerance_mm: float | None = None,
    use_points: bool = True,
    compensated: bool | None = None,
    probe_radius: float | None = None,
) -> CharacteristicVerification:
    """Recompute every characteristic measurement of a QIF document from its feature actuals (and points).

    Parameters
    ----------
    document : CmmDocument
        From :func:`~pcmm_geo.io.cmm.read_qif` (other formats: every characteristic is listed,
        those needing datums are not computable).
    definitions : QifDefinitions, optional
        From :func:`~pcmm_geo.io.cmm.qif.characteristic_definitions.read_qif_definitions`; read
        from ``document.source`` when None and the document is QIF.
    fraction : float
        Fraction of the tolerance width within which a value agrees (default 0.01).
    tolerance_mm : float, optional
        A fixed agreement bound for lengths (mm) instead of the rule.
    use_points : bool
        Recompute from the feature's points where they exist: form characteristics the actuals do
        not carry, and point profiles (the compensated point rather than the reported actual).
    compensated : bool, optional
        For point sets without a ``Compensated`` flag: are the points surface points?
    probe_radius : float, optional
        Overrides the file's probe radius (mm) in the refits.

    Returns
    -------
    CharacteristicVerification

    Raises
    ------
    InvalidInputError
        ``fraction`` not in (0, 1], ``tolerance_mm`` not positive.
    QifError, UnsafeXmlError, FileFormatError
        Reading the definitions (as :func:`~pcmm_geo.io.cmm.read_qif`).
    """
    if not (0.0 < fraction <= 1.0):
        raise InvalidInputError("fraction", "a fraction of the tolerance in (0, 1]", repr(fraction))
    if tolerance_mm is not None and not tolerance_mm > 0.0:
        raise InvalidInputError("tolerance_mm", "a positive agreement bound in mm", repr(tolerance_mm))
    if definitions is None and document.format == "qif":
        from pcmm_geo.io.cmm.qif.characteristic_definitions import read_qif_definitions

        definitions = read_qif_definitions(document.source)
    features = {feature.id: feature for feature in document.measured_features}
    repeats = _duplicates(document)
    checks = []
    for characteristic in document.characteristics:
        bound = _bound(characteristic, fraction, tolerance_mm)
        try:
            result = recompute(document, definitions, characteristic, features, use_points=use_points,
                               options={"compensated": compensated, "probe_radius": probe_radius},
                               handlers=HANDLERS)
        except PcmmGeoError as exc:  # a frame or refit that fails: that characteristic only
            result = Recomputation(None, "could not be recomputed: " + " ".join(str(exc).split()))
        checks.append(_judge(characteristic, result, bound, repeats))
    rule = ("a characteristic agrees when |reported - recomputed| <= "
            + (f"{tolerance_mm:g} mm" if tolerance_mm is not None else
               f"max({DEFAULT_FLOOR_MM * 1000:g} µm, {fraction:g} x its tolerance width) "
               f"(angles: max({DEFAULT_FLOOR_RAD * 1e6:g} µrad, {fraction:g} x the tolerance))"))
    return CharacteristicVerification(source=document.source, checks=tuple(checks), rule=rule)


def _judge(characteristic: Characteristic, result: Recomputation, bound: float,
           repeats: Mapping[int, int]) -> CharacteristicCheck:
    reported = characteristic.value
    base = {"id": characteristic.id, "name": characteristic.name, "type": characteristic.type,
            "unit": _unit(characteristic), "reported": reported, "bound": bound, "source": result.source}
    if reported is None:
        return CharacteristicCheck(**base, recomputed=result.value, status=NOT_COMPUTABLE,
                                   reason="the file reports no value")
    if result.value is None:
        return CharacteristicCheck(**base, recomputed=None, status=NOT_COMPUTABLE, reason=result.reason)
    if characteristic.id in repeats:
        return CharacteristicCheck(**base, recomputed=None, status=NOT_COMPUTABLE,
                                   reason=f"a second measurement of the same item and feature as "
                                          f"{repeats[characteristic.id]}: QIF does not say what it measures")
    difference = abs(reported - result.value)
    if difference <= bound:
        return CharacteristicCheck(**base, recomputed=result.value, status=AGREES, reason=result.reason)
    if result.accepted_range is not None and \
            result.accepted_range[0] - bound <= reported <= result.accepted_range[1] + bound:
        low, high = result.accepted_range
        return CharacteristicCheck(**base, recomputed=result.value, status=AGREES,
                                   reason=f"{result.reason}; the reported value lies in [{low:.6g}, {high:.6g}], "
                                          "the values the datum shift allows")
    if result.below is not None and reported < result.value:
        return CharacteristicCheck(**base, recomputed=result.value, status=NOT_COMPUTABLE,
                                   reason=f"{result.reason}; the reported value is below it, which {result.below}")
    alternatives = [(name, accepted) for name, value, accepted in result.alternatives
                    if abs(reported - value) <= bound]
    if alternatives:
        name, accepted = alternatives[0]
        return CharacteristicCheck(**base, recomputed=result.value, status=AGREES if accepted else DISAGREES,
                                   reason=f"{result.reason}; the reported value is {name}")
    return CharacteristicCheck(**base, recomputed=result.value, status=DISAGREES,
                               reason=f"{result.reason}; differs by {difference:.6g} (bound {bound:.3g})")

