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
