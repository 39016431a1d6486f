"""Position with datum features at MMB / LMB: the mobility domain of a frame and the position over it.

:func:`mobility_domain` turns a frame's datums (the base DRF, associated as at RMB, and each datum's
modifier) into the :class:`~pcmm_geo.gdt.reference.mobility.MobilityDomain` of the part;
:func:`evaluate_position_mobility` evaluates position frames -- one, or a pattern as one simultaneous
requirement -- as the best over that mobility (ASME Y14.5-2018 7.17 datum shift; ISO 2692:2014 MMR applied
to a datum feature).  Definitions and scope: :mod:`~pcmm_geo.gdt.reference.mobility`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.gdt.reference.frame import DatumReferenceFrame
from pcmm_geo.gdt.reference.mobility import DatumBoundary, MobilityDomain, _across

__all__ = ["DatumInFrame", "datum_boundary", "evaluate_position_mobility", "frame_mobility", "mobility_domain",
           "mobility_results"]

FloatArray = NDArray[np.float64]
_UNIT = {"x": np.array([1.0, 0, 0]), "y": np.array([0, 1.0, 0]), "z": np.array([0, 0, 1.0])}


@record
class DatumInFrame:
    """One datum of a frame, as the mobility needs it.

    Attributes
    ----------
    label : str
    modifier : {"RMB", "MMB", "LMB"}
    element : str
        ``"plane"`` or ``"cylinder"`` (others are refused with a modifier).
    points : ndarray, shape (N, 3)
        The datum feature's points, measurement coordinates, mm.
    point, direction : ndarray, shape (3,)
        Nominal point and direction (plane: inward normal; cylinder: axis) in the DRF.
    side : {"internal", "external"}
    size_limits : (float, float)
        Diameter limits, mm (NaN when not a feature of size).
    boundary_diameter : float or None
        The plan's boundary size, when not the size limit.
    free_before, free_after : tuple of str
        The DRF's free degrees of freedom before and after this datum (from the prefix DRFs).
    """

    label: str
    modifier: str
    element: str
    points: FloatArray
    point: FloatArray
    direction: FloatArray
    side: str = "external"
    size_limits: tuple[float, float] = (float("nan"), float("nan"))
    boundary_diameter: float | None = None
    free_before: tuple[str, ...] = ()
    free_after: tuple[str, ...] = ()


def datum_boundary(label: str, modifier: str, points_drf: FloatArray, side: str, size_limits: tuple[float, float],
                   nominal_point: FloatArray, axis: FloatArray, *,
                   boundary_diameter: float | None = None) -> DatumBoundary:
    """The boundary of a cylindrical datum feature at MMB / LMB and the envelope it bears on.

    Parameters
    ----------
    label : str
    modifier : {"MMB", "LMB"}
    points_drf : ndarray, shape (N, 3)
        The datum feature's points in DRF coordinates, mm.
    side : {"internal", "external"}
    size_limits : (float, float)
        Lower and upper size limits (diameters), mm.
    nominal_point : ndarray, shape (3,)
        A point of the nominal axis, DRF coordinates.
    axis : ndarray, shape (3,)
        The primary's direction (the boundary's orientation), unit, DRF coordinates.
    boundary_diameter : float, optional
        The boundary's size when not the size limit (e.g. a virtual condition), mm.
    """
    from pcmm_geo.fit import fit_circle

    if modifier not in ("MMB", "LMB"):
        raise InvalidInputError(f"datum {label} modifier", "MMB or LMB", repr(modifier))
    hole = side == "internal"
    lo, hi = size_limits
    if boundary_diameter is None:
        boundary_diameter = (lo if hole else hi) if modifier == "MMB" else (hi if hole else lo)
    envelope = ("mic" if hole else "mcc") if modifier == "MMB" else ("mcc" if hole else "mic")
    e1, e2 = _across(axis)
    planar = points_drf @ np.c_[e1, e2]
    fit = fit_circle(planar, criterion=envelope)
    centre = np.asarray(fit.center, dtype=float) @ np.array([e1, e2])
    nominal = np.asarray(nominal_point, dtype=float)
    nominal = nominal - (nominal @ axis) * axis
    env_d = 2.0 * float(fit.radius)
    # the boundary inside a hole's mating envelope / around a pin's, and the reverse at LMB
    inside = (modifier == "MMB") == hole
    gap = (env_d - boundary_diameter) / 2.0 if inside else (boundary_diameter - env_d) / 2.0
    return DatumBoundary(label, modifier, side, float(boundary_diameter), envelope, env_d, centre, nominal, float(gap))


def mobility_domain(drf: DatumReferenceFrame, datums: list[DatumInFrame]) -> MobilityDomain:
    """The motions the frame's datums allow the part in its DRF.

    Raises
    ------
    InvalidInputError
        A modifier on the primary, on a datum that is not a cylinder with its axis along the primary's
        direction or without size limits, or a primary that is not a plane (named).
    """
    primary = datums[0]
    if primary.modifier != "RMB":
        raise InvalidInputError(f"datum {primary.label}", "a primary datum referenced RMB (mobility of a primary "
                                "datum feature of size is not handled)", primary.modifier)
    if primary.element != "plane":
        raise InvalidInputError(f"datum {primary.label}", "a plane primary datum when a datum is referenced at "
                                "MMB / LMB", primary.element)
    axis = np.asarray(primary.direction, dtype=float) / np.linalg.norm(primary.direction)
    boundaries = []
    held: list[tuple[FloatArray, FloatArray]] = []
    rotation = "free"
    previous_centre: FloatArray | None = None
    for d in datums[1:]:
        fixes = [n for n in d.free_before if n not in d.free_after]
        gives_rotation = any(n.startswith("r") for n in fixes)
        translations = [_UNIT[n[1]] for n in fixes if n.startswith("t")]
        if d.modifier != "RMB":
            if d.element != "cylinder" or np.linalg.norm(np.cross(d.direction, axis)) > 1e-9:
                raise InvalidInputError(f"datum {d.label}", f"a cylinder along the primary {primary.label}'s "
                                        f"direction to be referenced at {d.modifier}", d.element)
            if not all(np.isfinite(d.size_limits)):
                raise InvalidInputError(f"datum {d.label}", f"a diameter and size_tolerance for {d.modifier}",
                                        "none")
            boundary = datum_boundary(d.label, d.modifier, d.points, d.side, d.size_limits, d.point, axis,
                                      boundary_diameter=d.boundary_diameter)
            boundaries.append(boundary)
            if gives_rotation:
                rotation = "mobile"
            previous_centre = boundary.nominal_center if previous_centre is None else previous_centre
            continue
        centre = np.asarray(d.point, dtype=float) - float(np.asarray(d.point) @ axis) * axis
        if d.element == "plane":
            n = np.asarray(d.direction, dtype=float)
            held.extend((centre, n / np.linalg.norm(n)) for _ in translations)
            if gives_rotation:
                rotation = "held"
        elif d.element == "cylinder":
            for t in translations:
                held.append((centre, t))
            if gives_rotation and previous_centre is not None:
                along = centre - previous_centre
                across = np.cross(axis, along / np.linalg.norm(along))
                held.append((centre, across))
                rotation = "mobile" if rotation != "held" else rotation
            elif gives_rotation:
                rotation = "held"
            previous_centre = centre if previous_centre is None else previous_centre
        else:
            raise InvalidInputError(f"datum {d.label}", "a plane or a cylinder after the primary when a datum is "
                                    "referenced at MMB / LMB", d.element)
    if rotation == "free" and "r" + _axis_name(axis) not in drf.free:
        rotation = "held"
    return MobilityDomain(axis, tuple(boundaries), tuple(held), rotation)


def _axis_name(axis: FloatArray) -> str:
    return "xyz"[int(np.argmax(np.abs(axis)))]


def evaluate_position_mobility(features: list[Any], drf: DatumReferenceFrame, domain: MobilityDomain,
                               tolerances_mm: list[float], *, names: list[str] | None = None,
                               modifiers: list[str] | None = None, pattern: str | None = None,
                               datum_modifiers: tuple[str, ...] = ()) -> tuple[Any, ...]:
    """Position of axes / centres / points as the best over the datum mobility.

    With ``pattern`` the features are one simultaneous requirement (one motion for all); without, each
    feature gets its own best motion (ISO's default: separate requirements).

    Returns
    -------
    tuple of CharacteristicResult
        ``details``: ``datum_shift_mm`` (the part's translation in the DRF used), ``datum_rotation_rad``,
        ``mobility_scope``, ``mobility_proven`` (PROVEN / NOT PROVEN: the placement is the best over the
        whole mobility, global), the boundaries (sizes, envelopes, gaps) and the KKT certificate.  A
        boundary the part does not fit: FAIL with the reason.
    """
    from pcmm_geo.gdt._sizes import allowed_zone
    from pcmm_geo.gdt.characteristics import CharacteristicResult, _position_targets, decide
    from pcmm_geo.gdt.reference.mobility import solve_mobility

    names = names or [f.name for f in features]
    modifiers = modifiers or ["RFS"] * len(features)
    groups = [list(range(len(features)))] if pattern is not None else [[k] for k in range(len(features))]
    prepared = []
    for k, (feature, tolerance, modifier) in enumerate(zip(features, tolerances_mm, modifiers, strict=True)):
        if feature.element not in ("cylinder", "sphere", "point"):
            raise InvalidInputError(f"{names[k]}: element", "an axis, a centre or a point for position with a "
                                    "datum at MMB / LMB", feature.element)
        pts, proj = _position_targets(feature, drf, names[k], "dia")
        details: dict[str, Any] = {"datum_modifiers": list(datum_modifiers)} if datum_modifiers else {}
        low, high, ok, bonus = allowed_zone(feature, tolerance, modifier, details)
        prepared.append((pts, proj, low, high, ok, bonus, details))
    results: list[Any] = [None] * len(features)
    boundaries = [b.to_dict() for b in domain.boundaries]
    violated = [b.label for b in domain.boundaries if b.gap_mm < 0]
    for group in groups:
        targets = np.vstack([prepared[k][0] for k in group])
        owner = np.concatenate([[k] * len(prepared[k][0]) for k in group])
        nominals = np.vstack([np.repeat(features[k].point[None, :], len(prepared[k][0]), axis=0) for k in group])
        projs = np.vstack([np.repeat(prepared[k][1][None], len(prepared[k][0]), axis=0) for k in group])
        weights = np.array([2.0 / prepared[k][2] for k in owner]) if pattern is not None else np.full(len(owner), 2.0)
        best = solve_mobility(targets, nominals, projs, weights, domain)
        for k in group:
            pts, proj, low, high, ok, bonus, details = prepared[k]
            mine = owner == k
            value = 2.0 * float(np.linalg.norm(best.deviations[mine], axis=1).max())
            details = {**details, **best.to_dict(), "datum_boundaries": boundaries,
                       "deviations_mm": best.deviations[mine].tolist(),
                       "mobility_proven": "PROVEN" if best.certificate.scope == "global" else "NOT PROVEN"}
            if pattern is not None:
                details["pattern"] = pattern
                details["pattern_ratio"] = best.value
                # the ratio against the largest allowances is at least the bound times min(low / high)
                shrink = min(prepared[j][2] / prepared[j][3] for j in group)
                verdict = "PASS" if best.value <= 1.0 else (
                    "FAIL" if np.isfinite(best.bound) and best.bound * shrink > 1.0 else "NOT PROVEN")
                bound = value if best.certificate.scope == "global" else float("nan")
            else:
                bound = best.bound
                verdict = decide(value, bound, low, high)
            if violated:
                verdict, bound = "FAIL", float("nan")
                details["reason"] = f"datum feature(s) {', '.join(violated)} violate their boundary (the part does " \
                                    "not fit the datum feature simulator)"
            elif not best.feasible and best.certificate.scope == "global":  # convex: no motion exists
                verdict = "FAIL"
                details["reason"] = "no motion fits every datum boundary at once"
            elif not best.feasible:
                verdict = "NOT PROVEN"
                details["reason"] = "no motion found that fits every datum boundary at once (a local search)"
            if not ok:
                verdict, bonus = "FAIL", 0.0
                details["reason"] = "size outside its limits"
            results[k] = CharacteristicResult(names[k], "position", value, bound, tolerances_mm[k], bonus, verdict,
                                              drf.datums, drf.standard, details)
    return tuple(results)


def frame_mobility(frames: Any, datums: tuple[str, ...], datum_modifiers: tuple[str, ...]) -> tuple[
        DatumReferenceFrame, MobilityDomain]:
    """The base DRF (every datum associated as at RMB) and the mobility domain of a plan's frame.

    ``frames`` is the plan's DRF cache (:class:`pcmm_geo.gdt.inspection._Frames`): ``frames.plan``,
    ``frames.drf(labels)``, ``frames.datum_feature(label)`` and ``frames.nominal_direction(label)``.
    """
    plan = frames.plan
    drf = frames.drf(datums)
    entries = []
    for k, (label, modifier) in enumerate(zip(datums, datum_modifiers, strict=True)):
        feature = frames.datum_feature(label)
        before = frames.drf(datums[:k]).free if k else ("tx", "ty", "tz", "rx", "ry", "rz")
        after = frames.drf(datums[:k + 1]).free
        sized = feature.element == "cylinder" and np.isfinite(feature.diameter)
        limits = (feature.diameter + feature.size_tolerance[0], feature.diameter + feature.size_tolerance[1]) \
            if sized else (float("nan"), float("nan"))
        direction = frames.nominal_direction(label)
        entries.append(DatumInFrame(label, modifier, feature.element, drf.to_frame(feature.points),
                                    np.asarray(feature.point, dtype=float), direction, feature.side, limits,
                                    plan.datum_options.get(label, {}).get("boundary_diameter"), before, after))
    return drf, mobility_domain(drf, entries)


def mobility_results(frames: Any, members: list[Any], pattern: str | None) -> tuple[Any, ...]:
    """Position frames of a plan (``PlannedCharacteristic``, the same datums and modifiers) over their datum
    mobility: one simultaneous requirement when ``pattern`` is given, else each on its own."""
    plan = frames.plan
    spec = members[0].frame
    drf, domain = frame_mobility(frames, spec.datums, spec.modifiers_of_datums)
    return evaluate_position_mobility([plan.features[m.feature] for m in members], drf, domain,
                                      [m.frame.tolerance_mm for m in members], names=[m.name for m in members],
                                      modifiers=[m.frame.modifier for m in members], pattern=pattern,
                                      datum_modifiers=spec.modifiers_of_datums)
