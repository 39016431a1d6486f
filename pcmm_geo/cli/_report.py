"""``--report FILE.md|FILE.html``: any :class:`~pcmm_geo.cli._output.Report` as Markdown or HTML.

A report is a lab record, in this order: the record (date and time in UTC, command line,
working folder, every input with its absolute path and SHA-256), the verdict and its
decision rule, the results tables and lines, the uncertainties (standard uncertainties and
correlation matrices), every figure once, and the software versions used (see
:mod:`pcmm_geo.cli._record`).  Markdown gets one pipe table per table and links the figures
relative to the report's folder; HTML is one self-contained page (inline style, PNG/SVG
figures embedded as ``data:`` URIs, other formats linked) with every piece of text escaped.
Numbers are formatted as in the terminal tables.
"""

from __future__ import annotations

import base64
import html
import os
import re
from collections.abc import Sequence
from pathlib import Path

from pcmm_geo.cli._output import Report, Table, _looks_numeric, check_report_path, format_cell, uncertainty_tables

_MARKDOWN_SPECIAL = "\\`*_[]<|"
_HEX_DIGEST = re.compile(r"[0-9a-f]{64}")  # SHA-256 cells: monospace, one line
_EMBEDDED_TYPES = {".png": "image/png", ".svg": "image/svg+xml"}
_STYLE = (
    "body{font-family:sans-serif;margin:2em;max-width:70em}"
    "table{border-collapse:collapse;margin:0.5em 0 1.5em}"
    "th,td{border:1px solid #bbb;padding:0.25em 0.6em}th{background:#eee}"
    "td.num{text-align:right;font-family:monospace;white-space:nowrap;overflow-wrap:normal}code{background:#f4f4f4}img{max-width:100%}"
    "td{overflow-wrap:anywhere}td.hash{font-family:monospace;font-size:0.8em;overflow-wrap:normal;white-space:nowrap}"
    ".verdict{font-size:1.4em;font-weight:bold;padding:0.3em 0.6em;display:inline-block}"
    ".pass{background:#d8f0d8;color:#145214}.fail{background:#f6d5d5;color:#7a1010}.none{background:#eee}"
)


def markdown_text(text: str) -> str:
    """``text`` with Markdown's special characters backslash-escaped and line breaks flattened.

    Examples
    --------
    >>> markdown_text("laser_a | 2*x")
    'laser\\\\_a \\\\| 2\\\\*x'
    """
    escaped = "".join("\\" + char if char in _MARKDOWN_SPECIAL else char for char in str(text))
    return " ".join(escaped.split())


def _unique_plots(plots: Sequence[str]) -> list[str]:
    """Each figure once, in first-seen order (two names of the same file count as one)."""
    seen: set[Path] = set()
    out = []
    for plot in plots:
        key = Path(plot).resolve()
        if key not in seen:
            seen.add(key)
            out.append(plot)
    return out


def record_sections(report: Report, command: Sequence[str] | None = None) -> dict[str, list[Table]]:
    """The report's content as titled tables, grouped in the order they are rendered.

    Groups: ``"record"`` (date and time, command line, inputs), ``"verdict"``, ``"results"``,
    ``"uncertainty"`` and ``"software"``.  Free lines and figures are rendered separately.

    Examples
    --------
    >>> from pcmm_geo.cli._output import Report
    >>> from pcmm_geo.cli._record import Verdict
    >>> sections = record_sections(Report({}, verdict=Verdict(True, "PASS", "simple acceptance")))
    >>> sections["verdict"][0].rows
    [['result', 'PASS'], ['decision rule', 'simple acceptance']]
    """
    provenance = report.provenance
    record: list[Table] = []
    software: list[Table] = []
    if provenance is not None:
        rows = [["date and time (UTC)", provenance.created_utc],
                ["command line", " ".join(provenance.command_line)],
                ["working folder", provenance.working_directory]]
        if provenance.platform:
            rows.append(["platform", provenance.platform])
        record.append(Table("Record", ["item", "value"], rows))
        if provenance.inputs:
            record.append(Table("Inputs", ["path", "SHA-256", "size / bytes", "files"],
                                [[f.path, f.sha256, f.size, f.files] for f in provenance.inputs]))
        if provenance.versions:
            software.append(Table("Software", ["package", "version"], [list(i) for i in provenance.versions.items()]))
    elif command:
        record.append(Table("Record", ["item", "value"], [["command line", " ".join(command)]]))
    verdict = []
    if report.verdict is not None:
        verdict.append(Table("Verdict", ["item", "value"],
                             [["result", report.verdict.statement], ["decision rule", report.verdict.decision_rule]]))
    uncertainty = uncertainty_tables(report)
    return {"record": record, "verdict": verdict, "results": list(report.tables),
            "uncertainty": uncertainty, "software": software}


