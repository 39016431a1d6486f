"""Artefact evaluations: gauge blocks (ISO 3650 and the seed's method), ISO 10360-2/-5/-6, micrometer stage, CAD.

- :mod:`~pcmm_geo.artefacts.gauge_block` -- central length, variation in length, the seed's
  eqs 5.1-5.3 and an exact projection.
- :mod:`~pcmm_geo.artefacts.iso10360_2` -- length measurement errors E0, repeatability R0, verdict.
- :mod:`~pcmm_geo.artefacts.iso10360_5` -- 25-point sphere probing pattern, P_FTU and P_STU.
- :mod:`~pcmm_geo.artefacts.iso10360_6` -- software test harness against reference data.
- :mod:`~pcmm_geo.artefacts.micrometer` -- micrometer-stage distances test (thesis Table 8.1).
- CAD comparison: :mod:`~pcmm_geo.artefacts.cad_segment` (planes and cylinders in a scan),
  :mod:`~pcmm_geo.artefacts.cad_register` (scan -> nominal mesh), :mod:`~pcmm_geo.artefacts.cad_distance`
  (exact signed distances from a mesh), :mod:`~pcmm_geo.artefacts.cad_compare` (deviations).

Names load lazily (PEP 562).

Examples
--------
>>> from pcmm_geo import artefacts
>>> artefacts.sphere_probing_pattern(radius=10.0).shape
(25, 3)
"""

from __future__ import annotations

from pcmm_geo._lazy import attach

_LAZY = {
    "FACE_LABELS": "gauge_block",
    "GaugeBlockMeasurement": "gauge_block",
    "SeedGaugeBlockLength": "gauge_block",
    "measure_gauge_block": "gauge_block",
    "plane_from_three_points": "gauge_block",
    "projected_length": "gauge_block",
    "seed_gauge_block_length": "gauge_block",
    "read_gauge_block_csv": "gauge_block",
    "DECISION_RULES": "iso10360_2",
    "E0Value": "iso10360_2",
    "LengthMeasurement": "iso10360_2",
    "LengthMpe": "iso10360_2",
    "LengthTestResult": "iso10360_2",
    "R0Value": "iso10360_2",
    "evaluate_length_test": "iso10360_2",
    "read_length_test_csv": "iso10360_2",
    "PATTERN_RINGS": "iso10360_5",
    "ProbingResult": "iso10360_5",
    "evaluate_probing": "iso10360_5",
    "read_points_csv": "iso10360_5",
    "sphere_probing_pattern": "iso10360_5",
    "ELEMENTS": "iso10360_6",
    "CaseDeviation": "iso10360_6",
    "ElementParameters": "iso10360_6",
    "HarnessMpe": "iso10360_6",
    "HarnessReport": "iso10360_6",
    "ReferenceCase": "iso10360_6",
    "cases_from_reference_data": "iso10360_6",
    "compare_results": "iso10360_6",
    "fit_with_pcmm_geo": "iso10360_6",
    "load_reference_cases": "iso10360_6_io",
    "read_element_parameters": "iso10360_6_io",
    "PairError": "micrometer",
    "StageTestResult": "micrometer",
    "evaluate_stage_test": "micrometer",
    "read_micrometer_csv": "micrometer",
    "stage_pairs": "micrometer",
    "CadComparison": "cad_compare",
    "DeviationSummary": "cad_compare",
    "MeshDeviations": "cad_compare",
    "compare_to_mesh": "cad_compare",
    "deviation_summary": "cad_compare",
    "mesh_deviations": "cad_compare",
    "Registration": "cad_register",
    "as_rigid_transform": "cad_register",
    "centroid_alignment": "cad_register",
    "register_to_mesh": "cad_register",
    "SurfaceDistances": "cad_distance",
    "SurfaceIndex": "cad_distance",
    "check_closed_mesh": "cad_distance",
    "surface_distances": "cad_distance",
    "Segment": "cad_segment",
    "Segmentation": "cad_segment",
    "segment_scan": "cad_segment",
}

__getattr__, __dir__, __all__ = attach(__name__, _LAZY)
