"""Mesh files (STL/OBJ/PLY) and nominal primitives, against closed-form geometry."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pcmm_geo.errors import FileFormatError, InvalidInputError, OutputExistsError
from pcmm_geo.io import box_mesh, cylinder_mesh, nominal_mesh, read_mesh, sphere_mesh, write_mesh, write_points
from pcmm_geo.io.meshes import cylinder_sections

# an off-origin block whose coordinates are not representable in single precision
OFFSET = np.array([123.456789012345, -0.000123456789, 987.654321098765])


def _offset_block() -> Any:
    block = box_mesh(100.0, 35.0, 9.0)
    block.apply_translation(OFFSET)
    return block


@pytest.mark.parametrize("suffix", [".stl", ".obj", ".ply"])
def test_round_trip_keeps_every_triangle(tmp_path: Path, suffix: str) -> None:
    block = _offset_block()
    path = write_mesh(tmp_path / f"block{suffix}", block)
    back = read_mesh(path)
    assert len(back.faces) == 12 and len(back.vertices) == 8 and back.is_watertight
    expected = np.sort(np.asarray(block.vertices), axis=0)
    got = np.sort(np.asarray(back.vertices), axis=0)
    if suffix == ".ply":  # binary doubles: bit for bit
        np.testing.assert_array_equal(got, expected)
    elif suffix == ".obj":  # 15 decimals
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    else:  # STL stores float32: half a unit in the last place of each coordinate
        np.testing.assert_allclose(got, expected, rtol=2.0**-24, atol=0)
        assert np.abs(got - expected).max() > 0  # the single precision is real, not a round trip of doubles
    # same outward orientation: the enclosed volume keeps its sign and value
    assert back.volume == pytest.approx(100.0 * 35.0 * 9.0, rel=1e-6)


@pytest.mark.parametrize("suffix", [".stl", ".obj", ".ply"])
def test_writer_refuses_to_overwrite(tmp_path: Path, suffix: str) -> None:
    path = write_mesh(tmp_path / f"part{suffix}", box_mesh(10.0, 10.0, 10.0))
    before = path.read_bytes()
    with pytest.raises(OutputExistsError, match="refusing to overwrite"):
        write_mesh(path, box_mesh(20.0, 20.0, 20.0))
    assert path.read_bytes() == before
    write_mesh(path, box_mesh(20.0, 20.0, 20.0), overwrite=True)
    assert read_mesh(path).extents.tolist() == [20.0, 20.0, 20.0]


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("empty.stl", b"", "empty file"),
        ("blank.obj", b"\n  \n", "empty file"),
        ("garbage.stl", b"this is not a mesh at all", "expected a binary STL"),
        ("zeros.stl", bytes(200), "announces 0 triangles"),
        ("facet.stl", b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\n"
                      b"endfacet\nendsolid\n", "not a valid STL"),
        ("nan.obj", b"v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n", "non-finite vertex"),
        ("index.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", "not a valid OBJ"),
        ("short.obj", b"v 1 2\nf 1 2 3\n", "not a valid OBJ"),
        ("header.ply", b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nend_header\n1\n", "PLY"),
        ("noply.ply", b"solid nothing\n", "PLY"),
    ],
)
def test_malformed_files_raise_file_format_error(tmp_path: Path, name: str, content: bytes, message: str) -> None:
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(FileFormatError, match=message) as caught:
        read_mesh(path)
    assert caught.value.path == str(path)


def test_truncated_binary_stl(tmp_path: Path) -> None:
    whole = write_mesh(tmp_path / "block.stl", box_mesh(100.0, 35.0, 9.0)).read_bytes()
    assert len(whole) == 84 + 50 * 12  # the binary STL layout the check relies on
    cut = tmp_path / "cut.stl"
    cut.write_bytes(whole[:-50])
    with pytest.raises(FileFormatError, match="announces 12 triangles \\(684 bytes\\), got 634 bytes"):
        read_mesh(cut)


def test_point_cloud_ply_is_not_a_mesh(tmp_path: Path) -> None:
    cloud = write_points(tmp_path / "cloud.ply", np.eye(3))
    with pytest.raises(FileFormatError, match="read_points"):
        read_mesh(cloud)


def test_unknown_suffix_and_missing_file(tmp_path: Path) -> None:
    with pytest.raises(FileFormatError, match=r"\.stl, \.obj, \.ply"):
        read_mesh(tmp_path / "part.step")
    with pytest.raises(FileFormatError, match="expected a name ending"):
        write_mesh(tmp_path / "part.step", box_mesh(1.0, 1.0, 1.0))
    with pytest.raises(FileNotFoundError):
        read_mesh(tmp_path / "missing.stl")


def test_mesh_without_triangles_is_not_written(tmp_path: Path) -> None:
    import trimesh

    with pytest.raises(InvalidInputError, match="at least one triangle"):
        write_mesh(tmp_path / "none.ply", trimesh.Trimesh())
    assert not (tmp_path / "none.ply").exists()


def test_box_is_the_exact_block() -> None:
    block = box_mesh(100.0, 35.0, 9.0)
    assert block.bounds.tolist() == [[-50.0, -17.5, -4.5], [50.0, 17.5, 4.5]]
    assert block.volume == pytest.approx(31500.0, rel=1e-15)
    assert block.area == pytest.approx(2 * (100 * 35 + 100 * 9 + 35 * 9), rel=1e-15)
    # outward normals: each face normal points away from the centre
    assert np.all(np.einsum("ij,ij->i", block.face_normals, block.triangles_center) > 0)


@pytest.mark.parametrize(("radius", "tolerance"), [(10.0, 0.001), (3.0, 0.0001), (50.0, 0.01)])
def test_cylinder_chord_within_tolerance_with_fewest_sides(radius: float, tolerance: float) -> None:
    sides = cylinder_sections(radius, tolerance)
    # closed form: an inscribed n-gon lies r (1 - cos(pi/n)) inside the circle at mid-side
    assert radius * (1 - math.cos(math.pi / sides)) <= tolerance
    assert sides == 16 or radius * (1 - math.cos(math.pi / (sides - 1))) > tolerance
    pin = cylinder_mesh(radius, 40.0, chord_tolerance=tolerance)
    side = np.abs(np.abs(pin.vertices[:, 2]) - 20.0) < 1e-12
    rho = np.hypot(pin.vertices[:, 0], pin.vertices[:, 1])
    np.testing.assert_allclose(rho[rho > 1e-9], radius, rtol=0, atol=1e-12)
    assert side.all() and pin.is_watertight
    # volume of the regular-n-gon prism
    assert pin.volume == pytest.approx(0.5 * sides * radius**2 * math.sin(2 * math.pi / sides) * 40.0, rel=1e-12)


def test_sphere_facets_within_tolerance() -> None:
    ball = sphere_mesh(12.5, chord_tolerance=0.01)
    np.testing.assert_allclose(np.linalg.norm(ball.vertices, axis=1), 12.5, rtol=0, atol=1e-12)
    facet_distance = np.einsum("ij,ij->i", ball.triangles_center, ball.face_normals)
    assert facet_distance.min() >= 12.5 - 0.01
    coarser = sphere_mesh(12.5, chord_tolerance=0.05)
    assert len(coarser.faces) < len(ball.faces)
    with pytest.raises(InvalidInputError, match="chord_tolerance"):
        sphere_mesh(12.5, chord_tolerance=1e-9)


@pytest.mark.parametrize(
    ("spec", "extents"),
    [("box:100x35x9", [100.0, 35.0, 9.0]), ("BOX: 2.5x1e1x0.5", [2.5, 10.0, 0.5]), ("sphere:5", [10.0, 10.0, 10.0])],
)
def test_nominal_specs(spec: str, extents: list[float]) -> None:
    np.testing.assert_allclose(nominal_mesh(spec).extents, extents, rtol=0, atol=1e-12)


def test_nominal_cylinder_spec() -> None:
    pin = nominal_mesh("cylinder:4x30")
    assert pin.bounds[:, 2].tolist() == [-15.0, 15.0]
    assert np.hypot(pin.vertices[:, 0], pin.vertices[:, 1]).max() == pytest.approx(4.0, abs=1e-12)


@pytest.mark.parametrize("spec", ["box:100x35", "cone:1x2", "box:0x1x1", "sphere:-3", "cylinder:axb", "100x35x9"])
def test_bad_nominal_specs(spec: str) -> None:
    with pytest.raises(InvalidInputError):
        nominal_mesh(spec)
