"""``pcmm`` sub-commands that evaluate measurements: ``fit``, ``form``, ``gauge-block``,
``iso10360-*``, ``micrometer``, ``thermal``, ``compare``, ``segment``, ``convert``,
``uncertainty``, ``batch``.

Each module exposes ``register(subparsers)`` and only wires arguments to the library
(:mod:`pcmm_geo.fit`, :mod:`pcmm_geo.artefacts`, :mod:`pcmm_geo.thermal`, :mod:`pcmm_geo.io`,
:mod:`pcmm_geo.uncertainty`);
it may import any library package and the private helpers of :mod:`pcmm_geo.cli`
(``_output``, ``_progress``, ``_report``), nothing imports it except
:func:`pcmm_geo.cli.build_parser`.
"""
