"""Running one sub-command: check the output paths, call its handler, write the report, print the result.

Above :mod:`pcmm_geo.cli._output` (tables, JSON, path checks) and :mod:`pcmm_geo.cli._report`
(Markdown / HTML reports), which it both uses; only :func:`pcmm_geo.cli.main` calls it.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

from pcmm_geo.cli._identity import check_identity_flags, method_for, resolve_identity
from pcmm_geo.cli._output import EXIT_USAGE, check_output_paths, output_plan, print_report
from pcmm_geo.cli._record import input_paths, software_versions, start_provenance
from pcmm_geo.cli._report import write_report
from pcmm_geo.errors import OutputExistsError, PcmmGeoError, PcmmGeoWarning

if TYPE_CHECKING:
    from pcmm_geo._atomic import OutputPlan


def _fail(args: argparse.Namespace, plan: OutputPlan | None, message: str) -> int:
    """Print ``message`` as the command's one error line (with what a rollback kept); exit code 2.

    The line starts with the whole sub-command (``pcmm qif show: error: ...``), as argparse's own do.
    """
    if plan is not None and plan.notes:
        message += "; " + "; ".join(plan.notes)
    print(f"{report_title(args)}: error: {message}", file=sys.stderr)
    return EXIT_USAGE


def report_title(args: argparse.Namespace) -> str:
    """``"pcmm COMMAND [ACTION]"``, e.g. ``"pcmm thermal correct-length"``."""
    action = getattr(args, "action", None)
    return f"pcmm {args.command}" + (f" {action}" if isinstance(action, str) else "")


def _print_warnings(args: argparse.Namespace, caught: list[warnings.WarningMessage]) -> None:
    """The library's own warnings as one line each on stderr (``pcmm fit: warning: ...``); others as usual."""
    for record in caught:
        if isinstance(record.message, PcmmGeoWarning):
            text = " ".join(str(record.message).split())
            print(f"{report_title(args)}: warning: {type(record.message).__name__}: {text}", file=sys.stderr)
        else:
            warnings.showwarning(record.message, record.category, record.filename, record.lineno)


def _warn_anonymous(args: argparse.Namespace, identity: object) -> None:
    """One console warning when a report names no party at all (every identity item "not stated")."""
    from pcmm_geo.cli._identity import TEXT_FIELDS

    if any(getattr(identity, key) for _, key, _ in TEXT_FIELDS) or getattr(identity, "references", ()):
        return
    options = ", ".join(option for option, _, _ in TEXT_FIELDS)
    print(f"{report_title(args)}: warning: the report states no laboratory, customer, item, instrument, operator, "
          f"approver or reference standard (every item 'not stated'); give them as {options}, --reference, "
          "or in pcmm.toml", file=sys.stderr)


def _refusal(args: argparse.Namespace, plan: OutputPlan | None, exc: OutputExistsError) -> str:
    """The one-line refusal of an existing output, naming the flags that would allow replacing it."""
    planned = None if plan is None else plan.find(exc.path)
    if planned is not None and hasattr(args, f"overwrite_{planned.label.removeprefix('--').replace('-', '_')}"):
        how = f"use --overwrite-{planned.label.removeprefix('--')} to replace it, or --overwrite for every output"
    elif hasattr(args, "overwrite"):
        how = "use --overwrite to replace it"
    else:
        how = "choose another name"
    return f"{exc.path}: already exists; refusing to overwrite ({how})"


def run_handler(args: argparse.Namespace) -> int:
    """Check every output, run the handler and write the report as one transaction; print the result.

    The outputs are checked before any work (:func:`~pcmm_geo.cli._output.check_output_paths`),
    after what killed runs left next to them is put right (:meth:`pcmm_geo._atomic.OutputPlan.recover`);
    if the handler or the report fails, or Ctrl-C, SIGTERM or SIGHUP ends the command
    (:mod:`pcmm_geo._signals`), every file this run wrote is removed and every file it
    replaced is put back (:class:`pcmm_geo._atomic.OutputPlan`), and the error is one line.
    """
    from pcmm_geo._signals import interrupt_on_signals

    with interrupt_on_signals():
        try:
            return _run(args)
        except KeyboardInterrupt as exc:  # after the outputs were committed (while printing the result)
            return _interrupted(args, None, exc)


