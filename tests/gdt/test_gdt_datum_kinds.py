"""Secondary datum planes at an angle, common datums (A-B) and datum targets, on constructed parts.

Each construction has a known contact set, so the associated datum is exactly the nominal one moved by
the pose; the certificates are checked by the independent checker of ``test_gdt_datums`` (extended with
the cone constraint here) and by short checkers for the common axis and the targets, each shown to reject
hand-made wrong answers.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_gdt_datums import check_plane_certificate

from pcmm_geo.errors import FileFormatError
from pcmm_geo.gdt import associate_datum, build_drf, inspect_plan
from pcmm_geo.gdt.reference.drf import nominal_of

ALPHA = np.radians(60.0)  # the angle between B's inward normal and A's
N_B = np.array([np.sin(ALPHA), 0.0, np.cos(ALPHA)])


def check_cone_certificate(points, point, normal, axis, cos_angle, contacts, levels, multipliers):
    """A tangent minimax plane whose normal keeps ``n . axis = cos_angle``: the plane checker with the one
    direction the normal may turn in (about ``axis`` on the cone) as the only free one."""
    n = np.asarray(normal, float)
    if abs(n @ axis - cos_angle) > 1e-12:
        return False
    turn = np.cross(axis, n)  # the cone's tangent at n
    return check_plane_certificate(points, point, n, contacts, levels, multipliers, fixed=(np.cross(n, turn),))


def _angled_part(maker, seed):
    rng = np.random.default_rng(seed)
    u = np.array([0.0, 1.0, 0.0])
    v = np.cross(N_B, u)
    face = maker.strip_face(rng, 200, (80.0, 25.0))
    b = face[:, :1] * u + face[:, 1:2] * v + face[:, 2:3] * N_B
    a = maker.datum_face(rng, 200, (120.0, 90.0)) + np.array([20.0, 0.0, 0.0])
    c = rng.uniform(0.05, 0.95, (200, 2)) * [100.0, 25.0]
    cw = rng.uniform(0.2, 0.8, 200) * maker.DATUM_FORM_MM
    cw[0] = 0.0
    pts = {"A": a, "B": b, "C": np.c_[20 + c[:, 0], cw, c[:, 1]]}
    rot = maker._rotation(np.radians(rng.uniform(-2, 2, 3)))
    t = rng.uniform(-2, 2, 3)
    return pts, rot, t


@pytest.mark.parametrize("seed", range(5))
def test_secondary_plane_at_60_degrees_has_the_constructed_contacts(maker, seed):
    pts, rot, t = _angled_part(maker, seed)
    measured = {k: p @ rot.T + t for k, p in pts.items()}
    a = associate_datum(measured["A"], "plane", label="A", nominal_direction=[0, 0, 1])
    b = associate_datum(measured["B"], "plane", label="B", nominal_direction=N_B,
                        angle_to=(a.direction, np.cos(ALPHA)), constraint_names=("at 60 deg to A",))
    assert np.allclose(b.direction, rot @ N_B, atol=1e-12)
    assert abs(b.deviation_mm - maker.DATUM_FORM_MM) < 1e-9
    cert = b.certificate
    assert sorted(cert.contacts[cert.levels == 0].tolist()) == [0, 1]
    assert cert.contacts[cert.levels == 1].tolist() == [2]
    assert cert.scope == "global" and abs(cert.bound_mm - maker.DATUM_FORM_MM) < 1e-9
    assert check_cone_certificate(measured["B"], b.point, b.direction, a.direction, np.cos(ALPHA), cert.contacts,
                                  cert.levels, cert.multipliers)
    c = associate_datum(measured["C"], "plane", label="C", nominal_direction=[0, 1, 0],
                        perpendicular_to=(a.direction, b.direction))
    drf = build_drf([(a, nominal_of([0, 0, 0], [0, 0, 1])), (b, nominal_of([0, 0, 0], N_B)),
                     (c, nominal_of([0, 0, 0], [0, 1, 0]))])
    # x is B's inward normal made perpendicular to z: the construction's x axis
    assert np.allclose(drf.rotation, rot.T, atol=1e-11) and np.allclose(drf.origin, t, atol=1e-9)
    assert np.allclose(drf.to_frame(measured["A"]), pts["A"], atol=1e-9)


def test_cone_checker_rejects_hand_made_wrong_answers(maker):
    pts, _, _ = _angled_part(maker, 3)
    b = pts["B"]
    axis = np.array([0.0, 0.0, 1.0])
    good = associate_datum(b, "plane", label="B", nominal_direction=N_B, angle_to=(axis, np.cos(ALPHA)))
    c = good.certificate
    assert check_cone_certificate(b, good.point, good.direction, axis, np.cos(ALPHA), c.contacts, c.levels,
                                  c.multipliers)
    # turned on the cone by 1e-5 rad, off the cone, the wrong angle, and the unconstrained certificate
    turned = np.array([np.sin(ALPHA) * np.cos(1e-5), np.sin(ALPHA) * np.sin(1e-5), np.cos(ALPHA)])
    assert not check_cone_certificate(b, good.point, turned, axis, np.cos(ALPHA), c.contacts, c.levels,
                                      c.multipliers)
    tilted = N_B + np.array([0, 0, 1e-5])
    assert not check_cone_certificate(b, good.point, tilted / np.linalg.norm(tilted), axis, np.cos(ALPHA),
                                      c.contacts, c.levels, c.multipliers)
    assert not check_cone_certificate(b, good.point, good.direction, axis, np.cos(ALPHA + 1e-4), c.contacts,
                                      c.levels, c.multipliers)
    assert not check_plane_certificate(b, good.point, good.direction, c.contacts, c.levels, c.multipliers)


def _write(tmp_path: Path, measured: dict[str, np.ndarray]) -> None:
    for name, p in measured.items():
        np.savetxt(tmp_path / f"{name}.csv", p, fmt="%.12f", delimiter=",")


def test_plan_with_an_angled_secondary_gives_the_exact_position(maker, tmp_path):
    pts, rot, t = _angled_part(maker, 7)
    rng = np.random.default_rng(7)
    ring = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    z = np.repeat([2.0, 20.0], 40)
    pts["H"] = np.c_[60.03 + 5 * np.cos(np.tile(ring, 2)), 40.0 - 0.04 + 5 * np.sin(np.tile(ring, 2)), z]
    del rng
    _write(tmp_path, {k: p @ rot.T + t for k, p in pts.items()})
    outward = ", ".join(f"{-v:.17g}" for v in N_B)
    (tmp_path / "plan.toml").write_text(f'''units = "mm"
[part]
frame = "A|B|C"
[features.A]
element = "plane"
points = "A.csv"
normal = [0, 0, -1]
[features.B]
element = "plane"
points = "B.csv"
normal = [{outward}]
[features.C]
element = "plane"
points = "C.csv"
normal = [0, -1, 0]
[features.H]
element = "cylinder"
points = "H.csv"
side = "internal"
point = [60, 40, 0]
axis = [0, 0, 1]
diameter = 10
[datums]
A = "A"
B = "B"
C = "C"
[[characteristics]]
name = "pos H"
feature = "H"
frame = "position dia 0.12 | A | B | C"
''', encoding="utf-8")
    result = inspect_plan(tmp_path / "plan.toml")
    (c,) = result.characteristics
    assert abs(c.value_mm - 2 * 0.05) < 1e-9 and c.verdict == "PASS"
    assert result.datums["B"].constrained_by == ("at 60 deg to A",)
    assert np.allclose(result.frames["A|B|C"].rotation, rot.T, atol=1e-11)


# --- common datums -------------------------------------------------------------------------------------------


def check_common_axis(parts, point, u, tau, contacts, multipliers, sign=1.0, tol=1e-9):
    """Independent check of a common axis: every surface within ``tau`` of its nominal radius
    (``sign * (d - R) <= tau``), the contacts at ``tau``, non-negative multipliers summing to one that balance
    the contacts' radial directions and their moments about the axis point (stationarity in the line's four
    degrees of freedom)."""
    pts = np.vstack([p for p, _ in parts])
    radii = np.concatenate([np.full(len(p), r) for p, r in parts])
    u = np.asarray(u, float) / np.linalg.norm(u)
    rel = pts - point
    h = rel @ u
    radial = rel - np.outer(h, u)
    d = np.linalg.norm(radial, axis=1)
    excess = sign * (d - radii)
    lam = np.asarray(multipliers, float)
    if excess.max() > tau + tol or np.any(np.abs(excess[contacts] - tau) > tol):
        return False
    if np.any(lam < -1e-12) or abs(lam.sum() - 1) > 1e-9:
        return False
    e = radial[contacts] / d[contacts, None]
    force = lam @ e
    moment = lam @ (e * h[contacts, None])
    return bool(np.linalg.norm(force) < 1e-7 and np.linalg.norm(moment) < 1e-7 * max(1.0, np.ptp(h)))


def _rings(centre, axis, radius, heights, n=36):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    e1 = np.cross(axis, [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.vstack([np.asarray(centre) + h * axis + radius * (np.outer(np.cos(a), e1) + np.outer(np.sin(a), e2))
                      for h in heights])


@pytest.mark.parametrize("seed", range(3))
def test_common_axis_of_two_coaxial_shafts(seed):
    from pcmm_geo.gdt.reference.common import associate_common_axis

    rng = np.random.default_rng(seed)
    axis = np.array([*rng.uniform(-0.02, 0.02, 2), 1.0])
    axis /= np.linalg.norm(axis)
    centre = rng.uniform(-1, 1, 3)
    a = _rings(centre, axis, 10.02, [0.0, 5.0, 10.0])        # nominal 10
    b = _rings(centre, axis, 15.02, [100.0, 105.0, 110.0])   # nominal 15
    # start from a line off the answer: the simultaneous association finds the common axis
    assoc = associate_common_axis([(a, 10.0), (b, 15.0)], label="A-B", side="external",
                                  nominal_direction=np.array([0, 0, 1.0]),
                                  start=(centre + np.array([0.01, -0.01, 0]), axis))
    assert abs(assoc.deviation_mm - 0.02) < 1e-9
    assert np.linalg.norm(np.cross(assoc.direction, axis)) < 1e-9
    assert np.linalg.norm(np.cross(assoc.point - centre, axis)) < 1e-8
    c = assoc.certificate
    assert check_common_axis([(a, 10.0), (b, 15.0)], assoc.point, assoc.direction, 0.02, c.contacts, c.multipliers)
    # wrong answers: an axis moved by 1 um, turned by 1e-6, a tau too small, unbalanced multipliers
    assert not check_common_axis([(a, 10.0), (b, 15.0)], assoc.point + np.array([1e-3, 0, 0]), assoc.direction, 0.02,
                                 c.contacts, c.multipliers)
    assert not check_common_axis([(a, 10.0), (b, 15.0)], assoc.point, assoc.direction + np.array([1e-6, 0, 0]), 0.02,
                                 c.contacts, c.multipliers)
    assert not check_common_axis([(a, 10.0), (b, 15.0)], assoc.point, assoc.direction, 0.0199, c.contacts,
                                 c.multipliers)
    skewed = np.zeros(len(c.contacts))
    skewed[0] = 1.0
    assert not check_common_axis([(a, 10.0), (b, 15.0)], assoc.point, assoc.direction, 0.02, c.contacts, skewed)


def _plan_text(features: str, datums: str, characteristics: str) -> str:
    return f'units = "mm"\n\n{features}\n[datums]\n{datums}\n\n{characteristics}'


def test_common_datum_axis_in_a_plan_coaxiality_and_runout(tmp_path, maker):
    rot = maker._rotation(np.radians([1.0, -0.5, 2.0]))
    t = np.array([0.5, -1.0, 2.0])
    pts = {"A": _rings([0, 0, 0], [0, 0, 1], 10.02, [0.0, 10.0]), "B": _rings([0, 0, 0], [0, 0, 1], 15.02,
                                                                              [100.0, 110.0]),
           "M": _rings([0.03, 0, 0], [0, 0, 1], 12.0, [50.0, 60.0])}
    _write(tmp_path, {k: p @ rot.T + t for k, p in pts.items()})
    features = "".join(f'[features.{k}]\nelement = "cylinder"\npoints = "{k}.csv"\nside = "external"\n'
                       f'point = [0, 0, 0]\naxis = [0, 0, 1]\ndiameter = {d}\n'
                       for k, d in (("A", 20), ("B", 30), ("M", 24)))
    chars = ('[[characteristics]]\nname = "coax M"\nfeature = "M"\nframe = "◎ ⌀0.1 | A-B"\n\n'
             '[[characteristics]]\nname = "runout M"\nfeature = "M"\nframe = "↗ 0.1 | A-B"\n')
    (tmp_path / "plan.toml").write_text(_plan_text(features, 'A = "A"\nB = "B"', chars), encoding="utf-8")
    result = inspect_plan(tmp_path / "plan.toml")
    coax, runout = result.characteristics
    assert abs(coax.value_mm - 0.06) < 1e-8 and coax.datums == ("A-B",)
    assert abs(runout.value_mm - 0.06) < 1e-8  # an offset ring: runout 2 e
    assoc = result.frames["A-B"].associations[0]
    assert assoc.criterion == "common" and abs(assoc.deviation_mm - 0.02) < 1e-9


def test_common_datum_plane_of_two_coplanar_faces(tmp_path, maker):
    rng = np.random.default_rng(5)
    # the contacts of the common plane z = 0: two points on A1, one on A2, the top point on A1 inside them
    a1 = np.c_[rng.uniform(0, 50, (60, 2)) * [1, 1.8], rng.uniform(0.2, 0.8, 60) * 0.004]
    a2 = np.c_[rng.uniform(80, 130, 60), rng.uniform(0, 90, 60), rng.uniform(0.2, 0.8, 60) * 0.004]
    a1[:3] = [[5, 5, 0], [5, 85, 0], [40, 45, 0.004]]
    a2[0] = [120, 45, 0]
    top = np.c_[rng.uniform(0, 130, (80, 2)) * [1, 0.7], np.zeros(80)]
    top[:2, 0] = [0, 130]
    top[:, 2] = 30 + 1e-4 * top[:, 0]
    rot = maker._rotation(np.radians([0.5, 1.0, -1.5]))
    t = np.array([1.0, 2.0, -0.5])
    _write(tmp_path, {"A1": a1 @ rot.T + t, "A2": a2 @ rot.T + t, "TOP": top @ rot.T + t})
    features = ('[features.A1]\nelement = "plane"\npoints = "A1.csv"\nnormal = [0, 0, -1]\n'
                '[features.A2]\nelement = "plane"\npoints = "A2.csv"\nnormal = [0, 0, -1]\n'
                '[features.TOP]\nelement = "plane"\npoints = "TOP.csv"\nnormal = [0, 0, 1]\npoint = [0, 0, 30]\n')
    chars = '[[characteristics]]\nname = "par TOP"\nfeature = "TOP"\nframe = "∥ 0.05 | A-B"\n'
    (tmp_path / "plan.toml").write_text(_plan_text(features, 'A = "A1"\nB = "A2"', chars), encoding="utf-8")
    result = inspect_plan(tmp_path / "plan.toml")
    (par,) = result.characteristics
    assert abs(par.value_mm - 1e-4 * 130) < 1e-9
    common = result.frames["A-B"].associations[0]
    assert np.allclose(common.direction, rot[:, 2], atol=1e-12) and abs(common.deviation_mm - 0.004) < 1e-9
    stacked = np.vstack([a1, a2]) @ rot.T + t
    c = common.certificate
    assert sorted(c.contacts[c.levels == 0].tolist()) == [0, 1, 60] and c.contacts[c.levels == 1].tolist() == [2]
    assert check_plane_certificate(stacked, common.point, common.direction, c.contacts, c.levels, c.multipliers)
    # A1 alone has another tangent plane: the common datum is not either face's own
    alone = associate_datum(a1 @ rot.T + t, "plane", nominal_direction=rot[:, 2])
    assert np.linalg.norm(np.cross(alone.direction, common.direction)) > 1e-6


def test_common_datum_of_planes_that_are_not_coplanar_is_refused(tmp_path, maker):
    test_common_datum_plane_of_two_coplanar_faces(tmp_path, maker)
    plan = tmp_path / "plan.toml"
    plan.write_text(plan.read_text().replace('points = "A2.csv"\nnormal = [0, 0, -1]',
                                             'points = "A2.csv"\nnormal = [0, 0, -1]\npoint = [0, 0, 1]'))
    with pytest.raises(FileFormatError, match="common datum A-B: expected nominally coplanar planes"):
        inspect_plan(plan)


# --- datum targets -------------------------------------------------------------------------------------------


def check_target_plane(targets, normal, inward, fixed=(), tol=1e-9):
    """Independent check of a datum plane from point targets: unit normal on the material side,
    perpendicular to the constraining directions, every target on the plane."""
    n = np.asarray(normal, float)
    if abs(np.linalg.norm(n) - 1) > 1e-12 or n @ inward <= 0:
        return False
    if any(abs(n @ f) > 1e-12 for f in fixed):
        return False
    return bool(np.all(np.abs((targets - targets[0]) @ n) <= tol))


def test_datum_targets_give_the_frame_and_the_checker_rejects_wrong_planes(tmp_path, maker):
    rot = maker._rotation(np.radians([1.5, -1.0, 0.5]))
    t = np.array([-1.0, 0.5, 1.5])
    # A1..A3 at heights 0, 0.01, 0.02: the datum plane through them is tilted by a known amount
    targets = {"A1": [10, 10, 0.0], "A2": [110, 10, 0.01], "A3": [60, 80, 0.02], "B1": [0, 15, 10],
               "B2": [0, 75, 10], "C1": [60, 0, 10]}
    hole = _rings([60.02, 40.0, 0], [0, 0, 1], 5.0, [2.0, 20.0], n=40)
    _write(tmp_path, {**{k: np.array([v]) @ rot.T + t for k, v in targets.items()}, "H": hole @ rot.T + t})
    nominal = {k: [round(c) if j < 2 or k[0] != "A" else 0 for j, c in enumerate(v)] for k, v in targets.items()}
    features = "".join(f'[features.{k}]\nelement = "point"\npoints = "{k}.csv"\npoint = {nominal[k]}\n'
                       for k in targets)
    features += ('[features.H]\nelement = "cylinder"\npoints = "H.csv"\nside = "internal"\npoint = [60, 40, 0]\n'
                 'axis = [0, 0, 1]\ndiameter = 10\n')
    datums = ('A = {targets = ["A1", "A2", "A3"], normal = [0, 0, -1]}\n'
              'B = {targets = ["B1", "B2"], normal = [-1, 0, 0]}\nC = {targets = ["C1"], normal = [0, -1, 0]}')
    chars = '[[characteristics]]\nname = "pos H"\nfeature = "H"\nframe = "position dia 0.1 | A | B | C"\n'
    (tmp_path / "plan.toml").write_text(_plan_text(features, datums, chars), encoding="utf-8")
    result = inspect_plan(tmp_path / "plan.toml")
    drf = result.frames["A|B|C"]
    a = np.array([targets[k] for k in ("A1", "A2", "A3")])
    n_a = np.cross(a[1] - a[0], a[2] - a[0])
    n_a /= np.linalg.norm(n_a)
    assert np.allclose(drf.z, rot @ n_a, atol=1e-12)
    assoc = drf.associations[0]
    assert assoc.criterion == "targets" and assoc.certificate.contacts.tolist() == [0, 1, 2]
    measured = a @ rot.T + t
    assert check_target_plane(measured, assoc.direction, rot[:, 2])
    # the B targets: their plane contains both, perpendicular to A
    b_assoc = drf.associations[1]
    b_pts = np.array([targets["B1"], targets["B2"]]) @ rot.T + t
    assert check_target_plane(b_pts, b_assoc.direction, rot[:, 0], fixed=(assoc.direction,))
    # wrong planes: the nominal normal (misses A3), a plane through A1, A2 only, a flipped normal
    assert not check_target_plane(measured, rot[:, 2], rot[:, 2])
    wrong = np.cross(measured[1] - measured[0], rot[:, 1])
    assert not check_target_plane(measured, wrong / np.linalg.norm(wrong), rot[:, 2])
    assert not check_target_plane(measured, -assoc.direction, rot[:, 2])
    assert not check_target_plane(b_pts, b_assoc.direction, rot[:, 0], fixed=(rot[:, 0],))
    # the exact DRF of the targets (part coordinates): z the A targets' normal, x the B targets' plane normal
    # perpendicular to z, the origin where the three target planes meet; the hole's ring centres in it
    n_b = np.cross(n_a, np.subtract(targets["B2"], targets["B1"]))
    n_b = n_b if n_b[0] > 0 else -n_b
    n_b /= np.linalg.norm(n_b)
    axes = np.array([n_b, np.cross(n_a, n_b), n_a])
    origin = np.linalg.solve(axes, [n_b @ targets["B1"], axes[1] @ targets["C1"], n_a @ targets["A1"]])
    ends = (np.array([[60.02, 40.0, 2.0], [60.02, 40.0, 20.0]]) - origin) @ axes.T
    expected = 2 * np.linalg.norm(ends[:, :2] - [60.0, 40.0], axis=1).max()
    (pos,) = result.characteristics
    assert abs(pos.value_mm - expected) < 1e-9 and pos.verdict == "PASS"
    assert np.allclose(drf.to_frame(np.array([targets["A1"]]) @ rot.T + t), [(targets["A1"] - origin) @ axes.T],
                       atol=1e-9)


def test_a_wrong_number_of_targets_is_refused_by_name(tmp_path, maker):
    test_datum_targets_give_the_frame_and_the_checker_rejects_wrong_planes(tmp_path, maker)
    plan = tmp_path / "plan.toml"
    plan.write_text(plan.read_text().replace('targets = ["B1", "B2"]', 'targets = ["B1", "B2", "C1"]'))
    with pytest.raises(FileFormatError, match=r"datum B targets: expected 2 point target\(s\)"):
        inspect_plan(plan)
    plan.write_text(plan.read_text().replace('targets = ["B1", "B2", "C1"]', 'targets = ["B1", "H"]'))
    with pytest.raises(FileFormatError, match="target 'H': expected a feature of element \"point\""):
        inspect_plan(plan)


def test_tertiary_plane_at_an_angle_to_the_angled_secondary_has_its_normal_fixed(maker, tmp_path):
    pts, rot, t = _angled_part(maker, 9)
    beta = np.radians(20.0)
    n_c = np.array([np.sin(beta), np.cos(beta), 0.0])  # perpendicular to A, not to B
    along = np.cross([0.0, 0.0, 1.0], n_c)
    rng = np.random.default_rng(9)
    uv = rng.uniform(5, 60, (150, 2))
    w = rng.uniform(0.2, 0.8, 150) * maker.DATUM_FORM_MM
    w[0] = 0.0
    pts["C"] = uv[:, :1] * along + uv[:, 1:] * [0.0, 0.0, 0.5] + w[:, None] * n_c
    _write(tmp_path, {k: p @ rot.T + t for k, p in pts.items()})
    b_out = ", ".join(f"{-v:.17g}" for v in N_B)
    c_out = ", ".join(f"{-v:.17g}" for v in n_c)
    features = ('[features.A]\nelement = "plane"\npoints = "A.csv"\nnormal = [0, 0, -1]\n'
                f'[features.B]\nelement = "plane"\npoints = "B.csv"\nnormal = [{b_out}]\n'
                f'[features.C]\nelement = "plane"\npoints = "C.csv"\nnormal = [{c_out}]\n')
    chars = '[[characteristics]]\nname = "flat A"\nfeature = "A"\nframe = "flatness 0.01"\n'
    (tmp_path / "plan.toml").write_text(_plan_text(features, 'A = "A"\nB = "B"\nC = "C"', chars) +
                                        '\n[part]\nframe = "A|B|C"\n', encoding="utf-8")
    result = inspect_plan(tmp_path / "plan.toml")
    c = result.datums["C"]
    assert np.allclose(c.direction, rot @ n_c, atol=1e-12) and c.certificate.contacts[0] == 0
    drf = result.frames["A|B|C"]
    assert np.allclose(drf.rotation, rot.T, atol=1e-11) and np.allclose(drf.origin, t, atol=1e-9)


def test_asme_constrained_least_squares_at_the_angle_is_a_local_minimum_on_the_cone(maker):
    pts, _, _ = _angled_part(maker, 4)
    b = pts["B"]
    axis = np.array([0.0, 0.0, 1.0])
    assoc = associate_datum(b, "plane", label="B", criterion="constrained-lsq", nominal_direction=N_B,
                            angle_to=(axis, np.cos(ALPHA)))
    n = assoc.direction
    assert abs(n @ axis - np.cos(ALPHA)) < 1e-12 and assoc.certificate.scope == "local"
    heights = (b - assoc.point) @ n
    assert heights.min() > -1e-9  # tangent: every point on the material side

    def cost(phi):  # the constrained least squares over the cone, independently: tangent offset, sum of squares
        h = b @ np.array([np.sin(ALPHA) * np.cos(phi), np.sin(ALPHA) * np.sin(phi), np.cos(ALPHA)])
        return float(np.sum((h - h.min()) ** 2))

    phi = float(np.arctan2(n[1], n[0]))
    assert cost(phi) <= min(cost(phi - 1e-5), cost(phi + 1e-5))
