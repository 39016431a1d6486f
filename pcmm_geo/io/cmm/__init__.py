"""Files from coordinate measuring machines: QIF 3.0 results, DMIS output, CALYPSO tables, PC-DMIS XYZIJK.

Every reader returns the plain frozen dataclasses of :mod:`pcmm_geo.io.cmm.model` in mm and
rad (inch files and degrees converted); the QIF writer takes the same classes.  Nothing here
knows a fit: refitting and comparing sits above both layers.

==============================  ===========================================================
function                        reads / writes
==============================  ===========================================================
:func:`read_qif`                a QIF 3.0 document -> :class:`CmmDocument` (streamed,
                                hostile XML refused: defusedxml, depth and size bounded)
:func:`write_qif`               :class:`CmmDocument` -> QIF 3.0 document (schema-valid)
:func:`results_document`        build a :class:`CmmDocument` for the writer from
                                :class:`FeatureReport` records (ids assigned)
:func:`validate_qif`            check a file against the QIF 3.0 XML schema (lxml; the
                                schema ships with pcmm_geo)
:func:`read_dmis`               DMIS output (``FA(..)=FEAT/...``, ``TA(..)=TOL/...``)
:func:`read_calypso_table`      ZEISS CALYPSO ``*_chr.txt`` characteristic tables
:func:`read_pcdmis_xyzijk`      PC-DMIS XYZIJK text -> :class:`MeasuredPointSet` with normals
:func:`detect_format`           which of these formats a file is, by its content
:func:`read_qif_definitions`    characteristic definitions, nominals, items, datum
                                definitions and datum reference frames of a QIF file ->
                                :class:`QifDefinitions`
==============================  ===========================================================

The readers never guess what a file does not say (units, a size beyond ``max_bytes``; the one
assumption, mm for a QIF file without ``FileUnits``, is recorded in the document); their
messages name the setting that would say it, spelled by ``spell_setting`` (default
:func:`python_setting`: ``units='mm'``; the command line passes its option names).

defusedxml (reading) and lxml (validation) come with the ``qif`` extra
(``pip install 'pcmm_geo[qif]'``); without them the functions raise
:class:`~pcmm_geo.errors.MissingDependencyError` naming the extra.
"""

from __future__ import annotations

from pcmm_geo._lazy import attach

_LAZY = {
    "FEATURE_TYPES": "model",
    "Characteristic": "model",
    "CmmDocument": "document",
    "CoordinateSystem": "model",
    "FeatureDefinition": "model",
    "FeatureGeometry": "model",
    "FeatureItem": "model",
    "FeatureNominal": "model",
    "MeasuredFeature": "model",
    "MeasuredPointSet": "model",
    "MeasurementResults": "model",
    "PointSetReference": "model",
    "Tolerance": "model",
    "Transform": "model",
    "Units": "model",
    "DEFAULT_MAX_BYTES": "qif._xml",
    "DEFAULT_MAX_DEPTH": "qif._xml",
    "SpellSetting": "settings",
    "python_setting": "settings",
    "read_qif": "qif.reader",
    "write_qif": "qif.write.writer",
    "FeatureReport": "qif.write.build",
    "results_document": "qif.write.build",
    "validate_qif": "qif.schema",
    "read_dmis": "dmis",
    "read_calypso_table": "calypso",
    "read_pcdmis_xyzijk": "pcdmis",
    "CMM_FORMATS": "detect",
    "detect_format": "detect",
    "read_qif_definitions": "qif.characteristic_definitions",
    "QifDefinitions": "qif.characteristic_definitions",
    "CharacteristicDefinition": "qif.characteristic_definitions",
    "CharacteristicNominal": "qif.characteristic_definitions",
    "CharacteristicItem": "qif.characteristic_definitions",
    "DatumDefinition": "qif.datums",
    "DatumReferenceFrame": "qif.datums",
    "DrfDatum": "qif.datums",
}

__getattr__, __dir__, __all__ = attach(__name__, _LAZY)
