"""QIF characteristics: definition, nominal, item and measurement flattened into :class:`Characteristic` records."""

from __future__ import annotations

from pcmm_geo.io.cmm.model import Characteristic, Tolerance
from pcmm_geo.io.cmm.qif._values import QifContext, snake_type
from pcmm_geo.io.cmm.qif._xml import Node

__all__ = ["ANGULAR_CHARACTERISTICS", "OTHER_CHARACTERISTICS", "quantity_of", "read_characteristics"]

#: characteristic types whose values are angles (QIF ``MeasuredAngularValueType``)
ANGULAR_CHARACTERISTICS = frozenset({"angle", "angle_between", "angle_from", "angular_coordinate",
                                     "user_defined_angular"})
#: characteristic types whose values are neither lengths nor angles (not converted)
OTHER_CHARACTERISTICS = frozenset({"user_defined_area", "user_defined_force", "user_defined_mass",
                                   "user_defined_pressure", "user_defined_speed", "user_defined_temperature",
                                   "user_defined_time", "user_defined_attribute", "user_defined_unit",
                                   "conical_taper", "flat_taper", "surface_texture", "thread", "chamfer"})


def quantity_of(kind: str) -> str:
    """``"linear"``, ``"angular"`` or ``"other"`` for a snake_case characteristic type."""
    if kind in ANGULAR_CHARACTERISTICS:
        return "angular"
    return "other" if kind in OTHER_CHARACTERISTICS else "linear"


def _ids(context: QifContext, node: Node | None, kinds: tuple[str, ...]) -> tuple[int, ...]:
    if node is None:
        return ()
    found = (context.reference(child, kinds) for child in node.all("Id"))
    return tuple(key for key in found if key is not None)


def _tolerance(context: QifContext, definition: Node, quantity: str) -> Tolerance | None:
    zone = definition.child("ToleranceValue")
    tolerance = definition.child("Tolerance")
    if zone is None and tolerance is None:
        return None
    values: dict[str, object] = {}
    if zone is not None:
        values["value"] = context.value(zone, quantity, pmi=True)
    if tolerance is not None:
        for tag, name in (("MaxValue", "max_value"), ("MinValue", "min_value")):
            child = tolerance.child(tag)
            if child is not None:
                values[name] = context.value(child, quantity, pmi=True)
        limit = tolerance.child("DefinedAsLimit")
        values["defined_as_limit"] = False if limit is None else context.boolean(limit)
    return Tolerance(**values)  # type: ignore[arg-type]


def read_characteristics(
    context: QifContext, measured: Node | None, results_id: int | None
) -> tuple[Characteristic, ...]:
    """Every ``*CharacteristicMeasurement`` below ``MeasuredCharacteristics/CharacteristicMeasurements``."""
    group = None if measured is None else measured.child("CharacteristicMeasurements")
    records = []
    for node in [] if group is None else group.children:
        if not node.tag.endswith("CharacteristicMeasurement"):
            continue
        kind = snake_type(node.tag, "CharacteristicMeasurement")
        quantity = quantity_of(kind)
        item_id = context.reference(node.child("CharacteristicItemId"), ("CharacteristicItem",))
        item = context.ids.get(item_id) if item_id is not None else None
        nominal_id = None if item is None else context.reference(item.child("CharacteristicNominalId"),
                                                                 ("CharacteristicNominal",))
        nominal = context.ids.get(nominal_id) if nominal_id is not None else None
        definition_id = None if nominal is None else context.reference(nominal.child("CharacteristicDefinitionId"),
                                                                       ("CharacteristicDefinition",))
        definition = context.ids.get(definition_id) if definition_id is not None else None
        status = node.child("Status")
        value = node.child("Value")
        target = None if nominal is None else nominal.child("TargetValue")
        name = None
        if item is not None:
            designator = item.child("CharacteristicDesignator")
            name = context.text(item.child("Name")) or (
                None if designator is None else context.text(designator.child("Designator")))
        shape = None if definition is None else definition.child("ZoneShape")
        records.append(Characteristic(
            id=context.id_of(node), type=kind, name=name, qif_element=node.tag, quantity=quantity,
            zone_shape=None if shape is None or not shape.children else snake_type(shape.children[0].tag, "Zone"),
            value=None if value is None else context.value(value, quantity, pmi=True),
            uncertainty=None if value is None else context.uncertainty(value, quantity, pmi=True),
            nominal=None if target is None else context.value(target, quantity, pmi=True),
            tolerance=None if definition is None else _tolerance(context, definition, quantity),
            status=None if status is None else (context.text(status.child("CharacteristicStatusEnum"))
                                                or context.text(status.child("OtherCharacteristicStatus"))),
            feature_measurement_ids=_ids(context, node.child("FeatureMeasurementIds"), ("FeatureMeasurement",)),
            feature_item_ids=() if item is None else _ids(context, item.child("FeatureItemIds"), ("FeatureItem",)),
            item_id=item_id, nominal_id=nominal_id, definition_id=definition_id, results_id=results_id,
        ))
    return tuple(records)
