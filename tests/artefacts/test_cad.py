"""CAD comparison: exact mesh distances, registration to a nominal mesh, deviations, segmentation.

Truth comes from closed forms (distance to an axis-aligned box), from a brute-force search
over every triangle (``trimesh.proximity.closest_point_naive``), from a known rigid
transform (scipy's rotation, not ours), from a generalized winding number (the sign of the
distance for a non-convex mesh) and from the generating geometry of synthetic scans.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from pcmm_geo.artefacts import (
    SurfaceIndex,
    cad_distance,
    centroid_alignment,
    check_closed_mesh,
    compare_to_mesh,
    deviation_summary,
    mesh_deviations,
    register_to_mesh,
    segment_scan,
    surface_distances,
)
from pcmm_geo.errors import ConvergenceError, IllConditionedWarning, InvalidInputError, TooFewPointsError
from pcmm_geo.io import box_mesh, cylinder_mesh

SIZE = np.array([100.0, 35.0, 9.0])
HALF = SIZE / 2


def box_signed_distance(points: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Closed-form signed distance from an axis-aligned box centred at the origin."""
    excess = np.abs(points) - half
    outside = np.linalg.norm(np.clip(excess, 0.0, None), axis=1)
    inside = np.minimum(excess.max(axis=1), 0.0)
    return outside + inside


def block_surface_points(
    rng: np.random.Generator, *, per_face: int = 300, faces: tuple[int, ...] = (0, 1, 2, 3, 4, 5), margin: float = 0.2
) -> tuple[np.ndarray, np.ndarray]:
    """Points on the faces of the nominal block (face k: axis k // 2, sign + for even k) and their normals."""
    points, normals = [], []
    for face in faces:
        axis, sign = face // 2, 1.0 if face % 2 == 0 else -1.0
        in_plane = [k for k in range(3) if k != axis]
        on_face = np.empty((per_face, 3))
        on_face[:, in_plane] = rng.uniform(-1, 1, (per_face, 2)) * (HALF[in_plane] - margin)
        on_face[:, axis] = sign * HALF[axis]
        normal = np.zeros(3)
        normal[axis] = sign
        points.append(on_face)
        normals.append(np.tile(normal, (per_face, 1)))
    return np.vstack(points), np.vstack(normals)


def rigid(rotation_vector_deg: tuple[float, float, float], translation: tuple[float, float, float]) -> np.ndarray:
    transform = np.eye(4)
    transform[:3, :3] = Rotation.from_rotvec(rotation_vector_deg, degrees=True).as_matrix()
    transform[:3, 3] = translation
    return transform


def moved(points: np.ndarray, transform: np.ndarray) -> np.ndarray:
    return points @ transform[:3, :3].T + transform[:3, 3]


def residual_motion(estimate: np.ndarray, truth_pose: np.ndarray) -> tuple[float, float]:
    """Rotation angle (rad) and translation (mm) left by ``estimate`` after the scan pose ``truth_pose``."""
    left = estimate @ truth_pose
    angle = Rotation.from_matrix(left[:3, :3]).magnitude()
    return float(angle), float(np.linalg.norm(left[:3, 3]))


# --------------------------------------------------------------------------- distances


def test_signed_distance_matches_closed_form_box() -> None:
    rng = np.random.default_rng(11)
    points = rng.uniform(-HALF - 4, HALF + 4, (3000, 3))
    found = surface_distances(points, box_mesh(*SIZE))
    expected = box_signed_distance(points, HALF)
    np.testing.assert_allclose(found.signed_distance, expected, rtol=0, atol=1e-12)
    assert (found.signed_distance < 0).sum() > 100 and (found.signed_distance > 0).sum() > 100
    np.testing.assert_allclose(box_signed_distance(found.closest, HALF), 0.0, atol=1e-12)
    # the direction is the gradient: stepping along it changes the distance one for one
    step = 1e-4
    np.testing.assert_allclose(box_signed_distance(points + step * found.direction, HALF) - expected, step,
                               atol=1e-10)


