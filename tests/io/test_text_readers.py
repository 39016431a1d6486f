"""The shared reader helpers of pcmm_geo.io._text and pcmm_geo.io._json, case by case.

The command-line corpus (tests/cli/test_bad_input.py) checks what users see; these tests pin
the helpers' own contracts: line numbers, bounds, what counts as a number, JSON paths.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.errors import FileFormatError, InvalidInputError, LogIntegrityError
from pcmm_geo.io._json import MAX_JSON_DEPTH, JsonNode, read_json_file
from pcmm_geo.io._text import (
    MAX_FIELD_CHARS,
    MAX_LINE_CHARS,
    excerpt,
    parse_decimal,
    read_csv_rows,
    read_text_lines,
)


def _file(tmp_path: Path, content: bytes | str, name: str = "f.csv") -> Path:
    path = tmp_path / name
    path.write_bytes(content.encode() if isinstance(content, str) else content)
    return path


def test_csv_rows_keep_line_numbers_through_comments_blanks_quotes_bom_and_crlf(tmp_path: Path) -> None:
    path = _file(tmp_path, b'\xef\xbb\xbf# comment\r\nname,x\r\n\r\n"a, ""b""",1\r\nc,2\r\n')
    table = read_csv_rows(path)
    assert table.rows == ((2, ("name", "x")), (4, ('a, "b"', "1")), (5, ("c", "2")))
    assert table.terminated and table.unterminated_row is None and table.line_count == 5


@pytest.mark.parametrize(("content", "unterminated"), [
    ("x\n1\n2", 3), ("x\n1\n2\n", None), ("x\n1\n# trailing note", None), ("x\n1\n   ", None), ("", None),
])
def test_unterminated_row_is_only_a_last_data_row_without_line_end(tmp_path: Path, content: str,
                                                                   unterminated: int | None) -> None:
    assert read_csv_rows(_file(tmp_path, content)).unterminated_row == unterminated


def test_field_and_line_bounds_give_short_messages_with_the_line(tmp_path: Path) -> None:
    at_limit = "9" * MAX_FIELD_CHARS
    assert read_csv_rows(_file(tmp_path, f"x,y\n{at_limit},1\n")).rows[1][1][0] == at_limit
    with pytest.raises(FileFormatError) as info:
        read_csv_rows(_file(tmp_path, f"x,y\n1,2\n3,{at_limit}9\n"))
    assert info.value.line == 3 and f"field 2 has {MAX_FIELD_CHARS + 1} characters" in info.value.reason
    assert len(str(info.value)) < 300
    with pytest.raises(FileFormatError) as info:
        read_text_lines(_file(tmp_path, "x\n" + "1," * MAX_LINE_CHARS + "\n"))
    assert info.value.line == 2 and f"line of {2 * MAX_LINE_CHARS} characters" in info.value.reason
    assert len(str(info.value)) < 300


@pytest.mark.parametrize(("line", "reason"), [('"a,1', "unexpected end of data"), ('a"b",1', "")])
def test_bad_quoting_names_the_line(tmp_path: Path, line: str, reason: str) -> None:
    path = _file(tmp_path, f"x,y\n{line}\n")
    if line.startswith('"'):
        with pytest.raises(FileFormatError, match=reason) as info:
            read_csv_rows(path)
        assert info.value.line == 2
    else:  # a quote inside an unquoted field is data, as in RFC 4180 readers
        assert read_csv_rows(path).rows[1][1] == ('a"b"', "1")


@pytest.mark.parametrize(("text", "value"), [("1", 1.0), (" -2.5e-3 ", -0.0025), ("+.5", 0.5), ("7.", 7.0),
                                              ("1E+2", 100.0), ("inf", np.inf), ("-Infinity", -np.inf)])
def test_parse_decimal_reads_ascii_decimals(text: str, value: float) -> None:
    assert parse_decimal(text) == value


@pytest.mark.parametrize("text", ["", "1_000", "\uff11", "\u0661\u0662", "2\u00b2", "\u00b2", "1,5", "0x10", "1e",
                                  "--1", "1 2", "nan1"])
def test_parse_decimal_refuses_what_float_would_misread(text: str) -> None:
    with pytest.raises(ValueError, match="expected a decimal number"):
        parse_decimal(text)


def test_nan_is_a_decimal_the_readers_then_refuse_as_not_finite() -> None:
    assert np.isnan(parse_decimal("NaN"))


