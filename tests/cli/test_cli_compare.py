"""``pcmm compare``, ``pcmm segment`` and ``pcmm convert`` in a subprocess, against known geometry."""

from __future__ import annotations

import importlib.util
import json
import subprocess
from pathlib import Path

import numpy as np
import pytest
from pcmm_runner import run_pcmm
from scipy.spatial.transform import Rotation

PACKAGE = Path(__file__).parents[2] / "pcmm_geo"
EXAMPLES = PACKAGE / "data" / "examples"
SCAN = EXAMPLES / "gauge_block_scan.csv"
NOMINAL = EXAMPLES / "gauge_block_nominal.stl"


def _run(*args: str | Path) -> subprocess.CompletedProcess[str]:
    return run_pcmm(*args)


def _example_pose() -> dict:
    return json.loads((EXAMPLES / "gauge_block_scan_pose.json").read_text())


def _one_line_error(done: subprocess.CompletedProcess[str], command: str, text: str) -> None:
    assert done.returncode == 2, done.stdout + done.stderr
    assert done.stderr.strip().count("\n") == 0 and done.stderr.startswith(f"pcmm {command}: error:")
    assert text in done.stderr
    assert done.stdout == ""


def _read_png(path: Path) -> np.ndarray:
    import matplotlib.image

    return matplotlib.image.imread(path)


def test_bundled_example_is_what_its_seeded_script_makes() -> None:
    spec = importlib.util.spec_from_file_location("make_cad_example", EXAMPLES / "make_cad_example.py")
    assert spec is not None and spec.loader is not None
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    from pcmm_geo.io import read_mesh, read_points

    # shipped data are the source of truth; a rebuild on other BLAS/libm kernels may differ in the last bits
    np.testing.assert_allclose(read_points(SCAN), script.make_scan(), rtol=0, atol=1e-9)
    assert read_mesh(NOMINAL).bounds.tolist() == [[-50.0, -17.5, -4.5], [50.0, 17.5, 4.5]]
    pose = _example_pose()
    np.testing.assert_allclose(np.array(pose["transform"]), script.pose(), rtol=0, atol=1e-12)
    assert pose["point_count"] == len(script.make_scan()) and SCAN.stat().st_size < 300_000


def test_compare_example_recovers_the_known_pose(tmp_path: Path) -> None:
    done = _run("compare", SCAN, NOMINAL, "--tolerance-mm", "0.005", "--json")
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)
    # truth: the scan was placed by machine = R @ nominal + t, so registration must return R^T, -R^T t
    pose = _example_pose()
    rotation = Rotation.from_rotvec(pose["rotation_vector_deg"], degrees=True).as_matrix()
    expected = np.eye(4)
    expected[:3, :3] = rotation.T
    expected[:3, 3] = -rotation.T @ np.array(pose["translation_mm"])
    found = np.array(data["registration"]["transform"])
    left = found @ np.linalg.inv(expected)
    # 2877 points with 1 µm probing noise fix the pose to a few 1e-6 rad and 1e-4 mm
    assert Rotation.from_matrix(left[:3, :3]).magnitude() < 2e-5
    assert np.linalg.norm(left[:3, 3]) < 2e-4
    registration = data["registration"]
    assert registration["fitness"] == 1.0 and registration["inlier_count"] == pose["point_count"]
    assert 0.0009 < registration["inlier_rms_mm"] < 0.0011
    deviations = data["deviations_mm"]
    assert deviations["count"] == pose["point_count"] and abs(deviations["mean"]) < 1e-4
    assert deviations["rms"] == pytest.approx(registration["inlier_rms_mm"], rel=1e-12)
    assert data["passed"] is True and deviations["count_beyond"] == 0

    # the same nominal as a primitive gives the same registration
    primitive = _run("compare", SCAN, "--nominal", "box:100x35x9", "--json")
    assert primitive.returncode == 0, primitive.stderr
    np.testing.assert_allclose(json.loads(primitive.stdout)["registration"]["transform"], found, atol=1e-9)


