"""Common datums (``A-B``) and datums from point targets.

Common datums (ISO 5459-1:2011 3.7 and 5459-2, "common datum": the datum features are associated
simultaneously; ASME Y14.5-2018 7.12, coplanar and coaxial datum features simulated together):

- two (or more) nominally **coplanar planes** -> one datum plane associated to all their points at once
  (the same tangent minimax or constrained least squares as one plane: :func:`associate_datum` on the
  union, whose certificate then covers both surfaces);
- two nominally **coaxial cylinders** -> one axis: the line minimising the largest distance of each
  surface from a cylinder of its own nominal radius about it -- shafts ``min max_i (d_i - R_k(i))``, holes
  ``max min_i (d_i - R_k(i))`` -- both simulators grow or shrink together from their nominal sizes.  SLSQP
  over the line from the line through the two individual envelopes' axes, with the KKT multipliers of the
  contacts (scope ``"local"``).

Datum targets (ISO 5459-1 clause 3.9 / ASME Y14.5-2018 7.24): point targets ``A1, A2, A3`` of a primary plane
give the plane through their measured contact points; ``B1, B2`` of a secondary the plane through both
with its normal perpendicular to the primary's direction; ``C1`` of a tertiary the plane through it with its
normal fixed by both.  The number of targets must equal the degrees of freedom the normal has left
(3, 2 or 1) -- otherwise refused by name.  Each target is a feature of element ``"point"`` (the mean of
its points is the contact).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.errors import InvalidInputError

__all__ = ["associate_common_axis", "associate_in_sequence", "associate_special", "associate_targets",
           "common_feature", "stand_in_feature", "targets_entry"]

FloatArray = NDArray[np.float64]


def common_feature(label: str, parts: list[object]) -> object:
    """A :class:`~pcmm_geo.gdt.FeatureData` standing for the common datum ``label`` of ``parts``.

    Raises
    ------
    InvalidInputError
        Parts of different elements, neither planes nor cylinders, or not nominally coplanar / coaxial.
    """
    import dataclasses

    first = parts[0]
    elements = {p.element for p in parts}  # type: ignore[attr-defined]
    if len(elements) != 1 or first.element not in ("plane", "cylinder"):  # type: ignore[attr-defined]
        raise InvalidInputError(f"common datum {label}", "coplanar planes or coaxial cylinders", " and ".join(
            sorted(elements)))
    d = np.asarray(first.direction, dtype=float)  # type: ignore[attr-defined]
    for p in parts[1:]:
        other = np.asarray(p.direction, dtype=float)  # type: ignore[attr-defined]
        offset = np.asarray(p.point, dtype=float) - np.asarray(first.point, dtype=float)  # type: ignore[attr-defined]
        if first.element == "plane":  # type: ignore[attr-defined]
            ok = np.allclose(other, d, atol=1e-9) and abs(offset @ d) <= 1e-9
            what = "nominally coplanar planes with the same outward normal"
        else:
            ok = np.linalg.norm(np.cross(other, d)) <= 1e-9 and np.linalg.norm(np.cross(offset, d)) <= 1e-9
            what = "nominally coaxial cylinders"
        if not ok:
            raise InvalidInputError(f"common datum {label}", what, f"{first.name} and {p.name}")  # type: ignore
    points = np.vstack([p.points for p in parts])  # type: ignore[attr-defined]
    return dataclasses.replace(first, name=label, points=points)  # type: ignore[type-var]


def associate_common_axis(parts: list[tuple[FloatArray, float]], *, label: str, side: str,
                          nominal_direction: FloatArray, start: tuple[FloatArray, FloatArray],
                          parallel_to: FloatArray | None = None, constraint_names: tuple[str, ...] = ()) -> object:
    """The common axis of coaxial cylinders (each ``(points (N, 3), nominal radius)``), a DatumAssociation.

    The association's ``radius`` is NaN and ``deviation_mm`` the common size change ``tau`` (shafts: the
    largest ``d_i - R_k``; holes: minus the smallest); the certificate's contacts index the stacked points.
    """
    from scipy.optimize import minimize

    from pcmm_geo.gdt.reference.datums import DatumAssociation, DatumCertificate

    pts = np.vstack([p for p, _ in parts])
    radii = np.concatenate([np.full(len(p), r) for p, r in parts])
    sign = 1.0 if side == "external" else -1.0
    p0, u0 = np.asarray(start[0], float), np.asarray(start[1], float)
    u0 = u0 / np.linalg.norm(u0)
    if parallel_to is not None:
        u0 = np.asarray(parallel_to, float) / np.linalg.norm(parallel_to)
        u0 = u0 if u0 @ nominal_direction >= 0 else -u0
    e1 = np.cross(u0, np.eye(3)[int(np.argmin(np.abs(u0)))])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u0, e1)
    centre = pts.mean(axis=0)
    p0 = p0 + ((centre - p0) @ u0) * u0
    length = max(float(np.ptp((pts - p0) @ u0)), 1.0)
    tilting = parallel_to is None

    def line(x: FloatArray) -> tuple[FloatArray, FloatArray]:
        u = u0 + ((x[2] * e1 + x[3] * e2) / length if tilting else 0.0)
        return p0 + x[0] * e1 + x[1] * e2, u / np.linalg.norm(u)

    def excess(x: FloatArray) -> FloatArray:
        point, u = line(x)
        rel = pts - point
        d = np.linalg.norm(rel - np.outer(rel @ u, u), axis=1)
        return sign * (d - radii)

    tau0 = float(excess(np.zeros(5)).max())
    res = minimize(lambda x: x[4], np.r_[0.0, 0.0, 0.0, 0.0, tau0], jac=lambda x: np.r_[0, 0, 0, 0, 1.0],
                   method="SLSQP", constraints=[{"type": "ineq", "fun": lambda x: x[4] - excess(x)}],
                   bounds=[(None, None)] * 2 + ([(None, None)] * 2 if tilting else [(0, 0)] * 2) + [(None, None)],
                   options={"ftol": 1e-16, "maxiter": 300})
    x = np.asarray(res.x, float)
    values = excess(x)
    tau = float(values.max())
    point, u = line(x)
    if u @ nominal_direction < 0:
        u = -u
    contacts = np.flatnonzero(values >= tau - 1e-9 * max(1.0, float(np.abs(radii).max())))
    mult, residual = _axis_multipliers(pts[contacts], point, u, sign, tilting)
    cert = DatumCertificate(contacts.astype(np.int64), np.zeros(len(contacts), dtype=np.int64), mult, "local",
                            float("nan"), residual, "lines near the line through the individual envelopes' axes",
                            "common axis: simultaneous minimax of each surface's excess over its nominal radius "
                            "(SLSQP + KKT)")
    return DatumAssociation(label, "cylinder", "common", point, u, float("nan"), sign * tau, constraint_names, cert)


def _axis_multipliers(contacts: FloatArray, point: FloatArray, u: FloatArray, sign: float,
                      tilting: bool) -> tuple[FloatArray, float]:
    """Non-negative multipliers summing to one balancing the contacts' radial directions (and their moments)."""
    from scipy.optimize import nnls

    rel = contacts - point
    heights = rel @ u
    radial = rel - np.outer(heights, u)
    radial /= np.linalg.norm(radial, axis=1)[:, None]
    rows = [sign * radial.T]
    if tilting:
        rows.append(sign * (radial * heights[:, None]).T / max(1.0, float(np.ptp(heights))))
    a = np.vstack([*rows, np.ones(len(contacts))])
    rhs = np.r_[np.zeros(a.shape[0] - 1), 1.0]
    mult, residual = nnls(a, rhs)
    return mult, float(residual)


