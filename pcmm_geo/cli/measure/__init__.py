"""``pcmm`` sub-commands that measure and evaluate: ``fit``, ``form``, ``compare``, ``segment``,
``thermal``, ``batch``.

The "measure and evaluate" group of ``pcmm --help``.  Each module exposes ``register(subparsers)``
and only wires arguments to the library (:mod:`pcmm_geo.fit`, :mod:`pcmm_geo.artefacts`,
:mod:`pcmm_geo.thermal`, :mod:`pcmm_geo.io`); it may import any library package and the private
helpers of :mod:`pcmm_geo.cli` (``_output``, ``_progress``, ``_report``), nothing imports it except
:func:`pcmm_geo.cli.build_parser`.
"""
