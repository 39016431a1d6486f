"""Output helpers shared by the sub-commands: reports, tables, JSON, one-line errors."""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pcmm_geo.cli._record import Condition, CovarianceBlock, Method, Provenance, UncertaintyEntry, Verdict

if TYPE_CHECKING:
    from pcmm_geo._atomic import OutputPlan
    from pcmm_geo.cli._identity import ReportIdentity

REPORT_SUFFIXES = (".md", ".html", ".htm")

EXIT_OK = 0
EXIT_FAILURE = 1  # the computation ran but the verdict is "fail" (e.g. an ISO test)
EXIT_USAGE = 2  # bad file, bad input, impossible geometry


@dataclass
class Table:
    """A titled table: ``columns`` are header strings (put units in them), ``rows`` lists of cells."""

    title: str
    columns: list[str]
    rows: list[list[Any]]


@dataclass
class Report:
    """What a handler returns: JSON-ready ``data`` plus human ``tables`` and free ``lines``.

    ``plots`` lists the image files the handler wrote; ``--report`` embeds or links them.
    ``verdict``, ``uncertainties`` and ``covariances`` are the slots a ``--report`` renders as
    its decision and uncertainty sections (the terminal prints the verdict from ``verdict`` too,
    so a handler does not repeat it in ``lines``); ``method`` (default: the command's, see
    :func:`pcmm_geo.cli._identity.method_for`) and ``environment`` (the temperatures the
    command used) fill the report's method and environmental conditions; ``provenance`` and
    ``identity`` are filled by :func:`pcmm_geo.cli._run.run_handler`.

    A ``--report`` also renders what the terminal leaves out: ``report_tables`` (every result
    a standard asks for, e.g. all 105 E0 values, after ``tables``), ``statements`` (titled
    paragraphs: method, traceability, thermal correction) and ``annex`` (a technical annex of
    supplementary tables, after the figures); ``title`` replaces the command as the report's
    heading (e.g. a calibration certificate).  ``console`` lines are printed on the terminal
    only (``plot written to ...``), never in a report.
    """

    data: dict[str, Any]
    tables: list[Table] = field(default_factory=list)
    lines: list[str] = field(default_factory=list)
    exit_code: int = EXIT_OK
    plots: list[str] = field(default_factory=list)
    verdict: Verdict | None = None
    uncertainties: list[UncertaintyEntry] = field(default_factory=list)
    covariances: list[CovarianceBlock] = field(default_factory=list)
    method: Method | None = None
    environment: list[Condition] = field(default_factory=list)
    provenance: Provenance | None = None
    identity: ReportIdentity | None = None
    report_tables: list[Table] = field(default_factory=list)
    statements: list[tuple[str, str]] = field(default_factory=list)
    annex: list[Table] = field(default_factory=list)
    title: str = ""
    console: list[str] = field(default_factory=list)


def add_json_flag(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print the result as JSON on stdout")


def add_decimal_flag(parser: argparse.ArgumentParser) -> None:
    """Add ``--decimal {.,,}``: the decimal mark of text point files (default: detected, ambiguity refused)."""
    parser.add_argument("--decimal", choices=(".", ","), default=None,
                        help="decimal mark of a text point file: '.' or ',' (with ';', tab or space separators); "
                             "default: detected, an ambiguous file is refused")


class _RenamedOption(argparse.Action):
    """An option renamed to carry its unit: using the old name stops the parser (exit 2)."""

    def __init__(self, option_strings: list[str], dest: str, new: str, **kwargs: Any) -> None:
        self.new = new
        super().__init__(option_strings, dest, nargs="*", default=argparse.SUPPRESS, help=argparse.SUPPRESS)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any,
                 option_string: str | None = None) -> None:
        parser.exit(2, f"{parser.prog}: error: {option_string} is now {self.new} (the unit is in the name); the old "
                       "name is refused, so no number is read in a unit it was not written in\n")  # one line, no usage