def associate_targets(points: FloatArray, *, label: str, inward: FloatArray,
                      perpendicular_to: tuple[FloatArray, ...] = (), constraint_names: tuple[str, ...] = ()) -> object:
    """The datum plane through point targets (``points`` (M, 3): one contact per target), a DatumAssociation.

    Raises
    ------
    InvalidInputError
        A number of targets other than the degrees of freedom the normal has left, or targets that do not
        fix the plane (collinear, or along a constrained direction).
    """
    from pcmm_geo.gdt.reference.datums import DatumAssociation, DatumCertificate

    pts = np.asarray(points, dtype=float)
    fixed = [np.asarray(v, float) / np.linalg.norm(v) for v in perpendicular_to]
    rows = [*fixed, *(pts[1:] - pts[0])]
    need = 3 - len(fixed)
    if len(pts) != need:
        raise InvalidInputError(f"datum {label} targets", f"{need} point target(s) for a datum plane constrained "
                                f"by {len(fixed)} higher datum direction(s)", str(len(pts)))
    _, s, vt = np.linalg.svd(np.array(rows).reshape(-1, 3))
    if len(rows) < 2 or np.sum(s > 1e-9 * max(1.0, float(s.max()))) < 2:
        raise InvalidInputError(f"datum {label} targets", "targets that fix one plane", "collinear targets")
    normal = vt[-1] if vt[-1] @ inward >= 0 else -vt[-1]
    cert = DatumCertificate(np.arange(len(pts), dtype=np.int64), np.zeros(len(pts), dtype=np.int64),
                            np.full(len(pts), np.nan), "global", float("nan"), 0.0,
                            "the plane through the targets", "plane through the point targets' contacts")
    deviation = float(np.abs((pts - pts[0]) @ normal).max())
    return DatumAssociation(label, "plane", "targets", pts[0], normal, float("nan"), deviation, constraint_names, cert)


