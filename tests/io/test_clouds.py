"""PLY, PCD and E57 point clouds: ASCII bodies streamed like text files, binary ones through open3d, E57."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.errors import FileFormatError
from pcmm_geo.io import read_points

POINTS = np.array([[1.5, -2.25, 3.0], [1000.123456789, 0.0, -7.5e-6], [4.0, 5.0, 6.0], [-1e-3, 2e3, 0.5]])


def _ply(points: np.ndarray, extra_element: bool = False, faces: bool = True) -> str:
    header = ["ply", "format ascii 1.0", "comment made by a scanner"]
    body = []
    if extra_element:  # an element before the vertices: its rows are skipped
        header += ["element camera 1", "property float f", "property float g"]
        body.append("0.5 0.25")
    header += [f"element vertex {len(points)}", "property uchar red", "property double x", "property double y",
               "property double z"]
    if faces:
        header += ["element face 1", "property list uchar int vertex_indices"]
    body += [f"7 {x!r} {y!r} {z!r}" for x, y, z in points.tolist()]
    if faces:
        body.append("3 0 1 2")
    return "\n".join([*header, "end_header", *body]) + "\n"


@pytest.mark.parametrize("extra_element", [False, True])
def test_ascii_ply_vertices_every_digit(tmp_path: Path, extra_element: bool) -> None:
    path = tmp_path / "scan.ply"
    path.write_text(_ply(POINTS, extra_element))
    np.testing.assert_array_equal(read_points(path), POINTS)


def test_ascii_pcd_with_counts_and_extra_fields(tmp_path: Path) -> None:
    header = ["# .PCD v0.7", "VERSION 0.7", "FIELDS normal x y z rgb", "SIZE 4 8 8 8 4", "TYPE F F F F U",
              "COUNT 3 1 1 1 1", f"WIDTH {len(POINTS)}", "HEIGHT 1", "VIEWPOINT 0 0 0 1 0 0 0",
              f"POINTS {len(POINTS)}", "DATA ascii"]
    body = [f"0 0 1 {x!r} {y!r} {z!r} 4278190080" for x, y, z in POINTS.tolist()]
    path = tmp_path / "scan.pcd"
    path.write_text("\n".join(header + body) + "\n")
    np.testing.assert_array_equal(read_points(path), POINTS)


@pytest.mark.parametrize(("edit", "line", "message"), [
    (lambda t: t.replace("7 4.0 5.0 6.0", "7 4.0 5,0 6.0"), 14, "decimal comma in '5,0'"),
    (lambda t: t.replace("7 4.0 5.0 6.0", "7 4.0 nan 6.0"), 14, "non-finite coordinate"),
    (lambda t: t.replace("7 4.0 5.0 6.0", "7 4.0 5.0"), 14, "expected 4 values separated by spaces"),
    (lambda t: t.replace("element vertex 4", "element vertex 9").replace("3 0 1 2\n", ""), None,
     "announces 9 points, found 4"),
    (lambda t: t.replace("property uchar red\n", ""), 11, "expected 3 values separated by spaces, got 4"),
    (lambda t: t.replace("property double y\n", ""), 4, "vertex element without x, y, z properties: red x z"),
    (lambda t: t.replace("end_header\n", ""), None, "header does not end"),
    (lambda t: "plx" + t[3:], 1, "expected a file starting with 'ply'"),
])
def test_bad_ascii_ply_names_the_line(tmp_path: Path, edit, line: int | None, message: str) -> None:
    path = tmp_path / "scan.ply"
    path.write_text(edit(_ply(POINTS)))
    with pytest.raises(FileFormatError, match=message) as info:
        read_points(path)
    if line is not None:
        assert info.value.line == line


def test_binary_clouds_go_through_open3d(tmp_path: Path) -> None:
    from pcmm_geo.io import write_points

    np.testing.assert_array_equal(read_points(write_points(tmp_path / "b.ply", POINTS)), POINTS)


def test_e57_in_metres_read_in_mm_with_pose_and_invalid_points(tmp_path: Path) -> None:
    import pye57
    rng = np.random.default_rng(2)
    metres = rng.uniform(-2, 2, (200, 3))
    state = np.zeros(200, dtype=np.int8)
    state[[3, 50]] = 1  # invalid returns: left out
    path = tmp_path / "scan.e57"
    e57 = pye57.E57(str(path), mode="w")
    angle = np.radians(30.0)
    quaternion = np.array([np.cos(angle / 2), 0.0, 0.0, np.sin(angle / 2)])  # w, x, y, z: 30 deg about z
    translation = np.array([1.0, -2.0, 0.5])
    e57.write_scan_raw({"cartesianX": metres[:, 0], "cartesianY": metres[:, 1], "cartesianZ": metres[:, 2],
                        "cartesianInvalidState": state}, rotation=quaternion, translation=translation)
    e57.close()
    raw = pye57.E57(str(path)).read_scan_raw(0)  # as stored (the writer quantises to scaled integers)
    stored = np.column_stack([raw["cartesianX"], raw["cartesianY"], raw["cartesianZ"]])
    np.testing.assert_allclose(stored, metres, rtol=0, atol=1e-7)
    rotation = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]])
    expected = (stored[state == 0] @ rotation.T + translation) * 1000.0
    np.testing.assert_allclose(read_points(path), expected, rtol=0, atol=1e-9)
    broken = tmp_path / "broken.e57"
    broken.write_bytes(b"ASTM-E57" + b"\x00" * 100)
    with pytest.raises(FileFormatError, match=r"broken\.e57: E57 file of 108 bytes, shorter than its first"):
        read_points(broken)
