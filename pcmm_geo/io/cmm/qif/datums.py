"""QIF datums: ``DatumDefinitions`` and ``DatumReferenceFrames`` as plain frozen records (ISO 23952, ISO 5459).

A QIF datum reference frame (``DatumReferenceFrame``) lists its datums with their precedence
(``PRIMARY``, ``SECONDARY``, ``TERTIARY``).  Each datum is one of

- ``SimpleDatum``: a ``DatumDefinitionId`` (the datum letter; the definition may name its datum
  feature by ``FeatureNominalIds``), a ``MaterialModifier`` (``NONE``, ``MAXIMUM``, ``LEAST``)
  and a ``ReferencedComponent`` (``ACTUAL``, ...);
- ``NominalDatumFeature`` / ``MeasuredDatumFeature``: a datum feature named directly by its
  feature nominal (or measurement) id;
- ``CompoundDatum``: several datums used together (``A-B``).

Nothing here computes: :mod:`pcmm_geo.gdt.qif_frames` builds a frame from these records and the
feature actuals.  An empty ``DatumReferenceFrame`` (files write one for "no datums": the
characteristic is evaluated in the file's coordinate system) reads as a frame with no datums.
"""

from __future__ import annotations

from dataclasses import dataclass

from pcmm_geo.io.cmm.qif._values import QifContext
from pcmm_geo.io.cmm.qif._xml import Node

__all__ = ["DatumDefinition", "DatumReferenceFrame", "DrfDatum", "read_datum_definitions",
           "read_datum_reference_frames"]

_PRECEDENCES = ("PRIMARY", "SECONDARY", "TERTIARY")


@dataclass(frozen=True)
class DatumDefinition:
    """A QIF ``DatumDefinition``: the datum's label and the feature nominals (or targets) that establish it.

    Attributes
    ----------
    id : int
        QIF id.
    label : str
        ``DatumLabel`` (``"A"``).
    feature_nominal_ids : tuple of int
        ``FeatureNominalIds``: the datum feature(s); empty when the file does not link them.
    datum_target_ids : tuple of int
        ``DatumTargetIds`` (datum targets; pcmm_geo reads but does not evaluate them).
    """

    id: int
    label: str
    feature_nominal_ids: tuple[int, ...] = ()
    datum_target_ids: tuple[int, ...] = ()


@dataclass(frozen=True)
class DrfDatum:
    """One datum of a datum reference frame, in its precedence.

    Attributes
    ----------
    precedence : str
        ``"PRIMARY"``, ``"SECONDARY"``, ``"TERTIARY"`` (QIF ``PrecedenceEnum``) or the file's
        ``OtherPrecedence`` text.
    kind : str
        ``"simple"``, ``"nominal_feature"``, ``"measured_feature"`` or ``"compound"``.
    datum_definition_ids : tuple of int
        The datum definition (one for a simple datum, several for a compound one).
    feature_ids : tuple of int
        The datum feature's ``FeatureNominalId`` (``nominal_feature`` and ``measured_feature``: a
        measured datum feature is the measurement of that nominal).
    material_modifiers : tuple of str
        ``MaterialModifier`` of each datum (``"NONE"``, ``"MAXIMUM"``, ``"LEAST"``): MMB / LMB.
    referenced_component : str or None
        ``ReferencedComponent`` of the (first) simple datum (``"ACTUAL"``, ...).
    """

    precedence: str
    kind: str
    datum_definition_ids: tuple[int, ...] = ()
    feature_ids: tuple[int, ...] = ()
    material_modifiers: tuple[str, ...] = ()
    referenced_component: str | None = None


@dataclass(frozen=True)
class DatumReferenceFrame:
    """A QIF ``DatumReferenceFrame``: its datums in precedence order (none: the file's coordinate system)."""

    id: int
    datums: tuple[DrfDatum, ...] = ()


def _ids(context: QifContext, node: Node | None, kinds: tuple[str, ...]) -> tuple[int, ...]:
    if node is None:
        return ()
    found = (context.reference(child, kinds) for child in node.all("Id"))
    return tuple(key for key in found if key is not None)


