"""Characteristics on constructed parts with exact answers, after random rigid motions.

The construction (``pcmm_geo/data/examples/gdt/make_gdt_example.py``) fixes the datum planes exactly
(known contact sets), the holes as exact cylinders with known offsets, tilts and diameters and the top
face as an exact tilted plane, so position (RFS and MMC with its bonus), perpendicularity and
parallelism have closed forms.
"""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.gdt import (
    FeatureData,
    associate_datum,
    build_drf,
    evaluate_orientation,
    evaluate_position,
    evaluate_runout,
)
from pcmm_geo.gdt.reference.drf import nominal_of


def _frames(part):
    a = associate_datum(part.measured("A"), "plane", label="A", nominal_direction=[0, 0, 1])
    b = associate_datum(part.measured("B"), "plane", label="B", nominal_direction=[1, 0, 0],
                        perpendicular_to=(a.direction,))
    c = associate_datum(part.measured("C"), "plane", label="C", nominal_direction=[0, 1, 0],
                        perpendicular_to=(a.direction, b.direction))
    na, nb, nc = nominal_of([0, 0, 0], [0, 0, 1]), nominal_of([0, 0, 0], [1, 0, 0]), nominal_of([0, 0, 0], [0, 1, 0])
    return build_drf([(a, na), (b, nb), (c, nc)]), build_drf([(a, na)]), build_drf([(a, na), (b, nb)])


def _hole(part, hole, tol=(0.0, 0.1)):
    return FeatureData(hole.name, "cylinder", part.measured(hole.name), np.array([*hole.centre, 0.0]),
                       np.array([0.0, 0.0, 1.0]), "internal", hole.diameter, tol)


@pytest.mark.parametrize("seed", range(8))
def test_position_rfs_is_exact_after_a_rigid_motion(maker, seed):
    part = maker.make_part(seed, n_points=200, n_holes=6, pose_deg=3.0, pose_mm=2.5)
    abc, _, _ = _frames(part)
    for hole in part.holes:
        rfs = evaluate_position(_hole(part, hole), abc, 0.1)
        assert abs(rfs.value_mm - hole.position_rfs()) < 1e-9
        assert rfs.bonus_mm is None
        assert rfs.verdict == ("PASS" if hole.position_rfs() <= 0.1 else "FAIL")
    assert [evaluate_position(_hole(part, h), abc, 0.1).verdict for h in part.holes[:3]] == ["PASS", "FAIL", "FAIL"]


@pytest.mark.parametrize("seed", range(3))
def test_position_mmc_bonus_is_exact_and_decides_the_verdict(maker, seed):
    part = maker.make_part(seed, n_points=80, n_holes=3, pose_deg=3.0, pose_mm=2.5)
    abc, _, _ = _frames(part)
    # H2 conforms only with its bonus, H3 fails even with it (one hole per seed keeps the test fast)
    hole = part.holes[1 + seed % 2]
    mmc = evaluate_position(_hole(part, hole), abc, 0.1, modifier="MMC")
    assert abs(mmc.value_mm - hole.position_rfs()) < 1e-9
    assert abs(mmc.bonus_mm - (hole.actual_diameter - 10.0)) < 1e-9
    assert mmc.verdict == ("PASS" if hole.name == "H2" else "FAIL")


@pytest.mark.parametrize("seed", range(6))
def test_perpendicularity_and_parallelism_are_exact(maker, seed):
    part = maker.make_part(seed, n_points=240, n_holes=2)
    abc, a_only, _ = _frames(part)
    for hole in part.holes:
        for drf in (abc, a_only):
            r = evaluate_orientation(_hole(part, hole), drf, 0.011, characteristic="perpendicularity", zone="dia")
            assert abs(r.value_mm - hole.perpendicularity()) < 1e-9
            assert r.verdict == ("PASS" if hole.perpendicularity() < 0.011 else "FAIL")
    top = FeatureData("TOP", "plane", part.measured("TOP"), np.array([0, 0, 30.0]), np.array([0, 0, 1.0]))
    exact = part.top_slope * part.top_extent
    for drf in (abc, a_only):
        r = evaluate_orientation(top, drf, 0.02, characteristic="parallelism")
        assert abs(r.value_mm - exact) < 1e-9 and r.verdict == "FAIL"
    assert evaluate_orientation(top, a_only, 0.022, characteristic="parallelism").verdict == "PASS"