def test_compare_tolerance_verdict_and_plot(tmp_path: Path) -> None:
    plot = tmp_path / "deviations.png"
    done = _run("compare", SCAN, NOMINAL, "--tolerance-mm", "0.002", "--plot", plot)
    assert done.returncode == 1, done.stderr  # 1 µm noise: some points beyond 2 µm
    assert "verdict: FAIL" in done.stdout and "deviations from nominal" in done.stdout
    assert "transform (4x4)" in done.stdout
    image = _read_png(plot)
    assert image.shape[0] >= 400 and image.shape[1] >= 600
    assert float(np.std(image[..., :3])) > 0.02  # not blank
    # coloured points: some pixels are clearly red or blue, not grey
    rgb = image[..., :3]
    assert np.count_nonzero(np.abs(rgb[..., 0] - rgb[..., 2]) > 0.3) > 100
    before = plot.read_bytes()
    again = _run("compare", SCAN, NOMINAL, "--plot", plot)
    _one_line_error(again, "compare", "already exists")
    assert plot.read_bytes() == before


def test_compare_noise_free_offset_scan(tmp_path: Path) -> None:
    """A mirror-symmetric scan of all faces, 0.01 mm outside and moved: every deviation is +0.01 mm."""
    rng = np.random.default_rng(4)
    half = np.array([50.0, 17.5, 4.5])
    points, normals = [], []
    for axis in range(3):
        in_plane = [k for k in range(3) if k != axis]
        face = np.zeros((40, 3))
        face[:, in_plane] = rng.uniform(0.05, 0.95, (40, 2)) * half[in_plane]
        face[:, axis] = half[axis]
        normal = np.zeros(3)
        normal[axis] = 1.0
        for mirror in ([sx, sy, sz] for sx in (1, -1) for sy in (1, -1) for sz in (1, -1)):
            points.append(face * mirror)
            normals.append(np.tile(normal * mirror, (40, 1)))
    scan = np.vstack(points) + 0.01 * np.vstack(normals)
    rotation = Rotation.from_rotvec([0.2, -0.5, 1.0], degrees=True).as_matrix()
    scan_file = tmp_path / "offset.csv"
    scan_file.write_text("x,y,z\n" + "\n".join(",".join(repr(float(v)) for v in p) for p in scan @ rotation.T
                                                + [0.5, 0.2, -0.3]) + "\n")
    done = _run("compare", scan_file, "--nominal", "box:100x35x9", "--json", "--deviations")
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)
    np.testing.assert_allclose(data["signed_distance_mm"], 0.01, rtol=0, atol=1e-9)
    assert data["deviations_mm"]["minimum"] == pytest.approx(0.01, abs=1e-9)
    assert data["registration"]["rotation_angle_rad"] == pytest.approx(np.radians(np.linalg.norm([0.2, -0.5, 1.0])),
                                                                       abs=1e-9)


def test_compare_initial_transform_file(tmp_path: Path) -> None:
    from pcmm_geo.io import read_points

    far_pose = np.eye(4)
    far_pose[:3, :3] = Rotation.from_euler("z", 90, degrees=True).as_matrix()
    far_pose[:3, 3] = [300.0, -150.0, 40.0]
    scan = read_points(SCAN)
    far_file = tmp_path / "far.csv"
    far_file.write_text("x,y,z\n" + "\n".join(",".join(repr(float(v)) for v in p) for p in
                                              scan @ far_pose[:3, :3].T + far_pose[:3, 3]) + "\n")
    start = tmp_path / "start.txt"
    np.savetxt(start, np.linalg.inv(far_pose), header="measured -> nominal, roughly")
    with_start = _run("compare", far_file, NOMINAL, "--init-transform", start, "--json")
    assert with_start.returncode == 0, with_start.stderr
    plain = json.loads(_run("compare", SCAN, NOMINAL, "--json").stdout)
    found = np.array(json.loads(with_start.stdout)["registration"]["transform"])
    # truth: undoing the far pose and then the example's pose gives the identity (to the noise level)
    pose = _example_pose()
    left = found @ far_pose @ np.array(pose["transform"])
    assert Rotation.from_matrix(left[:3, :3]).magnitude() < 2e-5 and np.linalg.norm(left[:3, 3]) < 2e-4
    # and registering the far copy = registering the original after undoing the far pose
    np.testing.assert_allclose(found @ far_pose, plain["registration"]["transform"], atol=1e-8)

    bad = tmp_path / "bad.txt"
    bad.write_text("1 0 0 0\n0 1 0 0\n0 0 1 0\n")
    _one_line_error(_run("compare", SCAN, NOMINAL, "--init-transform", bad), "compare", "expected 16 numbers")
    scaled = tmp_path / "scaled.txt"
    np.savetxt(scaled, np.diag([2.0, 1.0, 1.0, 1.0]))
    _one_line_error(_run("compare", SCAN, NOMINAL, "--init-transform", scaled), "compare", "proper rotation")


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("garbage.stl", b"not a mesh", "expected a binary STL"),
        ("cut.stl", (NOMINAL.read_bytes())[:-50], "announces 12 triangles"),
        ("empty.obj", b"", "empty file"),
        ("broken.obj", b"v 1 2\nf 1 2 3\n", "not a valid OBJ"),
    ],
)
def test_compare_malformed_mesh_is_one_line(tmp_path: Path, name: str, content: bytes, message: str) -> None:
    mesh = tmp_path / name
    mesh.write_bytes(content)
    _one_line_error(_run("compare", SCAN, mesh), "compare", message)


