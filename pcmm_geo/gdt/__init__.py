"""GD&T with datums: datum features, datum reference frames and tolerance characteristics.

Above :mod:`pcmm_geo.fit` (associations), :mod:`pcmm_geo.cmm` (files of external CMMs),
:mod:`pcmm_geo.uncertainty` (conformity decisions) and :mod:`pcmm_geo.artefacts` (mesh distances
for profile) in the layer table of ``tests/test_architecture.py``.
"""
