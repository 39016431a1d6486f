"""GD&T with datums: datum features, datum reference frames and tolerance characteristics.

Above :mod:`pcmm_geo.fit` (associations), :mod:`pcmm_geo.cmm` (files of external CMMs),
:mod:`pcmm_geo.uncertainty` (conformity decisions) and :mod:`pcmm_geo.artefacts` (mesh distances
for profile) in the layer table of ``tests/test_architecture.py``.

Public API (names load on first use):

- :class:`DatumReferenceFrame` (:mod:`~pcmm_geo.gdt.reference.frame`): rotation rows = DRF x, y, z axes in
  measurement coordinates, origin, free degrees of freedom;
- :func:`associate_datum`, :class:`DatumAssociation`, :class:`DatumCertificate`, :data:`DATUM_CRITERIA`
  (:mod:`~pcmm_geo.gdt.reference.datums`); :func:`build_drf`, :class:`DatumNominal`
  (:mod:`~pcmm_geo.gdt.reference.drf`); :func:`associate_common_axis`, :func:`associate_targets`
  (:mod:`~pcmm_geo.gdt.reference.common`); datum mobility (MMB / LMB): :func:`evaluate_position_mobility`,
  :class:`DatumBoundary`, :class:`MobilityResult` (:mod:`~pcmm_geo.gdt.reference.shift`, ``.mobility``);
- :class:`FeatureData`, :class:`CharacteristicResult`, :func:`evaluate_position`,
  :func:`evaluate_position_pattern`, :func:`evaluate_orientation`, :func:`evaluate_flatness`, :func:`evaluate_runout`,
  :func:`toleranced_axis`, :func:`size_evaluation`, :func:`apply_uncertainty` (:mod:`~pcmm_geo.gdt.characteristics`);
  :func:`evaluate_profile`, :func:`read_nominal_mesh` (:mod:`~pcmm_geo.gdt.profile`);
  :func:`propagate_point_uncertainty`, :class:`PropagatedUncertainty` (:mod:`~pcmm_geo.gdt.propagation`: U
  from the points' ``point_u_mm``); :func:`evaluate_position_segments`, :class:`PositionSegment` (composite and
  stacked frames, :mod:`~pcmm_geo.gdt.composite`); :func:`evaluate_symmetry`, :func:`evaluate_line_profile`
  (:mod:`~pcmm_geo.gdt.derived`); :func:`evaluate_coordinate`,
  :func:`evaluate_distance`, :func:`evaluate_angle`, :func:`feature_location` (:mod:`~pcmm_geo.gdt.dimensions`);
- :func:`parse_frame`, :class:`FrameSpec` (:mod:`~pcmm_geo.gdt.plan`); :func:`load_plan`,
  :func:`inspect_plan`, :class:`InspectionPlan`, :class:`InspectionResult` (:mod:`~pcmm_geo.gdt.inspection`);
- the second opinion on a QIF file's characteristics (:mod:`~pcmm_geo.gdt.qif`):
  :func:`verify_characteristics`, :class:`CharacteristicCheck`, :class:`CharacteristicVerification`
  and the statuses :data:`AGREES`, :data:`DISAGREES`, :data:`NOT_COMPUTABLE`; frames from feature actuals
  :func:`datum_frame`, :func:`frame_map`, :class:`DatumFrame`, :class:`FrameMap`, :class:`DatumFeatureGeometry`;
- an inspection's results as a QIF 3.0 results file: :func:`inspection_to_qif`, :class:`QifExport`
  (:mod:`~pcmm_geo.gdt.qif.results`).
"""

from __future__ import annotations

from pcmm_geo._lazy import attach

_LAZY = {
    "DEGREES_OF_FREEDOM": "reference.frame",
    "DatumReferenceFrame": "reference.frame",
    "DATUM_CRITERIA": "reference.datums",
    "DatumAssociation": "reference.datums",
    "DatumCertificate": "reference.datums",
    "associate_datum": "reference.datums",
    "default_criterion": "reference.datums",
    "DatumNominal": "reference.drf",
    "build_drf": "reference.drf",
    "DatumBoundary": "reference.mobility",
    "MobilityResult": "reference.mobility",
    "evaluate_position_mobility": "reference.shift",
    "associate_common_axis": "reference.common",
    "associate_targets": "reference.common",
    "CharacteristicResult": "characteristics",
    "apply_uncertainty": "characteristics",
    "FeatureData": "characteristics",
    "evaluate_flatness": "characteristics",
    "evaluate_orientation": "characteristics",
    "evaluate_position": "characteristics",
    "evaluate_position_pattern": "pattern",
    "PositionSegment": "composite",
    "evaluate_position_segments": "composite",
    "evaluate_symmetry": "derived",
    "evaluate_line_profile": "derived",
    "evaluate_runout": "characteristics",
    "size_evaluation": "characteristics",
    "toleranced_axis": "characteristics",
    "evaluate_profile": "profile",
    "read_nominal_mesh": "profile",
    "PropagatedUncertainty": "propagation",
    "propagate_point_uncertainty": "propagation",
    "evaluate_angle": "dimensions",
    "evaluate_coordinate": "dimensions",
    "evaluate_distance": "dimensions",
    "feature_location": "dimensions",
    "FrameSpec": "plan",
    "SYMBOLS": "plan",
    "parse_frame": "plan",
    "InspectionPlan": "inspection",
    "InspectionResult": "inspection",
    "PlannedCharacteristic": "inspection",
    "inspect_plan": "inspection",
    "load_plan": "inspection",
    "AGREES": "qif.characteristics",
    "DISAGREES": "qif.characteristics",
    "NOT_COMPUTABLE": "qif.characteristics",
    "DEFAULT_FRACTION": "qif.characteristics",
    "CharacteristicCheck": "qif.characteristics",
    "CharacteristicVerification": "qif.characteristics",
    "verify_characteristics": "qif.characteristics",
    "DatumFeatureGeometry": "qif.frames",
    "DatumFrame": "qif.frames",
    "FrameMap": "qif.frames",
    "datum_frame": "qif.frames",
    "frame_map": "qif.frames",
    "QifExport": "qif.results",
    "inspection_to_qif": "qif.results",
}

__getattr__, __dir__, __all__ = attach(__name__, _LAZY)