def test_compare_refuses_an_open_mesh_and_too_few_points(tmp_path: Path) -> None:
    from pcmm_geo.io import box_mesh, write_mesh

    open_block = box_mesh(100.0, 35.0, 9.0)
    open_block.update_faces(np.arange(10))  # two triangles of one face missing
    open_file = write_mesh(tmp_path / "open_block.stl", open_block)
    _one_line_error(_run("compare", SCAN, open_file), "compare", "open_block.stl: expected a closed mesh")
    three = tmp_path / "three.csv"
    three.write_text("x,y,z\n50,0,0\n0,17.5,0\n0,0,4.5\n")
    _one_line_error(_run("compare", three, NOMINAL), "compare", "at least 6 points, got 3")
    _one_line_error(_run("segment", three), "segment", "got 3")


def test_compare_report_is_not_overwritten_unless_asked(tmp_path: Path) -> None:
    report = tmp_path / "compare.md"
    report.write_text("earlier result\n")
    done = _run("compare", SCAN, NOMINAL, "--report", report)
    _one_line_error(done, "compare", "already exists")
    assert report.read_text() == "earlier result\n"
    replaced = _run("compare", SCAN, NOMINAL, "--report", report, "--overwrite")
    assert replaced.returncode == 0, replaced.stderr
    assert "deviations from nominal" in report.read_text()


def test_example_script_refuses_to_overwrite(tmp_path: Path) -> None:
    from pcmm_geo.errors import OutputExistsError

    spec = importlib.util.spec_from_file_location("make_cad_example", EXAMPLES / "make_cad_example.py")
    assert spec is not None and spec.loader is not None
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    (tmp_path / script.POSE_NAME).write_text("{}\n")  # only the last of the three files exists
    with pytest.raises(OutputExistsError):
        script.main(["--out-dir", str(tmp_path)])
    assert sorted(p.name for p in tmp_path.iterdir()) == [script.POSE_NAME]  # nothing written
    assert script.main(["--out-dir", str(tmp_path), "--overwrite"]) == 0
    np.testing.assert_allclose(np.loadtxt(tmp_path / script.SCAN_NAME, delimiter=",", skiprows=1),
                               np.loadtxt(SCAN, delimiter=",", skiprows=1), rtol=0, atol=1e-9)


def test_compare_argument_errors(tmp_path: Path) -> None:
    _one_line_error(_run("compare", SCAN), "compare", "exactly one nominal surface")
    _one_line_error(_run("compare", SCAN, NOMINAL, "--nominal", "box:1x1x1"), "compare", "got both")
    _one_line_error(_run("compare", SCAN, "--nominal", "prism:3"), "compare", "box:LENGTHxWIDTHxHEIGHT")
    bad_points = tmp_path / "bad.csv"
    bad_points.write_text("x,y,z\n1,2,3\n4,five,6\n")
    _one_line_error(_run("compare", bad_points, NOMINAL), "compare", "bad.csv:3: expected numbers")