def test_excerpt_bounds_any_text() -> None:
    assert excerpt("abc") == "'abc'"
    long = excerpt("x" * 10_000_000)
    assert long.endswith("... (10000000 characters)") and len(long) < 100


def test_errors_never_grow_with_the_quoted_input() -> None:
    huge = "7" * 1_000_000
    for error in (FileFormatError("f.csv", f"bad {huge}", line=3), LogIntegrityError("log.csv", huge, 2),
                  InvalidInputError("points", "finite numbers", huge)):
        assert len(str(error)) < 600 and "characters left out" in str(error)
    assert str(FileFormatError("f.csv", "short reason", line=1)) == "f.csv:1: short reason"


# --- JSON -------------------------------------------------------------------------------------------------------

def _json(tmp_path: Path, text: str) -> Path:
    return _file(tmp_path, text, "doc.json")


def test_json_nesting_at_the_limit_reads_one_deeper_is_refused(tmp_path: Path) -> None:
    deep = "[" * MAX_JSON_DEPTH + "]" * MAX_JSON_DEPTH
    value = read_json_file(_json(tmp_path, deep))
    for _ in range(MAX_JSON_DEPTH - 1):
        value = value[0]
    assert value == []
    with pytest.raises(FileFormatError, match=f"nested at most {MAX_JSON_DEPTH} deep"):
        read_json_file(_json(tmp_path, "[" + deep + "]"))


def test_json_brackets_inside_strings_do_not_count_as_nesting(tmp_path: Path) -> None:
    text = json.dumps({"note": "[" * 1000 + '\\"{' * 500, "value": [1, 2]})
    assert read_json_file(_json(tmp_path, text))["value"] == [1, 2]


def test_json_deep_nesting_is_found_on_its_line(tmp_path: Path) -> None:
    with pytest.raises(FileFormatError) as info:
        read_json_file(_json(tmp_path, '{\n"a": 1,\n"b": ' + "[" * 200_000 + "]" * 200_000 + "\n}"))
    assert info.value.line == 3


@pytest.mark.parametrize(("text", "line", "reason"), [
    ('{"a": 1,\n "b": 1e400}', 2, "expected a finite number, got 1e400"),
    ('{"a": 1,\n\n "b": -2.5E+309}', 3, r"got -2\.5E\+309"),
    ('{"a": [1,\n Infinity]}', 2, "non-finite number Infinity"),
    ('{"a": -NaN}', 1, "expected JSON, got Expecting value"),  # not JSON at all
    ('{"a": 1' + "0" * 400 + "}", 1, "integer of 401 digits"),
    ('{"a": 1,\n "b": {"c": 1, "c": 2}}', 2, "key 'c' appears twice"),
    ('{"a": 1,\n "a": 2}', 2, "key 'a' appears twice"),
    ('{"a": 1,,}', 1, "expected JSON, got Expecting property name"),
])
def test_json_loader_refuses_what_json_lets_through(tmp_path: Path, text: str, line: int | None, reason: str) -> None:
    with pytest.raises(FileFormatError, match=reason) as info:
        read_json_file(_json(tmp_path, text))
    if line is not None:
        assert info.value.line == line


def test_json_long_lines_are_fine(tmp_path: Path) -> None:
    values = list(range(50_000))
    assert read_json_file(_json(tmp_path, json.dumps({"v": values})))["v"] == values  # one line of ~340 kB


