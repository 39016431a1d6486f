"""Patterns of holes as a simultaneous requirement: one motion in the DRF's free degrees of freedom."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.gdt import (
    FeatureData,
    associate_datum,
    build_drf,
    evaluate_position,
    evaluate_position_pattern,
)
from pcmm_geo.gdt.reference.drf import nominal_of


def _setup(maker, seed, offsets):
    part = maker.make_part(seed, n_points=100, n_holes=0)
    rng = np.random.default_rng(seed)
    a = associate_datum(part.measured("A"), "plane", label="A", nominal_direction=[0, 0, 1])
    b = associate_datum(part.measured("B"), "plane", label="B", nominal_direction=[1, 0, 0],
                        perpendicular_to=(a.direction,))
    c = associate_datum(part.measured("C"), "plane", label="C", nominal_direction=[0, 1, 0],
                        perpendicular_to=(a.direction, b.direction))
    pairs = [(a, nominal_of([0, 0, 0], [0, 0, 1])), (b, nominal_of([0, 0, 0], [1, 0, 0])),
             (c, nominal_of([0, 0, 0], [0, 1, 0]))]
    features = []
    for k, (centre, offset) in enumerate(zip([(30.0, 25.0), (90.0, 25.0), (60.0, 65.0)], offsets, strict=False)):
        hole = maker.Hole(f"P{k + 1}", centre, 10.0, offset, (0.0, 0.0), 10.03)
        pts = maker.hole_points(rng, hole, 100) @ part.rotation.T + part.translation
        features.append(FeatureData(hole.name, "cylinder", pts, np.array([*centre, 0.0]), np.array([0, 0, 1.0]),
                                    "internal", 10.0, (0.0, 0.1)))
    return features, build_drf(pairs), build_drf(pairs[:2])


@pytest.mark.parametrize("seed", range(3))
def test_a_complete_drf_makes_the_pattern_the_single_positions(maker, seed):
    features, abc, _ = _setup(maker, seed, [(0.02, -0.01), (0.03, 0.0), (-0.01, 0.04)])
    group = evaluate_position_pattern(features, abc, [0.1] * 3)
    for f, g in zip(features, group, strict=True):
        single = evaluate_position(f, abc, 0.1)
        assert abs(g.value_mm - single.value_mm) < 1e-9 and g.verdict == single.verdict == "PASS"


@pytest.mark.parametrize("seed", range(3))
def test_zones_float_together_not_one_by_one(maker, seed):
    # A|B leaves y free: opposite y offsets of +-60 um each float away alone, not together
    features, _, ab = _setup(maker, seed, [(0.0, 0.06), (0.0, -0.06)])
    singles = [evaluate_position(f, ab, 0.1) for f in features]
    assert all(s.value_mm < 1e-7 and s.verdict == "PASS" for s in singles)
    group = evaluate_position_pattern(features, ab, [0.1, 0.1], pattern="P")
    assert [g.verdict for g in group] == ["FAIL", "FAIL"]
    assert all(abs(g.value_mm - 0.12) < 1e-7 for g in group)
    assert abs(group[0].details["pattern_ratio"] - 1.2) < 1e-6
    # the same offsets at MMC: the 30 um bonus of each hole allows 0.13
    at_mmc = evaluate_position_pattern(features, ab, [0.1, 0.1], modifiers=["MMC", "MMC"])
    assert [g.verdict for g in at_mmc] == ["PASS", "PASS"]
    assert all(abs(g.bonus_mm - 0.03) < 1e-9 for g in at_mmc)
    # a common y shift floats away entirely
    shifted, _, ab2 = _setup(maker, seed, [(0.0, 0.07), (0.0, 0.07)])
    assert all(g.value_mm < 1e-7 for g in evaluate_position_pattern(shifted, ab2, [0.1, 0.1]))


def test_asme_positions_to_the_same_datums_are_simultaneous_by_default(maker, tmp_path):
    from pcmm_geo.gdt import inspect_plan

    features, _, _ = _setup(maker, 1, [(0.0, 0.06), (0.0, -0.06)])
    part = maker.make_part(1, n_points=100, n_holes=0)
    lines = ['standard = "ASME"', "[features.A]", 'element = "plane"', 'points = "A.csv"', "normal = [0, 0, -1]",
             "[features.B]", 'element = "plane"', 'points = "B.csv"', "normal = [-1, 0, 0]"]
    np.savetxt(tmp_path / "A.csv", part.measured("A"), delimiter=",", fmt="%.12f")
    np.savetxt(tmp_path / "B.csv", part.measured("B"), delimiter=",", fmt="%.12f")
    for f in features:
        np.savetxt(tmp_path / f"{f.name}.csv", f.points, delimiter=",", fmt="%.12f")
        lines += [f"[features.{f.name}]", 'element = "cylinder"', f'points = "{f.name}.csv"', 'side = "internal"',
                  f"point = [{f.point[0]:g}, {f.point[1]:g}, 0]", "axis = [0, 0, 1]", "diameter = 10"]
    lines += ["[datums]", 'A = {feature = "A", criterion = "minimax"}', 'B = {feature = "B", criterion = "minimax"}']
    for f in features:
        lines += ["[[characteristics]]", f'name = "pos {f.name}"', f'feature = "{f.name}"',
                  'frame = "position dia 0.1 | A | B"']
    plan = tmp_path / "plan.toml"
    plan.write_text("\n".join(lines) + "\n", encoding="utf-8")
    assert [c.verdict for c in inspect_plan(plan).characteristics] == ["FAIL", "FAIL"]
    plan.write_text("\n".join(lines).replace('frame = "position dia 0.1 | A | B"',
                                             'frame = "position dia 0.1 | A | B"\nseparate = true') + "\n")
    assert [c.verdict for c in inspect_plan(plan).characteristics] == ["PASS", "PASS"]


def test_shaft_with_a_shoulder_face_as_secondary_datum(tmp_path):
    # A: a shaft along z (MCC); B: its shoulder face, normal fixed to A's axis; the DRF leaves rz free
    from pcmm_geo.gdt import inspect_plan

    rng = np.random.default_rng(5)
    theta, z = rng.uniform(0, 2 * np.pi, 300), rng.uniform(5, 40, 300)
    tilt = 3e-4  # the shoulder face leans by 0.3 mrad: its datum plane is still normal to A's axis
    shaft = np.c_[8 * np.cos(theta), 8 * np.sin(theta), z]
    rr, phi = rng.uniform(9, 20, 300), rng.uniform(0, 2 * np.pi, 300)
    face = np.c_[rr * np.cos(phi), rr * np.sin(phi), 5.0 - tilt * rr * np.cos(phi) - 0.001]
    np.savetxt(tmp_path / "A.csv", shaft, delimiter=",", fmt="%.12f")
    np.savetxt(tmp_path / "B.csv", face, delimiter=",", fmt="%.12f")
    plan = tmp_path / "plan.toml"
    plan.write_text('[features.A]\nelement = "cylinder"\npoints = "A.csv"\npoint = [0, 0, 0]\naxis = [0, 0, 1]\n'
                    'diameter = 16\n[features.B]\nelement = "plane"\npoints = "B.csv"\nnormal = [0, 0, 1]\n'
                    'point = [0, 0, 5]\n[datums]\nA = "A"\nB = "B"\n[[characteristics]]\nname = "t"\n'
                    'feature = "B"\nframe = "⌰ 0.02 | A"\n[part]\nframe = "A|B"\n', encoding="utf-8")
    result = inspect_plan(plan)
    b = result.datums["B"]
    assert "perpendicular to the axis A" in b.constrained_by
    assert np.allclose(np.abs(b.direction), [0, 0, 1], atol=1e-12)
    drf = result.frames["A|B"]
    assert drf.free == ("rz",)
    # the material is below the face (outward normal +z): the datum plane touches its highest point, and the
    # nominal B point (0, 0, 5) lands there on A's axis
    assert abs(drf.origin[2] - (face[:, 2].max() - 5.0)) < 1e-9 and np.hypot(*drf.origin[:2]) < 1e-9
