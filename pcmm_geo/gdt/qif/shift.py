"""Datum feature shift: how far a position may come down when its datums are at MMB / LMB (ASME Y14.5 §7.11, ISO 2692).

A datum feature of size referenced at its maximum (or least) material boundary may move inside
its boundary: the datum reference frame may shift relative to the part by up to half the
difference between the datum feature's actual size and its boundary size.  A CMM may report
a position with the datums fixed at their actual features (the shift is then extra
tolerance, as ``Bonus`` is), or with the frame moved to use the shift; QIF says which only
through a ``DRFTransformActualId`` (none of the public samples writes one).

The second opinion therefore evaluates the position with each datum fixed at its actual
feature (value ``v``) and bounds how far the shift can bring it down:

- a secondary (or tertiary) datum axis or centre that fixes a translation: the frame may
  translate by ``s/2`` perpendicular to it, which changes ``2 |d|`` by at most ``s``;
- a tertiary datum that only clocks the frame about the primary axis: a rotation of at most
  ``(s/2) / r`` with ``r`` the datum's distance from the primary axis through the origin, which
  moves a feature at distance ``R`` by at most ``R (s/2) / r``, changing ``2 |d|`` by ``s R / r``;
- a primary datum at MMB (its tilt and translation together) is not bounded here: a reported
  value equal to ``v`` agrees (the file did not use the shift), one above it disagrees (a shift
  only lowers the value), one below it is not computable, by name.

``s = |actual size - boundary size|`` with the boundary size the datum feature's MMC (MMB) or
LMC (LMB) size limit from the size characteristic the file reports for that feature; a datum
feature's orientation or position tolerance that would enlarge its boundary (its virtual
condition) is not added, so the bound is the smaller one.  A reported value between
``max(0, v - sum of the bounds)`` and ``v`` agrees (the reason gives both ends).  Lengths in mm.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from pcmm_geo.gdt.qif.frames import AXIS_TYPES, POINT_TYPES

if TYPE_CHECKING:
    from pcmm_geo.io.cmm import CmmDocument, MeasuredFeature
    from pcmm_geo.io.cmm.qif.datums import DrfDatum

__all__ = ["DatumShift", "boundary_shift", "position_reduction"]


@dataclass(frozen=True)
class DatumShift:
    """One datum at MMB / LMB: its label, precedence index (0 primary), the shift ``s`` (mm, diametral) and how."""

    label: str
    precedence: int
    shift: float
    words: str
    feature: MeasuredFeature
    boundary: str = "MMB"


class ShiftNotBounded(Exception):
    """A datum's shift that cannot be bounded (the message says why)."""


def boundary_shift(document: CmmDocument, feature: MeasuredFeature, modifier: str, label: str,
                   precedence: int) -> DatumShift:
    """The shift ``s`` a datum feature at ``modifier`` (``"MAXIMUM"`` / ``"LEAST"``) allows (see the module docstring).

    Raises ``ShiftNotBounded`` when the datum feature has no size, no stated size limits or no side.
    """
    boundary = "MMB" if modifier == "MAXIMUM" else "LMB"
    if feature.type not in AXIS_TYPES and feature.type not in POINT_TYPES:
        raise ShiftNotBounded(f"datum {label} at {boundary} is a {feature.type}, not a feature of size")
    sizes = [c for c in document.characteristics if c.type in ("diameter", "spherical_diameter", "width")
             and c.tolerance is not None and c.feature_measurement_ids == (feature.id,)]
    definition = document.definition_of(feature)
    side = feature.material_side or (None if definition is None else {
        "INTERNAL": "internal", "EXTERNAL": "external"}.get(definition.internal_external or ""))
    actual = feature.actual.diameter if feature.actual.diameter is not None else feature.actual.width
    if not sizes or side is None or actual is None:
        raise ShiftNotBounded(f"datum {label} at {boundary}: the file states no size tolerance, side or actual size "
                              "for its feature, so its shift is not known")
    lower, upper = sizes[0].tolerance.limits(sizes[0].nominal)  # type: ignore[union-attr]
    if lower is None or upper is None:
        raise ShiftNotBounded(f"datum {label} at {boundary}: its size limits are not stated")
    size = lower if (side == "internal") == (modifier == "MAXIMUM") else upper
    shift = max(0.0, actual - size if side == "internal" else size - actual)
    if modifier == "LEAST":
        shift = max(0.0, size - actual if side == "internal" else actual - size)
    words = (f"datum {label} at {boundary}: actual size {actual:.6g} mm, {boundary} size {size:.6g} mm, "
             f"shift {shift:.6g} mm")
    return DatumShift(label, precedence, shift, words, feature, boundary)


def position_reduction(shifts: list[DatumShift], fixes_translation: list[bool], origin: np.ndarray,
                       axis: np.ndarray | None, location: np.ndarray) -> tuple[float, str]:
    """Largest decrease of a diametral position value ``2 |d|`` the datum shifts allow (mm), and how it was bounded.

    Parameters
    ----------
    shifts : list of DatumShift
    fixes_translation : list of bool
        Per shift: does that datum fix a translation (else it only clocks the frame)?
    origin : (3,) ndarray
        The frame's origin (measured coordinates, mm).
    axis : (3,) ndarray or None
        The primary direction (unit); None: no clocking to bound.
    location : (3,) ndarray
        The toleranced feature's actual location (mm).
    """
    total, parts = 0.0, []
    for shift, translates in zip(shifts, fixes_translation, strict=True):
        if shift.precedence == 0 and shift.shift > 0.0:
            raise ShiftNotBounded(f"the primary datum {shift.label} at {shift.boundary} may tilt as well as translate "
                                  "by its shift, which is not bounded here")
        if translates or axis is None:
            total += shift.shift
            parts.append(f"{shift.shift:.6g} mm (a translation by half of it)")
            continue
        def radial(point: np.ndarray) -> float:
            delta = point - origin
            return float(np.linalg.norm(delta - float(axis @ delta) * axis))

        datum_location = shift.feature.actual.location
        reach = 0.0 if datum_location is None else radial(datum_location)
        if reach == 0.0:
            raise ShiftNotBounded(f"{shift.label}'s clocking shift is not bounded (the datum lies on the primary axis)")
        effect = shift.shift * radial(location) / reach
        total += effect
        parts.append(f"{effect:.6g} mm (a rotation about the primary axis of up to {shift.shift / 2 / reach:.3g} rad)")
    return total, " + ".join(parts)


def shifted_datums(frame_datums: tuple[DrfDatum, ...]) -> list[tuple[int, str]]:
    """``(precedence index, modifier)`` of every datum of a frame at MMB / LMB."""
    found = []
    for index, datum in enumerate(frame_datums):
        modifiers = [m for m in datum.material_modifiers if m not in ("NONE", "REGARDLESS")]
        if modifiers:
            found.append((index, modifiers[0]))
    return found
