"""Composite and stacked position frames of a pattern (ASME Y14.5-2018 10.5.1-10.5.2; ISO 5458:2018 ``CZ``).

A pattern's position may be given by two segments:

- **composite** (ASME Y14.5-2018 10.5.1; one position symbol spans both segments): the upper segment's
  pattern-locating zones (PLTZF) locate the pattern to all its datums, floating together in what that
  DRF leaves free; the lower segment's feature-relating zones (FRTZF) control the holes' spacing and
  orientation: its datums constrain **orientation only**, so the group of zones floats in every
  translation and in the rotations those datums leave free;
- **stacked single-segment frames** (ASME 10.5.2; a symbol in each segment): each segment is a position
  requirement of its own; the lower segment's datums constrain translation too;
- **ISO 5458:2018** writes the same as two stacked frames: ``CZ`` (combined zone) makes a segment's
  zones one simultaneous pattern (without it, or with ``SZ``, each zone stands alone), and ``><``
  (ISO 1101:2017 orientation constraint only) frees every translation, as the FRTZF.

The float is a minimax: ``min over motions of max_k w_k |P_k (a_k - n_k) - motion|`` with ``a_k`` the
toleranced targets (an axis's end points, a centre), ``n_k`` the true positions, ``P_k`` the projection
on the zone's cross-section and ``w_k = 2 / allowed_k`` (allowed = tolerance + the hole's proven bonus,
per hole and per segment).  In the translations it is convex (``minimax_translation``, in
:mod:`pcmm_geo.gdt.reference._floating`): solved, then polished on its KKT system,
and certified by Lagrange duality -- for multipliers ``lam`` on the simplex,
``min_s sum_k lam_k |b_k - J_k s|^2`` (a weighted least-squares problem, closed form) is a lower bound
of the squared optimum, tight at the optimum.  One free rotation (the FRTZF to a primary plane): branch and
bound over the whole turn ``[-pi, pi]``; on a cell ``|theta - m| <= h`` the targets move by the linear
term ``delta u_k`` plus at most ``rho_k (h^2/2 + h^3/6)``, and the dual bound with the box ``|delta| <= h``
(closed form in ``delta``) bounds the cell from below: a proven global lower bound (scope ``"global"``).
Two or more free rotations: the local Gauss-Newton float (scope ``"local"``), PASS or NOT PROVEN only.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.gdt.characteristics import CharacteristicResult, FeatureData, _position_targets, size_evaluation
from pcmm_geo.gdt.reference._floating import float_position, minimax_translation
from pcmm_geo.gdt.reference.frame import DatumReferenceFrame

__all__ = ["FloatCertificate", "PositionSegment", "evaluate_planned_segments", "evaluate_position_segments",
           "float_group", "minimax_translation"]

FloatArray = NDArray[np.float64]
_UNIT = {"x": np.array([1.0, 0, 0]), "y": np.array([0, 1.0, 0]), "z": np.array([0, 0, 1.0])}


@dataclass(frozen=True)
class PositionSegment:
    """One segment of a position frame of a pattern.

    Attributes
    ----------
    drf : DatumReferenceFrame
        The frame of the segment's datums (``DatumReferenceFrame.measurement()`` without datums).
    tolerance_mm : float
        Zone diameter, mm.
    modifier : {"RFS", "MMC", "LMC"}
    simultaneous : bool
        The zones float together (ASME default, ISO ``CZ``); False: each hole on its own (ISO ``SZ``).
    orientation_only : bool
        The datums constrain orientation only: every translation floats (ASME FRTZF, ISO ``><``).
    label : str
        ``"PLTZF"``, ``"FRTZF"``, ``"segment 2"`` ... (names the results).
    """

    drf: DatumReferenceFrame
    tolerance_mm: float
    modifier: str = "RFS"
    simultaneous: bool = True
    orientation_only: bool = False
    label: str = "segment 1"


@record
class FloatCertificate:
    """The float of a group of zones: value, proven lower bound and placement.

    Attributes
    ----------
    value : float
        ``max_k w_k |deviation_k|`` at the placement found (an upper bound of the optimum).
    bound : float
        Proven lower bound of the optimum over every allowed motion (NaN when not proven: scope local).
    scope : {"global", "local"}
    deviations : ndarray, shape (K, 3)
        Unweighted deviations (projected) of each target at the placement, mm.
    multipliers : ndarray, shape (K,)
        The dual certificate ``lam`` (non-negative, sum 1) of the final translation problem.
    theta : float
        The free rotation's angle at the placement, rad (0 without one).
    evaluations : int
        Translation problems solved.
    """

    value: float
    bound: float
    scope: str
    deviations: FloatArray
    multipliers: FloatArray
    theta: float = 0.0
    evaluations: int = 1


def _rot(axis: FloatArray, theta: float) -> FloatArray:
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(theta) * k + (1 - np.cos(theta)) * k @ k


def float_group(targets: FloatArray, nominals: FloatArray, projs: FloatArray, weights: FloatArray,
                trans: list[FloatArray], rots: list[FloatArray], pivot: FloatArray, *,
                tol: float = 1e-10, budget: int = 3000) -> FloatCertificate:
    """Float a group of zones in the free motions; see the module docstring.

    Parameters
    ----------
    targets, nominals : ndarray, shape (K, 3)
        Toleranced targets and their true positions, DRF coordinates, mm.
    projs : ndarray, shape (K, 3, 3)
        Projection of each target's deviation on its zone's cross-section.
    weights : ndarray, shape (K,)
        ``2 / allowed_k`` (a ratio of 1 fills the zone).
    trans, rots : list of ndarray, shape (3,)
        Free translation directions and free rotation axes (unit, DRF).
    pivot : ndarray, shape (3,)
        A point on the free rotation axes.
    tol : float
        Branch and bound stops when the proven bound is within ``tol * max(1, value)`` of the value.
    budget : int
        Largest number of translation problems solved by the branch and bound.
    """
    targets = np.asarray(targets, dtype=float)
    w = np.asarray(weights, dtype=float)
    tmat = np.column_stack(trans) if trans else np.zeros((3, 0))
    jac = w[:, None, None] * np.einsum("kij,jp->kip", projs, tmat)
    if tmat.shape[1]:  # keep a basis of the translations that move a projected target
        _, sv, vt = np.linalg.svd(jac.reshape(-1, tmat.shape[1]), full_matrices=False)
        basis = vt[sv > 1e-12 * max(1.0, float(sv[0]))].T
        tmat, jac = tmat @ basis, jac @ basis

    def at(cloud: FloatArray) -> tuple[float, float, FloatArray, FloatArray, FloatArray]:
        b = w[:, None] * np.einsum("kij,kj->ki", projs, cloud - nominals)
        value, bound, s, lam = minimax_translation(b, jac)
        return value, bound, s, lam, b

    def deviations(cloud: FloatArray, s: FloatArray) -> FloatArray:
        return np.einsum("kij,kj->ki", projs, cloud - nominals - tmat @ s)

    # a rotation whose motion of the targets free translations already give adds nothing: drop it
    kept = []
    for r in rots:
        col = np.einsum("kij,kj->ki", projs, np.cross(r, targets - pivot)).reshape(-1)
        base = np.einsum("kij,jp->kip", projs, tmat).reshape(-1, tmat.shape[1])
        rest = col - base @ np.linalg.lstsq(base, col, rcond=None)[0] if base.shape[1] else col
        if np.linalg.norm(rest) > 1e-9 * max(1.0, float(np.linalg.norm(col))):
            kept.append(r)
    if not kept:
        value, bound, s, lam, _ = at(targets)
        return FloatCertificate(value, bound, "global", deviations(targets, s), lam)
    if len(kept) > 1:
        value, _, dev = float_position(targets, nominals, projs, trans, kept, pivot, w)
        return FloatCertificate(value, float("nan"), "local", dev, np.full(len(targets), np.nan), float("nan"))
    axis = kept[0]
    centre = np.asarray(pivot, dtype=float)
    # turning about another point is the same turn plus a translation: when the translations across the
    # axis float, turn about the targets' centroid (the smallest radii, the tightest cell bounds)
    across = np.eye(3) - np.outer(axis, axis)
    if tmat.shape[1] and np.linalg.matrix_rank(across @ tmat, tol=1e-9) == 2:
        centre = targets.mean(axis=0)
    rel = targets - centre
    radius = np.linalg.norm(rel - np.outer(rel @ axis, axis), axis=1)
    lip = w * radius

    def cell_bound(m: float, h: float, lam: FloatArray, b: FloatArray) -> float:
        cloud = centre + (targets - centre) @ _rot(axis, m).T
        u = w[:, None] * np.einsum("kij,kj->ki", projs, np.cross(axis, cloud - centre))
        root = np.sqrt(lam)[:, None]
        bb, uu = (b * root).reshape(-1), (u * root).reshape(-1)
        if jac.shape[2]:
            a = (jac * root[:, :, None]).reshape(-1, jac.shape[2])
            q, _ = np.linalg.qr(a)
            bb, uu = bb - q @ (q.T @ bb), uu - q @ (q.T @ uu)
        uu2 = float(uu @ uu)
        delta = 0.0 if uu2 == 0 else float(np.clip(-(bb @ uu) / uu2, -h, h))
        g = float(np.sum((bb + delta * uu) ** 2))
        return float(np.sqrt(g)) * (1 - 1e-12) - float(lip.max()) * (h * h / 2 + h ** 3 / 6)

    def evaluate(m: float) -> tuple[float, FloatArray, FloatArray, FloatArray]:
        cloud = centre + (targets - centre) @ _rot(axis, m).T
        value, _, s, lam, b = at(cloud)
        return value, s, lam, b

    cells = 64
    h = np.pi / cells
    best = (np.inf, 0.0, np.zeros(jac.shape[2]), np.zeros(len(targets)))
    heap: list[tuple[float, float, float]] = []
    evaluations = 0
    for m in -np.pi + h * (2 * np.arange(cells) + 1):
        value, s, lam, b = evaluate(float(m))
        evaluations += 1
        if value < best[0]:
            best = (value, float(m), s, lam)
        heapq.heappush(heap, (cell_bound(float(m), h, lam, b), float(m), h))
    while heap and evaluations < budget:
        low, m, half = heapq.heappop(heap)
        if best[0] - low <= tol * max(1.0, best[0]) or half < 1e-13:
            heapq.heappush(heap, (low, m, half))
            break
        for child in (m - half / 2, m + half / 2):
            value, s, lam, b = evaluate(child)
            evaluations += 1
            if value < best[0]:
                best = (value, child, s, lam)
            heapq.heappush(heap, (cell_bound(child, half / 2, lam, b), child, half / 2))
    bound = min(best[0], heap[0][0]) if heap else best[0]
    value, theta, s, lam = best
    cloud = centre + (targets - centre) @ _rot(axis, theta).T
    return FloatCertificate(value, max(bound, 0.0), "global", deviations(cloud, s), lam, theta, evaluations)


def _free(drf: DatumReferenceFrame, orientation_only: bool) -> tuple[list[FloatArray], list[FloatArray]]:
    trans = [_UNIT[n[1]] for n in drf.free if n.startswith("t")]
    if orientation_only:
        trans = [_UNIT[a] for a in "xyz"]
    rots = [_UNIT[n[1]] for n in drf.free if n.startswith("r")]
    return trans, rots


def _segment(features: list[FeatureData], names: list[str], segment: PositionSegment, pattern: str,
             cache: dict[tuple[int, str], Any]) -> list[CharacteristicResult]:
    """One segment's results (one per feature); ``cache`` keeps each feature's toleranced targets (measurement
    coordinates: an envelope fit does not depend on the frame) and sizes across the segments."""
    drf = segment.drf
    trans, rots = _free(drf, segment.orientation_only)
    targets, owner, nominals, projs, sizes = [], [], [], [], []
    for k, feature in enumerate(features):
        if feature.element not in ("cylinder", "sphere", "point"):
            raise InvalidInputError(f"{names[k]}: element", "an axis, a centre or a point in a position pattern",
                                    feature.element)
        if (k, "targets") not in cache:
            pts, proj = _position_targets(feature, drf, names[k], "dia")
            cache[k, "targets"] = (drf.to_measurement(pts), proj)
        measured, proj = cache[k, "targets"]
        pts = drf.to_frame(measured)
        targets.append(pts)
        owner += [k] * len(pts)
        nominals.append(np.repeat(np.asarray(feature.point, dtype=float)[None, :], len(pts), axis=0))
        projs.append(np.repeat(proj[None], len(pts), axis=0))
        if segment.modifier == "RFS":
            sizes.append({"size_ok": True, "bonus_low_mm": 0.0, "bonus_high_mm": 0.0, "_rfs": True})
        else:
            if not np.isfinite(feature.diameter):
                raise InvalidInputError(f"{names[k]}: {segment.modifier}", "a feature of size with a diameter",
                                        feature.element)
            if (k, segment.modifier) not in cache:
                cache[k, segment.modifier] = size_evaluation(feature, segment.modifier)
            sizes.append(dict(cache[k, segment.modifier]))
    own = np.array(owner)
    groups = [list(range(len(features)))] if segment.simultaneous else [[k] for k in range(len(features))]
    results: list[CharacteristicResult | None] = [None] * len(features)
    for group in groups:
        rows = np.flatnonzero(np.isin(own, group))
        low = np.array([segment.tolerance_mm + sizes[k]["bonus_low_mm"] for k in own[rows]])
        high = np.array([segment.tolerance_mm + sizes[k]["bonus_high_mm"] for k in own[rows]])
        args = (np.vstack(targets)[rows], np.vstack(nominals)[rows], np.vstack(projs)[rows])
        cert = float_group(*args, 2.0 / low, trans, rots, drf.pivot)
        units = "bonus_low_mm"  # the allowances of the ratio whose bound is reported
        if cert.value <= 1.0:
            verdict, lower = "PASS", cert.bound
        else:
            high_cert = cert if np.array_equal(low, high) else float_group(*args, 2.0 / high, trans, rots, drf.pivot)
            lower, units = high_cert.bound, "bonus_high_mm"
            verdict = "FAIL" if cert.scope == "global" and high_cert.bound > 1.0 else "NOT PROVEN"
        for k in group:
            sel = own[rows] == k
            value = 2.0 * float(np.linalg.norm(cert.deviations[sel], axis=1).max())
            details: dict[str, Any] = {"pattern": pattern, "segment": segment.label,
                                       "floating": [n for n in drf.free if n.startswith("r")] +
                                       (["tx", "ty", "tz"] if segment.orientation_only else
                                        [n for n in drf.free if n.startswith("t")]),
                                       "pattern_ratio": cert.value, "pattern_ratio_bound": lower,
                                       "scope": cert.scope, "simultaneous": segment.simultaneous,
                                       "orientation_only": segment.orientation_only,
                                       "deviations_mm": cert.deviations[sel].tolist()}
            if np.isfinite(cert.theta) and cert.theta:
                details["pattern_turned_deg"] = float(np.degrees(cert.theta))
            size = {key: v for key, v in sizes[k].items() if key != "_rfs"}
            ok = size.pop("size_ok")
            bonus = None if "_rfs" in sizes[k] else size["bonus_low_mm"]
            if bonus is not None:
                details.update(size)
            one = len(group) == 1 and np.isfinite(lower)
            bound = lower * (segment.tolerance_mm + sizes[k][units]) if one else float("nan")
            v = verdict
            if not ok:
                v, bonus = "FAIL", 0.0
                details["reason"] = "size outside its limits"
            results[k] = CharacteristicResult(names[k], "position", value, bound, segment.tolerance_mm, bonus, v,
                                              drf.datums, drf.standard, details)
    return [r for r in results if r is not None]


def evaluate_position_segments(
    features: list[FeatureData],
    segments: list[PositionSegment],
    *,
    names: list[str] | None = None,
    pattern: str = "pattern",
) -> tuple[CharacteristicResult, ...]:
    """Position of a pattern under each segment of a composite or stacked frame (see the module docstring).

    Parameters
    ----------
    features : list of FeatureData
        The pattern's cylinders (axes), spheres or points; nominals in the part's DRF.
    segments : list of PositionSegment
        Upper segment first.  A composite frame (ASME): the lower segment ``orientation_only=True``.
    names : list of str, optional
        Result names per feature (default: the features' names, suffixed with the segment's label).
    pattern : str
        Names the requirement in the results' ``details``.

    Returns
    -------
    tuple of CharacteristicResult
        Segment by segment, one per feature: its zone diameter at the group's placement; ``details``:
        ``segment``, ``pattern_ratio`` (largest value / allowance at the placement), ``pattern_ratio_bound``
        (its proven lower bound over every allowed motion, NaN when only a local float was possible),
        ``scope``, ``floating`` and the sizes with a modifier.  Verdicts: PASS when the placement fits
        every zone; FAIL when the proven bound with the largest bonuses exceeds 1 (or a size is outside
        its limits); NOT PROVEN otherwise.

    Raises
    ------
    InvalidInputError
        A feature that is not an axis, a centre or a point; a modifier on a feature without a diameter;
        no segment.
    """
    if not segments:
        raise InvalidInputError("segments", "at least one segment", "none")
    out: list[CharacteristicResult] = []
    cache: dict[tuple[int, str], Any] = {}
    for segment in segments:
        labels = [f"{n} ({segment.label})" for n in (names or [f.name for f in features])]
        out += _segment(features, labels, segment, pattern, cache)
    return tuple(out)


def evaluate_planned_segments(extra: dict[str, Any], features: dict[str, FeatureData],
                              drf_of: Any) -> tuple[CharacteristicResult, ...]:
    """A plan's multi-segment frame (``extra`` from :func:`pcmm_geo.gdt.plan.segment_entries`); ``drf_of(datums)``
    gives the DRF of a datum sequence."""
    segments = [PositionSegment(drf_of(g["datums"]) if g["datums"] else DatumReferenceFrame.measurement(),
                                g["tolerance_mm"], g["modifier"], g["simultaneous"], g["orientation_only"], g["label"])
                for g in extra["segments"]]
    names = extra["features"]
    return evaluate_position_segments([features[n] for n in names], segments, pattern=extra["name"],
                                      names=[f"{extra['name']} {n}" for n in names])