def test_sign_of_non_convex_mesh_matches_winding_number() -> None:
    import trimesh

    ring = trimesh.creation.torus(major_radius=20.0, minor_radius=5.0, major_sections=40, minor_sections=20)
    rng = np.random.default_rng(3)
    points = rng.uniform(ring.bounds[0] - 2, ring.bounds[1] + 2, (600, 3))
    corners = ring.triangles[None] - points[:, None, None, :]
    a, b, c = corners[:, :, 0], corners[:, :, 1], corners[:, :, 2]
    la, lb, lc = (np.linalg.norm(v, axis=2) for v in (a, b, c))
    numerator = np.einsum("pfi,pfi->pf", a, np.cross(b, c))
    denominator = (la * lb * lc + np.einsum("pfi,pfi->pf", a, b) * lc + np.einsum("pfi,pfi->pf", b, c) * la
                   + np.einsum("pfi,pfi->pf", c, a) * lb)
    winding = (2 * np.arctan2(numerator, denominator)).sum(axis=1) / (4 * np.pi)
    inside = winding > 0.5
    assert 50 < inside.sum() < 550
    found = surface_distances(points, ring)
    np.testing.assert_array_equal(found.signed_distance < 0, inside)
    np.testing.assert_allclose(np.abs(found.signed_distance), np.linalg.norm(points - found.closest, axis=1))


def _brute_force_distances(points: np.ndarray, mesh: object) -> np.ndarray:
    """Unsigned distances from trimesh's search over every triangle (no spatial index)."""
    import trimesh

    return np.concatenate([trimesh.proximity.closest_point_naive(mesh, points[start:start + 40])[1]
                           for start in range(0, len(points), 40)])


def _fine_meshes() -> list[object]:
    """A cylinder of long thin facets (2812 triangles) and a non-convex torus (3600 triangles)."""
    import trimesh

    return [cylinder_mesh(10.0, 40.0, chord_tolerance=1e-4),
            trimesh.creation.torus(major_radius=20.0, minor_radius=5.0, major_sections=60, minor_sections=30)]


@pytest.mark.parametrize("mesh_number", [0, 1])
def test_distances_equal_a_search_over_every_triangle(mesh_number: int) -> None:
    import trimesh

    mesh = _fine_meshes()[mesh_number]
    assert 2000 < len(mesh.faces) < 5000
    rng = np.random.default_rng(30 + mesh_number)
    near_surface, _ = trimesh.sample.sample_surface(mesh, 300, seed=mesh_number)
    points = np.vstack([
        rng.uniform(mesh.bounds[0] - 5.0, mesh.bounds[1] + 5.0, (300, 3)),  # anywhere, inside and out
        near_surface + 0.05 * rng.standard_normal((300, 3)),  # where scans are
        mesh.vertices[rng.choice(len(mesh.vertices), 30)],  # exactly on vertices and
        mesh.triangles_center[rng.choice(len(mesh.faces), 30)],  # faces
    ])
    found = surface_distances(points, mesh)
    np.testing.assert_allclose(np.abs(found.signed_distance), _brute_force_distances(points, mesh), rtol=0, atol=1e-12)
    # the reported nearest point is at that distance and lies on the reported triangle
    np.testing.assert_allclose(np.linalg.norm(points - found.closest, axis=1), np.abs(found.signed_distance),
                               rtol=0, atol=1e-12)
    on_face = trimesh.triangles.closest_point(mesh.triangles[found.face_index], found.closest)
    np.testing.assert_allclose(on_face, found.closest, rtol=0, atol=1e-12)


def _rows_of(points: np.ndarray, values: np.ndarray) -> object:
    """A stand-in candidate method: ``values`` of the rows of ``points`` in a block of the query (a slice)."""
    def pick(self: SurfaceIndex, query: np.ndarray, **_: object) -> np.ndarray:
        start = int(np.flatnonzero(np.all(points == query[0], axis=1))[0])
        return values[start:start + len(query)].copy()

    return pick


@pytest.mark.parametrize("mesh_number", [0, 1])
def test_a_wrong_candidate_is_corrected(monkeypatch: pytest.MonkeyPatch, mesh_number: int) -> None:
    """The first candidates (nearest centroid's, open3d's float32 one) replaced by a far triangle and the pairs
    split into tiny blocks: still exact."""
    from pcmm_geo.artefacts import _triangle

    mesh = _fine_meshes()[mesh_number]
    points = np.random.default_rng(4).uniform(mesh.bounds[0] - 3.0, mesh.bounds[1] + 3.0, (200, 3))
    index = SurfaceIndex.build(mesh)
    far = np.argmax(points @ -index.triangles.mean(axis=1).T, axis=1)  # roughly opposite, far away
    for first in ("nearby", "candidates"):  # the nearest centroid's triangle, and open3d's for far points
        monkeypatch.setattr(SurfaceIndex, first, _rows_of(points, far))
    monkeypatch.setattr(cad_distance, "_PAIRS_PER_BLOCK", 64)
    monkeypatch.setattr(_triangle, "_FIRST_NEIGHBOURS", 2)
    found = index.distances(points)
    np.testing.assert_allclose(np.abs(found.signed_distance), _brute_force_distances(points, mesh), rtol=0, atol=1e-12)