def test_segment_block_and_pin(tmp_path: Path) -> None:
    rng = np.random.default_rng(6)
    floor = np.c_[rng.uniform(-40, 40, 3000), rng.uniform(-25, 25, 3000), np.zeros(3000)]
    floor = floor[np.hypot(floor[:, 0] - 10, floor[:, 1] + 5) > 4.3]
    angle, height = rng.uniform(0, 2 * np.pi, 800), rng.uniform(0.3, 25, 800)
    pin = np.c_[10 + 4 * np.cos(angle), -5 + 4 * np.sin(angle), height]
    scan_file = tmp_path / "plate_with_pin.csv"
    scan_file.write_text("x,y,z\n" + "\n".join(",".join(repr(float(v)) for v in p) for p in np.vstack([floor, pin]))
                         + "\n")
    plot = tmp_path / "segments.png"
    done = _run("segment", scan_file, "--distance-threshold-mm", "0.005", "--json", "--plot", plot)
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)
    kinds = sorted(s["kind"] for s in data["segments"])
    assert kinds == ["cylinder", "plane"]
    cylinder = next(s for s in data["segments"] if s["kind"] == "cylinder")
    assert abs(cylinder["radius_mm"] - 4.0) < 1e-9 and cylinder["count"] == 800
    np.testing.assert_allclose(np.abs(cylinder["axis"]), [0.0, 0.0, 1.0], atol=1e-9)
    np.testing.assert_allclose(cylinder["point"][:2], [10.0, -5.0], atol=1e-9)
    plane = next(s for s in data["segments"] if s["kind"] == "plane")
    assert plane["count"] == len(floor) and plane["rms_mm"] < 1e-12
    image = _read_png(plot)
    assert image.shape[0] >= 400 and float(np.std(image[..., :3])) > 0.02
    human = _run("segment", scan_file, "--distance-threshold-mm", "0.005")
    assert "1 planes, 1 cylinders" in human.stdout and "radius / mm" in human.stdout


def test_convert_round_trips_and_refuses_to_overwrite(tmp_path: Path) -> None:
    from pcmm_geo.io import read_mesh, read_points

    obj, ply, stl = tmp_path / "block.obj", tmp_path / "block.ply", tmp_path / "back.stl"
    for source, target in ((NOMINAL, obj), (obj, ply), (ply, stl)):
        done = _run("convert", source, target, "--json")
        assert done.returncode == 0, done.stderr
        assert json.loads(done.stdout)["written_as"] == "mesh"
    back = read_mesh(stl)
    assert back.bounds.tolist() == [[-50.0, -17.5, -4.5], [50.0, 17.5, 4.5]] and len(back.faces) == 12
    assert back.volume == pytest.approx(31500.0, rel=1e-12)

    vertices = tmp_path / "vertices.csv"
    assert _run("convert", ply, vertices).returncode == 0
    corners = read_points(vertices)
    assert sorted(map(tuple, np.abs(corners))) == [(50.0, 17.5, 4.5)] * 8

    sampled = tmp_path / "sampled.ply"
    assert _run("convert", stl, sampled, "--sample", "2000", "--seed", "3").returncode == 0
    cloud = read_points(sampled)
    assert cloud.shape == (2000, 3)
    excess = np.abs(cloud) - [50.0, 17.5, 4.5]
    np.testing.assert_allclose(excess.max(axis=1), 0.0, atol=1e-12)  # every sample on the surface

    scan_copy = tmp_path / "scan.ply"
    assert _run("convert", SCAN, scan_copy).returncode == 0
    np.testing.assert_array_equal(read_points(scan_copy), read_points(SCAN))

    before = obj.read_bytes()
    _one_line_error(_run("convert", ply, obj), "convert", "already exists")
    assert obj.read_bytes() == before
    assert _run("convert", SCAN, obj, "--overwrite").returncode == 2  # points have no triangles
    assert obj.read_bytes() == before
    assert _run("convert", stl, obj, "--overwrite").returncode == 0


def test_convert_element_export_gives_sphere_centres(tmp_path: Path) -> None:
    export = PACKAGE / "data" / "appendix_cd" / "cmm_export.csv"
    centres = tmp_path / "centres.csv"
    done = _run("convert", export, centres)
    assert done.returncode == 0, done.stderr
    assert "element export (2 positions x 3 joints + tip)" in done.stdout
    from pcmm_geo.io import read_points

    expected = np.loadtxt(export, delimiter=",", skiprows=1, usecols=(0, 1, 2))
    np.testing.assert_array_equal(read_points(centres), expected)


def test_convert_errors(tmp_path: Path) -> None:
    garbage = tmp_path / "garbage.stl"
    garbage.write_bytes(b"\x00" * 20)
    _one_line_error(_run("convert", garbage, tmp_path / "out.obj"), "convert", "garbage.stl")
    _one_line_error(_run("convert", SCAN, tmp_path / "out.csv", "--sample", "10"), "convert", "--sample")
    _one_line_error(_run("convert", SCAN, SCAN), "convert", "already exists")
    assert not (tmp_path / "out.obj").exists() and not (tmp_path / "out.csv").exists()


def test_help_lists_the_cad_commands() -> None:
    listing = _run("--help")
    assert listing.returncode == 0
    for command in ("compare", "segment", "convert"):
        assert f"    {command} " in listing.stdout
