"""Plain data of a CMM results file: features, point sets, characteristics, transforms, units.

One set of frozen dataclasses for every CMM format pcmm_geo reads (QIF 3.0, DMIS output,
CALYPSO characteristic tables, PC-DMIS XYZIJK text) and for the QIF writer.  The classes
follow QIF 3.0 (ISO 23952) where QIF has a concept and keep its vocabulary:

- :class:`FeatureDefinition`: ``<Type>FeatureDefinition`` (``InternalExternal``, nominal size);
- :class:`FeatureNominal`: ``<Type>FeatureNominal`` (nominal location, normal, axis);
- :class:`FeatureItem`: ``<Type>FeatureItem`` (``FeatureName``);
- :class:`MeasuredFeature`: ``<Type>FeatureMeasurement`` (the CMM's actuals, ``PointList``);
- :class:`MeasuredPointSet`: ``MeasuredPointSet`` (points, normals, ``Compensated``, ``ProbeRadius``);
- :class:`Characteristic`: ``<Type>Characteristic{Definition,Nominal,Item,Measurement}`` flattened
  into one record per measurement;
- :class:`Transform`: ``Transform``, ``ActualTransforms/Transform``, ``NominalTransform``;
- :class:`Units`: ``FileUnits/PrimaryUnits`` (what the file used);
- :class:`~pcmm_geo.io.cmm.document.CmmDocument`: ``QIFDocument`` (or a whole DMIS / CALYPSO file).

Units inside are always millimetres and radians: readers convert (inch files, degrees) and
:class:`Units` records what the file said.  Vectors are ``(3,)`` float64 arrays, point sets
``(N, 3)``; all arrays are read-only.  Ids are the file's QIF ids (formats without ids get
ids numbered from 1 in file order, their labels kept as names).

This module imports nothing of :mod:`pcmm_geo.fit`: fits are converted to and from these
classes above both layers.

Examples
--------
>>> import numpy as np
>>> circle = FeatureGeometry(location=np.array([1.0, 2.0, 0.0]), normal=np.array([0.0, 0.0, 1.0]),
...                          diameter=12.0)
>>> circle
FeatureGeometry(location=[1.0, 2.0, 0.0], normal=[0.0, 0.0, 1.0], diameter=12.0)
>>> move = Transform(id=1, rotation=np.eye(3), translation=np.array([0.0, 0.0, 5.0]))
>>> move.apply(np.array([[1.0, 2.0, 3.0]])).tolist()
[[1.0, 2.0, 8.0]]
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.elements import FEATURE_TYPES as ELEMENT_FEATURE_TYPES
from pcmm_geo.elements import FeatureType
from pcmm_geo.errors import InvalidInputError

__all__ = [
    "FEATURE_TYPES",
    "Characteristic",
    "CoordinateSystem",
    "FeatureDefinition",
    "FeatureGeometry",
    "FeatureItem",
    "FeatureNominal",
    "MeasuredFeature",
    "MeasuredPointSet",
    "MeasurementResults",
    "PointSetReference",
    "Tolerance",
    "Transform",
    "Units",
]

FloatArray = NDArray[np.float64]

#: feature types with a geometry pcmm_geo refits; other QIF types keep their snake_case name
#: (``EdgePointFeatureMeasurement`` -> ``"edge_point"``)
FEATURE_TYPES: tuple[FeatureType, ...] = ELEMENT_FEATURE_TYPES  # pcmm_geo.elements


def frozen_array(values: Any, shape: tuple[int | None, ...], what: str, dtype: Any = np.float64) -> NDArray[Any]:
    """``values`` as a read-only array of ``shape`` (None = any length); a copy only when needed."""
    array = np.asarray(values, dtype=dtype)
    if array.ndim != len(shape) or any(n is not None and n != m for n, m in zip(shape, array.shape, strict=True)):
        wanted = "(" + ", ".join("N" if n is None else str(n) for n in shape) + ")"
        raise InvalidInputError(what, f"an array of shape {wanted}", f"shape {array.shape}")
    if array.flags.writeable:
        array = array.view()
        array.flags.writeable = False
    return array


@record
class Units:
    """Units a file stated; values in the dataclasses are already converted to mm and rad.

    Attributes
    ----------
    linear_unit : str
        Name in the file (``"mm"``, ``"inch"``, ...).
    mm_per_linear_unit : float
        Factor applied to every length (25.4 for inch).
    angular_unit : str
        Name in the file (``"degree"``, ``"radian"``).
    rad_per_angular_unit : float
        Factor applied to every angle (pi / 180 for degrees).
    stated : bool
        False when the file gave no units and the format's default was assumed.
    """

    linear_unit: str = "mm"
    mm_per_linear_unit: float = 1.0
    angular_unit: str = "radian"
    rad_per_angular_unit: float = 1.0
    stated: bool = True


@record
class FeatureGeometry:
    """Geometry of a feature as a file states it (nominal or actual); absent quantities are None.

    Attributes
    ----------
    location : ndarray (3,) or None
        mm; QIF ``Location``, or ``Axis/AxisPoint`` of cylinders and cones.
    normal : ndarray (3,) or None
        Unit vector; QIF ``Normal`` (plane, circle, point; a line's optional normal).
    direction : ndarray (3,) or None
        Unit vector; QIF ``Direction`` of a line, ``Axis/Direction`` of cylinders and cones.
    diameter, diameter_min, diameter_max, length, width : float or None
        mm.
    half_angle : float or None
        rad; a cone's half apex angle (QIF ``FullAngle`` is halved).
    form : float or None
        mm; the form deviation the file reports with the feature.
    uncertainty : dict
        QIF ``combinedUncertainty`` by field name (``"diameter"``, ``"location"``, ...), mm or rad.
    """

    location: FloatArray | None = None
    normal: FloatArray | None = None
    direction: FloatArray | None = None
    diameter: float | None = None
    diameter_min: float | None = None
    diameter_max: float | None = None
    length: float | None = None
    width: float | None = None
    half_angle: float | None = None
    form: float | None = None
    uncertainty: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name in ("location", "normal", "direction"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, frozen_array(value, (3,), name))


@record
class FeatureDefinition:
    """What a feature is, independent of where: QIF ``<Type>FeatureDefinition``.

    ``internal_external`` is the QIF ``InternalExternal`` value verbatim (``"INTERNAL"``,
    ``"EXTERNAL"``, ``"NOT_APPLICABLE"``) or None when not stated; sizes in mm / rad.
    """

    id: int
    type: str
    qif_element: str = ""
    internal_external: str | None = None
    diameter: float | None = None
    length: float | None = None
    width: float | None = None
    half_angle: float | None = None


@record
class FeatureNominal:
    """Nominal placement of a feature: QIF ``<Type>FeatureNominal``."""

    id: int
    type: str
    definition_id: int | None
    geometry: FeatureGeometry
    qif_element: str = ""


@record
class FeatureItem:
    """A feature of the part to be inspected, with its name: QIF ``<Type>FeatureItem``."""

    id: int
    type: str
    name: str | None
    nominal_id: int | None
    qif_element: str = ""


@record
class PointSetReference:
    """Which points of a :class:`MeasuredPointSet` a feature used, as a 0-based half-open slice.

    QIF ``WholePointSetId`` is ``start=0, stop=None``; ``RangePointSetId range="a b"`` (1-based,
    inclusive) is ``start=a-1, stop=b``; ``SinglePointSetId index="i"`` is ``start=i-1, stop=i``.
    """

    point_set_id: int
    start: int = 0
    stop: int | None = None

    def indices(self, count: int) -> slice:
        """The slice of a set of ``count`` points."""
        return slice(self.start, count if self.stop is None else self.stop)


@record
class MeasuredPointSet:
    """Measured points of one set: QIF ``MeasuredPointSet`` (or a PC-DMIS XYZIJK file).

    Attributes
    ----------
    id : int or None
        QIF id (None for points combined from several sets by :meth:`~pcmm_geo.io.cmm.document.CmmDocument.points_of`).
    points : ndarray (N, 3)
        mm, as stored (probe-ball centers when ``compensated`` is False).
    normals : ndarray (N, 3) or None
        Unit vectors per point (QIF ``Normals``, PC-DMIS IJK), where given.
    compensated : bool or None
        QIF ``Compensated`` (or the common value of per-point ``Compensations``); None when the
        format does not say or the per-point flags differ (then see ``compensated_per_point``).
    compensated_per_point : ndarray (N,) of bool or None
        Per-point flags when the file gives them and they differ.
    probe_radius : float or None
        mm; QIF ``ProbeRadius`` (or the common value of per-point ``ProbeRadii``).
    probe_radii : ndarray (N,) or None
        mm; per-point radii when the file gives them and they differ.
    transform_id, coordinate_system_id : int or None
        QIF ``TranformId`` / ``CoordinateSystemId``: the points are not in the common frame.
    results_id : int or None
        The ``MeasurementResults`` holding the set.
    """

    id: int | None
    points: FloatArray
    normals: FloatArray | None = None
    compensated: bool | None = None
    compensated_per_point: NDArray[np.bool_] | None = None
    probe_radius: float | None = None
    probe_radii: FloatArray | None = None
    transform_id: int | None = None
    coordinate_system_id: int | None = None
    results_id: int | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "points", frozen_array(self.points, (None, 3), "points"))
        n = len(self.points)
        if self.normals is not None:
            object.__setattr__(self, "normals", frozen_array(self.normals, (n, 3), "normals"))
        if self.compensated_per_point is not None:
            flags = frozen_array(self.compensated_per_point, (n,), "compensated_per_point", dtype=bool)
            object.__setattr__(self, "compensated_per_point", flags)
        if self.probe_radii is not None:
            object.__setattr__(self, "probe_radii", frozen_array(self.probe_radii, (n,), "probe_radii"))

    def __len__(self) -> int:
        return len(self.points)


@record
class MeasuredFeature:
    """A feature as the CMM measured it: QIF ``<Type>FeatureMeasurement`` (DMIS ``FA(label)``).

    Attributes
    ----------
    id : int
        QIF id of the feature measurement.
    type : str
        ``"circle"``, ``"cylinder"``, ... (:data:`FEATURE_TYPES`) or another QIF type in snake_case.
    name : str or None
        ``FeatureName`` of the measurement, else of its item.
    actual : FeatureGeometry
        The CMM's reported actuals (mm, rad).
    item_id : int or None
        ``FeatureItemId``.
    internal_external : str or None
        From the feature's definition (through item and nominal) or the format's own flag
        (DMIS ``INNER``/``OUTER``): ``"INTERNAL"``, ``"EXTERNAL"``, ``"NOT_APPLICABLE"`` or None.
    point_set_refs : tuple of PointSetReference
        The ``PointList``, in order (empty: no points).
    substitute_algorithm : str or None
        QIF ``SubstituteFeatureAlgorithmEnum`` (``"LEASTSQUARES"``, ``"MINMAX"``, ...) or other text.
    transform_id : int or None
        ``ActualTransformId`` (the actual frame the feature originated in; its numbers are in the
        common frame all the same, QIF 3.0 Features.xsd).
    results_id : int or None
        The ``MeasurementResults`` holding the measurement.
    problems : tuple of str
        What the reader could not use and left out (e.g. a ``PointList`` naming an element that
        is not a point set), each naming the QIF id and element path.
    """

    id: int
    type: str
    name: str | None
    actual: FeatureGeometry
    qif_element: str = ""
    item_id: int | None = None
    internal_external: str | None = None
    point_set_refs: tuple[PointSetReference, ...] = ()
    substitute_algorithm: str | None = None
    transform_id: int | None = None
    results_id: int | None = None
    problems: tuple[str, ...] = ()

    @property
    def material_side(self) -> str | None:
        """``"internal"`` / ``"external"`` from ``internal_external``, else None (not stated or not applicable)."""
        return {"INTERNAL": "internal", "EXTERNAL": "external"}.get(self.internal_external or "")


@record
class Tolerance:
    """A characteristic's tolerance as the file states it (mm or rad).

    ``max_value`` / ``min_value`` are deviations from the nominal (QIF ``DefinedAsLimit`` false)
    or absolute limits (true); ``value`` is a geometric tolerance zone (QIF ``ToleranceValue``).
    """

    max_value: float | None = None
    min_value: float | None = None
    defined_as_limit: bool = False
    value: float | None = None

    def limits(self, nominal: float | None) -> tuple[float | None, float | None]:
        """(lower, upper) absolute limits; a geometric zone gives (None, value)."""
        if self.value is not None:
            return None, self.value
        if self.defined_as_limit:
            return self.min_value, self.max_value
        if nominal is None:
            return None, None
        return (None if self.min_value is None else nominal + self.min_value,
                None if self.max_value is None else nominal + self.max_value)


@record
class Characteristic:
    """One measured characteristic: QIF definition, nominal, item and measurement in one record.

    Attributes
    ----------
    id : int
        QIF id of the ``<Type>CharacteristicMeasurement`` (or a running number).
    type : str
        snake_case of the QIF type: ``"diameter"``, ``"circularity"``, ``"flatness"``, ``"position"``, ...
    name : str or None
        ``Name`` of the item (DMIS / CALYPSO label).
    value : float or None
        The measured value (mm, or rad for angular types).
    nominal : float or None
        QIF ``TargetValue``.
    deviation : float or None
        The deviation from nominal where the file states it (CALYPSO's ``deviation`` column, a
        DMIS size tolerance read with ``size_values="deviation"``); None where it is not stated.
    tolerance : Tolerance or None
    status : str or None
        QIF ``CharacteristicStatusEnum`` verbatim (``"PASS"``, ``"FAIL"``, ``"INDETERMINATE"``,
        ``"NOT_ANALYZED"``, ...) or ``OtherCharacteristicStatus`` text.
    uncertainty : float or None
        ``combinedUncertainty`` of the value (mm / rad).
    quantity : str
        ``"linear"``, ``"angular"`` or ``"other"`` (how the value was converted).
    zone_shape : str or None
        snake_case of the definition's ``ZoneShape`` child (``"diametrical"``, ``"non_diametrical"``,
        ``"planar"``, ...); the writer needs it for straightness (a 3-D line's cylinder zone is
        ``"diametrical"``, two parallel lines ``"non_diametrical"``).
    feature_measurement_ids, feature_item_ids : tuple of int
    item_id, nominal_id, definition_id, results_id : int or None
    """

    id: int
    type: str
    name: str | None = None
    value: float | None = None
    nominal: float | None = None
    deviation: float | None = None
    tolerance: Tolerance | None = None
    status: str | None = None
    uncertainty: float | None = None
    quantity: str = "linear"
    zone_shape: str | None = None
    feature_measurement_ids: tuple[int, ...] = ()
    feature_item_ids: tuple[int, ...] = ()
    qif_element: str = ""
    item_id: int | None = None
    nominal_id: int | None = None
    definition_id: int | None = None
    results_id: int | None = None


@record
class Transform:
    """A rigid transform ``X = rotation @ x + translation`` (QIF ``TransformMatrixType``).

    QIF states it as the rows-turned-columns ``XDirection``, ``YDirection``, ``ZDirection``
    (the columns of ``rotation``) and ``Origin`` (``translation``, mm).  It maps coordinates
    in the transform's own frame (a point set's frame, a coordinate system, an actual DRF) into
    the document's common frame.

    Attributes
    ----------
    id : int or None
    rotation : ndarray (3, 3)
    translation : ndarray (3,)
    name : str or None
    role : str
        ``"transform"`` (document ``Transforms``), ``"actual"`` (``ActualTransforms``) or
        ``"nominal"`` (a coordinate system's ``NominalTransform``).
    """

    id: int | None
    rotation: FloatArray
    translation: FloatArray
    name: str | None = None
    role: str = "transform"

    def __post_init__(self) -> None:
        object.__setattr__(self, "rotation", frozen_array(self.rotation, (3, 3), "rotation"))
        object.__setattr__(self, "translation", frozen_array(self.translation, (3,), "translation"))

    @property
    def matrix(self) -> FloatArray:
        """The homogeneous ``(4, 4)`` matrix."""
        matrix = np.eye(4)
        matrix[:3, :3] = self.rotation
        matrix[:3, 3] = self.translation
        return matrix

    def apply(self, points: FloatArray) -> FloatArray:
        """Points ``(..., 3)`` mapped into the common frame."""
        return np.asarray(points, dtype=np.float64) @ self.rotation.T + self.translation

    def apply_to_vectors(self, vectors: FloatArray) -> FloatArray:
        """Directions ``(..., 3)`` rotated into the common frame."""
        return np.asarray(vectors, dtype=np.float64) @ self.rotation.T


@record
class CoordinateSystem:
    """A QIF ``CoordinateSystem``: its nominal transform and the actual transform associated with it."""

    id: int
    name: str | None = None
    nominal_transform: Transform | None = None
    actual_transform_id: int | None = None


@record
class MeasurementResults:
    """One QIF ``MeasurementResults`` (one measured part / run).

    ``serial_numbers`` are those of the ``ActualComponent`` s it names (``ActualComponentIds``):
    what tells the samples of a multi-sample file apart; ``inspection_status`` its verdict
    (``PASS``, ``FAIL``, ...), possibly all a status-only file states.
    """

    id: int | None
    features: tuple[MeasuredFeature, ...] = ()
    point_sets: Mapping[int, MeasuredPointSet] = field(default_factory=dict)
    characteristics: tuple[Characteristic, ...] = ()
    actual_transforms: Mapping[int, Transform] = field(default_factory=dict)
    inspection_status: str | None = None
    serial_numbers: tuple[str, ...] = ()
