"""Output helpers shared by the sub-commands: reports, tables, JSON, one-line errors."""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pcmm_geo.cli._record import CovarianceBlock, Provenance, UncertaintyEntry, Verdict

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
    its verdict and uncertainty sections; ``provenance`` is filled by :func:`run_handler`.
    """

    data: dict[str, Any]
    tables: list[Table] = field(default_factory=list)
    lines: list[str] = field(default_factory=list)
    exit_code: int = EXIT_OK
    plots: list[str] = field(default_factory=list)
    verdict: Verdict | None = None
    uncertainties: list[UncertaintyEntry] = field(default_factory=list)
    covariances: list[CovarianceBlock] = field(default_factory=list)
    provenance: Provenance | None = None


def add_json_flag(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print the result as JSON on stdout")


def add_decimal_flag(parser: argparse.ArgumentParser) -> None:
    """Add ``--decimal {.,,}``: the decimal mark of text point files (default: detected, ambiguity refused)."""
    parser.add_argument("--decimal", choices=(".", ","), default=None,
                        help="decimal mark of a text point file: '.' or ',' (with ';', tab or space separators); "
                             "default: detected, an ambiguous file is refused")


def add_plot_flag(parser: argparse.ArgumentParser, what: str) -> None:
    """Add ``--plot FILE.png`` (``what`` says what is drawn); the file is checked before any work."""
    parser.add_argument("--plot", metavar="FILE.png", help=f"write {what} (.png, .svg or .pdf)")
    parser.set_defaults(shared_plot_flag=True)  # run_handler checks the path before the handler runs


def add_report_flag(parser: argparse.ArgumentParser) -> None:
    """Add ``--report FILE.md|FILE.html``: the tables and lines as Markdown or a self-contained HTML page."""
    parser.add_argument("--report", metavar="FILE.md|FILE.html",
                        help="also write the result as Markdown (.md) or a self-contained HTML page (.html)")
    parser.set_defaults(shared_report_flag=True)  # run_handler writes the report after the handler


def add_overwrite_flag(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--overwrite", action="store_true", help="replace existing --plot/--report files")


def check_output_paths(args: argparse.Namespace) -> None:
    """Refuse, before any work, a ``--plot``/``--report`` path that exists (unless ``--overwrite``).

    Only flags added by :func:`add_plot_flag` / :func:`add_report_flag` are checked, so a
    sub-command may define its own ``--report`` with another meaning.

    Raises
    ------
    OutputExistsError
        The file exists and ``args.overwrite`` is not set.
    InvalidInputError
        A suffix the writer does not know.
    """
    overwrite = bool(getattr(args, "overwrite", False))
    if getattr(args, "shared_plot_flag", False) and getattr(args, "plot", None):
        from pcmm_geo.plots import check_plot_path

        check_plot_path(args.plot, overwrite=overwrite)
    if getattr(args, "shared_report_flag", False) and getattr(args, "report", None):
        check_report_path(args.report, overwrite=overwrite)


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
    blocks = [render_table(t) for t in report.tables]
    if report.lines:
        blocks.append("\n".join(report.lines))
    blocks += [render_table(t) for t in uncertainty_tables(report, correlations=False)]
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
    from pcmm_geo.errors import InvalidInputError, OutputExistsError

    target = Path(path)
    if target.suffix.lower() not in REPORT_SUFFIXES:
        raise InvalidInputError("report file", "a name ending in .md or .html", repr(str(target)))
    if target.exists() and not overwrite:
        raise OutputExistsError(str(target))
    return target
