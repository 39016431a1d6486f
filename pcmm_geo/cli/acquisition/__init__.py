"""``pcmm`` sub-commands that acquire and process the micro-CMM's readings: ``acquire``, ``serve``,
``process-log``.

Part of the "micro-CMM: acquire, calibrate, process" group of ``pcmm --help`` (the machine's
model and calibration are in :mod:`pcmm_geo.cli.machine`).  Each module exposes
``register(subparsers)`` and only wires arguments to the library (:mod:`pcmm_geo.acquisition`,
:mod:`pcmm_geo.ippdme`, :mod:`pcmm_geo.machine`); it may import any library package and the
private helpers of :mod:`pcmm_geo.cli`, nothing imports it except :func:`pcmm_geo.cli.build_parser`.
"""
