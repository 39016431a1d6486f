"""Decoding text files line by line with errors that name the file and the line.

Every text reader of pcmm_geo goes through :func:`read_text_lines` / :func:`iter_text_lines`
(or :func:`read_csv_rows`, built on the same blocks of :mod:`pcmm_geo.io._lines`), so a binary
file, bytes that are not UTF-8, a directory, an over-long line or a bad quote give one
:class:`FileFormatError` (``path:line: reason``) instead of a bare ``UnicodeDecodeError`` or
``_csv.Error``.  Messages quote at most a short :func:`excerpt` of the offending text, however
long the line is.  The file is read in blocks: a reader that checks its header while iterating
(:func:`iter_text_lines`, ``read_csv_rows(check_header=...)``) refuses a wrong file without
reading the rest of it.

A leading UTF-8 byte-order mark (as Excel and Windows Notepad write) is dropped here, so
every reader accepts such files.

:func:`read_json_file` parses JSON strictly and refuses, each with a :class:`FileFormatError`
naming the file and the line: ``NaN`` / ``Infinity`` (Python writes them, JSON has none);
numbers that overflow a float (``1e400`` would silently become ``inf``) and integers of more
than 308 digits; the same key twice in one object (``json`` keeps the last one silently);
nesting deeper than :data:`MAX_JSON_DEPTH` (``json`` would end in ``RecursionError``).
:class:`pcmm_geo.io._json.JsonNode` then checks the fields of the parsed document.
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pcmm_geo.errors import FileFormatError
from pcmm_geo.io._lines import EXCERPT_CHARS, MAX_LINE_CHARS, decode_block, excerpt, iter_blocks, text_codec

__all__ = [
    "EXCERPT_CHARS",
    "MAX_FIELD_CHARS",
    "MAX_JSON_DEPTH",
    "MAX_LINE_CHARS",
    "CsvRows",
    "excerpt",
    "iter_text_lines",
    "parse_decimal",
    "read_csv_rows",
    "read_json_file",
    "read_text_file",
    "read_text_lines",
]

#: longest CSV field (characters) :func:`read_csv_rows` accepts
MAX_FIELD_CHARS = 4_096
_DECIMAL = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|[+-]?(?:nan|inf|infinity)", re.IGNORECASE | re.ASCII)


def parse_decimal(text: str) -> float:
    """An ASCII decimal number (``-1.5``, ``2e-3``, ``nan``, ``inf``) as float; anything else raises ValueError.

    Stricter than :class:`float`, which also takes ``1_000``, full-width or Arabic-Indic
    digits: a file holding those is refused rather than read as numbers nobody wrote.

    Examples
    --------
    >>> parse_decimal(" 12.5 ")
    12.5
    >>> float("1_0"), float("\\uff11\\uff12")
    (10.0, 12.0)
    >>> for bad in ("1_0", "\\uff11\\uff12", "2\\u00b2", "1,5"):
    ...     try:
    ...         parse_decimal(bad)
    ...     except ValueError:
    ...         print("refused", ascii(bad))
    refused '1_0'
    refused '\\uff11\\uff12'
    refused '2\\xb2'
    refused '1,5'
    """
    stripped = text.strip()
    if not _DECIMAL.fullmatch(stripped):
        raise ValueError(f"expected a decimal number, got {excerpt(stripped)}")
    return float(stripped)


def _decode(path: str | Path, max_line: int | None = MAX_LINE_CHARS) -> tuple[list[tuple[int, str]], bool]:
    """Lines of ``path`` and whether the last one ends with a line end (see :func:`read_text_lines`)."""
    lines: list[tuple[int, str]] = []
    for block in iter_blocks(path, max_line=max_line):
        lines.extend(decode_block(path, block, max_line))
        if block.last:
            return lines, block.terminated
    raise AssertionError("iter_blocks ends with a last block")  # pragma: no cover


def iter_text_lines(path: str | Path, *, encoding: str | None = None) -> Iterator[tuple[int, str]]:
    """The lines of a text file as :func:`read_text_lines` gives them, read block by block.

    A reader that refuses a wrong header while iterating stops there: the rest of the file is
    never read.  Errors (as :func:`read_text_lines`) are raised when the line is reached.
    ``encoding`` None reads UTF-8; a reader that lets its caller name the encoding (files from
    CMM software) passes it here: it must be ASCII-compatible (``cp1252``, ``latin-1``, ...)
    and is checked before the file is opened.

    Raises
    ------
    FileFormatError
        As :func:`read_text_lines`; an unknown or not ASCII-compatible ``encoding``.
    FileNotFoundError
        The file does not exist.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "report.dmo")
    >>> _ = open(path, "wb").write("$$ Prüfbericht\\nEND\\n".encode("cp1252"))
    >>> list(iter_text_lines(path, encoding="cp1252"))
    [(1, '$$ Prüfbericht'), (2, 'END')]
    >>> try:
    ...     next(iter_text_lines(path))
    ... except FileFormatError as exc:
    ...     print(exc.line, exc.reason)
    1 not UTF-8 text: byte 0xfc at column 6
    """
    codec = None if encoding is None else text_codec(path, encoding)
    for block in iter_blocks(path):
        yield from decode_block(path, block, encoding=codec)


def read_text_lines(path: str | Path) -> list[tuple[int, str]]:
    """The lines of a UTF-8 text file as ``(line_number, text)``, line numbers from 1.

    A leading byte-order mark is dropped; line ends (``\\n``, ``\\r\\n``) are removed.

    Raises
    ------
    FileFormatError
        The path is a directory, the file holds NUL bytes (binary data) or other control
        characters (not tab, CR, LF), a line is not valid UTF-8 or longer than
        :data:`MAX_LINE_CHARS`; the message names the line and quotes at most an excerpt.
    FileNotFoundError
        The file does not exist.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "t.csv")
    >>> _ = open(path, "wb").write(b"\\xef\\xbb\\xbfx,y,z\\r\\n1,2,3\\n")
    >>> read_text_lines(path)
    [(1, 'x,y,z'), (2, '1,2,3')]
    >>> _ = open(path, "wb").write(b"x,y,z\\n1,2,\\xb53\\n")
    >>> try:
    ...     read_text_lines(path)
    ... except FileFormatError as exc:
    ...     print(exc.line, exc.reason)
    2 not UTF-8 text: byte 0xb5 at column 5
    """
    return _decode(path)[0]


def read_text_file(path: str | Path, *, max_line: int | None = MAX_LINE_CHARS) -> str:
    """The whole text of a UTF-8 file (BOM dropped, ``\\r\\n`` as ``\\n``), checked as :func:`read_text_lines` does.

    ``max_line=None`` lifts the line-length bound (JSON may be written on one line).

    Raises
    ------
    FileFormatError
        Directory, binary data, non-UTF-8 bytes or an over-long line (the message names the line).
    FileNotFoundError
        The file does not exist.
    """
    return "".join(text + "\n" for _, text in _decode(path, max_line)[0])


@dataclass(frozen=True)
class CsvRows:
    """The data of a CSV file as read by :func:`read_csv_rows`.

    Attributes
    ----------
    rows : tuple of (int, tuple of str)
        ``(line_number, cells)`` for every line that is neither blank nor a ``#`` comment;
        cells are not stripped.
    terminated : bool
        Whether the file's last line ends with a line end.  A file written row by row that
        was cut off (power loss, a copy in progress) usually is not, and its last value may
        be torn mid-number: ``12.34`` where ``12.3456`` was being written.
    path : str
        The file, for messages.
    line_count : int
        Lines in the file (the last one counted also without a line end).
    """

    rows: tuple[tuple[int, tuple[str, ...]], ...]
    terminated: bool
    path: str
    line_count: int = 0

    @property
    def unterminated_row(self) -> int | None:
        """Line number of the last row when it is the file's last line and has no line end, else None."""
        if self.terminated or not self.rows or self.rows[-1][0] != self.line_count:
            return None
        return self.rows[-1][0]