@pytest.mark.parametrize("mesh_number", [1, 2])
def test_neighbour_lists_correct_a_nearby_wrong_candidate(monkeypatch: pytest.MonkeyPatch, mesh_number: int) -> None:
    """Near-surface points given a wrong but adjacent candidate are answered (and corrected) from the
    per-triangle neighbour lists, without a tree search; with the lists switched off the trees agree.
    (On the cylinder's long facets the lists are too short to prove anything: the trees answer.)"""
    import trimesh

    from pcmm_geo.artefacts import _triangle

    meshes = [*_fine_meshes(), trimesh.creation.icosphere(subdivisions=4, radius=10.0)]
    mesh = meshes[mesh_number]
    on_surface, _ = trimesh.sample.sample_surface(mesh, 400, seed=11 + mesh_number)
    points = on_surface + 0.02 * np.random.default_rng(12).standard_normal((400, 3))
    truth = _brute_force_distances(points, mesh)
    index = SurfaceIndex.build(mesh)
    true_face = index.candidates(points)
    listed = index.neighbours.listed[true_face]  # nearest centroids first, padded with len(triangles)
    wrong = listed[np.arange(len(listed)), np.argmax(listed < len(index.triangles), axis=1)]  # a neighbour
    assert np.all(wrong < len(index.triangles)) and np.all(wrong != true_face)
    for first in ("nearby", "candidates"):
        monkeypatch.setattr(SurfaceIndex, first, _rows_of(points, wrong))
    answered = []
    spy = _triangle.listed_pairs

    def counting(*args: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        found = spy(*args)
        answered.append(args[1].shape[1] - len(found[2]))  # args[1]: the points transposed, (3, N)
        return found

    monkeypatch.setattr(cad_distance, "listed_pairs", counting)
    found = index.distances(points)
    # proved from the lists (14 centroids each; the torus' facets are long: 18 and 192 of 400 are answered there)
    assert sum(answered) > (10 if mesh_number == 1 else 120)
    assert np.count_nonzero(found.face_index != wrong) > 350  # and corrected
    np.testing.assert_allclose(np.abs(found.signed_distance), truth, rtol=0, atol=1e-12)
    monkeypatch.setattr(_triangle, "_LISTED_NEIGHBOURS", 1)  # lists hold only the triangle itself
    trees_only = SurfaceIndex.build(mesh)
    answered.clear()
    found = trees_only.distances(points)
    assert sum(answered) == 0
    np.testing.assert_allclose(np.abs(found.signed_distance), truth, rtol=0, atol=1e-12)


def test_adversarial_points_match_a_double_precision_brute_force() -> None:
    """Points a float32 search cannot separate: on edges and vertices, near-equidistant from two
    walls 1e-6 mm apart in distance, at the centre of a sphere (every triangle nearly equidistant),
    far away, and 500 mm from the origin."""
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=4, radius=10.0)
    sphere.apply_translation([500.0, -300.0, 200.0])
    rng = np.random.default_rng(8)
    edge = rng.integers(0, len(sphere.edges_unique), 200)
    ends = sphere.vertices[sphere.edges_unique[edge]]
    along = rng.uniform(0, 1, (200, 1))
    on_edges = ends[:, 0] * along + ends[:, 1] * (1 - along)
    center = sphere.bounds.mean(axis=0)
    radial = (on_edges - center) / np.linalg.norm(on_edges - center, axis=1, keepdims=True)
    points = np.vstack([
        on_edges + 1e-7 * radial, on_edges - 1e-7 * radial,  # just off an edge, either side
        sphere.vertices[:100] + 1e-8 * rng.standard_normal((100, 3)),  # at vertices
        center + 1e-3 * rng.standard_normal((20, 3)),  # all triangles within a hair of the same distance
        center + rng.standard_normal((50, 3)) * 1e3,  # far away
    ])
    found = surface_distances(points, sphere)
    np.testing.assert_allclose(np.abs(found.signed_distance), _brute_force_distances(points, sphere),
                               rtol=0, atol=1e-12)
    # a thin slab: points in the middle are 1e-6 mm nearer one wall than the other
    slab = box_mesh(20.0, 20.0, 0.002)
    middle = np.c_[rng.uniform(-5, 5, (300, 2)), rng.choice([-1e-6, 1e-6, 0.0], 300)]
    found = surface_distances(middle, slab)
    np.testing.assert_allclose(found.signed_distance, box_signed_distance(middle, np.array([10.0, 10.0, 0.001])),
                               rtol=0, atol=1e-15)
    off_middle = middle[:, 2] != 0.0
    np.testing.assert_array_equal(np.sign(found.closest[off_middle, 2]), np.sign(middle[off_middle, 2]))


