"""``--report FILE.md|FILE.html``: any :class:`~pcmm_geo.cli._output.Report` as a lab record (ISO/IEC 17025 7.8).

A report reads, in this order: the report's identity (report id, the report it supersedes,
laboratory, customer, item measured, measuring instrument, operator, approver, measurement
date, date of issue, method with standard and clause), the reference standards with their
certificates and calibration uncertainties, the environmental conditions (the temperatures
the command used), the decision -- stated once: result, the ISO 14253-1 conformity state, the
decision rule, and U or what a verdict without U rests on --, the results tables and lines,
the uncertainties (standard uncertainties and correlation matrices), every figure once, the
record (command line, working folder, every input with its absolute path and SHA-256), the
software (version, git revision marked dirty or the package digest, library versions) and the
statement that the results relate only to the item measured.  The identity comes from
:mod:`pcmm_geo.cli._identity`, provenance from :mod:`pcmm_geo.cli._record`.

Markdown gets one pipe table per table and links the figures relative to the report's
folder; HTML is one self-contained page (inline style, PNG/SVG figures embedded as
``data:`` URIs, other formats linked) with every piece of text escaped, and prints on A4
with the report id at the top and "page N of M" at the foot of every page.  Numbers are
formatted as in the terminal tables.
"""

from __future__ import annotations

import base64
import html
import os
import re
import shlex
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path

from pcmm_geo.cli._output import Report, Table, _looks_numeric, check_report_path, format_cell, uncertainty_tables
from pcmm_geo.cli._record import software_identity

_MARKDOWN_SPECIAL = "\\`*_[]<|"
_WRITTEN = re.compile(r"^[\w .-]* written to \S")  # a console note of a file written, never a result
_LONG_WORD = 24  # characters: a longer token may break anywhere in print (paths, XPaths), shorter ones never
_HEX_DIGEST = re.compile(r"[0-9a-f]{64}")  # SHA-256 cells: monospace, one line
_EMBEDDED_TYPES = {".png": "image/png", ".svg": "image/svg+xml"}
_STYLE = (
    "body{font-family:sans-serif;margin:2em;max-width:70em}"
    "table{border-collapse:collapse;margin:0.5em 0 1.5em;max-width:100%}"
    "thead{display:table-header-group}"  # a long table repeats its header on every printed page
    "th,td{border:1px solid #bbb;padding:0.25em 0.6em}th{background:#eee}"
    "td.num{text-align:right;font-family:monospace;white-space:nowrap;overflow-wrap:normal}code{background:#f4f4f4}img{max-width:100%}"
    "td{overflow-wrap:break-word}td.long{overflow-wrap:anywhere}td.hash{font-family:monospace;font-size:0.8em;overflow-wrap:anywhere}"
    ".verdict{font-size:1.4em;font-weight:bold;padding:0.3em 0.6em;display:inline-block}"
    ".pass{background:#d8f0d8;color:#145214}.fail{background:#f6d5d5;color:#7a1010}.none{background:#eee}"
    "li,p{overflow-wrap:anywhere}p.statement{margin-top:2em;font-style:italic}p.amends{font-weight:bold;color:#7a1010}"
    "table.approval{width:100%}table.approval td{height:2.2em;vertical-align:bottom}"
    "@media print{body{margin:0;max-width:none;font-size:9pt}table{width:100%;font-size:8.5pt}"
    "th,td{padding:0.15em 0.35em}td.num{white-space:normal}tr,figure,table.approval{break-inside:avoid}"
    "h1,h2,h3{break-after:avoid}td.hash{font-size:0.7em}img{max-height:120mm}}"
)
_PAGE_STYLE = (  # the id is checked to [A-Za-z0-9._/-] (or generated), so it needs no CSS escaping
    "@page{size:A4;margin:18mm 14mm 20mm;"
    "@top-left{content:\"{label}\";font:8pt sans-serif;color:#555}"
    "@bottom-right{content:\"page \" counter(page) \" of \" counter(pages);font:8pt sans-serif;color:#555}}"
)
NOT_STATED = "not stated"


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


