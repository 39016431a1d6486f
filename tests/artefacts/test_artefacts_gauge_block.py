"""Gauge block evaluation: ISO 3650 method, the seed's eqs 5.1-5.3 and the exact projection."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pcmm_geo.artefacts import (
    measure_gauge_block,
    plane_from_three_points,
    projected_length,
    read_gauge_block_csv,
    seed_gauge_block_length,
)
from pcmm_geo.errors import DegenerateGeometryError, FileFormatError, InvalidInputError, TooFewPointsError

WIDTH, HEIGHT = 35.0, 9.0
GRID = [(y, z) for y in (-12.0, 0.0, 12.0) for z in (-3.0, 0.0, 3.0)]


def block_points(
    length: float,
    rotation: Rotation,
    shift: np.ndarray,
    *,
    noise: float = 0.0,
    rng: np.random.Generator | None = None,
    first_offsets: tuple[tuple[float, float], tuple[float, float]] | None = None,
) -> dict[str, np.ndarray]:
    """Points on a block of known length: axis u (0..length), side normal y, top normal z, then posed."""
    faces: dict[str, list[list[float]]] = {"face_1": [], "face_2": [], "top": [], "side": []}
    grid1 = list(GRID)
    grid2 = list(GRID)
    if first_offsets is not None:
        grid1.insert(0, first_offsets[0])
        grid2.insert(0, first_offsets[1])
    faces["face_1"] = [[0.0, y, z] for y, z in grid1]
    faces["face_2"] = [[length, y, z] for y, z in grid2]
    stations = np.linspace(0.1 * length, 0.9 * length, 5)
    faces["top"] = [[u, y, HEIGHT / 2] for u, y in zip(stations, (-10.0, 5.0, -5.0, 10.0, 0.0), strict=True)]
    faces["side"] = [[u, WIDTH / 2, z] for u, z in zip(stations, (-3.0, 2.0, -1.0, 3.0, 0.0), strict=True)]
    out = {}
    for label, pts in faces.items():
        arr = rotation.apply(np.asarray(pts)) + shift
        if noise:
            assert rng is not None
            arr = arr + rng.normal(0.0, noise, arr.shape)
        out[label] = arr
    return out


def random_pose(rng: np.random.Generator, max_angle_deg: float = 30.0) -> tuple[Rotation, np.ndarray]:
    axis = rng.normal(size=3)
    angle = math.radians(rng.uniform(0.0, max_angle_deg))
    return Rotation.from_rotvec(angle * axis / np.linalg.norm(axis)), rng.uniform(-200, 200, 3)


def test_iso_method_exact_in_random_poses() -> None:
    rng = np.random.default_rng(3650)
    for _ in range(25):
        length = rng.uniform(5.0, 100.0)
        rotation, shift = random_pose(rng)
        result = measure_gauge_block(block_points(length, rotation, shift))
        assert abs(result.central_length - length) < 1e-9
        assert abs(result.length_face1_to_plane2 - length) < 1e-9
        assert abs(result.length_face2_to_plane1 - length) < 1e-9
        assert result.variation_in_length < 1e-9
        assert result.parallelism < 1e-10
        assert abs(result.projected_length - length) < 1e-9
        np.testing.assert_allclose(result.axis, rotation.apply([1.0, 0.0, 0.0]), atol=1e-12)
        # seed method: exact when the two probed points are opposite each other, planes at 90 deg
        assert result.seed is not None
        assert abs(result.seed.length - length) < 1e-9
        assert result.seed.phi == pytest.approx(math.pi / 2, abs=1e-12)


def test_seed_method_error_with_offset_points() -> None:
    # points (0, -12, -3) and (L, +12, +3): v = (L, 24, 6) in block axes
    length = 100.0
    rotation, shift = Rotation.from_euler("zyx", [25.0, -12.0, 8.0], degrees=True), np.array([5.0, 6.0, 7.0])
    faces = block_points(length, rotation, shift, first_offsets=((-12.0, -3.0), (12.0, 3.0)))
    result = measure_gauge_block(faces)
    dy, dz = 24.0, 6.0
    v2 = length**2 + dy**2 + dz**2
    expected_seed = math.sqrt((v2 - dz**2) * (v2 - dy**2) / v2)
    assert result.seed is not None
    assert result.seed.length == pytest.approx(expected_seed, abs=1e-9)
    assert result.seed.vector_length == pytest.approx(math.sqrt(v2), abs=1e-9)
    assert result.seed.theta_top == pytest.approx(math.asin(dz / math.sqrt(v2)), abs=1e-12)
    assert result.seed.theta_side == pytest.approx(math.asin(dy / math.sqrt(v2)), abs=1e-12)
    # the seed overestimates by about L t_y^2 t_z^2 / (2 (1 + t_y^2 + t_z^2)) (9.8 um here); ISO and
    # projection are exact
    ty, tz = dy / length, dz / length
    approx_bias = length * ty**2 * tz**2 / (2 * (1 + ty**2 + tz**2))
    assert result.seed.length - length == pytest.approx(approx_bias, rel=1e-3)
    assert abs(result.central_length - length) < 1e-9
    assert abs(result.projected_length - length) < 1e-9


def test_noise_iso_beats_seed() -> None:
    rng = np.random.default_rng(53)
    iso_err, seed_err = [], []
    for _ in range(40):
        length = 100.0
        rotation, shift = random_pose(rng)
        faces = block_points(length, rotation, shift, noise=1e-3, rng=rng)
        result = measure_gauge_block(faces)
        assert result.seed is not None
        iso_err.append(result.central_length - length)
        seed_err.append(result.seed.length - length)
    iso_rms = float(np.sqrt(np.mean(np.square(iso_err))))
    seed_rms = float(np.sqrt(np.mean(np.square(seed_err))))
    # 9 points per face average the noise; the seed's two single points carry sigma*sqrt(2) ~ 1.4 um
    assert iso_rms < 0.8e-3
    assert seed_rms > 0.8e-3
    assert iso_rms < 0.6 * seed_rms


def test_wedge_block_variation_and_parallelism() -> None:
    # face 2 tilted by gamma about y: x = L + z tan(gamma)
    length, gamma = 50.0, 2e-4
    face_1 = np.array([[0.0, y, z] for y, z in GRID])
    face_2 = np.array([[length + z * math.tan(gamma), y, z] for y, z in GRID])
    result = measure_gauge_block({"face_1": face_1, "face_2": face_2})
    assert result.length_face1_to_plane2 == pytest.approx(length * math.cos(gamma), abs=1e-10)
    assert result.length_face2_to_plane1 == pytest.approx(length, abs=1e-10)
    assert result.variation_in_length == pytest.approx(6.0 * math.tan(gamma), abs=1e-10)
    assert result.parallelism == pytest.approx(gamma, abs=1e-12)
    assert result.seed is None and math.isnan(result.projected_length)


def test_three_point_plane_and_projection() -> None:
    normal = plane_from_three_points([[1.0, 2.0, 3.0], [2.0, 2.0, 3.0], [1.0, 5.0, 3.0]])
    np.testing.assert_allclose(normal / np.linalg.norm(normal), [0.0, 0.0, 1.0], atol=1e-15)
    with pytest.raises(DegenerateGeometryError, match="collinear"):
        plane_from_three_points([[0, 0, 0], [1, 1, 1], [2, 2, 2]])
    top = [[0, 0, 4.5], [50, 0, 4.5], [0, 10, 4.5], [20, 3, 4.5]]
    side = [[0, 17.5, 0], [50, 17.5, 0], [0, 17.5, 3]]
    assert projected_length(top, side, [0.0, 3.0, 1.0], [80.0, -5.0, 2.0]) == pytest.approx(80.0, abs=1e-12)
    res = seed_gauge_block_length(top, side, [0.0, 0.0, 0.0], [80.0, 0.0, 0.0])
    assert res.length == pytest.approx(80.0, abs=1e-12)


def test_bad_input() -> None:
    face = np.array([[0.0, y, z] for y, z in GRID])
    with pytest.raises(InvalidInputError, match="face_2"):
        measure_gauge_block({"face_1": face})
    with pytest.raises(InvalidInputError, match="labels"):
        measure_gauge_block({"face_1": face, "face_2": face + np.array([10.0, 0.0, 0.0]), "bottom": face})
    with pytest.raises(TooFewPointsError):
        measure_gauge_block({"face_1": face[:2], "face_2": face + np.array([10.0, 0.0, 0.0])})


def test_csv_reader(tmp_path: Path) -> None:
    good = tmp_path / "block.csv"
    good.write_text("# comment\nface,x,y,z\nface_1,0,0,0\nface_1,0,1,0\nface_1,0,0,1\n"
                    "face_2,25,0,0\nface_2,25,1,0\nface_2,25,0,1\n")
    faces = read_gauge_block_csv(good)
    assert measure_gauge_block(faces).central_length == pytest.approx(25.0, abs=1e-12)
    bad = tmp_path / "bad.csv"
    bad.write_text("face,x,y,z\nface_1,0,0,0\nbottom,1,2,3\n")
    with pytest.raises(FileFormatError, match=r"bad\.csv:3: face"):
        read_gauge_block_csv(bad)