def refuse_renamed_options(parser: argparse.ArgumentParser, renamed: dict[str, str]) -> None:
    """Refuse each old option name of ``renamed`` (``{"--mpe-a": "--mpe-a-um"}``), naming its replacement.

    Every length option carries its unit in its name (``--tolerance-mm``, ``--mpe-a-um``); an old
    name is registered hidden and exact, so argparse neither abbreviates it to the new name nor
    accepts it silently: it prints the one line ``OLD is now NEW ...`` on stderr (no usage) and exits 2.

    Examples
    --------
    >>> import contextlib, io
    >>> parser = argparse.ArgumentParser(prog="pcmm form")
    >>> _ = parser.add_argument("--tolerance-mm", dest="tolerance", type=float)
    >>> refuse_renamed_options(parser, {"--tolerance": "--tolerance-mm"})
    >>> parser.parse_args(["--tolerance-mm", "0.01"]).tolerance
    0.01
    >>> with contextlib.redirect_stderr(io.StringIO()) as err:  # doctest: +ELLIPSIS
    ...     try:
    ...         parser.parse_args(["--tolerance", "0.01"])
    ...     except SystemExit as stop:
    ...         print(stop.code, err.getvalue().splitlines()[-1])
    2 pcmm form: error: --tolerance is now --tolerance-mm (the unit is in the name); the old name is refused, ...
    """
    for old, new in renamed.items():
        parser.add_argument(old, action=_RenamedOption, new=new, dest="renamed_" + old.lstrip("-").replace("-", "_"))


@dataclass(frozen=True)
class OutputOption:
    """A command-line option naming a file the command writes (see :func:`declare_output`)."""

    dest: str
    option: str
    append_when: str | None = None
    folder: bool = False
    unused_when: str | None = None


def declare_output(parser: argparse.ArgumentParser, dest: str, option: str | None = None, *,
                   append_when: str | None = None, folder: bool = False, unused_when: str | None = None) -> None:
    """Register the option stored in ``args.<dest>`` as one of the command's output files.

    Every declared output is checked before any work (existence, folder, writability; see
    :class:`pcmm_geo._atomic.OutputPlan`) and all of them are written all-or-nothing.
    :func:`add_overwrite_flag`, called after the declarations, adds ``--overwrite`` (all
    outputs) and one ``--overwrite-NAME`` per output.  ``append_when`` names a boolean option
    (e.g. ``"resume"``) under which an existing file is appended to rather than refused;
    ``folder=True`` declares a folder the command writes new files into (checked, no
    ``--overwrite-NAME``); ``unused_when`` names a boolean option under which it is not written.
    """
    outputs = parser.get_default("output_options")
    if outputs is None:
        outputs = []
        parser.set_defaults(output_options=outputs)
    outputs.append(OutputOption(dest, option or "--" + dest.replace("_", "-"), append_when, folder, unused_when))


def add_plot_flag(parser: argparse.ArgumentParser, what: str) -> None:
    """Add ``--plot FILE.png`` (``what`` says what is drawn); the file is checked before any work."""
    parser.add_argument("--plot", metavar="FILE.png", help=f"write {what} (.png, .svg or .pdf)")
    parser.set_defaults(shared_plot_flag=True)  # run_handler checks the suffix before the handler runs
    declare_output(parser, "plot")


def add_report_flag(parser: argparse.ArgumentParser) -> None:
    """Add ``--report FILE.md|FILE.html`` (a lab record as Markdown or a self-contained HTML page).

    Also adds the report identity options (``--report-id``, ``--laboratory``, ...; see
    :mod:`pcmm_geo.cli._identity`).
    """
    from pcmm_geo.cli._identity import add_identity_flags

    parser.add_argument("--report", metavar="FILE.md|FILE.html",
                        help="also write the result as a lab record: Markdown (.md) or a self-contained HTML "
                             "page (.html)")
    parser.set_defaults(shared_report_flag=True)  # run_handler writes the report after the handler
    declare_output(parser, "report")
    add_identity_flags(parser)


