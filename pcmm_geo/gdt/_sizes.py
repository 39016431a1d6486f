"""Sizes of a feature of size for a position modifier: the mating and minimum-material envelopes.

A hole's actual mating size is its maximum inscribed cylinder (MIC), its actual minimum material
size its minimum circumscribed cylinder (MCC); a shaft's the other way round (ISO 14405-1 GX / GN,
ASME Y14.5-2018 1.3.25).  The size check needs both limits -- ``MIC >= lower limit`` and
``MCC <= upper limit`` for a hole and a shaft alike -- but only the envelope of the modifier
(MMC: the mating one, LMC: the minimum-material one) needs its exact value; the other side of the
check is first decided by a bound from the least-squares axis, free to compute:

* every axis gives a circumscribed cylinder, so twice the largest distance from the least-squares
  axis bounds the MCC diameter from above;
* when the points surround the least-squares axis (its trace lies inside the convex hull of the
  points projected along it), twice the smallest distance from it bounds the MIC diameter from below.

Only when that bound does not decide the check is the exact envelope computed.

The exact envelopes are searched (``pcmm_geo.fit.zone``) over a tight axis region around the
least-squares axis instead of the default 45 deg / 2R one.  With ``s`` the spread of the points'
distances from the least-squares axis (their form error about it) and ``L`` their extent along
it, in a cross-section the points surround the MIC / MCC axis lies within about ``s`` of the
least-squares axis (an axis moved by ``d`` brings the points on one side ``d`` nearer, on the other
``d`` farther, and the least-squares axis already inscribes ``R - s/2`` and circumscribes
``R + s/2``), so its offset at the centroid is at most about ``s`` and its tilt about ``2 s / L``.
The region takes twice that (offset ``2 s``, tilt ``4 s / L``, with small floors).  That argument
needs points all round each section, so it is checked, not trusted: when the optimum lies on the
region's edge (``certificate.on_region_boundary``) the region is widened eightfold and searched
again, up to the default region.  The certificate states the region searched (``domain``), and the
details record it (``mating_region`` / ``minimum_material_region``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

__all__ = ["size_evaluation"]

#: tight region: multiples of the distance spread for the offset and of spread / extent for the tilt
_OFFSET_SPREADS, _TILT_SPREADS = 2.0, 4.0
#: floors of the tight region: offset in radii, tilt (tan)
_OFFSET_FLOOR_RADII, _TILT_FLOOR = 1e-4, 1e-5
#: widening factor when the optimum lies on the region's edge
_WIDEN = 8.0
#: the default region of pcmm_geo.fit.zone (45 deg, twice the least-squares radius): the widening stops there
_DEFAULT_CONE_DEG, _DEFAULT_OFFSET_RADII = 45.0, 2.0


def _axis_distances(points: FloatArray, gauss: Any) -> tuple[FloatArray, FloatArray]:
    """Distances (N,) of the points from the least-squares axis and heights (N,) along it (mm)."""
    axis = np.asarray(gauss.axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    rel = points - np.asarray(gauss.point, dtype=float)
    heights = rel @ axis
    radial = rel - np.outer(heights, axis)
    return np.sqrt(np.einsum("ij,ij->i", radial, radial)), heights


def _surrounds(points: FloatArray, gauss: Any) -> bool:
    """Whether the trace of the least-squares axis lies strictly inside the points' projected hull."""
    from scipy.spatial import ConvexHull, QhullError

    axis = np.asarray(gauss.axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    first = np.cross(axis, np.eye(3)[int(np.argmin(np.abs(axis)))])
    first /= np.linalg.norm(first)
    planar = (points - np.asarray(gauss.point, dtype=float)) @ np.c_[first, np.cross(axis, first)]
    try:
        hull = ConvexHull(planar)
    except (QhullError, ValueError):
        return False
    # equations n . p + c <= 0 inside; the trace is the origin: inside when every c < 0
    return bool(hull.equations[:, 2].max() < 0.0)


def _envelope(points: FloatArray, criterion: str, gauss: Any, distances: FloatArray, heights: FloatArray,
              surrounded: bool) -> Any:
    """The exact MIC / MCC cylinder over a tight region around the least-squares axis, widened while hit.

    A MIC of points that do not surround the least-squares axis (a partial arc) is searched over the
    default region at once: the tight region may hold no axis they surround.
    """
    from pcmm_geo.fit import AxisRegion, fit_cylinder

    if criterion == "mic" and not surrounded:
        return fit_cylinder(points, criterion=criterion)
    radius = float(gauss.radius)
    spread = float(np.ptp(distances))
    extent = max(float(np.ptp(heights)), 1e-300)
    offset = max(_OFFSET_SPREADS * spread, _OFFSET_FLOOR_RADII * radius)
    tilt = max(_TILT_SPREADS * spread / extent, _TILT_FLOOR)
    while True:
        cone_deg = float(np.degrees(np.arctan(tilt)))
        if cone_deg >= _DEFAULT_CONE_DEG or offset >= _DEFAULT_OFFSET_RADII * radius:
            return fit_cylinder(points, criterion=criterion)  # the default region: the widening ends here
        region = AxisRegion(cone_deg=cone_deg, offset_mm=offset, axis=gauss.axis, point=gauss.point)
        fit = fit_cylinder(points, criterion=criterion, axis_region=region)
        if not fit.certificate.on_region_boundary:
            return fit
        tilt, offset = tilt * _WIDEN, offset * _WIDEN


def _diameter_range(fit: Any, inscribed: bool) -> tuple[float, float]:
    """Proven range (mm) of an envelope's diameter from its certificate."""
    value = 2.0 * float(fit.radius)
    bound = 2.0 * float(fit.certificate.bound_mm)
    if fit.certificate.scope == "global":
        return value, value
    if not np.isfinite(bound):
        return (value, np.inf) if inscribed else (0.0, value)
    return (value, bound) if inscribed else (bound, value)


def size_evaluation(feature: Any, modifier: str, *, points: FloatArray | None = None, gauss: Any = None,
                    envelope: tuple[str, Any] | None = None) -> dict[str, Any]:
    """Sizes of a cylinder / sphere and the bonus of ``modifier`` ("MMC" / "LMC").

    Parameters
    ----------
    feature : FeatureData
        A cylinder or sphere with a diameter and a size tolerance.
    modifier : {"MMC", "LMC", "RFS"}
    points : ndarray, shape (N, 3), optional
        The feature's points in any rigid frame (sizes do not depend on it); default ``feature.points``.
    gauss : CylinderFit, optional
        The least-squares cylinder of ``points`` when already fitted (reused; cylinders only).
    envelope : tuple of (str, CylinderFit), optional
        ``("mic" | "mcc", fit)``: that envelope of ``points`` over the default region when already
        fitted (the ASME toleranced axis), reused.

    Returns
    -------
    dict
        ``mating_size_mm`` (hole: MIC, shaft: MCC diameter) and ``minimum_material_size_mm`` (hole:
        MCC, shaft: MIC) -- the exact value, or None where only a bound was needed, given then as
        ``minimum_material_size_bound_mm`` / ``mating_size_bound_mm`` (an upper bound of an MCC, a
        lower one of an MIC) --, the limits, ``size_ok`` and ``bonus_low_mm`` / ``bonus_high_mm``
        (proven range of the bonus: the envelope's certificate bounds it).  Cylinders add the
        searched axis regions (``mating_region`` / ``minimum_material_region``).
    """
    pts = feature.points if points is None else points
    lo, hi = feature.diameter + feature.size_tolerance[0], feature.diameter + feature.size_tolerance[1]
    hole = feature.side == "internal"
    mating_name, minmat_name = ("mic", "mcc") if hole else ("mcc", "mic")
    exact_needed = {"MMC": mating_name, "LMC": minmat_name}.get(modifier)
    fits: dict[str, Any] = {}
    ranges: dict[str, tuple[float, float]] = {}
    out: dict[str, Any] = {}
    if feature.element == "cylinder":
        from pcmm_geo.fit import fit_cylinder

        gauss = fit_cylinder(pts) if gauss is None else gauss
        distances, heights = _axis_distances(pts, gauss)
        if envelope is not None:
            fits[envelope[0]] = envelope[1]
        # the side of the size check the modifier does not need: a free bound first
        cheap = {"mcc": (0.0, 2.0 * float(distances.max()))}
        surrounded = _surrounds(pts, gauss)
        if surrounded:
            cheap["mic"] = (2.0 * float(distances.min()), np.inf)
        for criterion in ("mic", "mcc"):
            if criterion in fits:
                continue
            decided = criterion in cheap and criterion != exact_needed and (
                cheap[criterion][0] >= lo if criterion == "mic" else cheap[criterion][1] <= hi)
            if decided:
                ranges[criterion] = cheap[criterion]
            else:
                fits[criterion] = _envelope(pts, criterion, gauss, distances, heights, surrounded)
    else:
        from pcmm_geo.fit import fit_sphere

        fits = {criterion: fit_sphere(pts, criterion=criterion) for criterion in ("mic", "mcc")}
    for criterion, fit in fits.items():
        ranges[criterion] = _diameter_range(fit, criterion == "mic")
    size_ok = ranges["mic"][0] >= lo and ranges["mcc"][1] <= hi
    mating, minmat = ranges[mating_name], ranges[minmat_name]
    mmc_size, lmc_size = (lo, hi) if hole else (hi, lo)
    if modifier == "MMC":
        bonus = sorted(abs(m - mmc_size) for m in mating)
    elif modifier == "LMC":
        bonus = sorted(abs(m - lmc_size) for m in minmat)
    else:
        bonus = [0.0, 0.0]
    for key, criterion in (("mating_size", mating_name), ("minimum_material_size", minmat_name)):
        fit = fits.get(criterion)
        out[f"{key}_mm"] = None if fit is None else 2.0 * float(fit.radius)
        if fit is None:
            out[f"{key}_bound_mm"] = ranges[criterion][0] if criterion == "mic" else ranges[criterion][1]
        elif feature.element == "cylinder":
            out[f"{key.replace('_size', '')}_region"] = fit.certificate.domain
    out.update({"size_limits_mm": [lo, hi], "size_ok": bool(size_ok),
                "bonus_low_mm": float(bonus[0]), "bonus_high_mm": float(bonus[1])})
    return out


def allowed_zone(feature: Any, tolerance_mm: float, modifier: str, details: dict[str, Any],
                 **fitted: Any) -> tuple[float, float, bool, float | None]:
    """The position zone a feature is allowed: ``(low, high, size_ok, bonus)`` (mm).

    ``tolerance_mm`` plus the proven range of the bonus of ``modifier`` (ASME Y14.5-2018 / ISO 2692:
    the departure of the actual size from MMC or LMC; 0 at RFS); ``size_ok`` False when the size is
    outside its limits (the characteristic then fails, never with a negative bonus).  The size
    evaluation (:func:`size_evaluation`, ``fitted`` passed on) is added to ``details``.
    """
    if modifier == "RFS":
        return tolerance_mm, tolerance_mm, True, None
    sizes = size_evaluation(feature, modifier, **fitted)
    size_ok = bool(sizes.pop("size_ok"))
    details.update(sizes)
    return (tolerance_mm + sizes["bonus_low_mm"], tolerance_mm + sizes["bonus_high_mm"], size_ok,
            sizes["bonus_low_mm"])