def _split_line(path: str, number: int, text: str) -> tuple[str, ...]:
    if '"' not in text:  # the csv module would split such a line at the commas too
        cells = tuple(text.split(","))
    else:
        try:
            cells = tuple(next(csv.reader([text], strict=True)))
        except csv.Error as exc:
            raise FileFormatError(path, f"bad CSV quoting ({exc}): {excerpt(text)}", line=number) from None
    if len(text) <= MAX_FIELD_CHARS:  # no field can be longer than its line
        return cells
    for column, cell in enumerate(cells, start=1):
        if len(cell) > MAX_FIELD_CHARS:
            raise FileFormatError(
                path, f"field {column} has {len(cell)} characters (at most {MAX_FIELD_CHARS} accepted): "
                f"{excerpt(cell)}", line=number,
            )
    return cells


def read_csv_rows(path: str | Path, *,
                  check_header: Callable[[int, tuple[str, ...]], None] | None = None) -> CsvRows:
    """Rows of a comma-separated UTF-8 file, each with its line number; blank and ``#`` lines skipped.

    ``check_header(line_number, cells)``, when given, sees the first row as soon as it is read
    and refuses a wrong file by raising: the rest of the file is then never read (a 300 MB
    point file handed to a log reader is refused after its first few kilobytes).

    The one CSV tokenizer of pcmm_geo: bounded line and field sizes (:data:`MAX_LINE_CHARS`,
    :data:`MAX_FIELD_CHARS`), double-quoted fields within one line (RFC 4180 without
    line breaks inside quotes), every problem a :class:`FileFormatError` naming the line.

    Raises
    ------
    FileFormatError
        Directory, binary or non-UTF-8 content, an over-long line or field, bad quoting.
    FileNotFoundError
        The file does not exist.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "t.csv")
    >>> _ = open(path, "w").write('# note\\nname,x\\n"a, b",1\\n\\nc,2')
    >>> table = read_csv_rows(path)
    >>> table.rows
    ((2, ('name', 'x')), (3, ('a, b', '1')), (5, ('c', '2')))
    >>> table.terminated
    False
    >>> _ = open(path, "w").write('x\\n"1\\n')
    >>> try:
    ...     read_csv_rows(path)
    ... except FileFormatError as exc:
    ...     print(exc.line, exc.reason)
    2 bad CSV quoting (unexpected end of data): '"1'
    """
    name = str(path)
    rows: list[tuple[int, tuple[str, ...]]] = []
    line_count = 0
    for block in iter_blocks(path):
        for number, text in decode_block(path, block):
            line_count = number
            if text.strip() and not text.lstrip().startswith("#"):
                rows.append((number, _split_line(name, number, text)))
                if check_header is not None and len(rows) == 1:
                    check_header(*rows[0])
        if block.last:
            return CsvRows(tuple(rows), block.terminated, name, line_count)
    raise AssertionError("iter_blocks ends with a last block")  # pragma: no cover


