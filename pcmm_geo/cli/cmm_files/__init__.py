"""``pcmm`` sub-commands about CMM files: ``results`` (alias of ``qif``: show, verify, validate),
``inspect`` (GD&T with datums from an inspection plan) and ``convert`` (point and mesh formats).

The "CMM files" group of ``pcmm --help``.  Each module exposes ``register(subparsers)`` and only
wires arguments to the library (:mod:`pcmm_geo.io`, :mod:`pcmm_geo.cmm`, :mod:`pcmm_geo.gdt`); it
may import any library package and the private helpers of :mod:`pcmm_geo.cli`, nothing imports it
except :func:`pcmm_geo.cli.build_parser`.
"""