def _identity_tables(report: Report) -> list[Table]:
    """Report, reference standards and environmental conditions (only for a report written by a run)."""
    identity = report.identity
    if identity is None:
        return []
    from pcmm_geo.cli._identity import TEXT_FIELDS

    issued = datetime.now(UTC).isoformat(timespec="seconds")
    rows = [["report id", identity.report_id + (" (generated)" if identity.generated_id else "")]]
    if identity.supersedes:
        rows.append(["supersedes", f"report {identity.supersedes}, which this amended report replaces"])
    rows += [[label, getattr(identity, key) or NOT_STATED] for _, key, label in TEXT_FIELDS]
    rows += [["measurement date", identity.measurement_date], ["date of issue (UTC)", issued]]
    if report.method is not None:
        rows.append(["method", report.method.text()])
    tables = [Table("Report", ["item", "value"], rows)]
    if identity.references:
        tables.append(Table("Reference standards", ["standard", "certificate", "calibration uncertainty", "calibrated"],
                            [[r.name, r.certificate, r.uncertainty_text(), r.calibrated or NOT_STATED]
                             for r in identity.references]))
    else:
        tables.append(Table("Reference standards", ["standard", "certificate", "calibration uncertainty"],
                            [[f"{NOT_STATED} (--reference or [[reference]] in pcmm.toml)", "-", "-"]]))
    rows = [[c.quantity, c.value, c.unit] for c in report.environment]  # what this evaluation used
    recorded = [[c.quantity, c.value, c.unit or "as recorded"] for c in identity.environment]  # pcmm.toml
    rows += recorded
    if not report.environment:  # one statement, never "none entered" beside a recorded temperature
        rows.append(["correction to 20 °C", "none applied: the data are evaluated as measured"
                     + (" (the conditions above are recorded, not used)" if recorded else
                        ", taken as at the reference temperature 20 °C (ISO 1); no temperature was entered"),
                     "-"])
    tables.append(Table("Environmental conditions", ["condition", "value", "unit"], rows))
    return tables


def _decision_table(report: Report) -> list[Table]:
    """The one decision of the report (or, in a run's report, the statement that none was made)."""
    verdict = report.verdict
    if verdict is None:
        if report.identity is None:
            return []
        return [Table("Decision", ["item", "value"],
                      [["decision", "no conformity statement: this evaluation has no specification to decide on"]])]
    agreement = verdict.conformity.startswith("not a conformity decision")  # a check between two evaluations
    rows = [["result", verdict.statement], ["kind of decision" if agreement else "conformity (ISO 14253-1)",
                                            verdict.conformity],
            ["decision rule", verdict.decision_rule]]
    if verdict.uncertainty:
        rows.append(["expanded uncertainty U", verdict.uncertainty])
    else:
        rows.append(["expanded uncertainty U", "none stated: " + (verdict.basis or "the verdict rests on the "
                                                                    "measured value alone")])
    return [Table("Decision", ["item", "value"], rows)]