def _markdown_table(table: Table) -> list[str]:
    def row(cells: Sequence[str]) -> str:
        return "| " + " | ".join(cells) + " |"

    cells = [[format_cell(value) for value in values] for values in table.rows]
    numeric = [bool(cells) and all(_looks_numeric(r[i]) for r in cells) for i in range(len(table.columns))]
    out = [f"## {markdown_text(table.title)}", "", row([markdown_text(c) for c in table.columns])]
    out.append(row(["---:" if is_number else "---" for is_number in numeric]))
    out.extend(row([markdown_text(c) for c in values]) for values in cells)
    return [*out, ""]


def render_markdown(
    report: Report, title: str, *, command: Sequence[str] | None = None, base_dir: str | Path = "."
) -> str:
    """The report as Markdown; plots are linked relative to ``base_dir`` (the report's folder).

    Examples
    --------
    >>> from pcmm_geo.cli._output import Report, Table
    >>> text = render_markdown(Report({}, [Table("Lengths", ["quantity", "L / mm"], [["L", 100.0]])]), "demo")
    >>> "| L | 100.000000 |" in text
    True
    """
    sections = record_sections(report, command)
    out = [f"# {markdown_text(title)}", ""]
    for group in ("record", "verdict", "results"):
        for table in sections[group]:
            out += _markdown_table(table)
    if report.lines:
        out += [f"- {markdown_text(line)}" for line in report.lines] + [""]
    for table in sections["uncertainty"]:
        out += _markdown_table(table)
    plots = _unique_plots(report.plots)
    if plots:
        out += ["## Figures", ""]
    for plot in plots:
        link = Path(os.path.relpath(Path(plot).resolve(), Path(base_dir).resolve())).as_posix()
        link = link.replace(" ", "%20").replace("(", "%28").replace(")", "%29")
        out += [f"![{markdown_text(Path(plot).name)}]({link})", ""]
    for table in sections["software"]:
        out += _markdown_table(table)
    return "\n".join(out)


def _html_table(table: Table) -> str:
    cells = [[format_cell(value) for value in values] for values in table.rows]
    numeric = [bool(cells) and all(_looks_numeric(r[i]) for r in cells) for i in range(len(table.columns))]
    head = "".join(f"<th>{html.escape(c)}</th>" for c in table.columns)
    def cell(text: str, is_number: bool) -> str:
        kind = "num" if is_number else ("hash" if _HEX_DIGEST.fullmatch(text) else "")
        return f'<td class="{kind}">{html.escape(text)}</td>' if kind else f"<td>{html.escape(text)}</td>"

    body = "".join(
        "<tr>" + "".join(cell(c, numeric[i]) for i, c in enumerate(values)) + "</tr>\n" for values in cells
    )
    return (f"<h2>{html.escape(table.title)}</h2>\n<table>\n<thead><tr>{head}</tr></thead>\n"
            f"<tbody>\n{body}</tbody>\n</table>\n")


