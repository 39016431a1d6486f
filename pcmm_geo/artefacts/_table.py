"""Small CSV reader shared by the artefact evaluations: named columns, typed cells, precise errors."""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from pathlib import Path

from pcmm_geo.errors import FileFormatError

__all__ = ["cell_float", "cell_int", "cell_text", "read_rows"]


def read_rows(path: str | Path, required: Sequence[str]) -> list[tuple[int, dict[str, str]]]:
    """Rows of a CSV file as ``(line_number, {column: text})``; ``#`` lines and blank lines are skipped.

    Raises
    ------
    FileFormatError
        No header, missing required columns, no data rows, a row with the wrong number of cells,
        binary or non-UTF-8 content, a directory.
    OSError
        The file cannot be read.
    """
    from pcmm_geo.io._text import read_text_lines

    text_path = str(path)
    lines = [(n, line) for n, line in read_text_lines(path) if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise FileFormatError(text_path, "empty file: expected a CSV header and data rows")
    reader = csv.reader([line for _, line in lines])
    rows = list(reader)
    header = [name.strip().lower() for name in rows[0]]
    missing = [name for name in required if name not in header]
    if missing:
        hint = "; fields must be separated by ',' with '.' as decimal mark" if ";" in lines[0][1] else ""
        raise FileFormatError(
            text_path, f"expected columns {', '.join(required)}; missing {', '.join(missing)}{hint}", line=lines[0][0]
        )
    out: list[tuple[int, dict[str, str]]] = []
    for (number, _), cells in zip(lines[1:], rows[1:], strict=True):
        if len(cells) != len(header):
            raise FileFormatError(text_path, f"expected {len(header)} cells, got {len(cells)}", line=number)
        out.append((number, {name: cell.strip() for name, cell in zip(header, cells, strict=True)}))
    if not out:
        raise FileFormatError(text_path, "no data rows after the header")
    return out


def cell_float(path: str | Path, line: int, row: dict[str, str], column: str, *, allow_empty: bool = False) -> float:
    """The cell as a finite float (NaN when empty and ``allow_empty``)."""
    text = row.get(column, "")
    if text == "" and allow_empty:
        return math.nan
    try:
        value = float(text)
    except ValueError:
        raise FileFormatError(str(path), f"column {column!r}: expected a number, got {text!r}", line=line) from None
    if not math.isfinite(value):
        raise FileFormatError(str(path), f"column {column!r}: expected a finite number, got {text!r}", line=line)
    return value


def cell_int(path: str | Path, line: int, row: dict[str, str], column: str) -> int:
    """The cell as an integer."""
    text = row.get(column, "")
    try:
        return int(text)
    except ValueError:
        raise FileFormatError(str(path), f"column {column!r}: expected an integer, got {text!r}", line=line) from None


def cell_text(path: str | Path, line: int, row: dict[str, str], column: str) -> str:
    """The cell as non-empty text."""
    text = row.get(column, "")
    if not text:
        raise FileFormatError(str(path), f"column {column!r}: expected a value, got an empty cell", line=line)
    return text
