"""Read QIF 3.0 results documents (ISO 23952) into :mod:`pcmm_geo.io.cmm` dataclasses, streamed and guarded.

:func:`read_qif` reads feature definitions, nominals and items, every ``MeasurementResults``
(measured features with their point lists, measured point sets, characteristic measurements,
actual transforms), document transforms and coordinate systems, and the file's units, and
converts every length to mm and every angle to rad.

Lenient about what it does not use (unknown elements, vendor extensions, schema details real
files get wrong are skipped); strict about what it uses: a dangling id, a point ``count`` that
disagrees with the numbers, a non-numeric or non-finite coordinate, a point range outside its
set, a unit it does not know, a non-unit direction are each a :class:`~pcmm_geo.errors.QifError`
naming the QIF id, the element path and the line.  A reference to an element of the wrong kind
(schema-valid, since QIF keys only check that the id exists) is left out and recorded in
``problems``, never guessed.

The file is untrusted: :mod:`pcmm_geo.io.cmm.qif._xml` refuses DTDs, entities and external
references (nothing is fetched), nesting deeper than ``max_depth`` and files over ``max_bytes``,
and streams point lists straight into one float64 array each.

Examples
--------
>>> import pathlib, tempfile
>>> path = pathlib.Path(tempfile.mkdtemp()) / "tiny.qif"
>>> _ = path.write_text('''<QIFDocument xmlns="http://qifstandards.org/xsd/qif3" versionQIF="3.0.0">
...  <FileUnits><PrimaryUnits><LinearUnit><SIUnitName>meter</SIUnitName><UnitName>inch</UnitName>
...  <UnitConversion><Factor>0.0254</Factor></UnitConversion></LinearUnit></PrimaryUnits></FileUnits>
...  <Results><MeasurementResultsSet n="1"><MeasurementResults id="1">
...   <MeasuredFeatures n="1"><SphereFeatureMeasurement id="2"><FeatureName>S1</FeatureName>
...     <PointList n="1"><WholePointSetId>3</WholePointSetId></PointList>
...     <Location>1 0 0</Location><Diameter>1</Diameter></SphereFeatureMeasurement></MeasuredFeatures>
...   <MeasuredPointSets n="1"><MeasuredPointSet id="3" count="2"><Points>0 0 0 1 1 1</Points>
...     <Compensated>false</Compensated><ProbeRadius>0.1</ProbeRadius></MeasuredPointSet></MeasuredPointSets>
...  </MeasurementResults></MeasurementResultsSet></Results></QIFDocument>''')
>>> document = read_qif(path)
>>> sphere = document.feature("S1")
>>> sphere.type, sphere.actual.diameter, sphere.actual.location.tolist()
('sphere', 25.4, [25.4, 0.0, 0.0])
>>> points = document.points_of(sphere)
>>> points.points.tolist(), points.compensated, round(points.probe_radius, 6)
([[0.0, 0.0, 0.0], [25.4, 25.4, 25.4]], False, 2.54)
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from pcmm_geo.errors import InvalidInputError, QifError
from pcmm_geo.io.cmm.document import CmmDocument
from pcmm_geo.io.cmm.model import (
    CoordinateSystem,
    FeatureDefinition,
    FeatureItem,
    FeatureNominal,
    MeasuredFeature,
    MeasuredPointSet,
    MeasurementResults,
    PointSetReference,
    Transform,
)
from pcmm_geo.io.cmm.qif._characteristics import read_characteristics
from pcmm_geo.io.cmm.qif._values import (
    QIF_ANGLE_UNITS,
    QIF_LENGTH_UNITS,
    QifContext,
    short_id,
    snake_type,
    xs_integer,
)
from pcmm_geo.io.cmm.qif._xml import (
    DEFAULT_MAX_BYTES,
    DEFAULT_MAX_DEPTH,
    DEFAULT_MAX_ELEMENTS,
    DuplicateElementError,
    Node,
    NumberList,
    NumberListFailure,
    parse_xml,
)
from pcmm_geo.io.cmm.settings import SpellSetting, python_setting

__all__ = ["QIF3_NAMESPACE", "read_qif"]

QIF3_NAMESPACE = "http://qifstandards.org/xsd/qif3"
#: elements of a MeasuredPointSet read as streamed number lists -> numbers per point
_STREAMED = {"Points": 3, "Normals": 3, "ProbeRadii": 1, "Compensations": 1}
_BINARY = ("BinaryPoints", "BinaryNormals", "BinaryCompensated", "BinaryProbeRadii")
#: a number in a text list takes at least two bytes ("0 ")
_MIN_BYTES_PER_NUMBER = 2
_ORTHONORMAL_TOLERANCE = 1e-6


def read_qif(
    path: str | Path, *, max_bytes: int = DEFAULT_MAX_BYTES, max_depth: int = DEFAULT_MAX_DEPTH,
    units: str | None = None, angle_unit: str | None = None, spell_setting: SpellSetting = python_setting,
    max_elements: int = DEFAULT_MAX_ELEMENTS,
) -> CmmDocument:
    """Read a QIF 3.0 document (see the module docstring).

    Parameters
    ----------
    path : str or Path
        The ``.qif`` file.
    max_bytes : int
        Largest file accepted (default 1 GiB; raise it for scanner-size point clouds).
    max_depth : int
        Deepest element nesting accepted (default 64).
    max_elements : int
        Most elements accepted (default 10^6, some 250 MB of tree): a file of millions of empty
        elements is refused before its tree fills the memory.
    units : {"mm", "cm", "m", "inch", "feet"} or None
        Length unit of a file without ``FileUnits`` (the QIF 3.0 schema states no default; mm is
        assumed, and said so in ``problems``, when None).  Refused for a file that states its units.
    angle_unit : {"degree", "radian"} or None
        Angle unit of a file without ``FileUnits`` (degree assumed when None).
    spell_setting : callable
        How a size refusal names ``max_bytes`` (:mod:`pcmm_geo.io.cmm.settings`; the command
        line passes its option name).

    Returns
    -------
    CmmDocument
        ``format="qif"``; lengths in mm, angles in rad, the file's units in ``units``.

    Raises
    ------
    QifError
        A dangling id, a ``count`` that disagrees with the points, a non-numeric coordinate, an
        unknown unit, a document that is not QIF 3 -- naming the QIF id and element path.
    UnsafeXmlError
        DTD, entity or external reference, too deep, too large (nothing is fetched).
    FileFormatError
        Not well-formed XML or not readable.
    MissingDependencyError
        defusedxml is not installed (``pip install 'pcmm_geo[qif]'``).
    """
    check_units(units, angle_unit, spell_setting)
    context, root, namespace = parse_qif_tree(path, max_bytes=max_bytes, max_depth=max_depth,
                                              max_elements=max_elements, spell_setting=spell_setting)
    try:
        return _read_document(context, root, namespace, units, angle_unit)
    except DuplicateElementError as exc:
        raise context.error(exc.second, str(exc)) from None


def check_units(units: str | None, angle_unit: str | None, spell_setting: SpellSetting) -> None:
    """Refuse a ``units`` / ``angle_unit`` QIF does not know (:class:`~pcmm_geo.errors.InvalidInputError`)."""
    for value, allowed, what in ((units, QIF_LENGTH_UNITS, "units"), (angle_unit, QIF_ANGLE_UNITS, "angle_unit")):
        if value is not None and value not in allowed:
            raise InvalidInputError(spell_setting(what), f"one of {', '.join(allowed)}", repr(value))


def parse_qif_tree(path: str | Path, *, max_bytes: int, max_depth: int, max_elements: int,
                   spell_setting: SpellSetting) -> tuple[QifContext, Node, str | None]:
    """The bounded, screened tree of a QIF file and the context its readers share (every QIF reader's first step).

    Point lists are streamed and checked as they arrive (a bad one is a :class:`~pcmm_geo.errors.QifError`
    naming its set); the tree is then checked to be a QIF 3 document and its ids indexed.
    """
    name = str(path)
    try:
        size = os.stat(path).st_size
    except OSError:
        size = 0  # parse_xml names the problem
    try:
        root, namespace = parse_xml(path, max_bytes=max_bytes, max_depth=max_depth,
                                    stream_rule=lambda node: _stream_rule(name, size, node),
                                    spell_setting=spell_setting, max_elements=max_elements)
    except NumberListFailure as failure:
        node = failure.node
        set_id = short_id(node.parent.attrib.get("id")) if node.parent is not None else None
        raise QifError(name, failure.list_reason, qif_id=set_id, element=node.path(), line=failure.line) from None
    context = QifContext(name, spell=spell_setting)
    try:
        _check_document(context, root, namespace)
        _index_ids(context, root)
    except DuplicateElementError as exc:
        raise context.error(exc.second, str(exc)) from None
    return context, root, namespace


def _read_document(context: QifContext, root: Node, namespace: str | None, units: str | None,
                   angle_unit: str | None) -> CmmDocument:
    name = context.path
    context.read_units(root, units=units, angle_unit=angle_unit)
    definitions, nominals, items = _read_features(context, root.child("Features"))
    transforms = {}
    transforms_node = root.child("Transforms")
    for node in [] if transforms_node is None else transforms_node.all("Transform"):
        transform = _transform(context, node, "transform")
        transforms[transform.id] = transform  # type: ignore[index]
    systems = _coordinate_systems(context, root.child("CoordinateSystems"))
    results = []
    results_node = root.child("Results")
    sets_node = None if results_node is None else results_node.child("MeasurementResultsSet")
    for results_element in [] if sets_node is None else sets_node.all("MeasurementResults"):
        results.append(_read_results(context, results_element, definitions, nominals, items, systems))
    application = root.child("Header")
    application = None if application is None else application.child("Application")
    return CmmDocument(
        source=name, format="qif", units=context.units(), version=root.attrib.get("versionQIF"),
        feature_definitions=definitions, feature_nominals=nominals, feature_items=items, results=tuple(results),
        transforms=transforms, coordinate_systems=systems,
        application=None if application is None else context.text(application.child("Name")),
        problems=tuple(context.problems),
    )


def _stream_rule(path: str, size: int, node: Node) -> NumberList | None:
    parent = node.parent
    if parent is None or parent.tag != "MeasuredPointSet":
        return None
    where = {"qif_id": short_id(parent.attrib.get("id")), "element": node.path(), "line": node.line or None}
    if node.tag in _BINARY:
        raise QifError(path, f"{node.tag}: QIF 3.0 does not state the byte order of binary arrays; pcmm_geo does "
                       "not guess it (write the points as text: Points, Normals)", **where)
    per_point = _STREAMED.get(node.tag)
    if per_point is None:
        return None
    count_text = parent.attrib.get("count")
    if count_text is None:
        return NumberList(None, boolean=node.tag == "Compensations")
    try:
        count = xs_integer(count_text)
    except ValueError:
        raise QifError(path, f"count: expected an integer, got {count_text[:40]!r}", qif_id=where["qif_id"],
                       element=parent.path(), line=parent.line or None) from None
    if count < 0 or (size and count * per_point * _MIN_BYTES_PER_NUMBER > size):
        raise QifError(path, f"count {count} cannot be right: {count * per_point} numbers do not fit in a file of "
                       f"{size} bytes", qif_id=where["qif_id"], element=parent.path(), line=parent.line or None)
    return NumberList(count * per_point, boolean=node.tag == "Compensations")


def _check_document(context: QifContext, root: Node, namespace: str | None) -> None:
    if root.tag != "QIFDocument":
        raise context.error(root, f"expected a QIFDocument, got the XML element {root.tag}")
    version = root.attrib.get("versionQIF", "")
    if namespace not in (QIF3_NAMESPACE, None) or (version and not version.startswith("3")):
        raise context.error(root, f"expected a QIF 3 document (namespace {QIF3_NAMESPACE}), got namespace "
                            f"{namespace!r}, versionQIF {version!r}")


def _index_ids(context: QifContext, root: Node) -> None:
    stack = [root]
    while stack:
        node = stack.pop()
        if "id" in node.attrib:
            key = context.id_of(node)
            if key in context.ids:
                first = context.ids[key]
                raise context.error(node, f"id {key} is used twice (also by {first.tag} on line {first.line})")
            context.ids[key] = node
        stack.extend(reversed(node.children))


def _read_features(context: QifContext, features: Node | None) -> tuple[dict, dict, dict]:  # type: ignore[type-arg]
    definitions: dict[int, FeatureDefinition] = {}
    nominals: dict[int, FeatureNominal] = {}
    items: dict[int, FeatureItem] = {}
    if features is None:
        return definitions, nominals, items
    group = features.child("FeatureDefinitions")
    for node in [] if group is None else group.children:
        if not node.tag.endswith("FeatureDefinition"):
            continue
        geometry = context.geometry(node)
        key = context.id_of(node)
        definitions[key] = FeatureDefinition(
            id=key, type=snake_type(node.tag, "FeatureDefinition"), qif_element=node.tag,
            internal_external=context.text(node.child("InternalExternal")), diameter=geometry.diameter,
            length=geometry.length, width=geometry.width, half_angle=geometry.half_angle)
    group = features.child("FeatureNominals")
    for node in [] if group is None else group.children:
        if not node.tag.endswith("FeatureNominal"):
            continue
        key = context.id_of(node)
        nominals[key] = FeatureNominal(
            id=key, type=snake_type(node.tag, "FeatureNominal"), qif_element=node.tag,
            definition_id=context.reference(node.child("FeatureDefinitionId"), ("FeatureDefinition",)),
            geometry=context.geometry(node))
    group = features.child("FeatureItems")
    for node in [] if group is None else group.children:
        if not node.tag.endswith("FeatureItem"):
            continue
        key = context.id_of(node)
        items[key] = FeatureItem(
            id=key, type=snake_type(node.tag, "FeatureItem"), qif_element=node.tag,
            name=context.text(node.child("FeatureName")),
            nominal_id=context.reference(node.child("FeatureNominalId"), ("FeatureNominal",)))
    return definitions, nominals, items


def _transform(context: QifContext, node: Node, role: str) -> Transform:
    rotation = np.eye(3)
    rotation_node = node.child("Rotation")
    if rotation_node is not None:
        for column, tag in enumerate(("XDirection", "YDirection", "ZDirection")):
            axis = rotation_node.child(tag)
            if axis is None:
                raise context.error(rotation_node, f"expected {tag}")
            rotation[:, column] = context.unit_vector(axis)
        error = float(np.abs(rotation.T @ rotation - np.eye(3)).max())
        if error > _ORTHONORMAL_TOLERANCE or np.linalg.det(rotation) < 0:
            raise context.error(rotation_node, "expected a right-handed orthonormal rotation (XDirection, YDirection, "
                                f"ZDirection), got one off by {error:.3g}")
    origin = node.child("Origin")
    translation = np.zeros(3) if origin is None else context.point(origin)
    return Transform(id=context.id_of(node) if "id" in node.attrib else None, rotation=rotation,
                     translation=translation, name=context.text(node.child("Name")), role=role)


def _coordinate_systems(context: QifContext, group: Node | None) -> dict[int, CoordinateSystem]:
    systems = {}
    for node in [] if group is None else group.all("CoordinateSystem"):
        key = context.id_of(node)
        nominal = node.child("NominalTransform")
        systems[key] = CoordinateSystem(id=key, name=context.text(node.child("Name")),
                                        nominal_transform=None if nominal is None else _transform(context, nominal,
                                                                                                  "nominal"))
    return systems


def _read_results(context: QifContext, node: Node, definitions: dict, nominals: dict, items: dict,  # type: ignore[type-arg]
                  systems: dict[int, CoordinateSystem]) -> MeasurementResults:
    results_id = context.id_of(node) if "id" in node.attrib else None
    point_sets = {}
    group = node.child("MeasuredPointSets")
    for set_node in [] if group is None else group.all("MeasuredPointSet"):
        point_set = _point_set(context, set_node, results_id)
        point_sets[point_set.id] = point_set
    features = []
    group = node.child("MeasuredFeatures")
    for feature_node in [] if group is None else group.children:
        if feature_node.tag.endswith("FeatureMeasurement"):
            features.append(_feature(context, feature_node, results_id, point_sets, definitions, nominals, items))
    actuals = {}
    group = node.child("ActualTransforms")
    for transform_node in [] if group is None else group.all("Transform"):
        transform = _transform(context, transform_node, "actual")
        actuals[transform.id] = transform
    group = node.child("CoordinateSystemActualTransformAssociations")
    for association in [] if group is None else group.all("CoordinateSystemActualTransformAssociation"):
        system_id = context.reference(association.child("CoordinateSystemId"), ("CoordinateSystem",))
        transform_id = context.reference(association.child("ActualTransformId"), ("Transform",))
        if system_id is not None and system_id in systems:
            old = systems[system_id]
            systems[system_id] = CoordinateSystem(id=old.id, name=old.name, nominal_transform=old.nominal_transform,
                                                  actual_transform_id=transform_id)
    status = node.child("InspectionStatus")
    serials = []
    group = node.child("ActualComponentIds")
    for id_node in [] if group is None else group.all("Id"):
        component = context.reference(id_node, ("ActualComponent",))
        serial = None if component is None else context.text(context.ids[component].child("SerialNumber"))
        if serial is not None:
            serials.append(serial)
    return MeasurementResults(
        id=results_id, features=tuple(features), point_sets=point_sets,
        characteristics=read_characteristics(context, node.child("MeasuredCharacteristics"), results_id),
        actual_transforms=actuals,
        inspection_status=None if status is None else context.text(status.child("InspectionStatusEnum")),
        serial_numbers=tuple(serials))


def _point_set(context: QifContext, node: Node, results_id: int | None) -> MeasuredPointSet:
    key = context.id_of(node)
    points_node = node.child("Points")
    if points_node is None or points_node.numbers is None:
        raise context.error(node, "expected Points")
    raw = points_node.numbers
    if "count" in node.attrib:
        count = context.integer(node, node.attrib["count"], "count", minimum=0)
    else:
        context.problem(node, "has no count attribute; the number of points is taken from Points")
        count = len(raw) // 3
    if len(raw) != 3 * count:
        raise context.error(points_node, f"count {count} disagrees with the points: expected {3 * count} numbers, "
                            f"got {len(raw)}")
    linear = 1.0
    units = node.child("Units")
    if units is not None and units.child("LinearUnit") is not None:
        linear = context._unit(units.child("LinearUnit"), angular=False).factor  # type: ignore[arg-type]
    else:
        linear = context.factor(points_node, "linear")
    points = raw.reshape(count, 3)
    if linear != 1.0:
        with np.errstate(over="ignore"):
            points *= linear  # in place: the streamed array is the only copy
        if not np.isfinite(points).all():
            raise context.error(points_node, "a coordinate overflows the float range when converted to mm")
    normals = _per_point_list(context, node, "Normals", count, 3)
    if normals is not None:
        lengths = np.linalg.norm(normals, axis=1)
        bad = np.flatnonzero(np.abs(lengths - 1.0) > 1e-3)
        if bad.size:
            raise context.error(node.child("Normals"), f"normal {bad[0] + 1} has length {lengths[bad[0]]:.6g}, "  # type: ignore[arg-type]
                                "expected unit vectors")
    flags = _per_point_list(context, node, "Compensations", count, 1)
    radii = _per_point_list(context, node, "ProbeRadii", count, 1)
    compensated = None if node.child("Compensated") is None else context.boolean(node.child("Compensated"))  # type: ignore[arg-type]
    if flags is not None and np.all(flags == flags[0]) and count:
        compensated, flags = bool(flags[0]), None
    radius_node = node.child("ProbeRadius")
    radius = None if radius_node is None else context.converted(radius_node, context.number(radius_node) * linear,
                                                                 radius_node.text)
    if radii is not None:
        with np.errstate(over="ignore"):
            radii = radii * linear
        if not np.isfinite(radii).all():
            raise context.error(node.child("ProbeRadii"), "a probe radius overflows the float range when converted "  # type: ignore[arg-type]
                                "to mm")
        if count and np.all(radii == radii[0]):
            radius, radii = float(radii[0]), None
    if radius_node is not None and radius is not None and radius < 0:
        raise context.error(radius_node, f"expected a probe radius >= 0, got {radius}")
    if radii is not None and (radii < 0).any():
        raise context.error(node.child("ProbeRadii"), "expected probe radii >= 0")  # type: ignore[arg-type]
    return MeasuredPointSet(
        id=key, points=points, normals=normals, compensated=compensated,
        compensated_per_point=None if flags is None else flags.astype(bool), probe_radius=radius,
        probe_radii=radii,
        transform_id=context.reference(node.child("TranformId") or node.child("TransformId"), ("Transform",)),
        coordinate_system_id=context.reference(node.child("CoordinateSystemId"), ("CoordinateSystem",)),
        results_id=results_id)


def _per_point_list(context: QifContext, node: Node, tag: str, count: int, per_point: int) -> np.ndarray | None:
    child = node.child(tag)
    if child is None:
        return None
    values = child.numbers if child.numbers is not None else np.empty(0)
    if len(values) != count * per_point:
        raise context.error(child, f"count {count} disagrees with {tag}: expected {count * per_point} numbers, "
                            f"got {len(values)}")
    return values.reshape(count, 3) if per_point == 3 else values


def _feature(context: QifContext, node: Node, results_id: int | None, point_sets: dict[int, MeasuredPointSet],
             definitions: dict, nominals: dict, items: dict) -> MeasuredFeature:  # type: ignore[type-arg]
    key = context.id_of(node)
    before = len(context.problems)
    item_id = context.reference(node.child("FeatureItemId"), ("FeatureItem",))
    item = items.get(item_id) if item_id is not None else None
    nominal = nominals.get(item.nominal_id) if item is not None and item.nominal_id is not None else None
    definition = (definitions.get(nominal.definition_id)
                  if nominal is not None and nominal.definition_id is not None else None)
    references = []
    point_list = node.child("PointList")
    for ref_node in [] if point_list is None else point_list.children:
        if ref_node.tag not in ("WholePointSetId", "RangePointSetId", "SinglePointSetId"):
            continue
        set_id = context.reference(ref_node, ("MeasuredPointSet",))
        if set_id is None:
            continue
        point_set = point_sets.get(set_id)
        if point_set is None:
            raise context.error(ref_node, f"names MeasuredPointSet {set_id} of another MeasurementResults")
        references.append(_slice(context, ref_node, set_id, len(point_set)))
    algorithm_node = node.child("SubstituteFeatureAlgorithm")
    algorithm = None
    if algorithm_node is not None:
        algorithm = context.text(algorithm_node.child("SubstituteFeatureAlgorithmEnum")) or context.text(
            algorithm_node.child("OtherSubstituteFeatureAlgorithm"))
    name = context.text(node.child("FeatureName")) or (item.name if item is not None else None)
    return MeasuredFeature(
        id=key, type=snake_type(node.tag, "FeatureMeasurement"), name=name, actual=context.geometry(node),
        qif_element=node.tag, item_id=item_id,
        internal_external=None if definition is None else definition.internal_external,
        point_set_refs=tuple(references), substitute_algorithm=algorithm,
        transform_id=context.reference(node.child("ActualTransformId"), ("Transform", "CoordinateSystem")),
        results_id=results_id, problems=tuple(context.problems[before:]))


def _slice(context: QifContext, node: Node, set_id: int, count: int) -> PointSetReference:
    if node.tag == "WholePointSetId":
        return PointSetReference(set_id)
    if node.tag == "SinglePointSetId":
        index = context.integer(node, node.attrib.get("index", ""), "index")
        first, last = index, index
    else:
        bounds = node.attrib.get("range", "").split()
        if len(bounds) != 2:
            raise context.error(node, f"range: expected two indices, got {node.attrib.get('range', '')[:40]!r}")
        first = context.integer(node, bounds[0], "range")
        last = context.integer(node, bounds[1], "range")
    if not 1 <= first <= last <= count:
        raise context.error(node, f"points {first} to {last} lie outside MeasuredPointSet {set_id} of {count} points")
    return PointSetReference(set_id, first - 1, last)