def _interrupted(args: argparse.Namespace, plan: OutputPlan | None, exc: KeyboardInterrupt) -> int:
    """The one line of an interrupted command (what the rollback kept) and its exit code (128 + signal)."""
    from pcmm_geo._signals import Interrupted

    notes = "" if plan is None or not plan.notes else " (" + "; ".join(plan.notes) + ")"
    by = f" by {exc.name}" if isinstance(exc, Interrupted) and exc.name != "SIGINT" else ""
    print(f"pcmm {args.command}: interrupted{by}{notes}", file=sys.stderr)
    return exc.exit_code if isinstance(exc, Interrupted) else 130


def _failed(args: argparse.Namespace, plan: OutputPlan, exc: Exception) -> int:
    """The one line of a failed command; an error that an interrupt caused ends as the interrupt.

    Library errors, files and bad values are one line, exit 2; anything else is a bug (traceback).
    """
    from pcmm_geo._signals import interruption

    interrupt = interruption(exc)  # e.g. zlib.error from a PDF writer's clean-up after Ctrl-C
    if interrupt is not None:
        return _interrupted(args, plan, interrupt)
    if isinstance(exc, OutputExistsError):
        return _fail(args, plan, _refusal(args, plan, exc))
    if isinstance(exc, PcmmGeoError):
        return _fail(args, plan, " ".join(str(exc).split()))
    if isinstance(exc, (OSError, ValueError)):
        if isinstance(exc, OSError) and exc.filename is not None and exc.strerror:
            message = f"{exc.filename}: {exc.strerror}"  # e.g. "run.csv: No such file or directory"
        else:
            message = " ".join(str(exc).split())  # one line, whatever the library put in it
        return _fail(args, plan, message)
    raise exc


def _run(args: argparse.Namespace) -> int:
    wants_report = bool(getattr(args, "shared_report_flag", False) and getattr(args, "report", None))
    plan = output_plan(args)
    try:
        for note in plan.recover():
            print(f"pcmm {args.command}: note: {note}", file=sys.stderr)
        check_output_paths(args, plan)
        check_identity_flags(args)
        if wants_report:  # inputs are hashed before the handler reads them, outputs do not exist yet
            inputs = input_paths(args)
            identity = resolve_identity(args, inputs)  # a bad pcmm.toml or --reference stops here, before work
            if identity.config and all(Path(p).resolve() != Path(identity.config) for p in inputs):
                inputs.append(identity.config)
            provenance = start_provenance(getattr(args, "command_line", None) or ["pcmm", args.command], inputs)
        with plan.transaction():
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", PcmmGeoWarning)
                report = args.handler(args)
            _print_warnings(args, caught)
            if wants_report:
                provenance.versions = software_versions()
                report.provenance = provenance
                report.identity = identity
                report.method = report.method or method_for(args)
                report.data["report_id"] = identity.report_id
                written = write_report(report, args.report, title=report_title(args),
                                       command=getattr(args, "command_line", None),
                                       overwrite=bool(getattr(args, "overwrite", False)))
                report.data["report"] = str(written)
                report.console.append(f"report written to {written}")
                _warn_anonymous(args, identity)
    except Exception as exc:
        return _failed(args, plan, exc)
    except KeyboardInterrupt as exc:
        return _interrupted(args, plan, exc)
    try:
        print_report(report, bool(getattr(args, "json", False)))
        sys.stdout.flush()
    except BrokenPipeError:  # e.g. ``pcmm ... | head``: the reader left, not an error of ours
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return report.exit_code
