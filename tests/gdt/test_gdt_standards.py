"""ASME associations and angularity: the constrained least-squares datum's KKT conditions checked
independently, and angularity of a face at a nominal angle on a constructed part."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import nnls

from pcmm_geo.gdt import FeatureData, associate_datum, build_drf, evaluate_orientation
from pcmm_geo.gdt.reference.drf import nominal_of


def check_constrained_lsq(points, point, normal, tol=1e-9):
    """KKT of min sum d^2 subject to d >= 0 (d = n.(p - point), |n| = 1), checked from scratch."""
    n = np.asarray(normal, float)
    d = (points - point) @ n
    if d.min() < -tol:
        return False
    active = np.flatnonzero(d <= tol)
    if len(active) == 0:
        return False
    u, _, _ = np.linalg.svd(np.eye(3) - np.outer(n, n))
    tangents = u[:, :2].T
    centre = points.mean(axis=0)
    rel = points - centre
    scale = np.abs(rel).max()
    # gradient of sum d^2 / 2 in the offset and the two turns = sum of nu_i times those of the active d_i
    grad = np.r_[d.sum(), (tangents @ (rel.T @ d)) / scale]
    cols = np.vstack([np.ones(len(active)), (tangents @ rel[active].T) / scale])
    _, residual = nnls(cols, grad)
    return bool(residual <= 1e-6 * max(1.0, np.linalg.norm(grad)))


@pytest.mark.parametrize("seed", range(5))
def test_asme_constrained_least_squares_datum_satisfies_its_kkt_conditions(maker, seed):
    part = maker.make_part(seed, n_points=300, n_holes=0)
    pts = part.measured("A")
    a = associate_datum(pts, "plane", label="A", nominal_direction=[0, 0, 1], criterion="constrained-lsq")
    assert a.criterion == "constrained-lsq" and a.certificate.scope == "local"
    assert check_constrained_lsq(pts, a.point, a.direction)
    assert a.certificate.kkt_residual < 1e-6
    # hand-made wrong answers: the least-squares plane moved out to touch, and the ISO minimax plane
    from pcmm_geo.fit import fit_plane

    ls = fit_plane(pts)
    n = ls.normal if ls.normal @ a.direction > 0 else -ls.normal
    touching = pts[np.argmin(pts @ n)]
    assert not check_constrained_lsq(pts, touching, n)
    # the construction's three contacts surround the d-weighted centroid of the other points, so the
    # constrained least-squares plane is the construction's plane z = 0, as the minimax one is
    assert np.allclose(a.direction, part.rotation[:, 2], atol=1e-9)
    assert abs((a.point - part.translation) @ part.rotation[:, 2]) < 1e-9
    assert check_constrained_lsq(pts, part.translation, part.rotation[:, 2])
    assert not check_constrained_lsq(pts, part.translation - 1e-6 * part.rotation[:, 2], part.rotation[:, 2])


def test_asme_datum_differs_from_iso_when_the_points_lean_away_from_the_contacts():
    # two ridges: the minimax plane rests on the high-side contacts, least squares leans into the bulk
    rng = np.random.default_rng(3)
    xy = rng.uniform(0, 100, (400, 2))
    z = 0.01 * (xy[:, 0] / 100) ** 2 + rng.uniform(0, 0.002, 400)
    pts = np.c_[xy, z]
    iso = associate_datum(pts, "plane", nominal_direction=[0, 0, 1])
    asme = associate_datum(pts, "plane", nominal_direction=[0, 0, 1], criterion="constrained-lsq")
    assert check_constrained_lsq(pts, asme.point, asme.direction)
    assert not check_constrained_lsq(pts, iso.point, iso.direction)
    assert np.degrees(np.arccos(iso.direction @ asme.direction)) > 1e-4


@pytest.mark.parametrize("seed", range(4))
def test_angularity_of_a_face_at_thirty_degrees(maker, seed):
    part = maker.make_part(seed, n_points=150, n_holes=0)
    rng = np.random.default_rng(seed)
    nominal = np.array([np.sin(np.radians(30)), 0.0, np.cos(np.radians(30))])  # outward normal, DRF
    delta = 2e-4 * (1 + seed)  # the face is turned by delta about y
    c, s = np.cos(delta), np.sin(delta)
    actual = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]) @ nominal
    along = np.cross([0.0, 1.0, 0.0], actual)
    uv = rng.uniform(0, 40, (300, 2))
    face = np.array([100.0, 0, 20]) + np.outer(uv[:, 0], [0, 1.0, 0]) + np.outer(uv[:, 1], along)
    exact = np.ptp(face @ nominal)  # the zone along the nominal normal in the DRF
    measured = face @ part.rotation.T + part.translation
    a = associate_datum(part.measured("A"), "plane", label="A", nominal_direction=[0, 0, 1])
    b = associate_datum(part.measured("B"), "plane", label="B", nominal_direction=[1, 0, 0],
                        perpendicular_to=(a.direction,))
    drf = build_drf([(a, nominal_of([0, 0, 0], [0, 0, 1])), (b, nominal_of([0, 0, 0], [1, 0, 0]))])
    feature = FeatureData("S", "plane", measured, np.array([100.0, 0, 20]), nominal)
    r = evaluate_orientation(feature, drf, 0.05, characteristic="angularity")
    assert abs(r.value_mm - exact) < 1e-9
    assert abs(exact - 40 * np.sin(delta) * np.ptp(uv[:, 1]) / 40) < 1e-9
    assert r.verdict == ("PASS" if exact <= 0.05 else "FAIL")


def test_asme_toleranced_axis_is_the_mating_envelopes_iso_the_least_squares(maker):
    # a hole with a patch of points pushed outward (material removed there): the MIC, the hole's unrelated
    # actual mating envelope, still rests on the exact cylinder; the least-squares axis leans toward the patch
    from pcmm_geo.gdt import evaluate_position

    part = maker.make_part(2, n_points=150, n_holes=1)
    hole = part.holes[0]
    pts = part.points["H1"].copy()
    base = np.array([hole.centre[0] + hole.offset[0], hole.centre[1] + hole.offset[1], 0.0])
    rel = pts - base
    radial = rel - np.outer(rel @ hole.axis(), hole.axis())
    patch = np.flatnonzero(radial[:, 0] > 0.8 * np.linalg.norm(radial, axis=1))
    pts[patch] += 0.05 * radial[patch] / np.linalg.norm(radial[patch], axis=1)[:, None]
    measured = pts @ part.rotation.T + part.translation
    a = associate_datum(part.measured("A"), "plane", label="A", nominal_direction=[0, 0, 1])
    b = associate_datum(part.measured("B"), "plane", label="B", nominal_direction=[1, 0, 0],
                        perpendicular_to=(a.direction,))
    c = associate_datum(part.measured("C"), "plane", label="C", nominal_direction=[0, 1, 0],
                        perpendicular_to=(a.direction, b.direction))
    pairs = [(a, nominal_of([0, 0, 0], [0, 0, 1])), (b, nominal_of([0, 0, 0], [1, 0, 0])),
             (c, nominal_of([0, 0, 0], [0, 1, 0]))]
    feature = FeatureData("H1", "cylinder", measured, np.array([*hole.centre, 0.0]), np.array([0, 0, 1.0]),
                          "internal", 10.0, (0.0, 0.1))
    asme = evaluate_position(feature, build_drf(pairs, standard="ASME"), 0.1)
    iso = evaluate_position(feature, build_drf(pairs, standard="ISO"), 0.1)
    assert len(patch) > 5
    assert abs(asme.value_mm - hole.position_rfs()) < 1e-8
    assert abs(iso.value_mm - hole.position_rfs()) > 1e-3