def _html_image(plot: str, base_dir: Path) -> str:
    source = Path(plot)
    kind = _EMBEDDED_TYPES.get(source.suffix.lower())
    name = html.escape(source.name)
    if kind is None:
        link = Path(os.path.relpath(source.resolve(), base_dir.resolve())).as_posix()
        return f'<p><a href="{html.escape(link)}">{name}</a></p>\n'
    encoded = base64.b64encode(source.read_bytes()).decode("ascii")
    return f'<figure><img alt="{name}" src="data:{kind};base64,{encoded}"><figcaption>{name}</figcaption></figure>\n'


def _html_verdict(report: Report) -> str:
    if report.verdict is None:
        return ""
    state = {True: "pass", False: "fail", None: "none"}[report.verdict.passed]
    return (f'<p class="verdict {state}">{html.escape(report.verdict.statement)}</p>\n'
            f"<p>Decision rule: {html.escape(report.verdict.decision_rule)}</p>\n")


def render_html(
    report: Report, title: str, *, command: Sequence[str] | None = None, base_dir: str | Path = "."
) -> str:
    """The report as one self-contained HTML page (PNG/SVG plots embedded).

    Raises
    ------
    OSError
        A plot file cannot be read.

    Examples
    --------
    >>> from pcmm_geo.cli._output import Report, Table
    >>> page = render_html(Report({}, [Table("A < B", ["x"], [[1.5]])]), "t")
    >>> "<h2>A &lt; B</h2>" in page and '<td class="num">1.500000</td>' in page
    True
    """
    sections = record_sections(report, command)
    parts = [
        "<!DOCTYPE html>\n",
        f'<html lang="en">\n<head>\n<meta charset="utf-8">\n<title>{html.escape(title)}</title>\n',
        f"<style>{_STYLE}</style>\n</head>\n<body>\n<h1>{html.escape(title)}</h1>\n",
    ]
    parts.extend(_html_table(table) for table in sections["record"])
    if report.verdict is not None:
        parts.append("<h2>Verdict</h2>\n" + _html_verdict(report))
    parts.extend(_html_table(table) for table in sections["results"])
    if report.lines:
        parts.append("<ul>\n" + "".join(f"<li>{html.escape(line)}</li>\n" for line in report.lines) + "</ul>\n")
    parts.extend(_html_table(table) for table in sections["uncertainty"])
    plots = _unique_plots(report.plots)
    if plots:
        parts.append("<h2>Figures</h2>\n")
    parts.extend(_html_image(plot, Path(base_dir)) for plot in plots)
    parts.extend(_html_table(table) for table in sections["software"])
    parts.append("</body>\n</html>\n")
    return "".join(parts)


def write_report(
    report: Report,
    path: str | Path,
    *,
    title: str,
    command: Sequence[str] | None = None,
    overwrite: bool = False,
) -> Path:
    """Write ``report`` as Markdown (``.md``) or HTML (``.html``/``.htm``), chosen by the suffix.

    Parameters
    ----------
    report : Report
    path : str or Path
    title : str
        Page heading, e.g. ``"pcmm calibrate"``.
    command : sequence of str, optional
        The command line, shown under the heading.
    overwrite : bool
        Replace an existing file.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    InvalidInputError
        Unknown suffix.
    OutputExistsError
        ``path`` exists and ``overwrite`` is False.
    OSError
        The folder cannot be created, or a plot cannot be read.

    Examples
    --------
    >>> import os, tempfile
    >>> from pcmm_geo.cli._output import Report
    >>> out = write_report(Report({}, lines=["ok"]), os.path.join(tempfile.mkdtemp(), "r.md"), title="t")
    >>> out.read_text(encoding="utf-8").splitlines()[-1]
    '- ok'
    """

    target = check_report_path(path, overwrite=overwrite)
    render = render_markdown if target.suffix.lower() == ".md" else render_html
    text = render(report, title, command=command, base_dir=target.parent)
    target.parent.mkdir(parents=True, exist_ok=True)
    from pcmm_geo._atomic import write_atomic

    return write_atomic(target, text, overwrite=overwrite)