def add_overwrite_flag(parser: argparse.ArgumentParser) -> None:
    """Add ``--overwrite`` (every declared output) and ``--overwrite-NAME`` for each declared output.

    Call it after the outputs are declared (:func:`add_plot_flag`, :func:`add_report_flag`,
    :func:`declare_output`).
    """
    outputs = [output for output in parser.get_default("output_options") or () if not output.folder]
    names = ", ".join(output.option for output in outputs) or "the outputs"
    parser.add_argument("--overwrite", action="store_true",
                        help=f"allow replacing every existing output file ({names}); without it, or the "
                             "per-output flags, an existing file is refused before any work")
    for output in outputs:
        parser.add_argument(f"--overwrite-{output.option.removeprefix('--')}", dest=f"overwrite_{output.dest}",
                            action="store_true", help=f"allow replacing an existing {output.option} file only")


def output_plan(args: argparse.Namespace) -> OutputPlan:
    """The :class:`~pcmm_geo._atomic.OutputPlan` of the outputs ``args`` names, with their permissions."""
    from pcmm_geo._atomic import OutputPlan

    plan = OutputPlan()
    everything = bool(getattr(args, "overwrite", False))
    for output in getattr(args, "output_options", None) or ():
        value = getattr(args, output.dest, None)
        if not value or (output.unused_when and getattr(args, output.unused_when, False)):
            continue
        plan.add(value, label=output.option,
                 overwrite=everything or bool(getattr(args, f"overwrite_{output.dest}", False)),
                 append=bool(output.append_when and getattr(args, output.append_when, False)),
                 folder=output.folder)
    return plan


def check_output_paths(args: argparse.Namespace, plan: OutputPlan | None = None) -> OutputPlan:
    """Check, before any work, every output the command declared; returns the plan to write them under.

    Suffixes of ``--plot``/``--report`` (when added by :func:`add_plot_flag` /
    :func:`add_report_flag`, so a sub-command may define its own ``--report``), then every
    declared output: an existing file is refused unless ``--overwrite`` or its own
    ``--overwrite-NAME`` allows it, two outputs may not name one file, and each folder must
    exist or be creatable and be writable.  ``plan`` defaults to :func:`output_plan` of ``args``.

    Raises
    ------
    OutputExistsError
        An output exists and may not be replaced.
    InvalidInputError
        A suffix the writer does not know, two outputs naming one file, or an unusable folder.
    """
    if getattr(args, "shared_plot_flag", False) and getattr(args, "plot", None):
        from pcmm_geo.plots import check_plot_path

        check_plot_path(args.plot, overwrite=True)  # the suffix; existence is the plan's
    if getattr(args, "shared_report_flag", False) and getattr(args, "report", None):
        check_report_path(args.report, overwrite=True)
    plan = output_plan(args) if plan is None else plan
    plan.check()
    return plan


