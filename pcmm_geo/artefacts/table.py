"""Small CSV reader shared by the artefact evaluations: named columns, typed cells, precise errors.

Public (not ``_table``) because the CLI reads its small tables the same way (``pcmm thermal
thermistor --calibration``): one reader, one wording of its errors (file, line, column).
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from pathlib import Path

from pcmm_geo.errors import FileFormatError

__all__ = ["cell_float", "cell_int", "cell_text", "read_rows"]


def read_rows(path: str | Path, required: Sequence[str]) -> list[tuple[int, dict[str, str]]]:
    """Rows of a CSV file as ``(line_number, {column: text})``; ``#`` lines and blank lines are skipped.

    Raises
    ------
    FileFormatError
        No header, missing or repeated columns, no data rows, a row with the wrong number of
        cells, binary or non-UTF-8 content, an over-long field, bad quoting, a directory.
    OSError
        The file cannot be read.
    """
    from pcmm_geo.io.text import read_csv_rows

    text_path = str(path)

    def check_header(line: int, cells: tuple[str, ...]) -> None:  # before the rest of the file is read
        header = [name.strip().lower() for name in cells]
        missing = [name for name in required if name not in header]
        if missing:
            semicolons = any(";" in cell for cell in cells)
            hint = "; fields must be separated by ',' with '.' as decimal mark" if semicolons else ""
            raise FileFormatError(
                text_path, f"expected columns {', '.join(required)}; missing {', '.join(missing)}{hint}", line=line
            )

    lines = read_csv_rows(path, check_header=check_header).rows
    if not lines:
        raise FileFormatError(text_path, "empty file: expected a CSV header and data rows")
    header = [name.strip().lower() for name in lines[0][1]]
    twice = sorted({name for name in header if name and header.count(name) > 1})
    if twice:
        raise FileFormatError(text_path, f"column {twice[0]!r} appears twice in the header (which one is meant?)",
                              line=lines[0][0])
    out: list[tuple[int, dict[str, str]]] = []
    for number, cells in lines[1:]:
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
    from pcmm_geo.io.text import excerpt, parse_decimal

    try:
        value = parse_decimal(text)
    except ValueError:
        raise FileFormatError(str(path), f"column {column!r}: expected a number, got {excerpt(text)}",
                              line=line) from None
    if not math.isfinite(value):
        raise FileFormatError(str(path), f"column {column!r}: expected a finite number, got {excerpt(text)}",
                              line=line)
    return value


def cell_int(path: str | Path, line: int, row: dict[str, str], column: str) -> int:
    """The cell as an integer."""
    from pcmm_geo.io.text import excerpt

    text = row.get(column, "")
    if not re.fullmatch(r"[+-]?[0-9]{1,18}", text):
        raise FileFormatError(str(path), f"column {column!r}: expected an integer, got {excerpt(text)}", line=line)
    return int(text)


def cell_text(path: str | Path, line: int, row: dict[str, str], column: str) -> str:
    """The cell as non-empty text."""
    text = row.get(column, "")
    if not text:
        raise FileFormatError(str(path), f"column {column!r}: expected a value, got an empty cell", line=line)
    return text