def targets_entry(label: str, entry: dict, features: dict, fail: object) -> object:
    """A plan's ``[datums] A = {targets = ["A1", "A2", "A3"], normal = [x, y, z]}``: the datum's stand-in
    feature (element ``"plane"``, one point per target: the mean of its points; nominal point: the mean of
    the targets' nominal points; ``normal``: the datum plane's outward nominal normal).

    ``fail(reason)`` makes the plan's error naming the entry's line.
    """
    import dataclasses

    names = entry.get("targets")
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        raise fail('targets = ["A1", ...] names the point target features')  # type: ignore[operator]
    for n in names:
        if n not in features or features[n].element != "point":
            raise fail(f"target {n!r}: expected a feature of element \"point\"")  # type: ignore[operator]
    normal = entry.get("normal")
    if (not isinstance(normal, list) or len(normal) != 3 or not all(isinstance(v, (int, float)) for v in normal)
            or not np.linalg.norm(normal) > 0):
        raise fail("normal = [x, y, z] (the datum plane's outward nominal normal) is required with targets")  # type: ignore[operator]
    contacts = np.array([features[n].points.mean(axis=0) for n in names])
    nominal = np.mean([features[n].point for n in names], axis=0)
    direction = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    return dataclasses.replace(features[names[0]], name=f"{label} ({', '.join(names)})", element="plane",
                               points=contacts, point=nominal, direction=direction)


def associate_special(frames: object, label: str, feature: object, inward: FloatArray,
                      perpendicular: list[FloatArray], parallel: FloatArray | None,
                      names: tuple[str, ...]) -> object | None:
    """A common datum or a datum from targets (``frames``: the plan's DRF cache); None for any other datum."""
    from pcmm_geo.gdt.reference.datums import associate_datum

    plan = frames.plan  # type: ignore[attr-defined]
    if "targets" in plan.datum_options.get(label, {}):
        return associate_targets(feature.points, label=label, inward=inward,  # type: ignore[attr-defined]
                                 perpendicular_to=tuple(perpendicular), constraint_names=names)
    if "-" not in label or feature.element != "cylinder":  # type: ignore[attr-defined]
        return None
    parts = [frames.datum_feature(p) for p in label.split("-")]  # type: ignore[attr-defined]
    if not all(np.isfinite(p.diameter) for p in parts):
        raise InvalidInputError(f"common datum {label}", "a nominal diameter for each cylinder", "none")
    singles = [associate_datum(p.points, "cylinder", label=p.name, side=p.side, nominal_direction=inward,
                               parallel_to=parallel) for p in parts]
    direction = singles[-1].point - singles[0].point
    direction = direction if direction @ inward >= 0 else -direction
    return associate_common_axis([(p.points, p.diameter / 2) for p in parts], label=label, side=parts[0].side,
                                 nominal_direction=inward, start=(singles[0].point, direction),
                                 parallel_to=parallel, constraint_names=names)


