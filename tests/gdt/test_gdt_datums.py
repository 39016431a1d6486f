"""Datum associations and DRFs on constructed datum faces with known contact sets.

The certificate checker here is independent of pcmm_geo: it tests feasibility (every point on the
material side), the contact levels, non-negative multipliers summing to one per level and the
stationarity of the largest distance in the directions the normal may turn to.  It is shown to reject
hand-made wrong answers.  A brute-force enumeration of every facet-vertex and edge-edge candidate on
small sets checks that a free primary is globally optimal.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.gdt import associate_datum, build_drf
from pcmm_geo.gdt.reference.drf import nominal_of


def check_plane_certificate(points, point, normal, contacts, levels, multipliers, fixed=(), tol=1e-9):
    """True when (point, normal) is a certified tangent minimax plane of ``points`` (independent checker)."""
    n = np.asarray(normal, float)
    if abs(np.linalg.norm(n) - 1) > 1e-12:
        return False
    d = (points - point) @ n
    width = d.max()
    if d.min() < -tol:  # a point outside the material
        return False
    lam = np.asarray(multipliers, float)
    lower, upper = contacts[levels == 0], contacts[levels == 1]
    if np.any(lam < -1e-12) or np.any(np.abs(d[lower]) > tol) or np.any(np.abs(d[upper] - width) > tol):
        return False
    lam_l, lam_u = lam[levels == 0], lam[levels == 1]
    if abs(lam_l.sum() - 1) > 1e-9 or abs(lam_u.sum() - 1) > 1e-9:
        return False
    r = lam_u @ points[upper] - lam_l @ points[lower] - width * n
    span = np.array([n, *fixed]).T
    q, _ = np.linalg.qr(span)
    r_free = r - q @ (q.T @ r)
    return bool(np.linalg.norm(r_free) <= 1e-7 * max(1.0, np.abs(points).max()))


def brute_force_min_width(points):
    """Minimum width over every facet-vertex and edge-edge direction (exhaustive, small sets only)."""
    best = np.inf
    for i, j, k in itertools.combinations(range(len(points)), 3):
        n = np.cross(points[j] - points[i], points[k] - points[i])
        if np.linalg.norm(n) > 1e-12:
            best = min(best, np.ptp(points @ (n / np.linalg.norm(n))))
    pairs = list(itertools.combinations(range(len(points)), 2))
    for (a, b), (c, e) in itertools.combinations(pairs, 2):
        n = np.cross(points[b] - points[a], points[e] - points[c])
        if np.linalg.norm(n) > 1e-12:
            best = min(best, np.ptp(points @ (n / np.linalg.norm(n))))
    return best


def _random_rotation(rng, deg=3.0):
    v = np.radians(rng.uniform(-deg, deg, 3))
    a = np.linalg.norm(v)
    k = v / a
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(a) * kx + (1 - np.cos(a)) * kx @ kx


@pytest.mark.parametrize("seed", range(8))
def test_primary_plane_has_the_constructed_contacts_and_a_certificate_the_checker_accepts(maker, seed):
    rng = np.random.default_rng(seed)
    face = maker.datum_face(rng, 300, (120.0, 90.0))
    rot, t = _random_rotation(rng), rng.uniform(-2, 2, 3)
    measured = face @ rot.T + t
    a = associate_datum(measured, "plane", label="A", nominal_direction=[0, 0, 1])
    # the exact answer: the plane z = 0 of the construction, inward normal +z, contacts {0, 1, 2} and {3}
    assert np.allclose(a.direction, rot[:, 2], atol=1e-12)
    assert abs((a.point - t) @ rot[:, 2]) < 1e-9
    assert abs(a.deviation_mm - maker.DATUM_FORM_MM) < 1e-9
    cert = a.certificate
    assert sorted(cert.contacts[cert.levels == 0].tolist()) == [0, 1, 2]
    assert cert.contacts[cert.levels == 1].tolist() == [3]
    assert cert.scope == "global"
    # multipliers of the lower contacts: barycentric coordinates of the upper contact's foot
    tri = face[:3, :2]
    bary = np.linalg.solve(np.vstack([tri.T, np.ones(3)]), np.r_[face[3, :2], 1.0])
    order = np.argsort(cert.contacts[cert.levels == 0])
    assert np.allclose(cert.multipliers[cert.levels == 0][order], bary, atol=1e-9)
    assert check_plane_certificate(measured, a.point, a.direction, cert.contacts, cert.levels, cert.multipliers)


def test_checker_rejects_hand_made_wrong_planes(maker):
    rng = np.random.default_rng(11)
    face = maker.datum_face(rng, 200, (120.0, 90.0))
    contacts, levels = np.array([0, 1, 2, 3]), np.array([0, 0, 0, 1])
    tri = face[:3, :2]
    bary = np.linalg.solve(np.vstack([tri.T, np.ones(3)]), np.r_[face[3, :2], 1.0])
    good = np.r_[bary, 1.0]
    assert check_plane_certificate(face, np.zeros(3), [0, 0, 1], contacts, levels, good)
    tilted = np.array([1e-4, 0, 1]) / np.linalg.norm([1e-4, 0, 1])
    assert not check_plane_certificate(face, np.zeros(3), tilted, contacts, levels, good)  # tilted plane
    assert not check_plane_certificate(face, np.array([0, 0, 1e-6]), [0, 0, 1], contacts, levels, good)  # cuts
    assert not check_plane_certificate(face, np.zeros(3), [0, 0, 1], contacts, levels, np.r_[1 / 3, 1 / 3, 1 / 3, 1])
    # the contact on the top is not a vertex above the triangle: a wrong contact set
    assert not check_plane_certificate(face, np.zeros(3), [0, 0, 1], np.array([0, 1, 2, 5]), levels, good)


@pytest.mark.parametrize("seed", range(6))
def test_free_primary_is_the_global_minimum_by_brute_force(seed):
    rng = np.random.default_rng(100 + seed)
    pts = np.c_[rng.uniform(0, 50, (11, 2)), rng.uniform(0, 0.05, 11)]
    a = associate_datum(pts, "plane", nominal_direction=[0, 0, 1])
    assert abs(a.deviation_mm - brute_force_min_width(pts)) < 1e-9
    c = a.certificate
    assert check_plane_certificate(pts, a.point, a.direction, c.contacts, c.levels, c.multipliers)


@pytest.mark.parametrize("seed", range(6))
def test_secondary_plane_constrained_perpendicular_to_the_primary(maker, seed):
    rng = np.random.default_rng(200 + seed)
    part = maker.make_part(seed, n_points=200, n_holes=0)
    a = associate_datum(part.measured("A"), "plane", label="A", nominal_direction=[0, 0, 1])
    b_pts = part.measured("B")
    b = associate_datum(b_pts, "plane", label="B", nominal_direction=[1, 0, 0], perpendicular_to=(a.direction,))
    assert abs(b.direction @ a.direction) < 1e-14
    assert np.allclose(b.direction, part.rotation[:, 0], atol=1e-11)
    assert abs(b.deviation_mm - maker.DATUM_FORM_MM) < 1e-9
    c = b.certificate
    assert sorted(c.contacts[c.levels == 0].tolist()) == [0, 1] and c.contacts[c.levels == 1].tolist() == [2]
    assert check_plane_certificate(b_pts, b.point, b.direction, c.contacts, c.levels, c.multipliers,
                                   fixed=(a.direction,))
    # without the constraint the certificate of the constrained plane does not hold
    assert not check_plane_certificate(b_pts, b.point, b.direction, c.contacts, c.levels, c.multipliers)
    del rng


@pytest.mark.parametrize("seed", range(8))
def test_drf_recovers_the_rigid_motion_and_the_free_degrees_of_freedom(maker, seed):
    part = maker.make_part(seed, n_points=150, n_holes=0, pose_deg=4.0, pose_mm=3.0)
    a = associate_datum(part.measured("A"), "plane", label="A", nominal_direction=[0, 0, 1])
    b = associate_datum(part.measured("B"), "plane", label="B", nominal_direction=[1, 0, 0],
                        perpendicular_to=(a.direction,))
    c = associate_datum(part.measured("C"), "plane", label="C", nominal_direction=[0, 1, 0],
                        perpendicular_to=(a.direction, b.direction))
    na, nb, nc = nominal_of([0, 0, 0], [0, 0, 1]), nominal_of([0, 0, 0], [1, 0, 0]), nominal_of([0, 0, 0], [0, 1, 0])
    drf = build_drf([(a, na), (b, nb), (c, nc)])
    assert np.allclose(drf.rotation, part.rotation.T, atol=1e-11)
    assert np.allclose(drf.origin, part.translation, atol=1e-9)
    assert drf.free == ()
    # every constructed point back in the nominal frame
    assert np.allclose(drf.to_frame(part.measured("TOP")), part.points["TOP"], atol=1e-9)
    assert build_drf([(a, na)]).free == ("tx", "ty", "rz")
    assert build_drf([(a, na), (b, nb)]).free == ("ty",)


def test_datum_that_constrains_nothing_new_is_refused_by_name(maker):
    part = maker.make_part(1, n_points=100, n_holes=0)
    a = associate_datum(part.measured("A"), "plane", label="A", nominal_direction=[0, 0, 1])
    top = associate_datum(part.measured("TOP"), "plane", label="D", nominal_direction=[0, 0, -1])
    with pytest.raises(InvalidInputError, match="datum D"):
        build_drf([(a, nominal_of([0, 0, 0], [0, 0, 1])), (top, nominal_of([0, 0, 30], [0, 0, -1]))])


def test_secondary_hole_parallel_to_the_primary_and_tertiary_hole_set_x(maker):
    part = maker.make_part(3, n_points=200, n_holes=3)
    a = associate_datum(part.measured("A"), "plane", label="A", nominal_direction=[0, 0, 1])
    h1, h3 = part.holes[0], part.holes[2]
    b = associate_datum(part.measured("H3"), "cylinder", label="B", side="internal", nominal_direction=[0, 0, 1],
                        parallel_to=a.direction)
    c = associate_datum(part.measured("H1"), "cylinder", label="C", side="internal", nominal_direction=[0, 0, 1],
                        parallel_to=a.direction)
    # exact MIC of the projected circle: the constructed radius (H3 is not tilted)
    assert abs(b.radius - h3.actual_diameter / 2) < 1e-9
    # MIC certificate, checked independently: contacts on the circle, every point outside, sum(lam u) = 0
    rel = part.measured("H3") - b.point
    rel -= np.outer(rel @ b.direction, b.direction)
    dist = np.linalg.norm(rel, axis=1)
    assert dist.min() > b.radius - 1e-9
    cert = b.certificate
    units = rel[cert.contacts] / dist[cert.contacts, None]
    assert np.all(cert.multipliers >= 0) and abs(cert.multipliers.sum() - 1) < 1e-9
    assert np.linalg.norm(cert.multipliers @ units) < 1e-9
    drf = build_drf([(a, nominal_of([0, 0, 0], [0, 0, 1])), (b, nominal_of([*h3.centre, 0], [0, 0, 1])),
                     (c, nominal_of([*h1.centre, 0], [0, 0, 1]))])
    assert drf.free == ()
    # the B axis lands on its nominal centre; x turns so that C lies on the nominal B->C line
    assert np.allclose(drf.to_frame(b.point)[:2], h3.centre, atol=1e-9)
    c_drf = drf.to_frame(c.point)[:2] - np.array(h3.centre)
    nominal = np.array(h1.centre) - np.array(h3.centre)
    assert abs(c_drf[0] * nominal[1] - c_drf[1] * nominal[0]) < 1e-9