def test_perpendicular_face_with_a_free_rotation_turns_the_zone_to_its_narrowest(maker):
    # a side face tilted by beta about y: with A only the zone turns about z and the width is S sin(beta)
    part = maker.make_part(5, n_points=100, n_holes=0)
    rng = np.random.default_rng(5)
    beta = 3e-4
    y = rng.uniform(0, 90, 300)
    s = rng.uniform(0, 30, 300)
    s[:2] = [0.0, 30.0]
    face = np.c_[120.0 - s * np.sin(beta), y, s * np.cos(beta)] + np.array([0.0, 0.0, 0.0])
    rot_y = np.array([[0.0, 0.0, 0.0]])
    del rot_y
    measured = face @ part.rotation.T + part.translation
    feature = FeatureData("R", "plane", measured, np.array([120.0, 0, 0]), np.array([1.0, 0, 0]))
    _, a_only, ab = _frames(part)
    exact = 30.0 * np.sin(beta)
    free = evaluate_orientation(feature, a_only, exact * 1.001, characteristic="perpendicularity")
    assert abs(free.value_mm - exact) < 1e-7 and free.bound_mm <= free.value_mm
    assert free.value_mm - free.bound_mm < 1e-6
    assert free.verdict == "PASS"
    assert evaluate_orientation(feature, a_only, exact * 0.99, characteristic="perpendicularity").verdict == "FAIL"
    fixed = evaluate_orientation(feature, ab, 0.1, characteristic="perpendicularity")
    assert abs(fixed.value_mm - np.ptp(face[:, 0])) < 1e-9


def test_size_outside_its_limits_is_fail_never_a_negative_bonus(maker):
    part = maker.make_part(2, n_points=80, n_holes=1)
    abc, _, _ = _frames(part)
    hole = part.holes[0]  # actual diameter 10.03
    small = _hole(part, hole, tol=(0.05, 0.1))  # MMC size 10.05 > 10.03: the hole is undersize
    r = evaluate_position(small, abc, 0.5, modifier="MMC")
    assert r.verdict == "FAIL" and r.bonus_mm == 0.0 and r.details["reason"] == "size outside its limits"
    lmc = evaluate_position(_hole(part, hole), abc, 0.1, modifier="LMC")
    assert abs(lmc.bonus_mm - (10.1 - hole.actual_diameter)) < 1e-9


def test_position_floats_in_the_free_translations(maker):
    part = maker.make_part(4, n_points=200, n_holes=1)
    _, a_only, ab = _frames(part)
    hole = part.holes[0]
    d = hole.end_deviations()
    # A only: x and y float, the zone keeps only the axis's tilt
    r = evaluate_position(_hole(part, hole), a_only, 0.1)
    assert abs(r.value_mm - np.linalg.norm(d[1] - d[0])) < 1e-7
    # A|B: y floats; the 1-D minimax over the y shift
    shifts = np.linspace(-0.1, 0.1, 200001)
    brute = 2 * min(max(np.hypot(d[0, 0], d[0, 1] - s), np.hypot(d[1, 0], d[1, 1] - s)) for s in shifts[::50])
    r2 = evaluate_position(_hole(part, hole), ab, 0.1)
    assert r2.value_mm <= brute + 1e-9 and brute - r2.value_mm < 2e-5


def test_runout_about_a_datum_axis_and_refusal_without_one(maker):
    rng = np.random.default_rng(9)
    from pcmm_geo.gdt import DatumReferenceFrame

    n = 400
    theta = rng.uniform(0, 2 * np.pi, n)
    z = np.round(rng.uniform(0, 20, n), 0)
    e = 0.003  # the shaft is off the datum axis by e: radial runout 2 e, every section
    shaft = np.c_[e + 8 * np.cos(theta), 8 * np.sin(theta), z]
    drf = DatumReferenceFrame(np.eye(3), np.zeros(3), free=("tz", "rz"), datums=("D",))
    f = FeatureData("S", "cylinder", shaft, np.zeros(3), np.array([0, 0, 1.0]), diameter=16.0)
    total = evaluate_runout(f, drf, 0.01, total=True)
    exact = np.ptp(np.hypot(shaft[:, 0], shaft[:, 1]))
    assert abs(total.value_mm - exact) < 1e-12 and abs(exact - 2 * e) < 1e-4
    circular = evaluate_runout(f, drf, 0.01, total=False)
    assert circular.value_mm <= total.value_mm + 1e-15
    with pytest.raises(InvalidInputError, match="datum axis"):
        evaluate_runout(f, DatumReferenceFrame.measurement(), 0.01, total=True)


