"""Simulated workpieces: signed distances against closed forms, first contact, probings of each kind of part."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.fit import fit_cylinder, fit_plane
from pcmm_geo.ippdme.machine import SimulatedMachine
from pcmm_geo.ippdme.workpieces import (
    BoxWorkpiece,
    CylinderWorkpiece,
    PlaneWorkpiece,
    SphereWorkpiece,
    first_contact,
)


def test_distances_match_closed_forms() -> None:
    box = BoxWorkpiece([0.0, 0.0, 0.0], [10.0, 20.0, 30.0])
    pts = np.array([[8.0, 0.0, 0.0], [0.0, 0.0, 0.0], [8.0, 13.0, 0.0], [4.0, 9.0, 14.0]])
    np.testing.assert_allclose(box.distance(pts), [3.0, -5.0, np.hypot(3.0, 3.0), -1.0], atol=1e-12)
    cyl = CylinderWorkpiece([0.0, 0.0, 0.0], [0.0, 0.0, 2.0], 10.0, 20.0)
    np.testing.assert_allclose(cyl.distance(np.array([[8.0, 0, 0], [0, 0, 13.0], [8.0, 0, 14.0], [1.0, 0, 0]])),
                               [3.0, 3.0, 5.0, -4.0], atol=1e-12)
    plane = PlaneWorkpiece([0.0, 0.0, 1.0], [0.0, 0.0, 3.0])
    np.testing.assert_allclose(plane.distance(np.array([[5.0, 5.0, 4.0]])), [3.0])
    sphere = SphereWorkpiece([1.0, 1.0, 1.0], 4.0)
    np.testing.assert_allclose(sphere.distance(np.array([[1.0, 1.0, 6.0]])), [3.0])
    # the first contact of a ball of radius 1 moving down onto the plane z = 1: centre at z = 2
    s = first_contact([plane], np.array([0.0, 0.0, 10.0]), np.array([0.0, 0.0, 0.0]), 1.0)
    assert s == pytest.approx(0.8, abs=1e-9)
    assert first_contact([plane], np.array([0.0, 0.0, 10.0]), np.array([0.0, 0.0, 5.0]), 1.0) is None
    with pytest.raises(InvalidInputError):
        SphereWorkpiece([0.0, 0.0], 1.0)
    with pytest.raises(InvalidInputError):
        BoxWorkpiece([0.0, 0.0, 0.0], [1.0, -1.0, 1.0])


def test_probed_plane_and_cylinder_lie_on_their_nominal_surfaces(model, center) -> None:
    plane_z = center[2] - 5.0
    machine = SimulatedMachine(model, [PlaneWorkpiece(center - [0.0, 0.0, 5.0], [0.0, 0.0, 1.0])], seed=1)
    grid = np.array([[center[0] + x, center[1] + y, plane_z] for x in (-8.0, 0.0, 8.0) for y in (-8.0, 0.0, 8.0)])
    up = np.tile([0.0, 0.0, 1.0], (len(grid), 1))
    points = np.array([r.result.point for r in machine.probe_many(grid, up, 2.0, 4.0, diagnostics=False)])
    plane = fit_plane(points)
    assert abs(abs(plane.normal[2]) - 1.0) < 1e-5  # micrometres over 16 mm
    assert np.max(np.abs(points[:, 2] - plane_z)) < 0.005
    cylinder = CylinderWorkpiece(center, [0.0, 0.0, 1.0], 16.0, 20.0)
    machine = SimulatedMachine(model, [cylinder], seed=2)
    angles = np.linspace(0.0, 2 * np.pi, 12, endpoint=False)
    normals = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(12)])
    nominal = center + 8.0 * normals + np.outer(np.tile([-4.0, 4.0], 6), [0.0, 0.0, 1.0])
    points = np.array([r.result.point for r in machine.probe_many(nominal, normals, 2.0, 4.0, diagnostics=False)])
    fit = fit_cylinder(points)
    assert abs(2 * fit.radius - 16.0) < 0.005
    # no surface on the search path: refused with 1006, not a guessed point
    miss = machine.probe_many(center[None] + [0.0, 0.0, 30.0], np.array([[0.0, 0.0, 1.0]]), 2.0, 4.0)[0]
    assert getattr(miss, "number", None) == 1006


def test_mesh_workpiece_matches_the_box(tmp_path) -> None:
    import trimesh

    from pcmm_geo.ippdme.workpieces import MeshWorkpiece

    trimesh.creation.box(extents=(10.0, 20.0, 30.0)).export(tmp_path / "box.stl")
    mesh = MeshWorkpiece(str(tmp_path / "box.stl"), offset=(1.0, 2.0, 3.0))
    box = BoxWorkpiece([1.0, 2.0, 3.0], [10.0, 20.0, 30.0])
    pts = np.array([[9.0, 2.0, 3.0], [1.0, 2.0, 3.0], [7.0, 13.0, 4.0], [20.0, 30.0, 40.0]])
    np.testing.assert_allclose(mesh.distance(pts), box.distance(pts), atol=1e-9)
