"""Symmetry (derived median surface) and profile of a line (sections): exact constructed parts."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.gdt import DatumReferenceFrame, FeatureData, associate_datum, build_drf
from pcmm_geo.gdt.derived import evaluate_line_profile, evaluate_symmetry
from pcmm_geo.gdt.reference.drf import nominal_of


def _frame(maker, seed, n=3):
    part = maker.make_part(seed, n_points=100, n_holes=0)
    a = associate_datum(part.measured("A"), "plane", label="A", nominal_direction=[0, 0, 1])
    b = associate_datum(part.measured("B"), "plane", label="B", nominal_direction=[1, 0, 0],
                        perpendicular_to=(a.direction,))
    c = associate_datum(part.measured("C"), "plane", label="C", nominal_direction=[0, 1, 0],
                        perpendicular_to=(a.direction, b.direction))
    pairs = [(a, nominal_of([0, 0, 0], [0, 0, 1])), (b, nominal_of([0, 0, 0], [1, 0, 0])),
             (c, nominal_of([0, 0, 0], [0, 1, 0]))]
    return part, build_drf(pairs[:n])


def _tab(part, rng, centre, width, e1, e2, slope, half=10.0, y0=40.0):
    """Faces x = centre + w/2 + e1 and x = centre - w/2 + e2 + slope (y - y0), y in y0 +- half, z in 5..25."""
    def face(x_of_y):
        y = np.r_[y0 - half, y0 + half, rng.uniform(y0 - half, y0 + half, 60)]
        z = rng.uniform(5, 25, len(y))
        return np.c_[x_of_y(y - y0), y, z] @ part.rotation.T + part.translation

    f1 = face(lambda dy: np.full_like(dy, centre + width / 2 + e1))
    f2 = face(lambda dy: centre - width / 2 + e2 + slope * dy)
    return (FeatureData("S1", "plane", f1, np.array([centre + width / 2, y0, 15.0]), np.array([1.0, 0, 0])),
            FeatureData("S2", "plane", f2, np.array([centre - width / 2, y0, 15.0]), np.array([-1.0, 0, 0])))


@pytest.mark.parametrize("seed", range(3))
def test_symmetry_of_offset_faces_is_twice_the_median_offset(maker, seed):
    part, abc = _frame(maker, seed)
    rng = np.random.default_rng(seed)
    e1, e2 = rng.uniform(-0.03, 0.03, 2)
    f1, f2 = _tab(part, rng, 60.0, 20.0, e1, e2, 0.0)
    r = evaluate_symmetry(f1, f2, abc, 0.05)
    assert abs(r.value_mm - abs(e1 + e2)) < 1e-9
    assert r.verdict == ("PASS" if abs(e1 + e2) < 0.05 else "FAIL")
    assert evaluate_symmetry(f1, f2, abc, abs(e1 + e2) * 0.9).verdict == "FAIL"


@pytest.mark.parametrize("seed", range(3))
def test_symmetry_of_a_tilted_face_follows_the_paired_median_points(maker, seed):
    # face 2 tilted by slope b: face 1's median points deviate (w b^2 + b y)/(2(1 + b^2)), face 2's by b y / 2
    part, abc = _frame(maker, seed)
    rng = np.random.default_rng(seed + 10)
    w, b, half = 20.0, 0.002 * (1 + seed), 10.0
    f1, f2 = _tab(part, rng, 60.0, w, 0.0, 0.0, b, half=half)
    expected = 2 * max((w * b * b + b * half) / (2 * (1 + b * b)), b * half / 2)
    r = evaluate_symmetry(f1, f2, abc, 0.1)
    assert abs(r.value_mm - expected) < 1e-9


def test_symmetry_needs_a_drf_that_locates_the_median_plane_and_opposite_faces(maker):
    part, a_only = _frame(maker, 0, n=1)
    rng = np.random.default_rng(0)
    f1, f2 = _tab(part, rng, 60.0, 20.0, 0.0, 0.0, 0.0)
    with pytest.raises(InvalidInputError, match="locates the median plane"):
        evaluate_symmetry(f1, f2, a_only, 0.1)
    with pytest.raises(InvalidInputError, match="opposite"):
        evaluate_symmetry(f1, f1, a_only, 0.1)


def _ellipse(n, a=30.0, b=15.0):
    t = 2 * np.pi * np.arange(n) / n
    pts = np.c_[60 + a * np.cos(t), 40 + b * np.sin(t)]
    normals = np.c_[b * np.cos(t), a * np.sin(t)]
    return pts, normals / np.linalg.norm(normals, axis=1)[:, None]


def _sections(curve, normals, heights):
    q = np.vstack([np.c_[curve, np.full(len(curve), h)] for h in heights])
    n = np.vstack([np.c_[normals, np.zeros(len(curve))] for _ in heights])
    return q, n


@pytest.mark.parametrize("seed", range(3))
def test_line_profile_with_datums_is_the_largest_section_deviation(maker, seed):
    part, abc = _frame(maker, seed)
    rng = np.random.default_rng(seed)
    curve, normals = _ellipse(360)
    heights = [5.0, 15.0, 25.0]
    q, n = _sections(curve, normals, heights)
    measured, expected = [], 0.0
    for h in heights:
        pick = np.arange(0, 360, 3)
        delta = rng.uniform(-0.01, 0.01, len(pick))
        shift = rng.uniform(-0.01, 0.01, 2)
        xy = curve[pick] + delta[:, None] * normals[pick] + shift
        measured.append(np.c_[xy, np.full(len(pick), h)])
        expected = max(expected, 2 * float(np.abs(delta + normals[pick] @ shift).max()))
    pts = np.vstack(measured) @ part.rotation.T + part.translation
    r = evaluate_line_profile(pts, abc, 0.05, q, n, section_normal=[0, 0, 1])
    assert abs(r.value_mm - expected) < 1e-9 and r.details["scope"] == "global" and r.verdict == "PASS"
    assert len(r.details["sections"]) == 3
    assert evaluate_line_profile(pts, abc, expected * 0.9, q, n, section_normal=[0, 0, 1]).verdict == "FAIL"


@pytest.mark.parametrize("seed", range(2))
def test_line_profile_without_datums_floats_each_section_in_its_plane(seed):
    # each section turned and shifted in its plane, deviations alternating +-delta: the fit undoes the motion
    rng = np.random.default_rng(seed)
    curve, normals = _ellipse(360)
    q, n = _sections(curve, normals, [5.0, 15.0])
    delta = 0.004
    measured = []
    for h in (5.0, 15.0):
        pick = np.arange(0, 360, 2)
        d = delta * (-1.0) ** np.arange(len(pick))
        xy = curve[pick] + d[:, None] * normals[pick]
        phi, shift = rng.uniform(-1e-3, 1e-3), rng.uniform(-0.05, 0.05, 2)
        c, s = np.cos(phi), np.sin(phi)
        xy = xy @ np.array([[c, -s], [s, c]]).T + shift
        measured.append(np.c_[xy, np.full(len(pick), h)])
    r = evaluate_line_profile(np.vstack(measured), DatumReferenceFrame.measurement(), 0.01, q, n,
                              section_normal=[0, 0, 1])
    assert abs(r.value_mm - 2 * delta) < 1e-9 and r.details["scope"] == "local"
    assert r.verdict == "PASS"
    # below the zone found: never FAIL without datums (a local fit)
    assert evaluate_line_profile(np.vstack(measured), DatumReferenceFrame.measurement(), 0.006, q, n,
                                 section_normal=[0, 0, 1]).verdict == "NOT PROVEN"


def test_line_profile_refuses_a_section_of_too_few_points_and_normals_along_the_section_normal():
    curve, normals = _ellipse(36)
    q, n = _sections(curve, normals, [5.0])
    pts = np.r_[np.c_[curve[:5], np.full(5, 5.0)], np.c_[curve[5:7], np.full(2, 6.0)]]
    with pytest.raises(InvalidInputError, match=r"section at 6\.000"):
        evaluate_line_profile(pts, DatumReferenceFrame.measurement(), 0.1, q, n, section_normal=[0, 0, 1])
    with pytest.raises(InvalidInputError, match="component in the section plane"):  # a normal along the section's
        evaluate_line_profile(pts, DatumReferenceFrame.measurement(), 0.1, q, n, section_normal=n[0])


@pytest.mark.parametrize("seed", range(2))
def test_line_profile_between_nominal_sections_intersects_the_nominal_surface(maker, seed):
    # an extruded nominal given at heights 0 and 30 only; sections at 10 and 20: the tangent planes' traces are
    # the nominal curve exactly
    part, abc = _frame(maker, seed)
    rng = np.random.default_rng(seed)
    curve, normals = _ellipse(360)
    q, n = _sections(curve, normals, [0.0, 30.0])
    pick = np.arange(0, 360, 3)
    delta = rng.uniform(-0.01, 0.01, (2, len(pick)))
    pts = np.vstack([np.c_[curve[pick] + delta[k][:, None] * normals[pick], np.full(len(pick), h)]
                     for k, h in enumerate((10.0, 20.0))])
    r = evaluate_line_profile(pts @ part.rotation.T + part.translation, abc, 0.05, q, n, section_normal=[0, 0, 1])
    assert abs(r.value_mm - 2 * np.abs(delta).max()) < 1e-9
    assert [sec["nominal"] for sec in r.details["sections"]] == ["surface intersected"] * 2
@pytest.mark.parametrize("seed", range(2))
def test_line_profile_floats_in_the_in_plane_translation_its_datums_leave_free(maker, seed):
    # A|B leaves y free: a y shift of the sections floats out (deviations alternating +-delta: exactly 2 delta);
    # A|B|C fixes it: 2 max |delta_i + e n_iy|
    part, ab = _frame(maker, seed, n=2)
    _, abc = _frame(maker, seed, n=3)
    rng = np.random.default_rng(seed + 20)
    curve, normals = _ellipse(360)
    q, n = _sections(curve, normals, [10.0, 20.0])
    delta, shift = 0.003, rng.uniform(0.01, 0.03)
    pick = np.arange(0, 360, 2)
    d = delta * (-1.0) ** np.arange(len(pick))
    xy = curve[pick] + d[:, None] * normals[pick] + [0.0, shift]
    pts = np.vstack([np.c_[xy, np.full(len(pick), h)] for h in (10.0, 20.0)]) @ part.rotation.T + part.translation
    floating = evaluate_line_profile(pts, ab, 0.01, q, n, section_normal=[0, 0, 1])
    assert abs(floating.value_mm - 2 * delta) < 1e-9 and floating.details["scope"] == "global"
    assert floating.details["floating"] == ["ty"]
    fixed = evaluate_line_profile(pts, abc, 0.01, q, n, section_normal=[0, 0, 1])
    assert abs(fixed.value_mm - 2 * float(np.abs(d + shift * normals[pick, 1]).max())) < 1e-9


def test_line_profile_of_a_cone_between_its_nominal_sections_is_exact():
    # a cone r(z) = 30 + 0.2 z given at z = 0 and 30: its tangent planes contain the generators, so their traces
    # at z = 10 are the section circle's tangents and d = (p - q) . n / |n_xy| is the radial deviation exactly
    t = 2 * np.pi * np.arange(360) / 360
    u = np.c_[np.cos(t), np.sin(t)]
    q = np.vstack([np.c_[(30 + 0.2 * h) * u, np.full(360, h)] for h in (0.0, 30.0)])
    n = np.vstack([np.c_[u, np.full(360, -0.2)]] * 2)
    delta = np.random.default_rng(1).uniform(-0.01, 0.01, 120)
    pts = np.c_[(32.0 + delta)[:, None] * u[::3], np.full(120, 10.0)]
    r = evaluate_line_profile(pts, DatumReferenceFrame(np.eye(3), np.zeros(3), free=()), 0.05, q, n,
                              section_normal=[0, 0, 1])
    assert abs(r.value_mm - 2 * np.abs(delta).max()) < 1e-9