def test_free_rotation_turns_about_the_datum_axis_not_the_origin(maker):
    # A | B with B a hole: rotation about B's axis floats; H1's zone turns about it
    part = maker.make_part(6, n_points=150, n_holes=3)
    h1, h3 = part.holes[0], part.holes[2]
    a = associate_datum(part.measured("A"), "plane", label="A", nominal_direction=[0, 0, 1])
    b = associate_datum(part.measured("H3"), "cylinder", label="B", side="internal", nominal_direction=[0, 0, 1],
                        parallel_to=a.direction)
    drf = build_drf([(a, nominal_of([0, 0, 0], [0, 0, 1])), (b, nominal_of([*h3.centre, 0], [0, 0, 1]))])
    assert drf.free == ("rz",) and np.allclose(drf.pivot, [*h3.centre, 0])
    r = evaluate_position(_hole(part, h1), drf, 0.1)
    # exact: B's measured axis is at its constructed offset; turn H1's true position about it
    pivot = np.array(h3.centre) + np.array(h3.offset)  # B's actual axis (H3 is not tilted)
    ends = np.array(h1.centre) + h1.end_deviations()
    q = np.array(h1.centre) - np.array(h3.centre)

    def value(theta):
        c, s = np.cos(theta), np.sin(theta)
        true = pivot + np.array([c * q[0] - s * q[1], s * q[0] + c * q[1]])
        return 2 * np.linalg.norm(ends - true, axis=1).max()

    thetas = np.linspace(-2e-3, 2e-3, 40001)
    exact = min(value(t) for t in thetas)
    assert abs(r.value_mm - exact) < 2e-5  # first order in the rotation: error ~ shift^2 / |q|
    assert abs(r.value_mm - value(0.0)) > 1e-3  # the rotation did float


def test_coaxiality_in_an_iso_plan_and_refused_under_asme(maker, tmp_path):
    from pcmm_geo.errors import FileFormatError
    from pcmm_geo.gdt import inspect_plan

    rng = np.random.default_rng(4)
    n = 300
    theta, z = rng.uniform(0, 2 * np.pi, n), rng.uniform(0, 40, n)
    shaft = np.c_[6 * np.cos(theta), 6 * np.sin(theta), z]  # datum D: axis z through the origin
    theta2, z2 = rng.uniform(0, 2 * np.pi, n), rng.uniform(50, 80, n)
    step = np.c_[0.004 + 9 * np.cos(theta2), -0.003 + 9 * np.sin(theta2), z2]  # off by (4, -3) um
    np.savetxt(tmp_path / "D.csv", shaft, fmt="%.12f", delimiter=",")
    np.savetxt(tmp_path / "E.csv", step, fmt="%.12f", delimiter=",")
    plan = tmp_path / "plan.toml"
    text = ('units = "mm"\n[features.D]\nelement = "cylinder"\npoints = "D.csv"\nside = "external"\n'
            'point = [0, 0, 0]\naxis = [0, 0, 1]\ndiameter = 12\n'
            '[features.E]\nelement = "cylinder"\npoints = "E.csv"\nside = "external"\npoint = [0, 0, 50]\n'
            'axis = [0, 0, 1]\ndiameter = 18\n[datums]\nD = "D"\n'
            '[[characteristics]]\nname = "coax E"\nfeature = "E"\nframe = "◎ ⌀0.012 | D"\n'
            '[[characteristics]]\nname = "runout E"\nfeature = "E"\nframe = "⌰ 0.02 | D"\n')
    plan.write_text(text, encoding="utf-8")
    coax, runout = inspect_plan(plan).characteristics
    assert coax.characteristic == "coaxiality" and abs(coax.value_mm - 0.010) < 1e-8 and coax.verdict == "PASS"
    assert abs(runout.value_mm - np.ptp(np.hypot(step[:, 0], step[:, 1]))) < 1e-8
    plan.write_text('standard = "ASME"\n' + text, encoding="utf-8")
    with pytest.raises(FileFormatError, match=r"removed in ASME Y14\.5-2018"):
        inspect_plan(plan)


def test_axial_runout_of_a_face_total_and_per_radius_band():
    from pcmm_geo.gdt import DatumReferenceFrame

    rng = np.random.default_rng(3)
    radii = np.repeat([10.0, 20.0, 30.0], 60)
    theta = rng.uniform(0, 2 * np.pi, len(radii))
    wobble = 0.002 * np.cos(theta) * radii / 30.0  # a face tilted by 2 um over 30 mm: the band at r spreads 4 r/30 um
    face = np.c_[radii * np.cos(theta), radii * np.sin(theta), 5.0 + wobble]
    drf = DatumReferenceFrame(np.eye(3), np.zeros(3), free=("tz", "rz"), datums=("D",))
    f = FeatureData("F", "plane", face, np.array([0, 0, 5.0]), np.array([0, 0, 1.0]))
    total = evaluate_runout(f, drf, 0.01, total=True)
    circular = evaluate_runout(f, drf, 0.01, total=False)
    assert abs(total.value_mm - np.ptp(face[:, 2])) < 1e-12
    band = face[radii == 30.0, 2]
    assert abs(circular.value_mm - np.ptp(band)) < 1e-12 and circular.value_mm < 0.004 + 1e-12
