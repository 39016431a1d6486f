"""QIF 3.0 (ISO 23952) results documents: the guarded streaming reader and validation; writing in ``write``.

:mod:`~pcmm_geo.io.cmm.qif.reader` (:func:`read_qif`), :mod:`~pcmm_geo.io.cmm.qif.write.build`
(:class:`FeatureReport`, :func:`results_document`), :mod:`~pcmm_geo.io.cmm.qif.write.writer`
(:func:`write_qif`; its features part :mod:`~pcmm_geo.io.cmm.qif.write._features_out`, its datums and
geometric characteristics :mod:`~pcmm_geo.io.cmm.qif.write.gdt_out`),
:mod:`~pcmm_geo.io.cmm.qif.schema` (:func:`validate_qif`); the hostile-XML guard is
:mod:`~pcmm_geo.io.cmm.qif._xml`.  Use them through :mod:`pcmm_geo.io.cmm`.
"""