def read_datum_definitions(context: QifContext, root: Node) -> dict[int, DatumDefinition]:
    """Every ``DatumDefinitions/DatumDefinition`` of the document, by QIF id."""
    group = root.child("DatumDefinitions")
    definitions: dict[int, DatumDefinition] = {}
    for node in [] if group is None else group.all("DatumDefinition"):
        key = context.id_of(node)
        label = context.text(node.child("DatumLabel"))
        if label is None:
            raise context.error(node, "expected a DatumLabel")
        definitions[key] = DatumDefinition(
            id=key, label=label,
            feature_nominal_ids=_ids(context, node.child("FeatureNominalIds"), ("FeatureNominal",)),
            datum_target_ids=_ids(context, node.child("DatumTargetIds"), ("DatumTarget", "DatumTargetDefinition")))
    return definitions


def _simple(context: QifContext, node: Node) -> tuple[int | None, str, str | None]:
    definition = context.reference(node.child("DatumDefinitionId"), ("DatumDefinition",))
    modifier = context.text(node.child("MaterialModifier")) or "NONE"
    return definition, modifier, context.text(node.child("ReferencedComponent"))


def _datum(context: QifContext, node: Node) -> DrfDatum:
    precedence_node = node.child("Precedence")
    precedence = None
    if precedence_node is not None:
        precedence = (context.text(precedence_node.child("PrecedenceEnum"))
                      or context.text(precedence_node.child("OtherPrecedence")))
    if precedence is None:
        raise context.error(node, "expected a Precedence (PRIMARY, SECONDARY, TERTIARY)")
    simple = node.child("SimpleDatum")
    if simple is not None:
        definition, modifier, component = _simple(context, simple)
        return DrfDatum(precedence=precedence, kind="simple",
                        datum_definition_ids=() if definition is None else (definition,),
                        material_modifiers=(modifier,), referenced_component=component)
    compound = node.child("CompoundDatum")
    if compound is not None:
        parts = [_simple(context, child.child("SimpleDatum")) for child in compound.all("Datum")
                 if child.child("SimpleDatum") is not None]
        return DrfDatum(precedence=precedence, kind="compound",
                        datum_definition_ids=tuple(p[0] for p in parts if p[0] is not None),
                        material_modifiers=tuple(p[1] for p in parts),
                        referenced_component=parts[0][2] if parts else None)
    for tag, kind in (("NominalDatumFeature", "nominal_feature"), ("MeasuredDatumFeature", "measured_feature")):
        feature = node.child(tag)
        if feature is not None:
            key = context.reference(feature.child("FeatureNominalId"), ("FeatureNominal",))
            modifier = context.text(feature.child("MaterialModifier")) or "NONE"
            return DrfDatum(precedence=precedence, kind=kind, feature_ids=() if key is None else (key,),
                            material_modifiers=(modifier,))
    raise context.error(node, "expected SimpleDatum, CompoundDatum, NominalDatumFeature or MeasuredDatumFeature")


def read_datum_reference_frames(context: QifContext, root: Node) -> dict[int, DatumReferenceFrame]:
    """Every ``DatumReferenceFrames/DatumReferenceFrame`` of the document, by QIF id, datums in precedence order."""
    group = root.child("DatumReferenceFrames")
    frames: dict[int, DatumReferenceFrame] = {}
    for node in [] if group is None else group.all("DatumReferenceFrame"):
        key = context.id_of(node)
        datums_node = node.child("Datums")
        datums = [] if datums_node is None else [_datum(context, child) for child in datums_node.all("Datum")]
        seen = [datum.precedence for datum in datums if datum.precedence in _PRECEDENCES]
        if len(seen) != len(set(seen)):
            raise context.error(node, f"two datums of the same precedence ({', '.join(seen)})")
        datums.sort(key=lambda d: _PRECEDENCES.index(d.precedence) if d.precedence in _PRECEDENCES else 3)
        frames[key] = DatumReferenceFrame(id=key, datums=tuple(datums))
    return frames
