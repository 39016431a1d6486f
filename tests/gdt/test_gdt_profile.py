"""Profile of a surface on a constructed cylindrical patch: known normal deviations, a rigid motion,
datums fixing it (exact), a floating translation (checked against a brute-force scan) and no datums
(the local six-degree-of-freedom fit: PASS or NOT PROVEN, never FAIL)."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.gdt import DatumReferenceFrame, associate_datum, build_drf, evaluate_profile
from pcmm_geo.gdt.reference.drf import nominal_of


def _patch(rng, n_nominal=4000, n_measured=600):
    """A cylindrical patch (axis along x, radius 40 about the line y = 45, z = 30): nominal samples with normals,
    the measured points = a subset moved by known deviations along their normals."""
    x = rng.uniform(10, 110, n_nominal)
    phi = rng.uniform(-0.6, 0.6, n_nominal)
    normals = np.c_[np.zeros(n_nominal), np.sin(phi), np.cos(phi)]
    nominal = np.c_[x, np.full(n_nominal, 45.0), np.full(n_nominal, 30.0)] + 40.0 * normals
    pick = rng.choice(n_nominal, n_measured, replace=False)
    dev = rng.uniform(-0.012, 0.008, n_measured)
    dev[:2] = [-0.012, 0.008]
    return nominal, normals, nominal[pick] + dev[:, None] * normals[pick], dev, pick


def _abc(part):
    a = associate_datum(part.measured("A"), "plane", label="A", nominal_direction=[0, 0, 1])
    b = associate_datum(part.measured("B"), "plane", label="B", nominal_direction=[1, 0, 0],
                        perpendicular_to=(a.direction,))
    c = associate_datum(part.measured("C"), "plane", label="C", nominal_direction=[0, 1, 0],
                        perpendicular_to=(a.direction, b.direction))
    pairs = [(a, nominal_of([0, 0, 0], [0, 0, 1])), (b, nominal_of([0, 0, 0], [1, 0, 0])),
             (c, nominal_of([0, 0, 0], [0, 1, 0]))]
    return build_drf(pairs), build_drf(pairs[:2])


@pytest.mark.parametrize("seed", range(4))
def test_profile_with_a_complete_drf_is_twice_the_largest_deviation(maker, seed):
    rng = np.random.default_rng(seed)
    part = maker.make_part(seed, n_points=120, n_holes=0)
    nominal, normals, measured, _, _ = _patch(rng)
    abc, _ = _abc(part)
    r = evaluate_profile(measured @ part.rotation.T + part.translation, abc, 0.025, nominal, normals)
    assert abs(r.value_mm - 2 * 0.012) < 1e-9 and r.details["scope"] == "global"
    assert r.verdict == "PASS"
    assert evaluate_profile(measured @ part.rotation.T + part.translation, abc, 0.02, nominal, normals).verdict == \
        "FAIL"


def test_profile_floats_in_the_translation_the_drf_leaves_free(maker):
    rng = np.random.default_rng(7)
    part = maker.make_part(7, n_points=120, n_holes=0)
    nominal, normals, measured, dev, pick = _patch(rng)
    measured = measured + np.array([0.0, 0.004, 0.0])  # a shift along y, which A|B leaves free
    _, ab = _abc(part)
    r = evaluate_profile(measured @ part.rotation.T + part.translation, ab, 0.05, nominal, normals)
    # brute force over the y shift with the constructed correspondences
    ny = normals[pick, 1]
    base = dev + 0.004 * ny
    shifts = np.linspace(-0.01, 0.01, 40001)
    brute = min(2 * np.abs(base - s * ny).max() for s in shifts)
    assert r.details["scope"] == "global" and r.details["floating"] == ["ty"]
    assert r.value_mm <= brute + 1e-9 and brute - r.value_mm < 2e-6


def test_profile_without_datums_is_a_local_fit_pass_or_not_proven(maker):
    rng = np.random.default_rng(8)
    nominal, normals, measured, _, _ = _patch(rng)
    angle = 2e-4
    rot = np.array([[1, 0, 0], [0, np.cos(angle), -np.sin(angle)], [0, np.sin(angle), np.cos(angle)]])
    moved = measured @ rot.T + np.array([0.003, -0.002, 0.001])
    free = DatumReferenceFrame.measurement()
    r = evaluate_profile(moved, free, 0.025, nominal, normals)
    assert r.details["scope"] == "local" and r.value_mm <= 2 * 0.012 + 1e-6
    assert r.verdict == "PASS"
    tight = evaluate_profile(moved, free, 0.5 * r.value_mm, nominal, normals)
    assert tight.verdict == "NOT PROVEN" and np.isnan(tight.bound_mm)
