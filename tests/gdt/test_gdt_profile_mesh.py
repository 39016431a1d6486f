"""Profile of a surface against a nominal mesh: a constructed block (a closed box mesh in the DRF) whose measured
points are moved by known distances along the faces' outward normals, then by the part's rigid motion.  With
datums the value is twice the largest distance (1e-9 mm); a floating translation matches a brute-force scan;
without datums the local six-degree-of-freedom fit is PASS or NOT PROVEN, never FAIL.  Open, flipped, too large
and missing meshes are refused by name, in the library and in a plan."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.errors import FileFormatError
from pcmm_geo.gdt import DatumReferenceFrame, associate_datum, build_drf, evaluate_profile, inspect_plan
from pcmm_geo.gdt.profile import read_nominal_mesh
from pcmm_geo.gdt.reference.drf import nominal_of

EXAMPLE = Path(__file__).parents[2] / "pcmm_geo" / "data" / "examples" / "gdt"
BLOCK = (120.0, 90.0, 30.0)


def _block_mesh():
    from pcmm_geo.io.meshes import box_mesh

    mesh = box_mesh(*BLOCK)
    mesh.apply_translation(np.array(BLOCK) / 2)  # the block of the example: corner at the DRF origin
    return mesh


def _measured_surface(rng, n=300, low=-0.012, high=0.008):
    """Points on the top face and the faces x = 120, y = 90 (away from edges), moved by known deviations along
    the outward normal; the deviations include both extremes."""
    lx, ly, lz = BLOCK
    face = rng.integers(0, 3, n)
    u, v = rng.uniform(0.1, 0.9, (2, n))
    nominal = np.where(face[:, None] == 0, np.c_[u * lx, v * ly, np.full(n, lz)],
                       np.where(face[:, None] == 1, np.c_[np.full(n, lx), u * ly, v * lz],
                                np.c_[u * lx, np.full(n, ly), v * lz]))
    normals = np.array([[0, 0, 1.0], [1.0, 0, 0], [0, 1.0, 0]])[face]
    dev = rng.uniform(low, high, n)
    dev[:2] = [low, high]
    return nominal + dev[:, None] * normals, dev, normals


def _abc(part):
    a = associate_datum(part.measured("A"), "plane", label="A", nominal_direction=[0, 0, 1])
    b = associate_datum(part.measured("B"), "plane", label="B", nominal_direction=[1, 0, 0],
                        perpendicular_to=(a.direction,))
    c = associate_datum(part.measured("C"), "plane", label="C", nominal_direction=[0, 1, 0],
                        perpendicular_to=(a.direction, b.direction))
    pairs = [(a, nominal_of([0, 0, 0], [0, 0, 1])), (b, nominal_of([0, 0, 0], [1, 0, 0])),
             (c, nominal_of([0, 0, 0], [0, 1, 0]))]
    return build_drf(pairs), build_drf(pairs[:2])


@pytest.fixture(scope="module")
def block_index():
    from pcmm_geo.artefacts.cad_distance import SurfaceIndex

    return SurfaceIndex.build(_block_mesh())


@pytest.mark.parametrize("seed", range(3))
def test_mesh_profile_with_a_complete_drf_is_twice_the_largest_distance(maker, block_index, seed):
    rng = np.random.default_rng(seed)
    part = maker.make_part(seed, n_points=120, n_holes=0)
    surface, _, _ = _measured_surface(rng)
    abc, _ = _abc(part)
    measured = surface @ part.rotation.T + part.translation
    r = evaluate_profile(measured, abc, 0.025, nominal_mesh=block_index)
    assert abs(r.value_mm - 2 * 0.012) < 1e-9 and r.details["scope"] == "global" and r.details["nominal"] == "mesh"
    assert abs(r.details["largest_deviation_mm"] - 0.008) < 1e-9  # signed: outside the material is positive
    assert abs(r.details["smallest_deviation_mm"] + 0.012) < 1e-9
    assert r.verdict == "PASS"
    assert evaluate_profile(measured, abc, 0.02, nominal_mesh=block_index).verdict == "FAIL"


def test_mesh_profile_floats_in_the_translation_the_drf_leaves_free(maker, block_index):
    rng = np.random.default_rng(7)
    part = maker.make_part(7, n_points=120, n_holes=0)
    surface, dev, normals = _measured_surface(rng)
    shifted = surface + np.array([0.0, 0.004, 0.0])  # along y, which A|B leaves free
    _, ab = _abc(part)
    r = evaluate_profile(shifted @ part.rotation.T + part.translation, ab, 0.05, nominal_mesh=block_index)
    base, ny = dev + 0.004 * normals[:, 1], normals[:, 1]
    brute = min(2 * np.abs(base - s * ny).max() for s in np.linspace(-0.01, 0.01, 40001))
    assert r.details["floating"] == ["ty"] and r.value_mm <= brute + 1e-9 and brute - r.value_mm < 2e-6


def test_mesh_profile_without_datums_is_a_local_fit_pass_or_not_proven(block_index):
    rng = np.random.default_rng(8)
    surface, _, _ = _measured_surface(rng)
    angle = 2e-4
    rot = np.array([[1, 0, 0], [0, np.cos(angle), -np.sin(angle)], [0, np.sin(angle), np.cos(angle)]])
    moved = surface @ rot.T + np.array([0.003, -0.002, 0.001])
    free = DatumReferenceFrame.measurement()
    r = evaluate_profile(moved, free, 0.025, nominal_mesh=block_index)
    assert r.details["scope"] == "local" and r.value_mm <= 2 * 0.012 + 1e-6 and r.verdict == "PASS"
    tight = evaluate_profile(moved, free, 0.5 * r.value_mm, nominal_mesh=block_index)
    assert tight.verdict == "NOT PROVEN" and np.isnan(tight.bound_mm)


def test_mesh_and_tangent_planes_agree_on_the_faces(maker, block_index):
    """The same block as nominal points with normals (dense on the three faces): the same deviations."""
    rng = np.random.default_rng(11)
    part = maker.make_part(11, n_points=120, n_holes=0)
    surface, _, _ = _measured_surface(rng, n=150)
    nominal, _, normals = _measured_surface(rng, n=6000, low=0.0, high=0.0)
    abc, _ = _abc(part)
    measured = surface @ part.rotation.T + part.translation
    by_mesh = evaluate_profile(measured, abc, 0.025, nominal_mesh=block_index)
    by_points = evaluate_profile(measured, abc, 0.025, nominal, normals)
    assert abs(by_mesh.value_mm - by_points.value_mm) < 1e-9


def _write(mesh, path: Path) -> Path:
    from pcmm_geo.io.meshes import write_mesh

    return write_mesh(path, mesh)


def test_meshes_whose_sign_cannot_be_trusted_are_refused_by_name(tmp_path):
    mesh = _block_mesh()
    good = _write(mesh, tmp_path / "block.ply")
    assert len(read_nominal_mesh(good).triangles) == 12
    open_box = mesh.copy()
    open_box.update_faces(np.arange(11))
    with pytest.raises(FileFormatError, match=r"open\.ply.*open edges"):
        read_nominal_mesh(_write(open_box, tmp_path / "open.ply"))
    flipped = mesh.copy()
    flipped.invert()
    with pytest.raises(FileFormatError, match=r"inward\.ply.*inward normals"):
        read_nominal_mesh(_write(flipped, tmp_path / "inward.ply"))
    one_flipped = mesh.copy()
    faces = one_flipped.faces.copy()
    faces[0] = faces[0][::-1]
    one_flipped.faces = faces
    with pytest.raises(FileFormatError, match=r"mixed\.ply.*inconsistent orientation"):
        read_nominal_mesh(_write(one_flipped, tmp_path / "mixed.ply"))
    with pytest.raises(FileFormatError, match=r"block\.ply: nominal mesh of \d+ bytes, larger than the limit of 100"):
        read_nominal_mesh(good, max_bytes=100)
    with pytest.raises(FileFormatError, match=r"absent\.stl: nominal mesh not found"):
        read_nominal_mesh(tmp_path / "absent.stl")
    (tmp_path / "junk.stl").write_bytes(b"\0" * 90)
    with pytest.raises(FileFormatError, match=r"junk\.stl"):
        read_nominal_mesh(tmp_path / "junk.stl")


def _plan_with_mesh(maker, tmp_path: Path, mesh_name: str) -> Path:
    for f in EXAMPLE.iterdir():
        if f.suffix in (".toml", ".csv"):
            shutil.copy(f, tmp_path / f.name)
    part = maker.make_part(n_points=maker.EXAMPLE_POINTS)
    surface, _, _ = _measured_surface(np.random.default_rng(5))
    np.savetxt(tmp_path / "S.csv", surface @ part.rotation.T + part.translation, fmt="%.12f", delimiter=",")
    plan = tmp_path / "plan.toml"
    text = plan.read_text(encoding="utf-8")
    text = text[:text.index("[[characteristics]]")]
    text = text.replace("[datums]", f'[features.S]\nelement = "surface"\npoints = "S.csv"\n'
                        f'nominal_mesh = "{mesh_name}"\n\n[datums]')
    text += '[[characteristics]]\nname = "profile S"\nfeature = "S"\nframe = "⌓ 0.025 | A | B | C"\n'
    plan.write_text(text, encoding="utf-8")
    return plan


def test_profile_against_a_mesh_in_a_plan_and_its_errors(maker, tmp_path):
    _write(_block_mesh(), tmp_path / "part.stl")  # binary STL: float32, exact for these coordinates
    plan = _plan_with_mesh(maker, tmp_path, "part.stl")
    (c,) = inspect_plan(plan).characteristics
    assert c.characteristic == "profile of a surface" and abs(c.value_mm - 0.024) < 1e-8 and c.verdict == "PASS"
    line = plan.read_text(encoding="utf-8").splitlines().index('nominal_mesh = "part.stl"') + 1
    open_box = _block_mesh()
    open_box.update_faces(np.arange(11))
    (tmp_path / "part.stl").unlink()
    _write(open_box, tmp_path / "part.stl")
    with pytest.raises(FileFormatError, match=rf"plan\.toml:{line}: features\.S: nominal_mesh 'part\.stl': .*part\.stl"
                                              r".*open edges"):
        inspect_plan(plan)
    plan.write_text(plan.read_text(encoding="utf-8").replace("part.stl", "missing.obj"), encoding="utf-8")
    with pytest.raises(FileFormatError, match=rf"plan\.toml:{line}: .*missing\.obj.*not found"):
        inspect_plan(plan)


def test_the_nominal_is_points_and_normals_or_a_mesh_not_both_nor_neither(block_index):
    from pcmm_geo.errors import InvalidInputError

    surface, _, normals = _measured_surface(np.random.default_rng(2), n=20)
    free = DatumReferenceFrame.measurement()
    with pytest.raises(InvalidInputError, match=r"nominal_mesh: expected either .* got neither"):
        evaluate_profile(surface, free, 0.1)
    with pytest.raises(InvalidInputError, match="got both"):
        evaluate_profile(surface, free, 0.1, surface, normals, nominal_mesh=block_index)
    # a trimesh is indexed on the way in, and refused unless closed
    assert abs(evaluate_profile(surface, free, 0.1, nominal_mesh=_block_mesh()).value_mm -
               evaluate_profile(surface, free, 0.1, nominal_mesh=block_index).value_mm) < 1e-12
    open_box = _block_mesh()
    open_box.update_faces(np.arange(11))
    with pytest.raises(InvalidInputError, match="open edges"):
        evaluate_profile(surface, free, 0.1, nominal_mesh=open_box)