def test_json_node_accessors_name_the_path() -> None:
    doc = JsonNode({"a": {"b": [{"c": [1, 2, "x"]}], "n": 2.0, "t": True, "m": [[1, 2, 3], [4, 5, 6]]}}, "f.json")
    assert doc["a"]["n"].integer(low=0) == 2 and doc["a"]["n"].number() == 2.0
    np.testing.assert_array_equal(doc["a"]["m"].matrix(None, 3), [[1, 2, 3], [4, 5, 6]])
    assert doc["a"].get("missing") is None and [k for k, _ in doc["a"].items()] == ["b", "n", "t", "m"]
    cases = [
        (lambda: doc["a"]["b"][0]["c"].vector(3), "f.json: a.b[0].c[2]: expected a number, got the string 'x'"),
        (lambda: doc["a"]["b"].object(), "f.json: a.b: expected an object, got a list"),
        (lambda: doc["a"]["b"][0]["c"].vector(2), "f.json: a.b[0].c: expected a list of 2 numbers, got a list of 3"),
        (lambda: doc["a"]["t"].number(), "f.json: a.t: expected a number, got true"),
        (lambda: doc["a"]["t"].integer(), "f.json: a.t: expected an integer, got true"),
        (lambda: doc["a"]["n"].integer(low=3, high=5),
         "f.json: a.n: expected an integer in [3, 5], got the number 2.0"),
        (lambda: doc["a"]["n"].number(high=1),
         "f.json: a.n: expected a finite number in [-inf, 1], got the number 2.0"),
        (lambda: doc["a"]["zz"], "f.json: a.zz: expected a value, got none (missing)"),
        (lambda: doc["a"]["m"].matrix(3, 3), "f.json: a.m: expected a list of 3 lists of 3 numbers, got a list of 2"),
        (lambda: doc["a"]["n"].string(("x", "y")), "f.json: a.n: expected one of 'x', 'y', got the number 2.0"),
        (lambda: JsonNode([1], "f.json").object(), "f.json: expected an object, got a list"),
    ]
    for call, message in cases:
        with pytest.raises(FileFormatError) as info:
            call()
        assert str(info.value) == message
    assert np.isnan(JsonNode(None, "f.json").number(allow_null=True))


@pytest.mark.parametrize("code", [0x00, 0x01, 0x0B, 0x0C, 0x1A, 0x1C, 0x1F, 0x7F])
def test_control_characters_are_refused_with_line_and_column(tmp_path: Path, code: int) -> None:
    path = _file(tmp_path, b"x,y\n1,2\n3," + bytes([code]) + b"4\n")
    with pytest.raises(FileFormatError) as info:
        read_text_lines(path)
    assert info.value.line == 3
    assert ("NUL byte" if code == 0 else f"control character 0x{code:02x} at column 3") in info.value.reason


def test_tabs_and_carriage_returns_are_text(tmp_path: Path) -> None:
    assert read_text_lines(_file(tmp_path, b"x\ty\r\n1\t2\r\n")) == [(1, "x\ty"), (2, "1\t2")]


def test_named_encodings_read_through_the_same_line_checks(tmp_path: Path) -> None:
    """CMM readers (DMIS, CALYPSO, PC-DMIS) take an encoding; the line checks are the same as for UTF-8."""
    from pcmm_geo.io._text import iter_text_lines

    latin = _file(tmp_path, "$$ Prüfbericht\r\nFA(P)=FEAT/POINT\n".encode("cp1252"), "r.dmo")
    assert list(iter_text_lines(latin, encoding="cp1252")) == [(1, "$$ Prüfbericht"), (2, "FA(P)=FEAT/POINT")]
    with pytest.raises(FileFormatError) as info:
        list(iter_text_lines(latin, encoding="utf-8"))
    assert info.value.line == 1 and info.value.reason == (
        "not UTF-8 text: byte 0xfc at column 6 (another encoding can be given, e.g. cp1252)")
    with pytest.raises(FileFormatError, match=r"not UTF-8 text: byte 0xfc at column 6$"):
        list(iter_text_lines(latin))  # a reader that reads UTF-8 only gives no hint
    for code in (0x00, 0x0B, 0x7F):
        damaged = _file(tmp_path, b"a\xe4\n\xe4b" + bytes([code]) + b"c\n", "c.txt")
        with pytest.raises(FileFormatError) as info:
            list(iter_text_lines(damaged, encoding="latin-1"))
        assert info.value.line == 2
        assert ("NUL byte" if code == 0 else f"control character 0x{code:02x} at column 3") in info.value.reason
    with pytest.raises(FileFormatError, match="unknown text encoding 'klingon'"):
        next(iter_text_lines(latin, encoding="klingon"))
    with pytest.raises(FileFormatError, match="encoding 'utf-16' is not ASCII-compatible"):
        next(iter_text_lines(latin, encoding="utf-16"))
    # a stateful encoding escapes with ESC (0x1b) bytes: checked as text, not as bytes
    japanese = _file(tmp_path, "測定 1\n".encode("iso2022_jp"), "j.txt")
    assert b"\x1b" in japanese.read_bytes()
    assert list(iter_text_lines(japanese, encoding="iso2022_jp")) == [(1, "測定 1")]
