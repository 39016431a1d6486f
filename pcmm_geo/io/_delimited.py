"""Delimited numeric text (point files, ASCII PLY/PCD bodies) parsed block by block into one array.

A :class:`Layout` fixes, for a whole file, the field separator (``,`` ``;`` tab or spaces), the
decimal mark (``.`` or ``,``; with a separator other than ``,`` a comma can only be a decimal
mark, so an undecided mark is taken from the first number that has one), the number of fields
a row and the three columns kept.  :func:`read_rows` streams a file's blocks
(:func:`pcmm_geo.io._lines.iter_blocks`) into a preallocated ``(n, 3)`` float64 array:

- the *fast path* proves a block clean with a few vectorised byte scans (only ASCII digits,
  signs, exponents, separators and the file's decimal mark; every line holding the file's
  number of fields; no line over the length bound) and parses it: a block of plain decimals
  (no exponent, no padding; :func:`_plain_fields`) with a few numpy passes over its bytes,
  else with numpy's C reader (:func:`numpy.loadtxt`); both correctly rounded, and both refuse
  any field that is not a whole decimal number;
- anything else (a comment, a blank line with spaces, a NaN, a bad byte, a wrong field) sends
  the block to the *careful path*, which checks it line by line with the rules the refusals are
  written in (:meth:`Layout.parse`) and raises a :class:`~pcmm_geo.errors.FileFormatError`
  naming the line, or reads the block when it is valid after all.

The fast path accepts only blocks the careful path accepts, with the same numbers
(``tests/io/test_streaming_points.py`` checks this on generated blocks).
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.errors import FileFormatError
from pcmm_geo.io._lines import MAX_LINE_CHARS, LineBlock, decode_block, excerpt, iter_blocks

__all__ = ["Layout", "count_lines", "looks_numeric", "read_rows", "parse_block"]

FloatArray = NDArray[np.float64]

POINT_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?|[+-]?(nan|inf|infinity)", re.IGNORECASE | re.ASCII)
COMMA_NUMBER = re.compile(r"[+-]?(\d+,?\d*|,\d+)([eE][+-]?\d+)?|[+-]?(nan|inf|infinity)", re.IGNORECASE | re.ASCII)
SEPARATOR_NAMES = {";": "';'", "\t": "tab", ",": "','", " ": "spaces"}
# bytes a clean block may hold (anything else goes to the careful path)
_CLEAN_BYTES = b"0123456789+-.eE,; \t\r\n"
#: longest field the plain parser reads (sign, digits and decimal mark; longer ones go to numpy's reader):
#: its digits as one integer stay below 10**15 < 2**53, exact in float64
_PLAIN_PLACES = 15
#: bytes of a field as the plain parser reads them, right-aligned (zeros in front)
_WINDOW = 16
#: per first column (0-16), the mask of the bytes from that column on, as two little-endian words
_KEEP = (np.arange(_WINDOW)[None, :] >= np.arange(_WINDOW + 1)[:, None]).astype(np.uint8).__mul__(255).view("<u8")
_POWERS = 10.0 ** np.arange(_PLAIN_PLACES + 1)  # exact in float64
_INTEGER_POWERS = 10 ** np.arange(_PLAIN_PLACES + 1, dtype=np.int64)


def _split(text: str, separator: str) -> list[str]:
    if separator == " ":
        return text.split()
    return [f.strip() for f in text.split(separator)]


def looks_numeric(text: str) -> bool:
    """Whether the line reads as numbers with some separator and decimal mark (else it is a header).

    Examples
    --------
    >>> [looks_numeric(t) for t in ("1.5, 2.5, 3.5", "12,5;3;7", "12,5 3,25 7,75", "x,y,z", "1,2,x")]
    [True, True, True, False, False]
    """
    def numbers(fields: list[str], *patterns: re.Pattern[str]) -> bool:
        return bool(fields) and all(any(p.fullmatch(f) for p in patterns) for f in fields)

    return (numbers(_split(text, ";"), POINT_NUMBER, COMMA_NUMBER) or numbers(_split(text, "\t"), POINT_NUMBER,
            COMMA_NUMBER) or numbers(_split(text, ","), POINT_NUMBER) or numbers(text.split(), POINT_NUMBER,
                                                                                 COMMA_NUMBER))


@dataclass
class Layout:
    """One field separator and one decimal mark for the whole file, checked on every line.

    Attributes
    ----------
    file : str
    separator : {",", ";", "\\t", " "}
        ``" "`` is any run of spaces and tabs.
    decimal : {".", ",", None}
        None until the first number with a mark is read (separators other than ``,`` only).
    width : int
        Fields in every row.
    columns : tuple of int
        The x, y, z columns.
    """

    file: str
    separator: str
    decimal: str | None
    width: int
    columns: tuple[int, int, int] = (0, 1, 2)

    @classmethod
    def detect(cls, file: str, number: int, text: str, decimal: str | None) -> Layout:
        """The layout of the first data line ``text`` (``decimal``: as stated, or None to detect)."""
        if ";" in text:
            separator = ";"
        elif "\t" in text:
            separator = "\t"
        elif decimal == ",":
            separator = " "
        elif "," in text and all(POINT_NUMBER.fullmatch(f.strip()) for f in text.split(",")):
            separator = ","
            if ", " in text and re.search(r",(?! )", text):
                raise FileFormatError(file, f"ambiguous line {excerpt(text)}: ',' both with and without a space "
                                      "after it (decimal commas separated by ', '?); state the layout by "
                                      "separating fields with ';'", line=number)
        elif "," in text and all(COMMA_NUMBER.fullmatch(f) for f in text.split()):
            separator = " "  # 12,5 3,25 7,75: spaces between fields, decimal commas
        elif "," in text:
            separator = ","
        else:
            separator = " "
        fields = _split(text, separator)
        if separator == "," and decimal == ",":
            raise FileFormatError(
                file, f"ambiguous line {excerpt(text)}: ',' cannot be both separator and decimal mark", line=number
            )
        if separator == ",":
            decimal = "."
        layout = cls(file, separator, decimal, len(fields))
        layout.parse(number, text)
        return layout

    def header_names(self, text: str) -> list[str]:
        """The column names of a header line, split like the data."""
        return [f.strip('"').lower() for f in _split(text, self.separator)]

    def parse(self, number: int, text: str) -> list[float]:
        """The numbers of one data line (all fields), or a FileFormatError naming the line."""
        fields = _split(text, self.separator)
        sep = SEPARATOR_NAMES[self.separator]
        if len(fields) != self.width:
            raise FileFormatError(
                self.file, f"expected {self.width} values separated by {sep}, got {len(fields)} in {excerpt(text)}",
                line=number,
            )
        if self.decimal is None:  # the first mark decides (a comma is no separator here)
            marks = [c for c in text if c in ".,"]
            if marks:
                self.decimal = marks[0]
        decimal = self.decimal or "."
        pattern = COMMA_NUMBER if decimal == "," else POINT_NUMBER
        values = []
        for text_field in fields:
            if not pattern.fullmatch(text_field):
                if decimal == "," and POINT_NUMBER.fullmatch(text_field) and "." in text_field:
                    reason = f"decimal point in {excerpt(text_field)}, but this file uses decimal commas"
                elif decimal == "." and COMMA_NUMBER.fullmatch(text_field) and "," in text_field:
                    reason = f"decimal comma in {excerpt(text_field)}, but this file uses decimal points"
                elif "," in text_field and decimal == ",":
                    reason = f"ambiguous number {excerpt(text_field)}: ',' as decimal mark and separator"
                else:
                    reason = f"expected numbers separated by {sep}, got {excerpt(text_field)}"
                raise FileFormatError(self.file, reason, line=number)
            values.append(float(text_field.replace(",", ".")))
        return values


def _fast(data: bytes, layout: Layout) -> FloatArray | None:
    """The x, y, z of a clean block (see the module), or None when the careful path must decide."""
    if data.translate(None, _CLEAN_BYTES):
        return None
    if b"\r" in data:
        if data.count(b"\r") != data.count(b"\r\n"):
            return None
        data = data.replace(b"\r\n", b"\n")
    separator, decimal = layout.separator, layout.decimal
    if separator != ",":
        dot, comma = b"." in data, b"," in data
        if (dot and comma) or (decimal == "." and comma) or (decimal == "," and dot):
            return None
        decimal = decimal or ("," if comma else "." if dot else None)
    plain = _plain_fields(data, ord(separator), ord(decimal or "."), layout.width)
    if plain is not None:
        layout.decimal = decimal
        return np.ascontiguousarray(plain[:, list(layout.columns)])
    text = data.decode("ascii")
    if not text.strip():  # nothing but line ends and spaces (loadtxt would warn)
        return None if text.strip("\n") else np.empty((0, 3))
    lines = (text.replace(",", ".") if decimal == "," else text).split("\n")[:-1]
    if max(map(len, lines)) > MAX_LINE_CHARS:
        return None
    try:  # loadtxt refuses a row whose field count differs from the first row's; empty lines it skips
        values = np.loadtxt(lines, delimiter=None if separator == " " else separator, comments=None, ndmin=2,
                            dtype=np.float64)
    except ValueError:
        return None
    if values.shape[1] != layout.width:
        return None
    points = values[:, list(layout.columns)]
    if not np.isfinite(points).all():
        return None
    layout.decimal = decimal
    return points


def _plain_fields(data: bytes, separator: int, decimal: int, width: int) -> FloatArray | None:
    """All fields ``(lines, width)`` of a block of plain decimals, or None when numpy's reader must decide.

    Plain: every line ends with ``\\n`` and holds ``width`` fields, each separated by exactly one
    ``separator`` byte (spaces: one space) and made of an optional sign in front, digits and at
    most one ``decimal`` mark, at least one digit, at most 15 bytes (no exponent, no
    blank line, no padding).  Each field is read as the integer ``m`` of its digits and the
    number ``k`` of digits after the mark, both exact in float64; ``m / 10**k`` is then one
    correctly rounded division: the correctly rounded value of the decimal, as ``float()`` and
    :func:`numpy.loadtxt` give it.  Vectorised over the whole block: the fields are gathered,
    right-aligned, into a ``(fields, 16)`` byte matrix (one sliding-window gather), whose rows
    are turned into integers eight digits at a time (:func:`_digits_value`).
    """
    raw = np.frombuffer(data, dtype=np.uint8)
    if len(raw) == 0 or raw[-1] != 10:
        return None
    newline = raw == 10
    ends = np.flatnonzero(newline | (raw == separator))
    lines = int(np.count_nonzero(newline))
    if len(ends) != lines * width or not newline[ends[width - 1::width]].all():
        return None  # a line with another number of fields (the newlines are then elsewhere)
    line_ends = ends[width - 1::width]
    if int(np.diff(line_ends, prepend=-1).max()) > MAX_LINE_CHARS:
        return None
    starts = np.empty_like(ends)
    starts[0] = 0
    starts[1:] = ends[:-1] + 1
    lengths = ends - starts
    if int(lengths.min()) < 1 or int(lengths.max()) > _PLAIN_PLACES:
        return None
    by_line = lengths.reshape(lines, width)
    if np.array_equal(by_line, np.broadcast_to(by_line[0], by_line.shape)):  # every line laid out alike
        fixed = _fixed_fields(raw.reshape(lines, -1), by_line[0], decimal)
        if fixed is not None:
            return fixed
    padded = np.empty(_WINDOW + len(raw), dtype=np.uint8)
    padded[:_WINDOW] = 0
    padded[_WINDOW:] = raw
    # the 8-byte words starting at every byte (unaligned): the field ending at ``e`` is padded[e:e + 16],
    # right-aligned with the bytes of its line before it, which the mask of its first column clears
    words_at = np.ndarray((len(padded) - 7,), dtype="<u8", buffer=padded, strides=(1,))
    first = _WINDOW - lengths  # the column of each field's first byte (1 or more)
    words = np.empty((len(ends), 2), dtype="<u8")
    words[:, 0] = words_at[ends]
    words[:, 1] = words_at[ends + 8]
    words &= _KEEP[first]
    field = words.view(np.uint8)  # (fields, 16)
    rows = np.arange(len(field))
    lead = field[rows, first]
    signed = (lead == ord("-")) | (lead == ord("+"))
    field -= np.uint8(ord("0"))  # digits 0-9; marks, signs and the cleared bytes wrap round to 208 and more
    is_digit = field < 10
    is_mark = field == np.uint8((decimal - ord("0")) % 256)
    mark_at = np.argmax(is_mark, axis=1)
    has_mark = is_mark[rows, mark_at]
    marks, signs = np.count_nonzero(is_mark), np.count_nonzero(signed)
    minus, plus = np.uint8(ord("-") - ord("0") + 256), np.uint8(ord("+") - ord("0") + 256)
    # the bytes are digits, marks and signs (disjoint) besides the cleared ones; one mark at most a field,
    # signs only in front, one digit at least
    if (np.count_nonzero(is_digit) + marks + signs + int(first.sum()) != field.size
            or marks != np.count_nonzero(has_mark)
            or np.count_nonzero(field == minus) + np.count_nonzero(field == plus) != signs
            or not (lengths - has_mark - signed).min() >= 1):
        return None
    field *= is_digit
    whole = _digits_value(field)  # the digits as one integer with a zero in the mark's place (below 10**15)
    after = np.where(has_mark, _WINDOW - 1 - mark_at, 0)
    scale = _INTEGER_POWERS[after]
    mantissa = np.where(has_mark, whole // (10 * scale) * scale + whole % scale, whole)
    values = mantissa.astype(np.float64) / _POWERS[after]
    np.negative(values, out=values, where=lead == ord("-"))
    return values.reshape(lines, width)


def _fixed_fields(table: NDArray[np.uint8], lengths: NDArray[np.int64], decimal: int) -> FloatArray | None:
    """:func:`_plain_fields` of lines of one layout, ``table`` (lines, bytes a line): field ``j`` is ``lengths[j]``
    bytes at the same place in every line, its mark (if any) in the same column in every line.

    Each field's columns are checked and copied, right-aligned without the mark, as whole
    column slices of the table (no gather), then read eight digits at a time.
    """
    lines = len(table)
    values = np.empty((lines, len(lengths)))
    start = 0
    for column, length in enumerate(lengths.tolist()):
        cells = table[:, start:start + length]
        start += length + 1
        marks = np.flatnonzero(cells[0] == decimal)
        mark = int(marks[0]) if len(marks) else length  # the mark's column (length: none)
        lead = cells[:, 0]
        signed = (lead == ord("-")) | (lead == ord("+"))
        digits = np.full((lines, _WINDOW), ord("0"), dtype=np.uint8)
        after = length - mark - 1 if mark < length else 0
        digits[:, _WINDOW - after:] = cells[:, mark + 1:] if after else ord("0")
        digits[:, _WINDOW - after - mark:_WINDOW - after] = cells[:, :mark]
        digits -= np.uint8(ord("0"))
        first = digits[:, _WINDOW - after - mark] if mark else None
        if first is not None and signed.any():
            if mark + after == 1:  # a sign alone, or before the mark only
                return None
            first[signed] = 0
        if (mark < length and not np.all(cells[:, mark] == decimal)) or not np.all(digits < 10):
            return None
        if mark == 0 and (signed.any() or after == 0):  # a field of one mark, or a sign in its place
            return None
        values[:, column] = _digits_value(digits) / _POWERS[after]
        np.negative(values[:, column], out=values[:, column], where=lead == ord("-"))
    return values


def _digits_value(digits: NDArray[np.uint8]) -> NDArray[np.int64]:
    """The integers whose decimal digits are the rows of ``digits`` (M, 16), most significant first.

    Eight bytes are read as one little-endian 64-bit word and combined pairwise in three
    multiply-shift-mask steps (10, 100, 10**4: two digits, four, eight); no lane carries.
    """
    words = np.ascontiguousarray(digits).view("<u8")  # (M, 2): the high eight digits, the low eight
    combined = np.empty_like(words)
    for factor, shift, mask in ((10, 8, 0x00FF00FF00FF00FF), (100, 16, 0x0000FFFF0000FFFF),
                                (10_000, 32, 0x00000000FFFFFFFF)):
        np.multiply(words, np.uint64(factor), out=combined)
        np.right_shift(words, np.uint64(shift), out=words)
        words += combined
        words &= np.uint64(mask)
    value = words[:, 0].astype(np.int64)
    value *= 100_000_000
    value += words[:, 1].astype(np.int64)
    return value


def _careful(path: str, block: LineBlock, layout: Layout) -> FloatArray:
    """The x, y, z of a block checked line by line; the first problem raises, naming its line."""
    rows = []
    columns = list(layout.columns)
    for number, raw in decode_block(path, block):
        text = raw.strip()
        if not text or text.startswith("#"):
            continue
        values = layout.parse(number, text)
        point = [values[c] for c in columns]
        if not all(np.isfinite(point)):
            raise FileFormatError(path, f"non-finite coordinate {excerpt(text)}", line=number)
        rows.append(point)
    return np.array(rows, dtype=np.float64).reshape(-1, 3)


def parse_block(path: str, block: LineBlock, layout: Layout) -> FloatArray:
    """The points ``(m, 3)`` of one block (fast path, else careful path; see the module)."""
    points = _fast(block.data, layout)
    return _careful(path, block, layout) if points is None else points


def _limited(blocks: Iterator[LineBlock], max_lines: int | None) -> Iterator[LineBlock]:
    """The blocks up to and including line ``first_line + max_lines - 1`` of the first block (None: all)."""
    remaining = max_lines
    for block in blocks:
        if remaining is None:
            yield block
            continue
        count = block.lines
        if count >= remaining:
            cut = 0
            for _ in range(remaining):
                cut = block.data.index(b"\n", cut) + 1
            yield LineBlock(block.offset, block.first_line, block.data[:cut], True, True)
            return
        remaining -= count
        yield block
        if block.last:
            return


def count_lines(path: str | Path, start: int = 0, chunk: int = 1 << 24) -> int:
    """Lines from byte ``start`` to the end (a last line without line end counted): an upper bound of the rows."""
    lines, last = 0, b"\n"
    with open(path, "rb") as handle:
        handle.seek(start)
        while chunk_bytes := handle.read(chunk):
            lines += chunk_bytes.count(b"\n")
            last = chunk_bytes[-1:]
    return lines + (last != b"\n")


def read_rows(path: str | Path, start: int, first_line: int, layout: Layout, *, capacity: int | None = None,
              max_lines: int | None = None, block_bytes: int | None = None) -> FloatArray:
    """The points ``(n, 3)`` of the data lines from byte ``start`` (line ``first_line``) on.

    Parameters
    ----------
    path : str or Path
    start, first_line : int
        Where the data begin (the first data line, already used to detect ``layout``).
    layout : Layout
    capacity : int, optional
        Rows to preallocate (an upper bound; default: the lines left in the file, counted).
    max_lines : int, optional
        Read only this many lines (PLY: the vertex lines before the faces).
    block_bytes : int, optional
        Block size (tests use small blocks to put block edges everywhere).

    Raises
    ------
    FileFormatError
        The first bad line, named (see :meth:`Layout.parse`), binary data, non-UTF-8 bytes.
    """
    name = str(path)
    if capacity is None:
        capacity = count_lines(path, start) if max_lines is None else max_lines
    out = np.empty((capacity, 3), dtype=np.float64)
    filled = 0
    options = {} if block_bytes is None else {"block_bytes": block_bytes, "first_block_bytes": block_bytes}
    for block in _limited(iter_blocks(path, start=start, first_line=first_line, **options), max_lines):
        points = parse_block(name, block, layout)
        if filled + len(points) > capacity:
            raise FileFormatError(name, "the file grew while it was read")
        out[filled:filled + len(points)] = points
        filled += len(points)
    if filled < capacity:
        out.resize((filled, 3), refcheck=False)
    return out
