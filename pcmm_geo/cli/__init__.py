"""The ``pcmm`` command: wiring only; the work happens in the library.

Each sub-command lives in its own module (``demo`` here, the others in one folder per task group of
``pcmm --help``: :mod:`~pcmm_geo.cli.measure`, :mod:`~pcmm_geo.cli.cmm_files`,
:mod:`~pcmm_geo.cli.standards`, :mod:`~pcmm_geo.cli.machine`, :mod:`~pcmm_geo.cli.acquisition`) and exposes
``register(subparsers)``; modules must import numpy and heavier libraries inside
their handlers so that ``pcmm --help`` stays fast.  A handler returns a
:class:`pcmm_geo.cli._output.Report`; ``main`` prints it as aligned text or, with
``--json``, as JSON.  Library errors become one line on stderr and exit code 2.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

# sub-command modules relative to pcmm_geo.cli (``pcmm --help`` groups them: pcmm_geo.cli._help.COMMAND_GROUPS)
COMMAND_MODULES = (
    "demo",
    "measure.fit",
    "measure.form",
    "machine.calibrate",
    "machine.kinematics",
    "acquisition.process_log",
    "machine.numcal",
    "machine.sensitivity",
    "machine.repeatability", "machine.laser_ratio",
    "standards.gauge_block",
    "standards.iso10360",
    "standards.micrometer",
    "measure.thermal",
    "acquisition.acquire",
    "acquisition.serve",
    "measure.compare",
    "measure.segment",
    "cmm_files.convert",
    "standards.uncertainty",
    "measure.batch",
    "cmm_files.qif",
    "cmm_files.inspect",
)


def build_parser() -> argparse.ArgumentParser:
    from pcmm_geo import __version__
    from pcmm_geo.cli._help import PcmmParser, add_completion_option, install_grouped_help

    parser = PcmmParser(
        prog="pcmm",
        description="Geometric metrology for coordinate measuring machines (pcmm_geo).",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"pcmm_geo {__version__}")
    add_completion_option(parser)
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        try:
            module = importlib.import_module(f"pcmm_geo.cli.{name}")
        except ModuleNotFoundError as exc:
            if exc.name == f"pcmm_geo.cli.{name}":
                continue  # sub-command not built yet
            raise
        module.register(subparsers)
    install_grouped_help(parser, subparsers)  # commands by task, ``pcmm results`` for ``pcmm qif``
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    from pcmm_geo._signals import guarded_command  # light: the handlers are in place before anything else loads

    return guarded_command(lambda: _main(argv))  # Ctrl-C from here on: one line, exit 130


def _main(argv: Sequence[str] | None) -> int:
    from pcmm_geo.cli._run import run_handler

    parser = build_parser()
    args = parser.parse_args(argv)
    args.command_line = ["pcmm", *(sys.argv[1:] if argv is None else argv)]
    if getattr(args, "handler", None) is None:  # ``pcmm`` or ``pcmm kinematics`` alone: usage, exit 2
        parser.print_help(sys.stderr)
        return 2
    return run_handler(args)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
