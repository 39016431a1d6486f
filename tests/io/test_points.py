"""Point-file formats: round trips and malformed files."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.errors import FileFormatError, OutputExistsError
from pcmm_geo.io import read_points, write_points

POINTS = np.array([[1.5, -2.25, 3.0], [1000.123456789, 0.0, -7.5e-6], [4.0, 5.0, 6.0]])


@pytest.mark.parametrize("suffix", [".csv", ".ply", ".pcd"])
def test_round_trip(tmp_path: Path, suffix: str) -> None:
    path = write_points(tmp_path / f"points{suffix}", POINTS)
    back = read_points(path)
    if suffix == ".pcd":  # open3d writes PCD in single precision: 2^-24 relative
        np.testing.assert_allclose(back, POINTS, rtol=2**-24, atol=1e-12)
    else:  # every digit survives (CSV repr, binary PLY in double precision)
        np.testing.assert_array_equal(back, POINTS)
    with pytest.raises(OutputExistsError, match="refusing to overwrite"):
        write_points(path, POINTS)
    write_points(path, POINTS[:2], overwrite=True)
    assert len(read_points(path)) == 2


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("1 2 3\n4 5 6\n", [[1, 2, 3], [4, 5, 6]]),
        ("1\t2\t3\n4\t5\t6\n", [[1, 2, 3], [4, 5, 6]]),
        ("# comment\n1;2;3\n\n4;5;6\n", [[1, 2, 3], [4, 5, 6]]),
        ("id,z,y,x\n7,3,2,1\n8,6,5,4\n", [[1, 2, 3], [4, 5, 6]]),
        ("2\n1 2 3\n4 5 6\n", [[1, 2, 3], [4, 5, 6]]),  # NIST .ds: count first
        ("1,2,3,0.5\n4,5,6,0.5\n", [[1, 2, 3], [4, 5, 6]]),  # extra columns ignored
    ],
)
def test_text_variants(tmp_path: Path, text: str, expected: list[list[float]]) -> None:
    path = tmp_path / "p.txt"
    path.write_text(text)
    np.testing.assert_array_equal(read_points(path), expected)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("1,2,3\n4,5\n", r"bad.csv:2: expected 3 values separated by ',', got 2"),
        ("1,2,3\n1,2,x\n", r"bad.csv:2: expected numbers"),
        ("1,2,x\n", "header without x, y, z"),
        ("a,b,c\n1,2,3\n", "header without x, y, z"),
        ("3\n1 2 3\n", "announces 3 points, found 1"),
        ("# nothing\n", "no points"),
        ("1,2\n3,4\n", "at least 3 columns"),
        ("1,2,nan\n", "non-finite"),
    ],
)
def test_malformed(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(FileFormatError, match=message):
        read_points(path)


def test_unknown_suffix_and_missing_file(tmp_path: Path) -> None:
    with pytest.raises(FileFormatError, match="expected one of"):
        read_points(tmp_path / "points.docx")
    with pytest.raises(FileNotFoundError):
        read_points(tmp_path / "missing.csv")


@pytest.mark.parametrize(
    ("text", "decimal", "expected"),
    [
        ("x;y;z\n12,5;3,25;7,75\n-1,0;2;3e-3\n", None, [[12.5, 3.25, 7.75], [-1.0, 2.0, 0.003]]),
        ("x\ty\tz\n12,5\t3,25\t7,75\n", None, [[12.5, 3.25, 7.75]]),
        ("12,5 3,25 7,75\n1 2 3\n", None, [[12.5, 3.25, 7.75], [1, 2, 3]]),
        ("x;y;z\n12.5;3.25;7.75\n", None, [[12.5, 3.25, 7.75]]),
        ("1;2;3\n4;5;6\n", ",", [[1, 2, 3], [4, 5, 6]]),
        ("12,5 3,25 7,75\n", ",", [[12.5, 3.25, 7.75]]),
        ("12.5,3.25,7.75\n", ".", [[12.5, 3.25, 7.75]]),
    ],
)
def test_decimal_comma_files(tmp_path: Path, text: str, decimal: str | None, expected: list[list[float]]) -> None:
    path = tmp_path / "p.csv"
    path.write_text(text)
    np.testing.assert_allclose(read_points(path, decimal=decimal), expected, rtol=0, atol=0)


@pytest.mark.parametrize(
    ("text", "decimal", "message"),
    [
        ("x;y;z\n12,5;3,25;7,75\n12,5,3\n", None, r"p.csv:3: expected 3 values separated by ';', got 1"),
        ("x;y;z\n12,5;3,25;7,75\n12,5;3,5,1;7\n", None, r"p.csv:3: ambiguous number '3,5,1'"),
        ("x;y;z\n12,5;3,25;7,75\n12.5;3;7\n", None, r"p.csv:3: decimal point in '12.5'"),
        ("12,5,3\n", ",", r"p.csv:1: expected at least 3 columns|ambiguous"),
        ("x;y;z\n12,5;3;7\n", ".", r"p.csv:2: decimal comma in '12,5'"),
        ("12;5;3\n1 2 3\n", None, r"p.csv:2: expected 3 values separated by ';', got 1"),
        ("1,2,3\n1;2;3\n", None, r"p.csv:2: expected 3 values separated by ',', got 1"),
        ("x,y,z\n12,5;3,25;7,75\n", None, r"p.csv:1: header has 1 columns"),
    ],
)
def test_ambiguous_or_mixed_files_are_refused(tmp_path: Path, text: str, decimal: str | None, message: str) -> None:
    path = tmp_path / "p.csv"
    path.write_text(text)
    with pytest.raises(FileFormatError, match=message):
        read_points(path, decimal=decimal)


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (b"x,y,z\n1,2,3\n\xff\xfe4,5,6\n", r"bin.csv:3: not UTF-8 text: byte 0xff at column 1"),
        (b"\x00\x01\x02\x03binary", r"bin.csv:1: binary data"),
        (b"x,y,z\n", r"bin.csv: no points in the file \(a header only\)"),
        (b"", r"bin.csv: no points in the file"),
        (b"x,y,z\n1,2,inf\n", r"bin.csv:2: non-finite coordinate '1,2,inf'"),
    ],
)
def test_garbage_bytes_name_file_and_line(tmp_path: Path, data: bytes, message: str) -> None:
    path = tmp_path / "bin.csv"
    path.write_bytes(data)
    with pytest.raises(FileFormatError, match=message):
        read_points(path)
    with pytest.raises(FileFormatError, match="is a directory"):
        read_points(tmp_path)


def test_outputs_are_written_whole_or_not_at_all(tmp_path: Path) -> None:
    from pcmm_geo._atomic import write_atomic

    target = tmp_path / "result.csv"
    target.write_text("earlier result\n")
    with pytest.raises(OutputExistsError):
        write_atomic(target, "new\n")

    def half_then_fail(stream) -> None:
        stream.write(b"x,y,z\n1,2,")
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        write_atomic(target, half_then_fail, overwrite=True)
    assert target.read_text() == "earlier result\n"  # the old content survives a failed replacement
    assert [p.name for p in tmp_path.iterdir()] == ["result.csv"]  # no temporary file left behind
    write_atomic(target, "x,y,z\n1,2,3\n", overwrite=True)
    np.testing.assert_array_equal(read_points(target), [[1.0, 2.0, 3.0]])
    mask = os.umask(0o022)
    os.umask(mask)
    assert target.stat().st_mode & 0o777 == 0o666 & ~mask  # the usual permissions, not mkstemp's 0600
