"""Running one sub-command: check the output paths, call its handler, write the report, print the result.

Above :mod:`pcmm_geo.cli._output` (tables, JSON, path checks) and :mod:`pcmm_geo.cli._report`
(Markdown / HTML reports), which it both uses; only :func:`pcmm_geo.cli.main` calls it.
"""

from __future__ import annotations

import argparse
import sys
import warnings

from pcmm_geo.cli._output import EXIT_USAGE, check_output_paths, print_report
from pcmm_geo.cli._record import input_paths, software_versions, start_provenance
from pcmm_geo.cli._report import write_report
from pcmm_geo.errors import OutputExistsError, PcmmGeoError, PcmmGeoWarning


def report_title(args: argparse.Namespace) -> str:
    """``"pcmm COMMAND [ACTION]"``, e.g. ``"pcmm thermal correct-length"``."""
    action = getattr(args, "action", None)
    return f"pcmm {args.command}" + (f" {action}" if isinstance(action, str) else "")


def _print_warnings(args: argparse.Namespace, caught: list[warnings.WarningMessage]) -> None:
    """The library's own warnings as one line each on stderr (``pcmm fit: warning: ...``); others as usual."""
    for record in caught:
        if isinstance(record.message, PcmmGeoWarning):
            text = " ".join(str(record.message).split())
            print(f"pcmm {args.command}: warning: {type(record.message).__name__}: {text}", file=sys.stderr)
        else:
            warnings.showwarning(record.message, record.category, record.filename, record.lineno)


def run_handler(args: argparse.Namespace) -> int:
    wants_report = bool(getattr(args, "shared_report_flag", False) and getattr(args, "report", None))
    try:
        check_output_paths(args)
        if wants_report:  # inputs are hashed before the handler reads them, outputs do not exist yet
            provenance = start_provenance(getattr(args, "command_line", None) or ["pcmm", args.command],
                                          input_paths(args))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", PcmmGeoWarning)
            report = args.handler(args)
        _print_warnings(args, caught)
        if wants_report:
            provenance.versions = software_versions()
            report.provenance = provenance
            written = write_report(report, args.report, title=report_title(args),
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