#: deepest nesting of arrays and objects accepted (pcmm_geo's own files need fewer than 8)
MAX_JSON_DEPTH = 64
_MAX_INT_DIGITS = 308
_STRING = re.compile(r'"(?:[^"\\\n]|\\.)*"')


class _Refused(Exception):
    """Raised inside the ``json`` hooks; carries the token to locate and the reason."""

    def __init__(self, token: str, reason: str) -> None:
        super().__init__(reason)
        self.token, self.reason = token, reason


def _parse_float(token: str) -> float:
    value = float(token)
    if not math.isfinite(value):
        raise _Refused(token, f"expected a finite number, got {token} (beyond the float range, it would read as inf)")
    return value


def _parse_int(token: str) -> int:
    if len(token.lstrip("-")) > _MAX_INT_DIGITS:
        raise _Refused(token[:20], f"expected a number, got an integer of {len(token.lstrip('-'))} digits")
    return int(token)


def _parse_constant(token: str) -> float:
    raise _Refused(token, f"expected JSON, got the non-finite number {token}")


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    result: dict[str, Any] = {}
    for key, value in pairs:
        if key in result:
            raise _Refused(f'"{key}"', f"key {excerpt(key)} appears twice in one object (which one is meant?)")
        result[key] = value
    return result


def _line_of(text: str, position: int) -> int:
    return text.count("\n", 0, position) + 1


