"""``pcmm`` sub-commands that inspect parts against their drawings: ``inspect`` (GD&T with datums).

Each module exposes ``register(subparsers)`` and only wires arguments to the library
(:mod:`pcmm_geo.gdt`); it may import any library package and the private helpers of
:mod:`pcmm_geo.cli`, nothing imports it except :func:`pcmm_geo.cli.build_parser`.
"""