def record_sections(report: Report, command: Sequence[str] | None = None) -> dict[str, list[Table]]:
    """The report's content as titled tables, grouped in the order they are rendered.

    Groups: ``"identity"`` (report, reference standards, environmental conditions; a run's
    report only), ``"decision"``, ``"results"`` (the terminal's tables, then the report's full
    tables), ``"uncertainty"``, ``"annex"`` (technical annex), ``"record"`` (date and time,
    command line, inputs) and ``"software"``.  Free lines and figures are rendered
    separately.

    Examples
    --------
    >>> from pcmm_geo.cli._output import Report
    >>> from pcmm_geo.cli._record import Verdict
    >>> sections = record_sections(Report({}, verdict=Verdict(True, "PASS", "simple acceptance")))
    >>> [row[0] for row in sections["decision"][0].rows]
    ['result', 'conformity (ISO 14253-1)', 'decision rule', 'expanded uncertainty U']
    """
    provenance = report.provenance
    record: list[Table] = []
    software: list[Table] = []
    if provenance is not None:
        rows = [["run started (UTC)", provenance.created_utc],
                ["command line", shlex.join(provenance.command_line)],
                ["working folder", provenance.working_directory]]
        if provenance.platform:
            rows.append(["platform", provenance.platform])
        record.append(Table("Record", ["item", "value"], rows))
        if provenance.inputs:
            record.append(Table("Inputs", ["path", "SHA-256", "size / bytes", "files"],
                                [[f.path, f.sha256, f.size, f.files] for f in provenance.inputs]))
        if provenance.versions:
            rows = [list(row) for row in software_identity()]
            rows += [[name, version] for name, version in provenance.versions.items() if name != "pcmm_geo"]
            software.append(Table("Software", ["package", "version"], rows))
    elif command:
        record.append(Table("Record", ["item", "value"], [["command line", " ".join(command)]]))
    return {"identity": _identity_tables(report), "decision": _decision_table(report),
            "results": [*report.tables, *report.report_tables], "uncertainty": uncertainty_tables(report),
            "annex": list(report.annex), "record": record, "software": software}


def _markdown_table(table: Table) -> list[str]:
    def row(cells: Sequence[str]) -> str:
        return "| " + " | ".join(cells) + " |"

    cells = [[format_cell(value) for value in values] for values in table.rows]
    numeric = [bool(cells) and all(_looks_numeric(r[i]) for r in cells) for i in range(len(table.columns))]
    out = [f"## {markdown_text(table.title)}", "", row([markdown_text(c) for c in table.columns])]
    out.append(row(["---:" if is_number else "---" for is_number in numeric]))
    out.extend(row([markdown_text(c) for c in values]) for values in cells)
    return [*out, ""]


def _closing_lines(report: Report) -> list[str]:
    """The statement every run's report ends with, and the approval line."""
    if report.identity is None:
        return []
    from pcmm_geo.cli._identity import STATEMENT

    approved = report.identity.approved_by or NOT_STATED
    return [STATEMENT, f"Approved by: {approved}. Report {report.identity.report_id}."]


def _approval_rows(report: Report) -> list[list[str]]:
    """The approval block of a run's report: who approves it, with room to sign and date."""
    if report.identity is None:
        return []
    return [["approved by (name, function)", report.identity.approved_by or NOT_STATED],
            ["signature", ""], ["date", ""]]


def _report_lines(report: Report) -> list[str]:
    """The free lines a report prints: without the terminal's notes of files written (``plot written to``)."""
    return [line for line in report.lines if not _WRITTEN.match(line)]


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
    out = [f"# {markdown_text(report.title or title)}", ""]
    if report.identity is not None and report.identity.supersedes:
        out += [f"**Amended report: replaces report {markdown_text(report.identity.supersedes)}.**", ""]
    for group in ("identity", "decision", "results"):
        for table in sections[group]:
            out += _markdown_table(table)
    lines = _report_lines(report)
    if lines:
        out += [f"- {markdown_text(line)}" for line in lines] + [""]
    for heading, text in report.statements:
        out += [f"## {markdown_text(heading)}", "", markdown_text(text), ""]
    for table in sections["uncertainty"]:
        out += _markdown_table(table)
    plots = _unique_plots(report.plots)
    if plots:
        out += ["## Figures", ""]
    for plot in plots:
        link = Path(os.path.relpath(Path(plot).resolve(), Path(base_dir).resolve())).as_posix()
        link = link.replace(" ", "%20").replace("(", "%28").replace(")", "%29")
        out += [f"![{markdown_text(Path(plot).name)}]({link})", ""]
    if sections["annex"]:
        out += ["# Technical annex", ""]
    for table in sections["annex"]:
        out += _markdown_table(table)
    for group in ("record", "software"):
        for table in sections[group]:
            out += _markdown_table(table)
    closing = _closing_lines(report)
    if closing:
        out += [f"*{markdown_text(closing[0])}*", ""]
        out += _markdown_table(Table("Approval", ["item", "value"],
                                     [[item, value or "_" * 30] for item, value in _approval_rows(report)]))
    return "\n".join(out)