def test_index_survives_pickling_and_dask_blocks() -> None:
    """The index crosses process boundaries (dask workers) without its open3d scene; lazy block-wise distances."""
    import pickle

    import dask.array as da

    mesh = _fine_meshes()[1]
    points = np.random.default_rng(5).uniform(mesh.bounds[0] - 2.0, mesh.bounds[1] + 2.0, (900, 3))
    index = pickle.loads(pickle.dumps(SurfaceIndex.build(mesh)))
    direct = index.distances(points)
    lazy = surface_distances(da.from_array(points, chunks=(250, 3)), mesh)
    assert isinstance(lazy.signed_distance, da.Array)
    np.testing.assert_allclose(lazy.signed_distance.compute(), _brute_force_distances(points, mesh)
                               * np.sign(direct.signed_distance), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(lazy.face_index.compute(), direct.face_index)
    np.testing.assert_allclose(lazy.direction.compute(), direct.direction, rtol=0, atol=1e-15)


def test_open_and_flipped_meshes_are_refused_for_signed_distances() -> None:
    import trimesh

    block = box_mesh(*SIZE)
    open_box = block.copy()
    open_box.update_faces(np.arange(10))  # one face of the block missing
    flipped = block.copy()
    flipped.invert()
    mixed = trimesh.Trimesh(block.vertices, np.vstack([block.faces[:11], block.faces[11, ::-1]]), process=False)
    scan = block_surface_points(np.random.default_rng(1), per_face=20)[0]
    for mesh, problem in ((open_box, "open edges"), (flipped, "inward normals"), (mixed, "inconsistent orientation")):
        with pytest.raises(InvalidInputError, match=problem):
            check_closed_mesh(mesh)
        for call in (lambda m: surface_distances(scan, m), lambda m: mesh_deviations(scan, m),
                     lambda m: register_to_mesh(scan, m), lambda m: compare_to_mesh(scan, m)):
            with pytest.raises(InvalidInputError, match="closed mesh") as caught:
                call(mesh)
            assert caught.value.what == "mesh"
    with pytest.raises(InvalidInputError, match="no triangles"):
        surface_distances(scan, trimesh.Trimesh())
    with pytest.raises(InvalidInputError, match="no triangles"):
        check_closed_mesh(trimesh.Trimesh(), what="part.stl")


def test_open_surface_on_request_gives_the_side_of_its_normals() -> None:
    """The top face of the block alone: distance to a rectangle, sign of z - 4.5 (closed form)."""
    block = box_mesh(*SIZE)
    top = block.copy()
    top.update_faces(np.flatnonzero(block.face_normals[:, 2] > 0.5))
    points = np.random.default_rng(12).uniform([-60, -25, -2], [60, 25, 10], (500, 3))
    found = surface_distances(points, top, require_closed=False)
    in_plane = np.clip(np.abs(points[:, :2]) - HALF[:2], 0.0, None)
    expected = np.hypot(np.linalg.norm(in_plane, axis=1), points[:, 2] - HALF[2])
    np.testing.assert_allclose(np.abs(found.signed_distance), expected, rtol=0, atol=1e-12)
    inside_rectangle = np.all(np.abs(points[:, :2]) < HALF[:2], axis=1)
    np.testing.assert_array_equal(np.sign(found.signed_distance[inside_rectangle]),
                                  np.sign(points[inside_rectangle, 2] - HALF[2]))


def test_too_few_points() -> None:
    block = box_mesh(*SIZE)
    with pytest.raises(TooFewPointsError):
        surface_distances(np.empty((0, 3)), block)
    with pytest.raises(TooFewPointsError):
        mesh_deviations(np.empty((0, 3)), block)
    with pytest.raises(TooFewPointsError, match="at least 6 points, got 5"):
        compare_to_mesh(block_surface_points(np.random.default_rng(0), per_face=1)[0][:5], block)


def test_points_offset_along_face_normals_deviate_by_the_offset() -> None:
    rng = np.random.default_rng(5)
    points, normals = block_surface_points(rng)
    for offset in (0.01, -0.01):
        result = mesh_deviations(points + offset * normals, box_mesh(*SIZE), tolerance=0.005)
        np.testing.assert_allclose(result.signed_distance, offset, rtol=0, atol=1e-12)
        np.testing.assert_allclose(result.closest, points, rtol=0, atol=1e-12)
        summary = result.summary
        assert summary.count == summary.count_beyond == len(points)
        for value in (summary.minimum, summary.maximum, summary.mean):
            assert value == pytest.approx(offset, abs=1e-12)
        assert summary.rms == pytest.approx(0.01, abs=1e-12)


def test_deviation_summary_statistics() -> None:
    summary = deviation_summary([0.003, -0.001, 0.0, -0.006], tolerance=0.002)
    assert (summary.minimum, summary.maximum, summary.count_beyond) == (-0.006, 0.003, 2)
    assert summary.mean == pytest.approx(-0.001, abs=1e-15)
    assert summary.rms == pytest.approx(np.sqrt((9 + 1 + 36) / 4) * 1e-3, rel=1e-14)
    assert deviation_summary([0.5]).count_beyond == 0 and deviation_summary([0.5]).tolerance is None
    with pytest.raises(InvalidInputError):
        deviation_summary([], tolerance=0.1)
    with pytest.raises(InvalidInputError):
        deviation_summary([0.1], tolerance=-0.1)


# --------------------------------------------------------------------------- registration


def test_box_scan_registered_back_exactly() -> None:
    rng = np.random.default_rng(21)
    nominal, _ = block_surface_points(rng, per_face=250, faces=(0, 1, 2, 3, 4))  # no bottom face
    pose = rigid((0.7, -0.4, 2.5), (1.3, -0.9, 0.6))
    result = register_to_mesh(moved(nominal, pose), box_mesh(*SIZE))
    angle, shift = residual_motion(result.transform, pose)
    assert angle < 1e-8 and shift < 1e-6
    assert result.fitness == 1.0 and result.inlier_count == len(nominal)
    assert result.inlier_rms < 1e-9
    assert result.rotation_angle == pytest.approx(np.radians(np.linalg.norm([0.7, -0.4, 2.5])), abs=1e-8)
    np.testing.assert_allclose(result.apply(moved(nominal, pose)), nominal, rtol=0, atol=1e-6)


def test_far_scan_needs_and_uses_an_initial_transform() -> None:
    rng = np.random.default_rng(8)
    nominal, _ = block_surface_points(rng, per_face=200)
    pose = rigid((0.0, 0.0, 35.0), (250.0, -120.0, 80.0))
    scan = moved(nominal, pose)
    block = box_mesh(*SIZE)
    with pytest.raises(ConvergenceError, match="initial transform"):
        register_to_mesh(scan, block, max_distance=2.0)
    rough = np.linalg.inv(rigid((0.5, -0.5, 33.0), (249.0, -119.0, 81.0)))
    result = register_to_mesh(scan, block, initial_transform=rough, max_distance=5.0)
    angle, shift = residual_motion(result.transform, pose)
    assert angle < 1e-8 and shift < 1e-6


def test_centroid_alignment_starts_a_translated_scan() -> None:
    rng = np.random.default_rng(9)
    nominal, _ = block_surface_points(rng, per_face=200)
    pose = rigid((0.3, 0.2, -1.0), (-400.0, 35.0, 12.0))
    scan = moved(nominal, pose)
    block = box_mesh(*SIZE)
    start = centroid_alignment(scan, block)
    # all six faces, equally sampled per face: the centroids match up to the sampling
    assert np.linalg.norm(moved(scan, start).mean(axis=0)) < 1.0
    result = register_to_mesh(scan, block, initial_transform=start)
    angle, shift = residual_motion(result.transform, pose)
    assert angle < 1e-8 and shift < 1e-6


def test_compare_outward_offset_survives_registration() -> None:
    """All six faces 0.01 mm outside: no rigid motion can absorb it, every deviation stays +0.01 mm.

    The points are spread symmetrically (mirrored in the block's three planes of symmetry),
    so the true pose is where the least-squares fit ends; for a lopsided sample the best fit
    would legitimately tilt to share out the size error.
    """
    rng = np.random.default_rng(13)
    half_scan, half_normals = block_surface_points(rng, per_face=40)
    mirrors = [np.array([sx, sy, sz]) for sx in (1, -1) for sy in (1, -1) for sz in (1, -1)]
    nominal = np.vstack([half_scan * m for m in mirrors])
    normals = np.vstack([half_normals * m for m in mirrors])
    pose = rigid((-0.6, 0.3, 1.2), (0.8, 0.5, -0.4))
    comparison = compare_to_mesh(moved(nominal + 0.01 * normals, pose), box_mesh(*SIZE), tolerance=0.012)
    np.testing.assert_allclose(comparison.deviations.signed_distance, 0.01, rtol=0, atol=1e-9)
    angle, shift = residual_motion(comparison.registration.transform, pose)
    assert angle < 1e-8 and shift < 1e-6
    assert comparison.deviations.summary.count_beyond == 0
    assert comparison.registration.inlier_rms == pytest.approx(0.01, abs=1e-9)


def test_noisy_scan_registration_and_deviations() -> None:
    rng = np.random.default_rng(17)
    nominal, normals = block_surface_points(rng, per_face=400, faces=(0, 1, 2, 3, 4))
    noise = 0.001 * rng.standard_normal(len(nominal))
    pose = rigid((0.4, -0.25, 1.5), (1.2, -0.7, 0.35))
    comparison = compare_to_mesh(moved(nominal + noise[:, None] * normals, pose), box_mesh(*SIZE))
    angle, shift = residual_motion(comparison.registration.transform, pose)
    assert angle < 2e-5 and shift < 2e-4  # 2000 points with 1 µm noise
    # each deviation is its noise plus the displacement the leftover rigid motion gives its point
    leftover = angle * float(np.linalg.norm(nominal, axis=1).max()) + shift
    assert np.abs(comparison.deviations.signed_distance - noise).max() <= leftover + 1e-12
    assert comparison.deviations.summary.rms == pytest.approx(np.sqrt(np.mean(noise**2)), rel=0.01)


def test_registration_on_a_plane_is_ill_conditioned() -> None:
    rng = np.random.default_rng(2)
    top, _ = block_surface_points(rng, per_face=100, faces=(4,))
    with pytest.warns(IllConditionedWarning, match="undetermined"):
        result = register_to_mesh(top + np.array([0.0, 0.0, 0.05]), box_mesh(*SIZE))
    assert result.inlier_rms < 1e-9  # a best fit exists; only its in-plane position is arbitrary


def test_registration_input_checks() -> None:
    block = box_mesh(*SIZE)
    with pytest.raises(TooFewPointsError):
        register_to_mesh(np.zeros((5, 3)), block)
    scan = block_surface_points(np.random.default_rng(0), per_face=10)[0]
    shear = np.eye(4)
    shear[0, 1] = 0.01
    with pytest.raises(InvalidInputError, match="proper rotation"):
        register_to_mesh(scan, block, initial_transform=shear)
    mirror = np.diag([1.0, 1.0, -1.0, 1.0])
    with pytest.raises(InvalidInputError, match="det"):
        register_to_mesh(scan, block, initial_transform=mirror)
    with pytest.raises(InvalidInputError, match="max_distance"):
        register_to_mesh(scan, block, max_distance=0.0)


# --------------------------------------------------------------------------- segmentation

BOSS_CENTRE = np.array([20.0, 3.0])
BOSS_RADIUS = 6.0
BOSS_HEIGHT = 15.0


def block_with_boss(rng: np.random.Generator, margin: float = 0.3) -> tuple[np.ndarray, list[np.ndarray]]:
    """Block (top and four sides, z from 0 to 9) with a cylindrical boss on top: points and the true plane normals."""
    length, width, height = SIZE

    def patch(count: int, u: tuple[float, float], v: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
        return rng.uniform(*u, count), rng.uniform(*v, count)

    u, v = patch(2400, (-length / 2 + margin, length / 2 - margin), (-width / 2 + margin, width / 2 - margin))
    top = np.c_[u, v, np.full_like(u, height)]
    top = top[np.hypot(*(top[:, :2] - BOSS_CENTRE).T) > BOSS_RADIUS + margin]
    parts = [top]
    for sign in (-1.0, 1.0):
        u, v = patch(600, (-length / 2 + margin, length / 2 - margin), (margin, height - margin))
        parts.append(np.c_[u, np.full_like(u, sign * width / 2), v])
        u, v = patch(250, (-width / 2 + margin, width / 2 - margin), (margin, height - margin))
        parts.append(np.c_[np.full_like(u, sign * length / 2), u, v])
    angle, z = patch(900, (0.0, 2 * np.pi), (height + margin, height + BOSS_HEIGHT - margin))
    parts.append(np.c_[BOSS_CENTRE + BOSS_RADIUS * np.c_[np.cos(angle), np.sin(angle)], z])
    radius = (BOSS_RADIUS - margin) * np.sqrt(rng.uniform(0, 1, 300))
    angle = rng.uniform(0, 2 * np.pi, 300)
    parts.append(np.c_[BOSS_CENTRE + radius[:, None] * np.c_[np.cos(angle), np.sin(angle)],
                       np.full(300, height + BOSS_HEIGHT)])
    normals = [np.array(n, dtype=float) for n in ([0, 0, 1], [0, 1, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [0, 0, 1])]
    return np.vstack(parts), normals


def test_segmentation_finds_block_planes_and_exact_boss_cylinder() -> None:
    points, plane_normals = block_with_boss(np.random.default_rng(7))
    result = segment_scan(points, distance_threshold=0.01, seed=4)
    assert len(result.planes) == 6 and len(result.cylinders) == 1
    boss = result.cylinders[0].fit
    assert abs(boss.radius - BOSS_RADIUS) < 1e-9
    assert np.linalg.norm(np.cross(boss.axis, [0.0, 0.0, 1.0])) < 1e-9
    assert np.linalg.norm(boss.point[:2] - BOSS_CENTRE) < 1e-9
    # every plane is one of the true faces, each true face found once
    found = sorted(tuple(np.round(np.abs(p.fit.normal), 9)) for p in result.planes)
    assert found == sorted(tuple(np.abs(n)) for n in plane_normals)
    for segment in result.segments:
        assert segment.fit.rms < 1e-9 and len(segment.indices) == segment.fit.n
    # no point in two segments; together with the unassigned ones they are all the points
    labels = np.concatenate([s.indices for s in result.segments] + [result.unassigned])
    np.testing.assert_array_equal(np.sort(labels), np.arange(len(points)))
    assert len(result.cylinders[0].indices) == 900
    again = segment_scan(points, distance_threshold=0.01, seed=4)
    np.testing.assert_array_equal(again.labels(), result.labels())


def test_segmentation_with_probing_noise() -> None:
    rng = np.random.default_rng(19)
    points, _ = block_with_boss(rng)
    noisy = points + 0.001 * rng.standard_normal(points.shape)
    result = segment_scan(noisy, distance_threshold=0.006, seed=1)
    assert len(result.planes) == 6 and len(result.cylinders) == 1
    boss = result.cylinders[0].fit
    assert abs(boss.radius - BOSS_RADIUS) < 2e-4
    assert all(0.0007 < s.fit.rms < 0.0013 for s in result.segments)


def test_segmentation_limited_to_planes() -> None:
    points, _ = block_with_boss(np.random.default_rng(7))
    result = segment_scan(points, distance_threshold=0.01, kinds=("plane",), seed=0)
    assert result.cylinders == () and len(result.planes) >= 6
    normals = np.abs(np.array([p.fit.normal for p in result.planes]))
    # the six true planes are among them, found exactly
    for truth in ([0, 0, 1], [0, 1, 0], [1, 0, 0]):
        assert np.any(np.linalg.norm(normals - truth, axis=1) < 1e-9)


def test_segmentation_input_checks() -> None:
    points, _ = block_with_boss(np.random.default_rng(7))
    with pytest.raises(InvalidInputError, match="distance_threshold"):
        segment_scan(points, distance_threshold=0.0)
    with pytest.raises(InvalidInputError, match="kinds"):
        segment_scan(points, kinds=("cone",))
    with pytest.raises(InvalidInputError, match="max_normal_angle"):
        segment_scan(points, max_normal_angle=2.0)
    with pytest.raises(TooFewPointsError):
        segment_scan(points[:10], min_points=20)


def test_compare_to_a_mesh_file_path(tmp_path: Path) -> None:
    """The nominal may be given as a file: read once, the same deviations as the mesh object (issue 31)."""
    from pcmm_geo.io import write_mesh

    rng = np.random.default_rng(13)
    scan, normals = block_surface_points(rng, per_face=12)
    pose = rigid((-0.6, 0.3, 1.2), (0.8, 0.5, -0.4))
    path = write_mesh(tmp_path / "block.stl", box_mesh(*SIZE))
    measured = moved(scan + 0.01 * normals, pose)
    from_file = compare_to_mesh(measured, str(path), tolerance=0.012)
    from_object = compare_to_mesh(measured, box_mesh(*SIZE), tolerance=0.012)
    np.testing.assert_allclose(from_file.deviations.signed_distance, from_object.deviations.signed_distance,
                               rtol=0, atol=1e-9)
    assert np.median(from_file.deviations.signed_distance) == pytest.approx(0.01, abs=2e-3)
    with pytest.raises(InvalidInputError, match=r"mesh: expected a trimesh\.Trimesh or the path of a mesh file"):
        compare_to_mesh(measured, 42)


@settings(max_examples=10, deadline=None)
@given(offsets=st.lists(st.sampled_from([0.0, 1e-9, 1e-6, 1e-3, 0.05, 0.4, 3.0, 40.0]), min_size=1, max_size=40),
       seed=st.integers(0, 10_000), far_from_origin=st.booleans())
def test_nearest_centroid_candidates_agree_with_open3d_candidates(offsets: list[float], seed: int,
                                                                 far_from_origin: bool) -> None:
    """The first candidate (nearest centroid; open3d's only beyond three triangle radii) gives the distances of the
    open3d-candidate path and of a brute-force search, on vertices, edges, faces and off them, near and far."""
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=2, radius=10.0)
    if far_from_origin:
        sphere.apply_translation([500.0, -300.0, 200.0])
    rng = np.random.default_rng(seed)
    triangles = sphere.triangles[rng.integers(0, len(sphere.faces), len(offsets))]
    weights = rng.choice([[1.0, 0.0, 0.0], [0.5, 0.5, 0.0], [1 / 3, 1 / 3, 1 / 3], [0.2, 0.3, 0.5]], len(offsets))
    on_surface = np.einsum("ij,ijk->ik", weights, triangles)
    direction = rng.standard_normal((len(offsets), 3))
    points = on_surface + direction / np.linalg.norm(direction, axis=1)[:, None] * np.array(offsets)[:, None]
    index = SurfaceIndex.build(sphere)
    nearby = index.nearby(points)
    assert np.all((nearby >= 0) | (np.array(offsets) > 3.0))  # only points a few triangles away lack a centroid
    found = index.distances(points, workers=1)
    _, squared, _, _ = index._nearest(points, index.candidates(points))  # the open3d-candidate path
    truth = _brute_force_distances(points, sphere)
    np.testing.assert_allclose(np.abs(found.signed_distance), np.sqrt(squared), rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.abs(found.signed_distance), truth, rtol=0, atol=1e-12)


@pytest.mark.parametrize("backend", ["scipy", "default"])
def test_ordered_queries_on_either_tree_equal_a_search_over_every_triangle(monkeypatch: pytest.MonkeyPatch,
                                                                         backend: str) -> None:
    """Enough points for the spatial order (>= 4096), answered in their own order, on scipy's tree and on the
    default one (pykdtree where installed): every distance that of a search over every triangle."""
    import trimesh

    from pcmm_geo.artefacts import _triangle

    if backend == "scipy":
        from scipy.spatial import cKDTree

        monkeypatch.setattr(_triangle, "_new_tree", lambda centroids: _triangle._ScipyTree(cKDTree(centroids)))
    mesh = _fine_meshes()[1]
    rng = np.random.default_rng(77)
    near_surface, _ = trimesh.sample.sample_surface(mesh, 4500, seed=7)
    points = np.vstack([near_surface + 0.05 * rng.standard_normal((4500, 3)),
                        rng.uniform(mesh.bounds[0] - 5.0, mesh.bounds[1] + 5.0, (200, 3))])
    found = SurfaceIndex.build(mesh).distances(points, workers=2)
    every_eighth = slice(3, None, 8)  # the brute force on a share: each point is answered on its own
    np.testing.assert_allclose(np.abs(found.signed_distance[every_eighth]),
                               _brute_force_distances(points[every_eighth], mesh), rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(points - found.closest, axis=1), np.abs(found.signed_distance),
                               rtol=0, atol=1e-12)
    on_face = trimesh.triangles.closest_point(mesh.triangles[found.face_index], found.closest)
    np.testing.assert_allclose(on_face, found.closest, rtol=0, atol=1e-12)


def test_neighbour_lists_made_in_chunks_on_threads_equal_one_pass() -> None:
    """Lists made in one chunk per thread (the tree asked for each chunk's rows) are those of one pass, and each
    list holds every centroid nearer than its completeness radius (brute force on a sample of triangles)."""
    import trimesh

    from pcmm_geo.artefacts._triangle import neighbour_lists

    mesh = trimesh.creation.icosphere(subdivisions=5, radius=25.0)
    triangles = np.asarray(mesh.triangles)
    one, two = neighbour_lists(triangles, 1), neighbour_lists(triangles, 3)
    assert len(triangles) // 4096 >= 3
    for name in ("listed", "complete_within", "listed_radius", "listed_near"):
        np.testing.assert_array_equal(getattr(one, name), getattr(two, name))
    centroids = triangles.mean(axis=1)
    for t in np.random.default_rng(5).choice(len(triangles), 40, replace=False):
        close = np.flatnonzero(np.linalg.norm(centroids - centroids[t], axis=1) < two.complete_within[t])
        assert set(close) - {t} <= set(two.listed[t])
