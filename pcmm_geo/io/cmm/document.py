"""A whole CMM results file: :class:`CmmDocument`, its look-ups and the points of a feature in the common frame."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import field

import numpy as np

from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError, QifError
from pcmm_geo.io.cmm.model import (
    Characteristic,
    CoordinateSystem,
    FeatureDefinition,
    FeatureItem,
    FeatureNominal,
    MeasuredFeature,
    MeasuredPointSet,
    MeasurementResults,
    Transform,
    Units,
)

__all__ = ["CmmDocument", "feature_points", "transform_of_point_set"]


@record
class CmmDocument:
    """A CMM results file (QIF document, DMIS output, CALYPSO table) in mm and rad.

    Attributes
    ----------
    source : str
        The file read ('' for a document built in memory).
    format : str
        ``"qif"``, ``"dmis"``, ``"calypso"`` or ``"pcdmis"``.
    version : str or None
        QIF ``versionQIF`` (e.g. ``"3.0.0"``).
    units : Units
    feature_definitions, feature_nominals, feature_items : dict id -> record, in file order
    results : tuple of MeasurementResults
    transforms : dict id -> Transform
        Document-level QIF ``Transforms``.
    coordinate_systems : dict id -> CoordinateSystem
    application : str or None
        Software that wrote the file.
    problems : tuple of str
        Everything the reader left out, each naming the QIF id and element path.
    """

    source: str
    format: str
    units: Units = field(default_factory=Units)
    version: str | None = None
    feature_definitions: Mapping[int, FeatureDefinition] = field(default_factory=dict)
    feature_nominals: Mapping[int, FeatureNominal] = field(default_factory=dict)
    feature_items: Mapping[int, FeatureItem] = field(default_factory=dict)
    results: tuple[MeasurementResults, ...] = ()
    transforms: Mapping[int, Transform] = field(default_factory=dict)
    coordinate_systems: Mapping[int, CoordinateSystem] = field(default_factory=dict)
    application: str | None = None
    problems: tuple[str, ...] = ()

    @property
    def measured_features(self) -> tuple[MeasuredFeature, ...]:
        """Every feature measurement of every results set, in file order."""
        return tuple(f for r in self.results for f in r.features)

    @property
    def characteristics(self) -> tuple[Characteristic, ...]:
        """Every characteristic measurement of every results set, in file order."""
        return tuple(c for r in self.results for c in r.characteristics)

    @property
    def point_sets(self) -> dict[int, MeasuredPointSet]:
        """Every measured point set by id."""
        return {k: v for r in self.results for k, v in r.point_sets.items()}

    def feature(self, key: int | str) -> MeasuredFeature:
        """The feature measurement with QIF id ``key`` (int) or name ``key`` (str; must be unique)."""
        found = [f for f in self.measured_features if (f.id == key if isinstance(key, int) else f.name == key)]
        if len(found) != 1:
            names = ", ".join(str(f.name if isinstance(key, str) else f.id) for f in self.measured_features)
            raise InvalidInputError("feature", f"one feature measurement {key!r} (one of: {names})",
                                    f"{len(found)} matches")
        return found[0]

    def item_of(self, feature: MeasuredFeature) -> FeatureItem | None:
        """The feature item a measurement refers to (None when it names none)."""
        return None if feature.item_id is None else self.feature_items.get(feature.item_id)

    def nominal_of(self, feature: MeasuredFeature) -> FeatureNominal | None:
        """The nominal of a measurement (through its item), or None."""
        item = self.item_of(feature)
        return None if item is None or item.nominal_id is None else self.feature_nominals.get(item.nominal_id)

    def definition_of(self, feature: MeasuredFeature) -> FeatureDefinition | None:
        """The definition of a measurement (through item and nominal), or None."""
        nominal = self.nominal_of(feature)
        if nominal is None or nominal.definition_id is None:
            return None
        return self.feature_definitions.get(nominal.definition_id)

    def characteristics_of(self, feature: MeasuredFeature) -> tuple[Characteristic, ...]:
        """Characteristic measurements that name this feature measurement."""
        return tuple(c for c in self.characteristics if feature.id in c.feature_measurement_ids)

    def points_of(self, feature: MeasuredFeature, *, frame: str = "common") -> MeasuredPointSet | None:
        """The points a feature measurement used (its ``PointList`` joined in order), or None.

        Parameters
        ----------
        feature : MeasuredFeature
        frame : {"common", "stored"}
            ``"common"`` maps points and normals of a set with a ``TranformId`` or
            ``CoordinateSystemId`` into the document's common frame (the frame of the actuals);
            ``"stored"`` returns them as written.

        Returns
        -------
        MeasuredPointSet or None
            The set itself when the feature uses one whole set; else a new set with ``id=None``
            and per-point flags / radii where the parts differ.  None when the feature has no points.
        """
        return feature_points(self, feature, frame)


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
    """See :meth:`CmmDocument.points_of`."""
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
