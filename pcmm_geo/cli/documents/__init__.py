"""What a ``--report`` holds beyond the terminal's summary: full results tables, certificates.

Each module builds :class:`~pcmm_geo.cli._output.Table` objects and statements from a
library result for one command (``iso10360`` for ISO 10360-2/-5, ``gauge_block`` for the
ISO 3650 calibration certificate); the handlers in
:mod:`pcmm_geo.cli.standards` and :mod:`pcmm_geo.cli.cmm_files` put them in the report's ``report_tables``,
``statements`` and ``annex`` slots.  Nothing here computes a result.
"""