def stand_in_feature(frames: object, label: str) -> object:
    """The feature standing for a target datum or a common datum ``A-B`` of a plan (``frames``: its DRF cache)."""
    options = frames.plan.datum_options.get(label, {})  # type: ignore[attr-defined]
    if "feature" in options:
        return options["feature"]
    return common_feature(label, [frames.datum_feature(p) for p in label.split("-")])  # type: ignore[attr-defined]


def associate_in_sequence(frames: Any, label: str, before: list[Any]) -> object:
    """Datum ``label`` associated under the constraints of the datums ``before`` it in a frame (their
    associations), for a plan's DRF cache ``frames``: a plane perpendicular to a higher plane or axis, or at
    its nominal angle to a higher plane; a cylinder parallel to a higher direction; a plane whose normal two
    higher directions fix; common datums and datums from targets (:func:`associate_special`)."""
    from pcmm_geo.gdt.reference.datums import associate_datum

    criterion = frames.plan.datums[label.split("-")[0]][1]
    feature = frames.datum_feature(label)
    inward = -feature.direction if feature.element == "plane" else feature.direction
    perpendicular: list[FloatArray] = []
    parallel, angle = None, None
    names: list[str] = []
    for prior in before:
        if prior.element not in ("plane", "cylinder"):
            continue
        nominal = frames.nominal_direction(prior.label)
        cos = abs(float(nominal @ inward)) if feature.element in ("plane", "cylinder") else 1.0
        if feature.element == "plane" and cos < 1e-9:
            perpendicular.append(prior.direction)
            names.append(f"perpendicular to {prior.label}")
        elif feature.element == "plane" and prior.element == "cylinder" and cos > 1 - 1e-9:
            # a face perpendicular to a datum axis (a shoulder): its normal is the axis
            u, _, _ = np.linalg.svd(np.eye(3) - np.outer(prior.direction, prior.direction))
            perpendicular += [u[:, 0], u[:, 1]]
            names.append(f"perpendicular to the axis {prior.label}")
        elif feature.element == "cylinder" and cos > 1 - 1e-9 and parallel is None:
            parallel = prior.direction
            names.append(f"parallel to {prior.label}")
        elif feature.element == "plane" and prior.element == "plane" and cos < 1 - 1e-9 and angle is None:
            # a plane at another angle: its normal keeps the nominal angle to the higher datum's
            angle = (prior.direction, float(nominal @ inward))
            names.append(f"at {np.degrees(np.arccos(float(nominal @ inward))):.6g} deg to {prior.label}")
    if angle is not None and (perpendicular or len(names) > 1):
        # two higher directions fix the normal: the nominal carried by their measured frame
        from pcmm_geo.gdt.reference.constrained import fixed_normal

        nominals = [frames.nominal_direction(b.label) for b in before]
        angle, perpendicular = None, fixed_normal(before, nominals, inward)
    special = associate_special(frames, label, feature, inward, perpendicular, parallel, tuple(names))
    if special is not None:
        return special
    return associate_datum(feature.points, feature.element, label=label, criterion=criterion, side=feature.side,
                           nominal_direction=inward if feature.element in ("plane", "cylinder") else None,
                           perpendicular_to=tuple(perpendicular), parallel_to=parallel,
                           constraint_names=tuple(names), angle_to=angle)
