"""Distances between features are intrinsic to the part: the same under any rigid motion of its points (to 1e-9 mm),
with or without a DRF, and equal to closed forms on constructed exact cylinders, planes and spheres."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.gdt import DatumReferenceFrame, FeatureData, evaluate_distance

_FREE = DatumReferenceFrame.measurement()


def _cylinder(maker, rng, offset, tilt, depth, name, n=200) -> np.ndarray:
    hole = maker.Hole(name, (0.0, 0.0), 10.0, offset, tilt, 10.0, depth=depth)
    return maker.hole_points(rng, hole, n)


def _feature(name, element, points, direction=(0.0, 0.0, 1.0)) -> FeatureData:
    return FeatureData(name, element, np.asarray(points, dtype=float), np.zeros(3), np.asarray(direction, dtype=float),
                       "internal", 10.0)


def _rigid(rng) -> tuple[np.ndarray, np.ndarray]:
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q)), rng.uniform(-500, 500, 3)


def _moved(feature: FeatureData, rot: np.ndarray, shift: np.ndarray) -> FeatureData:
    import dataclasses

    return dataclasses.replace(feature, points=feature.points @ rot.T + shift,
                               direction=rot @ feature.direction)


@pytest.mark.parametrize("seed", range(6))
def test_skew_axes_distance_is_the_closed_form_and_pose_invariant(maker, seed):
    rng = np.random.default_rng(seed)
    d, t = rng.uniform(20, 80), rng.uniform(1e-4, 2e-3)
    # axis 1: x = -d/2 + t z over z in [2, 28]; axis 2: x = d/2 - t z over z in [10, 40]: the mean direction is z,
    # the common extent [10, 28], its middle z = 19, where the axes are d - 2 t 19 apart
    h1 = _feature("H1", "cylinder", _cylinder(maker, rng, (-d / 2, 0.0), (t, 0.0), (2.0, 28.0), "H1"))
    h2 = _feature("H2", "cylinder", _cylinder(maker, rng, (d / 2, 0.0), (-t, 0.0), (10.0, 40.0), "H2"))
    exact = d - 2 * t * 19.0
    r = evaluate_distance(h1, h2, _FREE, exact, (-0.1, 0.1))
    assert abs(r.value_mm - exact) < 1e-9 and r.verdict == "PASS"
    assert r.details["definition"] == "between the axes at the middle of their common extent"
    assert np.allclose(np.asarray(r.details["between_mm"])[:, 2], 19.0, atol=1e-9)
    for _ in range(5):
        rot, shift = _rigid(rng)
        moved = evaluate_distance(_moved(h1, rot, shift), _moved(h2, rot, shift), _FREE, exact, (-0.1, 0.1))
        assert abs(moved.value_mm - r.value_mm) < 1e-9
        assert abs(evaluate_distance(_moved(h2, rot, shift), _moved(h1, rot, shift), _FREE, exact,
                                     (-0.1, 0.1)).value_mm - exact) < 1e-9


@pytest.mark.parametrize("seed", range(4))
def test_parallel_axes_plane_and_sphere_distances(maker, seed):
    rng = np.random.default_rng(100 + seed)
    off1, off2 = rng.uniform(-30, 30, 2), rng.uniform(-30, 30, 2)
    h1 = _feature("H1", "cylinder", _cylinder(maker, rng, tuple(off1), (0.0, 0.0), (2.0, 28.0), "H1"))
    h2 = _feature("H2", "cylinder", _cylinder(maker, rng, tuple(off2), (0.0, 0.0), (30.0, 50.0), "H2"))  # no overlap
    top = _feature("TOP", "plane", np.c_[rng.uniform(-50, 50, (80, 2)), np.full(80, 45.0)])
    centre = np.r_[rng.uniform(-20, 20, 2), 7.0]
    v = rng.normal(size=(60, 3))
    ball = _feature("S", "sphere", centre + 4.0 * v / np.linalg.norm(v, axis=1)[:, None], (np.nan,) * 3)
    cases = [(h1, h2, float(np.linalg.norm(off2 - off1))),  # parallel lines
             (top, h1, 45.0 - 15.0),  # the plane to the middle of the axis
             (h1, top, 45.0 - 15.0),
             (ball, h1, float(np.linalg.norm(centre[:2] - off1))),  # a centre from an axis
             (top, ball, 45.0 - 7.0)]
    for rot, shift in [(np.eye(3), np.zeros(3)), _rigid(rng), _rigid(rng)]:
        for first, second, exact in cases:
            r = evaluate_distance(_moved(first, rot, shift), _moved(second, rot, shift), _FREE, exact, (-1, 1))
            assert abs(r.value_mm - exact) < 1e-9, (first.name, second.name)


def test_example_plan_distance_with_datums_at_the_nominal_height_without_at_the_common_middle(maker):
    import dataclasses

    from pcmm_geo.gdt.inspection import _Frames, load_plan

    plan = load_plan(Path(__file__).parents[2] / "pcmm_geo" / "data" / "examples" / "gdt" / "plan.toml")
    h1, h2 = plan.features["H1"], plan.features["H2"]
    holes = {h.name: h for h in maker.make_part(n_points=maker.EXAMPLE_POINTS).holes}
    # constructed axes: x, y = centre + offset + z * tilt (exact cylinders, exact datums)
    def at(name: str, z: float) -> np.ndarray:
        h = holes[name]
        return np.add(h.centre, h.offset) + z * np.asarray(h.tilt)

    in_abc = evaluate_distance(h1, h2, _Frames(plan).drf(("A", "B", "C")), 60.0, (-0.1, 0.1))
    assert abs(in_abc.value_mm - float(np.linalg.norm(at("H2", 0.0) - at("H1", 0.0)))) < 1e-9
    free = evaluate_distance(h1, h2, _FREE, 60.0, (-0.1, 0.1))
    # both holes span z in [2, 28]: the middle of the common extent is z = 15 up to the tilt of the mean
    # direction (second order: below 60 mm x (6.4e-4)^2 = 2.5e-5 mm)
    assert abs(free.value_mm - float(np.linalg.norm(at("H2", 15.0) - at("H1", 15.0)))) < 3e-5
    assert abs(free.value_mm - in_abc.value_mm) > 1e-3  # the holes are skew: the height matters
    rng = np.random.default_rng(3)
    for _ in range(4):
        rot, shift = _rigid(rng)
        moved = [dataclasses.replace(f, points=f.points @ rot.T + shift) for f in (h1, h2)]
        assert abs(evaluate_distance(*moved, _FREE, 60.0, (-0.1, 0.1)).value_mm - free.value_mm) < 1e-9
