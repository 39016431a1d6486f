"""QIF characteristic definitions, nominals and items with their datums: what a second opinion needs beyond read_qif.

:func:`read_qif` flattens each ``<Type>CharacteristicMeasurement`` with its item, nominal and
definition into one :class:`~pcmm_geo.io.cmm.model.Characteristic`.  A second opinion on a
characteristic also needs what the flattened record leaves out, and a product definition (the
NIST CTC / FTC models) holds definitions without any measurement.  :func:`read_qif_definitions`
reads, as plain frozen records in mm and rad:

- every ``<Type>CharacteristicDefinition`` (:class:`CharacteristicDefinition`: tolerance, zone
  shape, material condition -- MMC / LMC / RFS --, the datum reference frames it names);
- every ``<Type>CharacteristicNominal`` (:class:`CharacteristicNominal`: target value, the
  ``Direction`` of a linear coordinate, the ``AnalysisMode`` of a distance);
- every ``<Type>CharacteristicItem`` (:class:`CharacteristicItem`: name, feature items);
- ``DatumDefinitions`` and ``DatumReferenceFrames`` (:mod:`pcmm_geo.io.cmm.qif.datums`).

The file is parsed with the same guard as :func:`read_qif` (no DTD, entities or external
references; ``max_bytes`` and ``max_depth`` bounded); a dangling id, a duplicate id, a number
that is not one, a datum reference frame with two primaries is a :class:`~pcmm_geo.errors.QifError`
naming the QIF id, the element path and the line.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pcmm_geo.io.cmm.model import Tolerance
from pcmm_geo.io.cmm.qif._characteristics import _tolerance, quantity_of
from pcmm_geo.io.cmm.qif._values import QifContext, snake_type
from pcmm_geo.io.cmm.qif._xml import (
    DEFAULT_MAX_BYTES,
    DEFAULT_MAX_DEPTH,
    DEFAULT_MAX_ELEMENTS,
    DuplicateElementError,
    Node,
)
from pcmm_geo.io.cmm.qif.datums import (
    DatumDefinition,
    DatumReferenceFrame,
    read_datum_definitions,
    read_datum_reference_frames,
)
from pcmm_geo.io.cmm.settings import SpellSetting, python_setting

if TYPE_CHECKING:
    from pcmm_geo.io.cmm.document import CmmDocument

__all__ = ["CharacteristicDefinition", "CharacteristicItem", "CharacteristicNominal", "QifDefinitions",
           "read_qif_definitions", "read_qif_with_definitions"]


@dataclass(frozen=True)
class CharacteristicDefinition:
    """A QIF ``<Type>CharacteristicDefinition``.

    Attributes
    ----------
    id : int
    type : str
        snake_case type (``"position"``, ``"diameter"``, ``"surface_profile"``, ...).
    tolerance : Tolerance or None
        ``ToleranceValue`` (a geometric zone, mm) or ``Tolerance`` (limits, mm or rad).
    non_tolerance : str or None
        ``NonTolerance`` (``"MEASURED"``, ``"SET"``, ...): a characteristic reported without a tolerance.
    material_condition : str or None
        ``MaterialCondition``: ``"MAXIMUM"`` (MMC), ``"LEAST"`` (LMC), ``"REGARDLESS"`` (RFS) or None.
    zone_shape : str or None
        snake_case of the ``ZoneShape`` child (``"diametrical"``, ``"non_diametrical"``, ``"spherical"``, ...).
    datum_reference_frame_ids : tuple of int
        Every ``DatumReferenceFrameId`` in the definition (a composite frame names one per segment).
    qif_element : str
    """

    id: int
    type: str
    tolerance: Tolerance | None = None
    non_tolerance: str | None = None
    material_condition: str | None = None
    zone_shape: str | None = None
    datum_reference_frame_ids: tuple[int, ...] = ()
    qif_element: str = ""


@dataclass(frozen=True)
class CharacteristicNominal:
    """A QIF ``<Type>CharacteristicNominal``: the definition it refines and its target (mm or rad).

    ``direction``: a linear coordinate's ``XAXIS`` / ``YAXIS`` / ``ZAXIS``; ``analysis_mode`` and
    ``analysis_vector`` (a unit ``(3,)`` array): how a distance or angle between is taken
    (``ONEDIMENSIONAL`` along the vector, ``TWODIMENSIONAL`` perpendicular to it, ``THREEDIMENSIONAL``).
    """

    id: int
    type: str
    definition_id: int | None
    target_value: float | None = None
    direction: str | None = None
    analysis_mode: str | None = None
    analysis_vector: np.ndarray | None = None
    qif_element: str = ""


@dataclass(frozen=True)
class CharacteristicItem:
    """A QIF ``<Type>CharacteristicItem``: its name and the feature items it is about."""

    id: int
    type: str
    name: str | None
    nominal_id: int | None
    feature_item_ids: tuple[int, ...] = ()
    qif_element: str = ""


@dataclass(frozen=True)
class QifDefinitions:
    """Characteristic definitions, nominals and items, datum definitions and datum reference frames of one file."""

    source: str
    characteristic_definitions: dict[int, CharacteristicDefinition] = field(default_factory=dict)
    characteristic_nominals: dict[int, CharacteristicNominal] = field(default_factory=dict)
    characteristic_items: dict[int, CharacteristicItem] = field(default_factory=dict)
    datum_definitions: dict[int, DatumDefinition] = field(default_factory=dict)
    datum_reference_frames: dict[int, DatumReferenceFrame] = field(default_factory=dict)
    problems: tuple[str, ...] = ()

    def counts(self) -> dict[str, int]:
        """How many records of each kind were read."""
        return {"characteristic_definitions": len(self.characteristic_definitions),
                "characteristic_nominals": len(self.characteristic_nominals),
                "characteristic_items": len(self.characteristic_items),
                "datum_definitions": len(self.datum_definitions),
                "datum_reference_frames": len(self.datum_reference_frames)}

    def definition_of(self, characteristic_definition_id: int | None) -> CharacteristicDefinition | None:
        """The definition with this id, or None."""
        if characteristic_definition_id is None:
            return None
        return self.characteristic_definitions.get(characteristic_definition_id)


def _descendants(node: Node, tag: str) -> list[Node]:
    found, stack = [], list(node.children)
    while stack:
        child = stack.pop()
        if child.tag == tag:
            found.append(child)
        stack.extend(child.children)
    return sorted(found, key=lambda n: n.line)


def _definitions(context: QifContext, group: Node | None) -> dict[int, CharacteristicDefinition]:
    out: dict[int, CharacteristicDefinition] = {}
    for node in [] if group is None else group.children:
        if not node.tag.endswith("CharacteristicDefinition"):
            continue
        kind = snake_type(node.tag, "CharacteristicDefinition")
        key = context.id_of(node)
        shape = node.child("ZoneShape")
        frames = (context.reference(ref, ("DatumReferenceFrame",))
                  for ref in _descendants(node, "DatumReferenceFrameId"))
        out[key] = CharacteristicDefinition(
            id=key, type=kind, tolerance=_tolerance(context, node, quantity_of(kind)),
            non_tolerance=context.text(node.child("NonTolerance")),
            material_condition=context.text(node.child("MaterialCondition")),
            zone_shape=None if shape is None or not shape.children else snake_type(shape.children[0].tag, "Zone"),
            datum_reference_frame_ids=tuple(f for f in frames if f is not None), qif_element=node.tag)
    return out


def _nominals(context: QifContext, group: Node | None) -> dict[int, CharacteristicNominal]:
    out: dict[int, CharacteristicNominal] = {}
    for node in [] if group is None else group.children:
        if not node.tag.endswith("CharacteristicNominal"):
            continue
        kind = snake_type(node.tag, "CharacteristicNominal")
        key = context.id_of(node)
        target = node.child("TargetValue")
        vector = node.child("AnalysisVector")
        out[key] = CharacteristicNominal(
            id=key, type=kind,
            definition_id=context.reference(node.child("CharacteristicDefinitionId"), ("CharacteristicDefinition",)),
            target_value=None if target is None else context.value(target, quantity_of(kind), pmi=True),
            direction=context.text(node.child("Direction")), analysis_mode=context.text(node.child("AnalysisMode")),
            analysis_vector=None if vector is None else context.unit_vector(vector), qif_element=node.tag)
    return out


def _items(context: QifContext, group: Node | None) -> dict[int, CharacteristicItem]:
    out: dict[int, CharacteristicItem] = {}
    for node in [] if group is None else group.children:
        if not node.tag.endswith("CharacteristicItem"):
            continue
        key = context.id_of(node)
        designator = node.child("CharacteristicDesignator")
        ids = node.child("FeatureItemIds")
        features = () if ids is None else tuple(
            k for k in (context.reference(child, ("FeatureItem",)) for child in ids.all("Id")) if k is not None)
        out[key] = CharacteristicItem(
            id=key, type=snake_type(node.tag, "CharacteristicItem"),
            name=context.text(node.child("Name")) or (
                None if designator is None else context.text(designator.child("Designator"))),
            nominal_id=context.reference(node.child("CharacteristicNominalId"), ("CharacteristicNominal",)),
            feature_item_ids=features, qif_element=node.tag)
    return out


def read_qif_definitions(
    path: str | Path, *, max_bytes: int = DEFAULT_MAX_BYTES, max_depth: int = DEFAULT_MAX_DEPTH,
    max_elements: int = DEFAULT_MAX_ELEMENTS, spell_setting: SpellSetting = python_setting,
) -> QifDefinitions:
    """Read the characteristic definitions, nominals, items and datums of a QIF 3.0 file (see the module docstring).

    Parameters
    ----------
    path : str or Path
        The ``.qif`` file (a results file or a product definition such as the NIST CTC / FTC models).
    max_bytes, max_depth, max_elements : int
        Largest file, deepest nesting and most elements accepted (as :func:`~pcmm_geo.io.cmm.read_qif`).
    spell_setting : callable
        How a size refusal names ``max_bytes``.

    Returns
    -------
    QifDefinitions
        Lengths in mm, angles in rad.

    Raises
    ------
    QifError
        A dangling or duplicate id, a value that is not a number, an unknown unit, a datum without
        a precedence, two datums of one precedence, not a QIF 3 document.
    UnsafeXmlError, FileFormatError, MissingDependencyError
        As :func:`~pcmm_geo.io.cmm.read_qif`.
    """
    from pcmm_geo.io.cmm.qif.reader import parse_qif_tree

    context, root, _ = parse_qif_tree(path, max_bytes=max_bytes, max_depth=max_depth, max_elements=max_elements,
                                      spell_setting=spell_setting)
    try:
        return _read_definitions(context, root)
    except DuplicateElementError as exc:
        raise context.error(exc.second, str(exc)) from None


def read_qif_with_definitions(
    path: str | Path, *, max_bytes: int = DEFAULT_MAX_BYTES, max_depth: int = DEFAULT_MAX_DEPTH,
    max_elements: int = DEFAULT_MAX_ELEMENTS, units: str | None = None, angle_unit: str | None = None,
    spell_setting: SpellSetting = python_setting,
) -> tuple[CmmDocument, QifDefinitions]:
    """:func:`~pcmm_geo.io.cmm.read_qif` and :func:`read_qif_definitions` from one bounded parse of the file.

    Parameters and errors as :func:`~pcmm_geo.io.cmm.read_qif` (``units`` / ``angle_unit`` for a
    file without ``FileUnits`` apply to both: the definitions' tolerances are converted alike).

    Returns
    -------
    (CmmDocument, QifDefinitions)
        ``definitions.problems`` holds only what reading the definitions added.
    """
    from pcmm_geo.io.cmm.qif.reader import _read_document, check_units, parse_qif_tree

    check_units(units, angle_unit, spell_setting)
    context, root, namespace = parse_qif_tree(path, max_bytes=max_bytes, max_depth=max_depth,
                                              max_elements=max_elements, spell_setting=spell_setting)
    try:
        document = _read_document(context, root, namespace, units, angle_unit)
        return document, _read_definitions(context, root, units_read=True)
    except DuplicateElementError as exc:
        raise context.error(exc.second, str(exc)) from None


def _read_definitions(context: QifContext, root: Node, *, units_read: bool = False) -> QifDefinitions:
    first_problem = len(context.problems)
    if not units_read:
        context.read_units(root)
    characteristics = root.child("Characteristics")

    def group(tag: str) -> Node | None:
        return None if characteristics is None else characteristics.child(tag)

    return QifDefinitions(
        source=context.path, characteristic_definitions=_definitions(context, group("CharacteristicDefinitions")),
        characteristic_nominals=_nominals(context, group("CharacteristicNominals")),
        characteristic_items=_items(context, group("CharacteristicItems")),
        datum_definitions=read_datum_definitions(context, root),
        datum_reference_frames=read_datum_reference_frames(context, root),
        problems=tuple(context.problems[first_problem:]))
