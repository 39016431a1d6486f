"""The points a feature measurement used, joined from its point-set references and put in the common frame."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from pcmm_geo.errors import QifError

if TYPE_CHECKING:
    from pcmm_geo.io.cmm.model import CmmDocument, MeasuredFeature, MeasuredPointSet, Transform

__all__ = ["feature_points", "transform_of_point_set"]


def transform_of_point_set(document: CmmDocument, point_set: MeasuredPointSet) -> Transform | None:
    """The transform that maps a point set into the common frame (None: it is in the common frame).

    A ``TranformId`` names a document ``Transform`` or an actual transform of the same results;
    a ``CoordinateSystemId`` uses the actual transform associated with that coordinate system
    when the document gives one, else its nominal transform.
    """
    results = next((r for r in document.results if r.id == point_set.results_id), None)
    actuals = {} if results is None else results.actual_transforms
    element = "MeasuredPointSet"
    if point_set.transform_id is not None:
        transform = document.transforms.get(point_set.transform_id) or actuals.get(point_set.transform_id)
        if transform is None:
            raise QifError(document.source, f"TranformId {point_set.transform_id} names no transform",
                           qif_id=point_set.id, element=element)
        return transform
    if point_set.coordinate_system_id is not None:
        system = document.coordinate_systems.get(point_set.coordinate_system_id)
        if system is None:
            raise QifError(document.source, f"CoordinateSystemId {point_set.coordinate_system_id} names no "
                           "coordinate system", qif_id=point_set.id, element=element)
        if system.actual_transform_id is not None and system.actual_transform_id in actuals:
            return actuals[system.actual_transform_id]
        if system.nominal_transform is None:
            raise QifError(document.source, f"coordinate system {system.id} has neither an actual nor a nominal "
                           "transform: the points cannot be put in the common frame", qif_id=point_set.id,
                           element=element)
        return system.nominal_transform
    return None


def feature_points(document: CmmDocument, feature: MeasuredFeature, frame: str) -> MeasuredPointSet | None:
    """See :meth:`pcmm_geo.io.cmm.model.CmmDocument.points_of`."""
    from pcmm_geo.io.cmm.model import MeasuredPointSet

    if frame not in ("common", "stored"):
        raise ValueError(f"frame: expected 'common' or 'stored', got {frame!r}")
    if not feature.point_set_refs:
        return None
    sets = document.point_sets
    parts = []
    for ref in feature.point_set_refs:
        point_set = sets.get(ref.point_set_id)
        if point_set is None:
            raise QifError(document.source, f"PointList names point set {ref.point_set_id}, which the document "
                           "does not hold", qif_id=feature.id, element=feature.qif_element or "FeatureMeasurement")
        chosen = ref.indices(len(point_set))
        transform = transform_of_point_set(document, point_set) if frame == "common" else None
        points = point_set.points[chosen]
        normals = None if point_set.normals is None else point_set.normals[chosen]
        if transform is not None:
            points = transform.apply(points)
            normals = None if normals is None else transform.apply_to_vectors(normals)
        parts.append((point_set, chosen, points, normals, transform))
    if len(parts) == 1 and parts[0][1] == slice(0, len(parts[0][0])) and parts[0][4] is None:
        return parts[0][0]
    n_each = [len(p[2]) for p in parts]
    flags = np.concatenate([_per_point(p[0].compensated_per_point, p[0].compensated, p[1], n)
                            for p, n in zip(parts, n_each, strict=True)])
    radii = np.concatenate([_per_point(p[0].probe_radii, p[0].probe_radius, p[1], n)
                            for p, n in zip(parts, n_each, strict=True)])
    has_normals = all(p[3] is not None for p in parts)
    common_flag = _common(flags)
    common_radius = _common(radii)
    return MeasuredPointSet(
        id=parts[0][0].id if len({p[0].id for p in parts}) == 1 else None,
        points=np.concatenate([p[2] for p in parts]),
        normals=np.concatenate([p[3] for p in parts]) if has_normals else None,
        compensated=None if common_flag is None else bool(common_flag),
        compensated_per_point=None if common_flag is not None or _any_unknown(flags) else flags.astype(bool),
        probe_radius=common_radius,
        probe_radii=None if common_radius is not None or np.isnan(radii).any() else radii,
        results_id=parts[0][0].results_id,
    )


def _per_point(per_point: np.ndarray | None, shared: object, chosen: slice, n: int) -> np.ndarray:
    if per_point is not None:
        return np.asarray(per_point, dtype=float)[chosen]
    return np.full(n, np.nan if shared is None else float(shared))  # type: ignore[arg-type]


def _common(values: np.ndarray) -> float | None:
    if values.size == 0 or np.isnan(values).any() or not np.all(values == values[0]):
        return None
    return float(values[0])


def _any_unknown(values: np.ndarray) -> bool:
    return bool(np.isnan(values).any())
