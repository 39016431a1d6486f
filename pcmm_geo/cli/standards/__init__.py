"""``pcmm`` sub-commands about artefacts, acceptance tests and uncertainty: ``gauge-block``,
``iso10360-2``, ``iso10360-5``, ``iso10360-6``, ``micrometer``, ``uncertainty``.

The "artefacts and standards" and "uncertainty" groups of ``pcmm --help``.  Each module
exposes ``register(subparsers)`` and only wires arguments to the library
(:mod:`pcmm_geo.artefacts`, :mod:`pcmm_geo.uncertainty`); it may import any library package and
the private helpers of :mod:`pcmm_geo.cli`, nothing imports it except
:func:`pcmm_geo.cli.build_parser`.
"""
