"""One point-file reader (io.read_points) and the labelled reader (io.read_labelled_points)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pcmm_geo import FileFormatError
from pcmm_geo.io import LabelledPoints, read_labelled_points, read_points


def write(tmp_path: Path, text: str, name: str = "points.csv") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_labels_are_kept_in_file_order_with_their_lines(tmp_path: Path) -> None:
    path = write(tmp_path, "# probed\nname,x,y,z\nP 1,1,2,3\nP2, 4.5 ,-6,7e-3\n\nP 1,0,0,1\n")
    found = read_labelled_points(path)
    assert isinstance(found, LabelledPoints)
    assert found.labels == ("P 1", "P2", "P 1") and found.lines == (3, 4, 6)
    np.testing.assert_array_equal(found.points, [[1, 2, 3], [4.5, -6, 0.007], [0, 0, 1]])
    groups = found.groups()
    assert list(groups) == ["P 1", "P2"]
    np.testing.assert_array_equal(groups["P 1"], [[1, 2, 3], [0, 0, 1]])
    assert repr(found).startswith("LabelledPoints(n=3, labels=2 distinct [P 1, P2]")


@pytest.mark.parametrize(("text", "labels", "first"), [
    ("x;y;z;face\n1;2;3;top\n4;5;6;side\n", ("top", "side"), [1, 2, 3]),  # label column anywhere
    ("A 1 2 3\nB 4 5 6\n", ("A", "B"), [1, 2, 3]),  # no header: name x y z
    ("id\tz\ty\tx\nq\t3\t2\t1\n", ("q",), [1, 2, 3]),  # columns found by name
    ("x,y,z,comment\n1,2,3,first\n", ("first",), [1, 2, 3]),  # the one other column is the label
])
def test_layouts(tmp_path: Path, text: str, labels: tuple[str, ...], first: list[float]) -> None:
    found = read_labelled_points(write(tmp_path, text))
    assert found.labels == labels
    np.testing.assert_array_equal(found.points[0], first)


@pytest.mark.parametrize(("text", "message"), [
    ("x,y,z\n1,2,3\n", "exactly one label column"),
    ("name,face,x,y,z\na,b,1,2,3\n", "exactly one label column"),
    ("name,x,y\na,1,2\n", "header with x, y, z"),
    ("1,2,3,4\n", "non-numeric name"),
    ("name,x,y,z\na,1,2\n", "expected 4 fields, got 3"),
    ("name,x,y,z\na,1,two,3\n", "expected numbers"),
    ("name,x,y,z\na,1,nan,3\n", "finite"),
    ("name,x,y,z\n,1,2,3\n", "expected a label"),
    ("name,x,y,z\n", "no points"),
])
def test_ambiguous_or_malformed_files_are_refused(tmp_path: Path, text: str, message: str) -> None:
    with pytest.raises(FileFormatError, match=message):
        read_labelled_points(write(tmp_path, text))


def test_read_points_csv_is_a_deprecated_alias_of_read_points(tmp_path: Path) -> None:
    from pcmm_geo.artefacts import read_points_csv

    path = write(tmp_path, "# c\nx,y,z\n1,2,3\n4,5,6\n")
    with pytest.warns(DeprecationWarning, match=r"read_points_csv is deprecated .* use pcmm_geo\.io\.read_points"):
        old = read_points_csv(path)
    np.testing.assert_array_equal(old, read_points(path))


def test_gauge_block_reader_uses_the_labelled_reader(tmp_path: Path) -> None:
    from pcmm_geo.artefacts.gauge_block import read_gauge_block_csv

    faces = read_gauge_block_csv(write(tmp_path, "face,x,y,z\nface_1,0,0,0\nFACE_2,0,0,100\nface_1,1,0,0\n"))
    assert list(faces) == ["face_1", "face_2"] and faces["face_1"].shape == (2, 3)
    with pytest.raises(FileFormatError, match=r":3: face: expected one of .*got 'bottom'"):
        read_gauge_block_csv(write(tmp_path, "face,x,y,z\nface_1,0,0,0\nbottom,0,0,1\n", "bad.csv"))