def format_cell(value: Any, digits: int = 6) -> str:
    if isinstance(value, bool) or value is None:
        return str(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if value != 0 and (abs(value) < 1e-4 or abs(value) >= 1e7):
            return f"{value:.{digits}e}"
        return f"{value:.{digits}f}"
    return str(value)


def render_table(table: Table) -> str:
    cells = [[format_cell(c) for c in row] for row in table.rows]
    widths = [len(h) for h in table.columns]
    for row in cells:
        for i, cell in enumerate(row):
            widths[i] = max(widths[i], len(cell))
    numeric = [
        all(_looks_numeric(row[i]) for row in cells) if cells else False for i in range(len(table.columns))
    ]

    def fmt(row: list[str]) -> str:
        cells = zip(row, widths, strict=True)
        return "  ".join(c.rjust(w) if numeric[i] else c.ljust(w) for i, (c, w) in enumerate(cells))

    out = [table.title, fmt(table.columns), "  ".join("-" * w for w in widths)]
    out.extend(fmt(r) for r in cells)
    return "\n".join(out)


def _looks_numeric(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def to_jsonable(value: Any) -> Any:
    """Convert numpy scalars/arrays and dataclass-like objects for ``json.dumps``."""
    if hasattr(value, "tolist"):
        return to_jsonable(value.tolist())
    if isinstance(value, dict):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_jsonable(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def uncertainty_tables(report: Report, *, correlations: bool = True) -> list[Table]:
    """The report's uncertainty slots as tables: one of the entries, one correlation matrix per block.

    The terminal shows the entries only (``correlations=False``); ``--report`` shows both.

    Examples
    --------
    >>> from pcmm_geo.cli._record import UncertaintyEntry
    >>> entry = UncertaintyEntry("L", 100.0, 2e-4, "mm", 2.0, method="GUM")
    >>> table = uncertainty_tables(Report({}, uncertainties=[entry]))[0]
    >>> table.title, table.columns, table.rows[0][5]
    ('Standard uncertainties (GUM)', ['quantity', 'value', 'u', 'unit', 'k', 'U = k u'], 0.0004)
    """
    tables = []
    entries = report.uncertainties
    if entries:
        methods = {e.method for e in entries}
        shared = methods.pop() if len(methods) == 1 else None
        expanded = any(e.coverage_factor is not None for e in entries)
        columns = ["quantity", "value", "u", "unit"] + (["k", "U = k u"] if expanded else [])
        columns += [] if shared is not None else ["method"]
        rows = []
        for e in entries:
            row = [e.quantity, e.value, e.standard_uncertainty, e.unit]
            if expanded:
                row += ["-" if e.coverage_factor is None else e.coverage_factor,
                        "-" if e.expanded_uncertainty is None else e.expanded_uncertainty]
            rows.append(row + ([] if shared is not None else [e.method]))
        # one method for all entries goes in the title, not in every row
        tables.append(Table("Standard uncertainties" + (f" ({shared})" if shared else ""), columns, rows))
    for block in report.covariances if correlations else ():
        names = list(block.names)
        tables.append(Table(f"{block.title}: correlation coefficients", ["", *names],
                            [[name, *(f"{round(value, 3) + 0.0:.3f}" for value in row)]
                             for name, row in zip(names, block.correlation(), strict=True)]))
    return tables


def print_report(report: Report, as_json: bool) -> None:
    if as_json:
        json.dump(to_jsonable(report.data), sys.stdout, indent=2, allow_nan=False)
        sys.stdout.write("\n")
        return
    annex = [Table(t.title, t.columns[:-1], [row[:-1] for row in t.rows]) if t.columns[-1] == "meaning" else t
             for t in report.annex]  # the terminal leaves out the annex's explanations (the report has them)
    blocks = [render_table(t) for t in (*report.tables, *annex)]
    blocks += [render_table(t) for t in uncertainty_tables(report, correlations=False)]
    if report.verdict is not None:  # the verdict once, from its slot: handlers do not repeat it in lines
        blocks.append("\n".join(report.verdict.lines()))
    if report.lines or report.console:
        blocks.append("\n".join([*report.lines, *report.console]))
    if blocks:  # a command that printed its own output (pcmm batch) returns an empty report
        print("\n\n".join(blocks))


def check_report_path(path: str | Path, *, overwrite: bool = False) -> Path:
    """Validate a report destination (suffix, existing file) before any work is done.

    Raises
    ------
    InvalidInputError
        The suffix is not ``.md``, ``.html`` or ``.htm``.
    OutputExistsError
        ``path`` exists and ``overwrite`` is False.

    Examples
    --------
    >>> check_report_path("summary.html").suffix
    '.html'
    """
    from pcmm_geo._atomic import may_overwrite
    from pcmm_geo.errors import InvalidInputError, OutputExistsError

    target = Path(path)
    if target.suffix.lower() not in REPORT_SUFFIXES:
        raise InvalidInputError("report file", "a name ending in .md or .html", repr(str(target)))
    if target.exists() and not may_overwrite(target, overwrite):
        raise OutputExistsError(str(target))
    return target
