"""``pcmm`` sub-commands about the machine itself: ``acquire``, ``calibrate``, ``kinematics``,
``process-log``, ``numcal``, ``sensitivity``, ``repeatability``, ``laser-ratio``, ``serve``.

Each module exposes ``register(subparsers)`` and only wires arguments to the library
(:mod:`pcmm_geo.machine`, :mod:`pcmm_geo.acquisition`); it may import any library package and
the private helpers of :mod:`pcmm_geo.cli` (``_output``, ``_progress``, ``_report``), nothing
imports it except :func:`pcmm_geo.cli.build_parser`.
"""
