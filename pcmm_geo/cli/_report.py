"""``--report FILE.md|FILE.html``: any :class:`~pcmm_geo.cli._output.Report` as Markdown or HTML.

Markdown gets one pipe table per :class:`~pcmm_geo.cli._output.Table`, the free lines as a
list and the plots as images linked relative to the report's folder.  HTML is one
self-contained page (inline style, PNG/SVG plots embedded as ``data:`` URIs, other formats
linked); every piece of text is escaped.  Numbers are formatted as in the terminal tables.
"""

from __future__ import annotations

import base64
import html
import os
from collections.abc import Sequence
from pathlib import Path

from pcmm_geo.cli._output import Report, Table, _looks_numeric, check_report_path, format_cell

_MARKDOWN_SPECIAL = "\\`*_[]<|"
_EMBEDDED_TYPES = {".png": "image/png", ".svg": "image/svg+xml"}
_STYLE = (
    "body{font-family:sans-serif;margin:2em;max-width:70em}"
    "table{border-collapse:collapse;margin:0.5em 0 1.5em}"
    "th,td{border:1px solid #bbb;padding:0.25em 0.6em}th{background:#eee}"
    "td.num{text-align:right;font-family:monospace}code{background:#f4f4f4}img{max-width:100%}"
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
    >>> text = render_markdown(Report({}, [Table("Lengths", ["quantity", "value (mm)"], [["L", 100.0]])]), "demo")
    >>> "| L | 100.000000 |" in text
    True
    """
    out = [f"# {markdown_text(title)}", ""]
    if command:
        out += [f"`{' '.join(command).replace('`', '')}`", ""]
    for table in report.tables:
        out += _markdown_table(table)
    if report.lines:
        out += [f"- {markdown_text(line)}" for line in report.lines] + [""]
    for plot in report.plots:
        link = Path(os.path.relpath(Path(plot).resolve(), Path(base_dir).resolve())).as_posix()
        link = link.replace(" ", "%20").replace("(", "%28").replace(")", "%29")
        out += [f"![{markdown_text(Path(plot).name)}]({link})", ""]
    return "\n".join(out)


def _html_table(table: Table) -> str:
    cells = [[format_cell(value) for value in values] for values in table.rows]
    numeric = [bool(cells) and all(_looks_numeric(r[i]) for r in cells) for i in range(len(table.columns))]
    head = "".join(f"<th>{html.escape(c)}</th>" for c in table.columns)
    body = "".join(
        "<tr>" + "".join(
            f'<td class="num">{html.escape(c)}</td>' if numeric[i] else f"<td>{html.escape(c)}</td>"
            for i, c in enumerate(values)
        ) + "</tr>\n"
        for values in cells
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
    from pcmm_geo import __version__

    parts = [
        "<!DOCTYPE html>\n",
        f'<html lang="en">\n<head>\n<meta charset="utf-8">\n<title>{html.escape(title)}</title>\n',
        f"<style>{_STYLE}</style>\n</head>\n<body>\n<h1>{html.escape(title)}</h1>\n",
    ]
    if command:
        parts.append(f"<p><code>{html.escape(' '.join(command))}</code></p>\n")
    parts.extend(_html_table(table) for table in report.tables)
    if report.lines:
        parts.append("<ul>\n" + "".join(f"<li>{html.escape(line)}</li>\n" for line in report.lines) + "</ul>\n")
    parts.extend(_html_image(plot, Path(base_dir)) for plot in report.plots)
    parts.append(f"<p><small>pcmm_geo {html.escape(__version__)}</small></p>\n</body>\n</html>\n")
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
        The folder does not exist, or a plot cannot be read.

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
    from pcmm_geo._atomic import write_atomic

    return write_atomic(target, text, overwrite=overwrite)
