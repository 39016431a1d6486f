"""The streaming point reader: block edges, line numbers, the fast path against the careful path.

Every point file is parsed block by block (:mod:`pcmm_geo.io._delimited`); these tests put the
block edges everywhere (tiny blocks) and check that what a file holds, and the line named by a
refusal, do not depend on where the edges fall.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pcmm_geo.errors import FileFormatError
from pcmm_geo.io import read_points
from pcmm_geo.io._delimited import Layout, _careful, _fast, _plain_fields, count_lines, read_rows
from pcmm_geo.io._lines import LineBlock, iter_blocks
from pcmm_geo.io.points import scan_head


def _read(path: Path, block_bytes: int, decimal: str | None = None) -> np.ndarray:
    head = scan_head(path, decimal)
    return read_rows(path, head.data_offset, head.data_line, head.layout, block_bytes=block_bytes)


def _rows(n: int, seed: int = 3) -> np.ndarray:
    return np.round(np.random.default_rng(seed).uniform(-500, 500, (n, 3)), 6)


@pytest.mark.parametrize("ending", ["\n", "\r\n"])
@pytest.mark.parametrize("terminated", [True, False])
@pytest.mark.parametrize("bom", [b"", b"\xef\xbb\xbf"])
def test_block_edges_do_not_change_what_is_read(tmp_path: Path, ending: str, terminated: bool, bom: bytes) -> None:
    points = _rows(40)
    lines = ["# scan export", "x,y,z"] + [",".join(repr(float(v)) for v in p) for p in points]
    lines.insert(20, "# a comment between data lines")
    lines.insert(30, "")
    text = ending.join(lines) + (ending if terminated else "")
    path = tmp_path / "p.csv"
    path.write_bytes(bom + text.encode())
    np.testing.assert_array_equal(read_points(path), points)
    for block_bytes in range(1, 90, 7):  # blocks of one byte up to a few lines: every edge position
        np.testing.assert_array_equal(_read(path, block_bytes), points)


@pytest.mark.parametrize(("bad", "message"), [
    ("1.5,2.5", r"expected 3 values separated by ',', got 2"),
    ("1.5,2.5,x", "expected numbers separated by ','"),
    ("1.5,2.5,nan", "non-finite coordinate"),
    ("1.5,2.5,\uff13", "expected numbers separated by ','"),  # a full-width digit: float() would take it
    ("1.5,2.5,1_0", "expected numbers separated by ','"),
    ("1.5,2.5,3 # note", "expected numbers separated by ','"),
    ("1.5,2.5,1e999", "non-finite coordinate"),
    ("1.5,2.5,\x0c3", "control character 0x0c"),
])
def test_a_bad_line_is_named_wherever_the_block_edges_fall(tmp_path: Path, bad: str, message: str) -> None:
    lines = [",".join(repr(float(v)) for v in p) for p in _rows(30)]
    for position in (1, 14, 29) if bad == "1.5,2.5" else (0, 1, 14, 29):  # a short first row: header mismatch
        damaged = [*lines[:position], bad, *lines[position + 1:]]
        path = tmp_path / "p.csv"
        path.write_text("x,y,z\n" + "\n".join(damaged) + "\n", encoding="utf-8")
        for block_bytes in (None, 1, 5, 33, 34, 35, 64, 4096):
            with pytest.raises(FileFormatError, match=message) as info:
                if block_bytes is None:
                    read_points(path)
                else:
                    _read(path, block_bytes)
            assert info.value.line == position + 2, (position, block_bytes)


def test_error_line_numbers_in_a_large_file(tmp_path: Path) -> None:
    """Beyond the first block (4 MiB) line numbers still count every line, comments included."""
    points = _rows(300_000)
    body = "".join(f"{x:.6f};{y:.6f};{z:.6f}\n".replace(".", ",") for x, y, z in points)
    lines = body.splitlines(keepends=True)
    lines.insert(100_000, "# operator note\n")
    lines[250_000] = lines[250_000].replace(",", ".", 1)  # one decimal point in a decimal-comma file
    path = tmp_path / "big.txt"
    path.write_text("x;y;z\n" + "".join(lines))
    with pytest.raises(FileFormatError, match=r"big.txt:250002: decimal point in") as info:
        read_points(path)
    assert info.value.line == 250_002
    lines[250_000] = lines[250_000].replace(".", ",", 1)
    path.write_text("x;y;z\n" + "".join(lines))
    np.testing.assert_allclose(read_points(path), points, rtol=0, atol=0)


@pytest.mark.parametrize(("text", "expected"), [
    ("1.5, 2.5, 3.5\n4, 5, 6\n", [[1.5, 2.5, 3.5], [4, 5, 6]]),  # ", " between fields, no header (issue 22)
    ("1;2;3\n1,5;2,5;3,5\n", [[1, 2, 3], [1.5, 2.5, 3.5]]),  # ";": a comma can only be a decimal mark
    ("x\ty\tz\n1\t2\t3\n1,5\t2,5\t3,5\n", [[1, 2, 3], [1.5, 2.5, 3.5]]),
    ("1 2 3\n1,5 2,5 3,5\n", [[1, 2, 3], [1.5, 2.5, 3.5]]),
    ("x;y;z\n1;2;3\n1.5;2;3\n", [[1, 2, 3], [1.5, 2, 3]]),
])
def test_separators_fix_what_a_comma_is(tmp_path: Path, text: str, expected: list[list[float]]) -> None:
    path = tmp_path / "p.txt"
    path.write_text(text)
    np.testing.assert_array_equal(read_points(path), expected)
    np.testing.assert_array_equal(_read(path, 3), expected)


@pytest.mark.parametrize(("text", "line", "message"), [
    ("1;2;3\n1,5;2,5;3,5\n1.5;2;3\n", 3, "decimal point in '1.5', but this file uses decimal commas"),
    ("1;2;3\n1.5;2;3\n1,5;2;3\n", 3, "decimal comma in '1,5', but this file uses decimal points"),
    ("1;2;3\n1,5;2.5;3\n", 2, "decimal point in '2.5'"),
    ("1,5, 2,5, 3,5\n", 1, "',' both with and without a space after it"),
    ("1;2;3\n1,5;3,5,1;7\n", 2, "ambiguous number '3,5,1'"),
])
def test_mixed_marks_are_refused_on_their_line(tmp_path: Path, text: str, line: int, message: str) -> None:
    path = tmp_path / "p.txt"
    path.write_text(text)
    for read in (lambda: read_points(path), lambda: _read(path, 2)):
        with pytest.raises(FileFormatError, match=message) as info:
            read()
        assert info.value.line == line


def test_a_wrong_header_is_refused_without_reading_the_file(tmp_path: Path) -> None:
    path = tmp_path / "log.csv"
    with open(path, "wb") as handle:
        handle.write(b"start_stop,probe,motor\n")
        handle.truncate(1 << 40)  # a terabyte (sparse): reading it would take hours
    with pytest.raises(FileFormatError, match=r"log\.csv:2: binary data"):
        read_points(path)


def test_over_long_line_is_refused_with_its_length_without_keeping_it(tmp_path: Path) -> None:
    path = tmp_path / "p.csv"
    path.write_bytes(b"x,y,z\n1,2,3\n" + b"7" * 3_000_000 + b"\n4,5,6\n")
    with pytest.raises(FileFormatError, match=r"line of 3000000 characters") as info:
        read_points(path)
    assert info.value.line == 3 and len(str(info.value)) < 300


def test_iter_blocks_yields_whole_lines_and_a_last_block(tmp_path: Path) -> None:
    path = tmp_path / "t.txt"
    path.write_bytes(b"\xef\xbb\xbfab\ncd\r\nef")
    blocks = list(iter_blocks(path, block_bytes=2, first_block_bytes=2))
    assert b"".join(b.data for b in blocks) == b"ab\ncd\r\nef\n"
    assert blocks[0].offset == 3 and blocks[-1].last and not blocks[-1].terminated
    assert [b.first_line for b in blocks if b.data] == [1, 2, 3]
    assert count_lines(path, 3) == 3
    empty = tmp_path / "empty.txt"
    empty.write_bytes(b"")
    assert [(b.data, b.last, b.terminated) for b in iter_blocks(empty)] == [(b"", True, True)]


# --- the fast path never accepts what the careful path refuses, nor reads other numbers -----------------------

_TOKENS = st.sampled_from(["0", "1", "-2.5", "+.5", "7.", "1e5", "2E-3", "1,5", "3,25", "nan", "1e999", "", " ",
                           "1.2.3", "1,2,3", "--1", "e5", ".", "x", "1_0", "\uff11", "12.5", "0.000001", "-0"])
_SEPARATORS = st.sampled_from([",", ";", "\t", " ", ", ", " ; "])


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(rows=st.lists(st.lists(_TOKENS, min_size=2, max_size=4), min_size=1, max_size=6), separator=_SEPARATORS,
       decimal=st.sampled_from([None, ".", ","]), width=st.sampled_from([3, 4]), ending=st.sampled_from(["\n", "\r\n"]))
def test_fast_path_agrees_with_the_careful_path(rows: list[list[str]], separator: str, decimal: str | None,
                                               width: int, ending: str) -> None:
    sep = separator.strip() or separator[0]
    if sep == "," and decimal == ",":
        decimal = "."
    data = "".join(separator.join(row) + ending for row in rows).encode()
    columns = (0, 1, 2) if width == 3 else (3, 1, 0)
    block = LineBlock(0, 1, data, True)
    fast = _fast(data, Layout("f.txt", sep, "." if sep == "," else decimal, width, columns))
    careful_layout = Layout("f.txt", sep, "." if sep == "," else decimal, width, columns)
    try:
        careful = _careful("f.txt", block, careful_layout)
    except FileFormatError:
        assert fast is None, data
        return
    if fast is not None:
        np.testing.assert_array_equal(fast, careful)


# --- the plain block parser (vectorised, no numpy reader) reads what numpy's reader and the careful path read ---

_PLAIN_TOKENS = st.sampled_from(["0", "-0", "+0", "1", "-2.5", "+.5", "7.", ".", "-", "+", "-.", "1.2.3", "--1",
                                 "1-2", "007.250", "123456789012345", "1234567890123456", "12345678.901234",
                                 "-.12345678901234", "99999999.999999", "1e5", "", " 1", "1 ", "0.000001", "x"])


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(rows=st.lists(st.lists(_PLAIN_TOKENS, min_size=2, max_size=4), min_size=1, max_size=5),
       separator=st.sampled_from([",", ";", "\t", " "]), decimal=st.sampled_from([".", ","]),
       width=st.sampled_from([2, 3, 4]), blank=st.booleans())
def test_plain_parser_agrees_with_numpy_and_the_careful_path(rows: list[list[str]], separator: str, decimal: str,
                                                             width: int, blank: bool) -> None:
    """On hostile fields the plain parser either declines (None) or gives exactly the careful path's numbers.

    Equality is exact by construction, not by luck of rounding: both sides return the correctly
    rounded double of each decimal (``float()``; the plain parser's one division of exact operands).
    """
    if separator == ",":
        decimal = "."
    text = "".join(separator.join(token.replace(".", decimal) for token in row) + "\n" for row in rows)
    data = (text + "\n" if blank else text).encode()
    plain = _plain_fields(data, ord(separator), ord(decimal), width)
    layout = Layout("f.txt", separator, decimal, width, (width - 1, 0, 1))
    try:
        careful = _careful("f.txt", LineBlock(0, 1, data, True), layout)
    except FileFormatError:
        assert plain is None, data
        return
    if plain is None:
        return
    columns = list(layout.columns)
    np.testing.assert_array_equal(plain[:, columns], careful)
    lines = text.replace(",", ".").split("\n")[:-1] if decimal == "," else text.split("\n")[:-1]
    numpy_values = np.loadtxt(lines, delimiter=None if separator == " " else separator, comments=None, ndmin=2)
    np.testing.assert_array_equal(plain, numpy_values)


def test_plain_parser_reads_scanner_rows_and_names_the_bad_line(tmp_path: Path) -> None:
    """Six-decimal rows of either sign (varying width) go through the plain parser with the values of ``float()``;
    a bad field later in the file still refuses with its line number."""
    rng = np.random.default_rng(31)
    values = rng.uniform(-2000.0, 2000.0, (500, 3))
    text = "".join(f"{x:.6f},{y:.6f},{z:.6f}\n" for x, y, z in values)
    plain = _plain_fields(text.encode(), ord(","), ord("."), 3)
    assert plain is not None
    expected = np.array([[float(f) for f in line.split(",")] for line in text.splitlines()])
    np.testing.assert_array_equal(plain, expected)
    np.testing.assert_allclose(plain, values, rtol=0, atol=5.1e-7)  # six decimals: within half a unit of 1e-6
    path = tmp_path / "scan.csv"
    lines = text.splitlines()
    lines[316] = lines[316].replace(".", "..", 1)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(FileFormatError, match=r"scan\.csv:317: .*\.\.\d"):
        read_rows(path, 0, 1, Layout(str(path), ",", ".", 3), block_bytes=4096)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(layout=st.lists(st.tuples(st.integers(0, 6), st.integers(0, 7), st.sampled_from(["", "-", "+", "+-"])),
                       min_size=3, max_size=4),
       seed=st.integers(0, 2**16), lines=st.integers(1, 6), separator=st.sampled_from([",", ";", " "]),
       spoil=st.sampled_from([None, "-", "+", ".", ",", "e", "0", " ", ""]), where=st.integers(0, 10_000))
def test_fixed_layout_blocks_read_as_float_reads_them(layout: list[tuple[int, int, str]], seed: int, lines: int,
                                                      separator: str, spoil: str | None, where: int) -> None:
    """Lines of one layout (same field widths, marks in the same columns: the column-slice path), sometimes with one
    byte replaced or removed: the plain parser gives ``float()`` of every field, or declines when the careful path
    refuses."""
    rng = np.random.default_rng(seed)
    rows = []
    for _ in range(lines):
        fields = []
        for whole, decimals, signs in layout:
            sign = str(rng.choice(list(signs))) if signs else ""
            digits = "".join(str(d) for d in rng.integers(0, 10, whole + decimals))
            fields.append(sign + digits[:whole] + ("." + digits[whole:] if decimals or not whole else ""))
        rows.append(separator.join(fields))
    text = "".join(row + "\n" for row in rows)
    if spoil is not None:
        position = where % len(text)
        if text[position] != "\n":
            text = text[:position] + spoil + text[position + 1:]
    data = text.encode()
    width = len(layout)
    plain = _plain_fields(data, ord(separator), ord("."), width)
    try:
        careful = _careful("f.txt", LineBlock(0, 1, data, True), Layout("f.txt", separator, ".", width, (0, 1, 2)))
    except FileFormatError:
        assert plain is None, data
        return
    if plain is not None:
        np.testing.assert_array_equal(plain, [[float(f) for f in row.split(separator)] for row in text.splitlines()])
        np.testing.assert_array_equal(plain[:, :3], careful)
    else:
        assert spoil is not None, data  # at most 15 bytes a field: an unspoilt block is never declined
