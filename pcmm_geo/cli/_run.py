"""Running one sub-command: check the output paths, call its handler, write the report, print the result.

Above :mod:`pcmm_geo.cli._output` (tables, JSON, path checks) and :mod:`pcmm_geo.cli._report`
(Markdown / HTML reports), which it both uses; only :func:`pcmm_geo.cli.main` calls it.
"""

from __future__ import annotations

import argparse
import sys

from pcmm_geo.cli._output import EXIT_USAGE, check_output_paths, print_report
from pcmm_geo.cli._report import write_report
from pcmm_geo.errors import OutputExistsError, PcmmGeoError


def run_handler(args: argparse.Namespace) -> int:
    try:
        check_output_paths(args)
        report = args.handler(args)
        if getattr(args, "shared_report_flag", False) and getattr(args, "report", None):
            written = write_report(report, args.report, title=f"pcmm {args.command}",
                                   command=getattr(args, "command_line", None),
                                   overwrite=bool(getattr(args, "overwrite", False)))
            report.data["report"] = str(written)
            report.lines.append(f"report written to {written}")
    except OutputExistsError as exc:
        how = "use --overwrite to replace it" if hasattr(args, "overwrite") else "choose another name"
        print(f"pcmm {args.command}: error: {exc.path}: already exists; refusing to overwrite ({how})",
              file=sys.stderr)
        return EXIT_USAGE
    except PcmmGeoError as exc:
        print(f"pcmm {args.command}: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return EXIT_USAGE
    except (OSError, ValueError) as exc:
        if isinstance(exc, OSError) and exc.filename is not None and exc.strerror:
            message = f"{exc.filename}: {exc.strerror}"  # e.g. "run.csv: No such file or directory"
        else:
            message = " ".join(str(exc).split())  # one line, whatever the library put in it
        print(f"pcmm {args.command}: error: {message}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f"pcmm {args.command}: interrupted", file=sys.stderr)
        return 130
    try:
        print_report(report, bool(getattr(args, "json", False)))
        sys.stdout.flush()
    except BrokenPipeError:  # e.g. ``pcmm ... | head``: the reader left, not an error of ours
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return report.exit_code
