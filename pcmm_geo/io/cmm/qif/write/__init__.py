"""Writing QIF 3.0 results documents: the document built from reports, the schema-valid writer.

:mod:`~pcmm_geo.io.cmm.qif.write.build` (:class:`FeatureReport`, :func:`results_document`),
:mod:`~pcmm_geo.io.cmm.qif.write.writer` (:func:`write_qif`; its features part
:mod:`~pcmm_geo.io.cmm.qif.write._features_out`, its datums and geometric characteristics
:mod:`~pcmm_geo.io.cmm.qif.write.gdt_out`, the exact number text
:mod:`~pcmm_geo.io.cmm.qif.write._xml_out`).  Reading is in :mod:`pcmm_geo.io.cmm.qif`; use both
through :mod:`pcmm_geo.io.cmm`.
"""