def _html_table(table: Table) -> str:
    cells = [[format_cell(value) for value in values] for values in table.rows]
    numeric = [bool(cells) and all(_looks_numeric(r[i]) for r in cells) for i in range(len(table.columns))]
    head = "".join(f"<th>{html.escape(c)}</th>" for c in table.columns)
    def cell(text: str, is_number: bool) -> str:
        # words keep whole (a narrow column widens); only long tokens (paths, XPaths) may break anywhere
        long = any(len(word) > _LONG_WORD for word in text.split())
        kind = "num" if is_number else ("hash" if _HEX_DIGEST.fullmatch(text) else ("long" if long else ""))
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


def _html_decision(report: Report, table: Table) -> str:
    """The decision table, headed by the verdict in colour (green pass, red fail, grey neither)."""
    if report.verdict is None:
        return _html_table(table)
    state = {True: "pass", False: "fail", None: "none"}[report.verdict.passed]
    rest = Table(table.title, table.columns, [row for row in table.rows if row[0] != "result"])  # the box says it
    return (f'<h2>Decision</h2>\n<p class="verdict {state}">{html.escape(report.verdict.statement)}</p>\n'
            + _html_table(rest).split("\n", 1)[1])


def render_html(
    report: Report, title: str, *, command: Sequence[str] | None = None, base_dir: str | Path = "."
) -> str:
    """The report as one self-contained HTML page (PNG/SVG plots embedded); prints with page numbers.

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
    >>> "counter(page)" in page and "counter(pages)" in page
    True
    """
    sections = record_sections(report, command)
    title = report.title or title
    label = f"{title} - report {report.identity.report_id}" if report.identity is not None else title
    page_style = _PAGE_STYLE.replace("{label}", re.sub(r'["\\\n]', " ", label))
    parts = [
        "<!DOCTYPE html>\n",
        f'<html lang="en">\n<head>\n<meta charset="utf-8">\n<title>{html.escape(title)}</title>\n',
        f"<style>{_STYLE}{page_style}</style>\n</head>\n<body>\n<h1>{html.escape(title)}</h1>\n",
    ]
    if report.identity is not None and report.identity.supersedes:
        parts.append(f'<p class="amends">Amended report: replaces report '
                     f"{html.escape(report.identity.supersedes)}.</p>\n")
    parts.extend(_html_table(table) for table in sections["identity"])
    parts.extend(_html_decision(report, table) for table in sections["decision"])
    parts.extend(_html_table(table) for table in sections["results"])
    lines = _report_lines(report)
    if lines:
        parts.append("<ul>\n" + "".join(f"<li>{html.escape(line)}</li>\n" for line in lines) + "</ul>\n")
    parts.extend(f"<h2>{html.escape(heading)}</h2>\n<p>{html.escape(text)}</p>\n"
                 for heading, text in report.statements)
    parts.extend(_html_table(table) for table in sections["uncertainty"])
    plots = _unique_plots(report.plots)
    if plots:
        parts.append("<h2>Figures</h2>\n")
    parts.extend(_html_image(plot, Path(base_dir)) for plot in plots)
    if sections["annex"]:
        parts.append('<h1 class="annex">Technical annex</h1>\n')
    parts.extend(_html_table(table) for table in sections["annex"])
    parts.extend(_html_table(table) for table in (*sections["record"], *sections["software"]))
    closing = _closing_lines(report)
    if closing:
        rows = "".join(f"<tr><th>{html.escape(item)}</th><td>{html.escape(value)}</td></tr>\n"
                       for item, value in _approval_rows(report))
        parts.append(f'<p class="statement">{html.escape(closing[0])}</p>\n<h2>Approval</h2>\n'
                     f'<table class="approval">\n{rows}</table>\n')
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
