"""``pcmm`` sub-commands about the micro-CMM's model and calibration: ``calibrate``, ``kinematics``,
``numcal``, ``sensitivity``, ``repeatability``, ``laser-ratio``.

Part of the "micro-CMM: acquire, calibrate, process" group of ``pcmm --help`` (acquiring and
processing readings: :mod:`pcmm_geo.cli.acquisition`).  Each module exposes ``register(subparsers)``
and only wires arguments to the library (:mod:`pcmm_geo.machine`); it may import any library
package and the private helpers of :mod:`pcmm_geo.cli` (``_output``, ``_progress``, ``_report``),
nothing imports it except :func:`pcmm_geo.cli.build_parser`.
"""