def _check_depth(path: str, text: str, limit: int) -> None:
    """Refuse nesting deeper than ``limit`` before ``json`` recurses into it."""
    if text.count("[") + text.count("{") <= limit:
        return
    import numpy as np

    skeleton = _STRING.sub('""', text)  # brackets inside strings do not nest
    codes = np.frombuffer(skeleton.encode("utf-8"), dtype=np.uint8)
    step = np.isin(codes, (ord("["), ord("{"))).astype(np.int64) - np.isin(codes, (ord("]"), ord("}")))
    depth = np.cumsum(step)
    if depth.size and depth.max() > limit:
        first = int(np.argmax(depth > limit))
        line = skeleton.encode("utf-8")[:first].count(b"\n") + 1
        raise FileFormatError(path, f"expected JSON nested at most {limit} deep, got deeper nesting", line=line)


def read_json_file(path: str | Path, *, max_depth: int = MAX_JSON_DEPTH) -> Any:
    """Parse a UTF-8 JSON file strictly (see the module docstring for what is refused).

    Parameters
    ----------
    path : str or Path
    max_depth : int
        Deepest nesting of arrays/objects accepted.

    Returns
    -------
    object
        ``dict``, ``list``, ``str``, ``int``, ``float``, ``bool`` or None, as :func:`json.loads`.

    Raises
    ------
    FileFormatError
        Not text, a syntax error, a non-finite or overflowing number, a duplicate key or too
        deep nesting; the message names the file and, where it can, the line.
    FileNotFoundError
        The file does not exist.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "c.json")
    >>> _ = open(path, "w").write('{"radius": 5.0,\\n "form": 1e400}')
    >>> try:
    ...     read_json_file(path)
    ... except FileFormatError as exc:
    ...     print(exc.line, exc.reason)
    2 expected a finite number, got 1e400 (beyond the float range, it would read as inf)
    >>> _ = open(path, "w").write("[" * 10_000 + "]" * 10_000)
    >>> try:
    ...     read_json_file(path)
    ... except FileFormatError as exc:
    ...     print(exc.reason)
    expected JSON nested at most 64 deep, got deeper nesting
    """
    import json

    name = str(path)
    text = read_text_file(path, max_line=None)
    _check_depth(name, text, max_depth)
    try:
        return json.loads(text, parse_float=_parse_float, parse_int=_parse_int, parse_constant=_parse_constant,
                          object_pairs_hook=_unique_keys)
    except json.JSONDecodeError as exc:
        raise FileFormatError(name, f"expected JSON, got {exc.msg}", line=exc.lineno) from None
    except _Refused as exc:
        found = re.search(rf"(?<![\w.+\-\"]){re.escape(exc.token)}", text)
        if exc.token.startswith('"'):  # a duplicate key: its second occurrence
            hits = [m.start() for m in re.finditer(re.escape(exc.token) + r"\s*:", text)]
            line = _line_of(text, hits[1]) if len(hits) > 1 else None
        else:
            line = _line_of(text, found.start()) if found else None
        raise FileFormatError(name, exc.reason, line=line) from None
    except RecursionError:  # pragma: no cover - _check_depth stops this first
        raise FileFormatError(name, "expected JSON, got nesting too deep to read") from None
