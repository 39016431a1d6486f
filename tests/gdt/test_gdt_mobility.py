"""Datum features at MMB / LMB: datum mobility (datum shift) on constructed parts with exact answers.

The parts: datum A the face z = 0, a datum hole (or pin) D with its axis along z at a known offset and
size, datum E the face y = 0, and toleranced holes at known offsets, all exact cylinders, measured in
a known pose.  With E a plane the mobility is the translation of the part within the gap between D's
boundary (its MMB) and its actual mating envelope: the position of a hole whose deviation from D's
actual axis is ``e`` is ``2 max(0, |e| - gap)`` (one hole), and a pattern floats by one shift.  The
KKT certificate of the best placement is verified by an independent checker, shown to reject wrong
answers.
"""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.errors import FileFormatError
from pcmm_geo.gdt import inspect_plan


def _cylinder(rng, centre, diameter, n=120, depth=(2.0, 28.0)):
    """Points exactly on a cylinder along z (full rings at both ends)."""
    ring = n // 4
    z = np.r_[np.full(ring, depth[0]), np.full(ring, depth[1]), rng.uniform(*depth, n - 2 * ring)]
    a = np.r_[np.linspace(0, 2 * np.pi, ring, endpoint=False), np.linspace(0, 2 * np.pi, ring, endpoint=False) + 0.05,
              rng.uniform(0, 2 * np.pi, n - 2 * ring)]
    r = diameter / 2
    return np.c_[centre[0] + r * np.cos(a), centre[1] + r * np.sin(a), z]


def _part(maker, tmp_path, *, seed=0, datum=("internal", (30.0, 25.0), (0.01, -0.02), 10.06),
          holes=(((90.0, 25.0), (0.05, 0.0)),), frames=("position dia 0.1 | A | D(M) | E",), standard="ISO",
          extra_datums="", hole_diameter=10.05, tertiary_hole=None):
    """Write a plan and its points; returns the plan path, the pose (R, t)."""
    rng = np.random.default_rng(seed)
    lx, ly, lz = maker.BLOCK_MM
    pts = {"A": maker.datum_face(rng, 150, (lx, ly))}
    e = maker.strip_face(rng, 150, (lx, lz))  # its narrowest strip along z is exactly y = 0
    pts["E"] = np.c_[e[:, 0], e[:, 2], e[:, 1]]
    side, centre, offset, dia = datum
    pts["D"] = _cylinder(rng, np.add(centre, offset), dia)
    if tertiary_hole is not None:
        pts["F"] = _cylinder(rng, np.add(tertiary_hole[0], tertiary_hole[1]), tertiary_hole[2])
    for k, (nominal, off) in enumerate(holes):
        pts[f"H{k + 1}"] = _cylinder(rng, np.add(nominal, off), hole_diameter)
    rot = maker._rotation(np.radians(rng.uniform(-2, 2, 3)))
    t = rng.uniform(-2, 2, 3)
    for name, p in pts.items():
        np.savetxt(tmp_path / f"{name}.csv", p @ rot.T + t, fmt="%.12f", delimiter=",")
    lines = ['units = "mm"', f'standard = "{standard}"', "",
             '[features.A]\nelement = "plane"\npoints = "A.csv"\nnormal = [0, 0, -1]',
             '[features.E]\nelement = "plane"\npoints = "E.csv"\nnormal = [0, -1, 0]',
             f'[features.D]\nelement = "cylinder"\npoints = "D.csv"\nside = "{side}"\npoint = [{centre[0]}, '
             f'{centre[1]}, 0]\naxis = [0, 0, 1]\ndiameter = 10\nsize_tolerance = [0, 0.1]']
    if tertiary_hole is not None:
        f = tertiary_hole[0]
        lines.append(f'[features.F]\nelement = "cylinder"\npoints = "F.csv"\nside = "internal"\npoint = [{f[0]}, '
                     f'{f[1]}, 0]\naxis = [0, 0, 1]\ndiameter = 8\nsize_tolerance = [0, 0.1]')
    for k, (nominal, _) in enumerate(holes):
        lines.append(f'[features.H{k + 1}]\nelement = "cylinder"\npoints = "H{k + 1}.csv"\nside = "internal"\n'
                     f'point = [{nominal[0]}, {nominal[1]}, 0]\naxis = [0, 0, 1]\ndiameter = 10\n'
                     'size_tolerance = [0, 0.1]')
    lines.append('[datums]\nA = "A"\nD = "D"\nE = "E"' + ('\nF = "F"' if tertiary_hole is not None else "")
                 + extra_datums)
    for k in range(len(holes)):
        for j, frame in enumerate(frames):
            lines.append(f'[[characteristics]]\nname = "pos H{k + 1} {j}"\nfeature = "H{k + 1}"\nframe = "{frame}"')
    plan = tmp_path / "plan.toml"
    plan.write_text("\n\n".join(lines) + "\n", encoding="utf-8")
    return plan, rot, t


def check_mobility_certificate(devs_fn, value, shift, boundaries, targets, mult, btargets, bmult, tol=1e-7):
    """Independent check of a translation-only best placement (a convex minimax).

    ``devs_fn(shift)`` gives the weighted deviation vectors (K, 2) of the targets after the part moves by
    ``shift`` (2,); ``boundaries`` are (centre_offset (2,), gap): the moved envelope centre minus the
    nominal is ``centre_offset + shift``.  Checks feasibility, that the active targets are at the value and
    the touched boundaries at their gap, non-negative multipliers summing to one, and stationarity
    ``sum mu_k d_k/|d_k| + sum nu_j s_j/|s_j| = 0``.
    """
    shift = np.asarray(shift, float)
    devs = devs_fn(shift)
    norms = np.linalg.norm(devs, axis=1)
    if abs(norms.max() - value) > tol or np.any(np.abs(norms[targets] - value) > tol):
        return False
    for off, gap in boundaries:
        if np.linalg.norm(np.asarray(off) + shift) > gap + tol:
            return False
    if value <= tol:  # zero is its own lower bound
        return bool(norms.max() <= tol)
    mult, bmult = np.asarray(mult, float), np.asarray(bmult, float)
    if np.any(mult < -1e-12) or np.any(bmult < -1e-12) or abs(mult.sum() - 1) > 1e-9:
        return False
    def grad(k):  # of |devs_k| with respect to the shift, by central differences
        h = 1e-7
        return np.array([(np.linalg.norm(devs_fn(shift + h * e)[k]) - np.linalg.norm(devs_fn(shift - h * e)[k]))
                         / (2 * h) for e in np.eye(2)])

    g = sum((m * grad(k) for k, m in zip(targets, mult, strict=True)), np.zeros(2))
    for j, nu in zip(btargets, bmult, strict=True):
        off, gap = boundaries[j]
        s = np.asarray(off) + shift
        if abs(np.linalg.norm(s) - gap) > tol:
            return False
        g = g + nu * s / np.linalg.norm(s)
    return bool(np.linalg.norm(g) <= 1e-6)  # central differences: ~1e-9


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("offset", [(0.05, 0.0), (0.03, 0.04), (-0.012, 0.016)])
def test_one_hole_gains_the_datum_shift_exactly(maker, tmp_path, seed, offset):
    # D's actual axis is 0.01, -0.02 off: in the DRF the hole's deviation is its offset less D's
    plan, _, _ = _part(maker, tmp_path, seed=seed, holes=(((90.0, 25.0), np.add(offset, (0.01, -0.02))),),
                       frames=("position dia 0.1 | A | D(M) | E", "position dia 0.1 | A | D | E"))
    with_shift, rmb = inspect_plan(plan).characteristics
    e = float(np.hypot(*offset))
    gap = (10.06 - 10.0) / 2
    assert abs(rmb.value_mm - 2 * e) < 1e-9
    assert abs(with_shift.value_mm - 2 * max(0.0, e - gap)) < 1e-9
    d = with_shift.details
    assert d["mobility_proven"] == "PROVEN" and d["scope"] == "global"
    assert 0 <= with_shift.value_mm - with_shift.bound_mm < 1e-9
    # the shift used: the whole gap, against the deviation (or less when the hole can be centred)
    expected_shift = -np.array(offset) * min(1.0, gap / e)
    assert np.allclose(d["datum_shift_mm"][:2], expected_shift, atol=1e-9)
    (b,) = d["datum_boundaries"]
    assert b["modifier"] == "MMB" and abs(b["boundary_diameter_mm"] - 10.0) < 1e-12
    assert abs(b["envelope_diameter_mm"] - 10.06) < 1e-9 and abs(b["gap_mm"] - gap) < 1e-9
    assert with_shift.verdict == "PASS"
    # the certificate, checked independently (weighted deviations: 2 x the end points' deviations)
    ends = np.array(d["deviations_mm"])[:, :2] - np.asarray(d["datum_shift_mm"][:2])
    cert = d["certificate"]

    def devs(shift):
        return 2.0 * (ends + shift)

    assert check_mobility_certificate(devs, with_shift.value_mm, d["datum_shift_mm"][:2], [(np.zeros(2), gap)],
                                      cert["targets"], cert["target_multipliers"], cert["boundaries"],
                                      cert["boundary_multipliers"])


def test_mobility_checker_rejects_hand_made_wrong_answers():
    ends = np.array([[0.05, 0.0], [0.05, 0.0]])
    gap = 0.03

    def devs(shift):
        return 2.0 * (ends + shift)

    good = dict(value=0.04, shift=[-0.03, 0.0], boundaries=[(np.zeros(2), gap)], targets=[0, 1],
                mult=[0.5, 0.5], btargets=[0], bmult=[2.0])  # d|2(e + t)|/dt = 2 u: balanced by nu = 2
    assert check_mobility_certificate(devs, *good.values())
    # a shift beyond the gap (infeasible), a value not attained, a shift that is not the best, bad multipliers
    assert not check_mobility_certificate(devs, 0.02, [-0.04, 0.0], *list(good.values())[2:])
    assert not check_mobility_certificate(devs, 0.03, *list(good.values())[1:])
    assert not check_mobility_certificate(devs, 2 * np.hypot(0.05 - 0.0294, 0.006), [-0.0294, -0.006],
                                          [(np.zeros(2), gap)], [0, 1], [0.5, 0.5], [0], [2.0])
    assert not check_mobility_certificate(devs, 0.04, [-0.03, 0.0], [(np.zeros(2), gap)], [0, 1], [0.7, 0.7], [0],
                                          [2.0])
    assert not check_mobility_certificate(devs, 0.04, [-0.03, 0.0], [(np.zeros(2), gap)], [0, 1], [0.5, 0.5], [0],
                                          [1.0])


def test_pattern_floats_by_one_shift_and_separate_frames_each_by_their_own(maker, tmp_path):
    # two holes deviating in opposite directions by 0.04 (relative to D's actual axis): one shift cannot
    # help both (the pattern keeps 0.08), separately each is centred within the 0.03 gap (0.02 left)
    holes = (((90.0, 25.0), (0.05, -0.02)), ((60.0, 65.0), (-0.03, -0.02)))
    plan, _, _ = _part(maker, tmp_path, holes=holes, frames=("position dia 0.1 | A | D(M) | E",))
    text = plan.read_text()
    separate = inspect_plan(plan).characteristics
    assert [abs(c.value_mm - 0.02) < 1e-9 for c in separate] == [True, True]
    plan.write_text(text.replace('frame = "position dia 0.1 | A | D(M) | E"',
                                 'frame = "position dia 0.1 | A | D(M) | E"\npattern = "P"'))
    together = inspect_plan(plan).characteristics
    assert all(abs(c.value_mm - 0.08) < 1e-9 for c in together)
    assert np.allclose(together[0].details["datum_shift_mm"][:2], 0.0, atol=1e-9)
    assert together[0].details["pattern_ratio"] == pytest.approx(0.8, abs=1e-9)
    # ASME: simultaneous by default
    plan.write_text(text.replace('standard = "ISO"', 'standard = "ASME"'))
    asme = inspect_plan(plan).characteristics
    assert asme[0].details["pattern"] == "simultaneous A|D(M)|E"


@pytest.mark.parametrize(("side", "modifier", "dia", "boundary", "gap"), [
    ("internal", "M", 10.06, 10.0, 0.03),    # hole at MMB: MIC 10.06 around the 10.00 boundary
    ("internal", "L", 10.06, 10.1, 0.02),    # hole at LMB: MCC 10.06 inside the 10.10 boundary
    ("external", "M", 10.04, 10.1, 0.03),    # pin at MMB: MCC 10.04 inside the 10.10 boundary
    ("external", "L", 10.04, 10.0, 0.02),    # pin at LMB: MIC 10.04 around the 10.00 boundary
])
def test_hole_and_pin_at_mmb_and_lmb(maker, tmp_path, side, modifier, dia, boundary, gap):
    plan, _, _ = _part(maker, tmp_path, datum=(side, (30.0, 25.0), (0.0, 0.0), dia),
                       holes=(((90.0, 25.0), (0.0, 0.05)),), frames=(f"position dia 0.1 | A | D({modifier}) | E",))
    (c,) = inspect_plan(plan).characteristics
    (b,) = c.details["datum_boundaries"]
    assert abs(b["boundary_diameter_mm"] - boundary) < 1e-12 and abs(b["gap_mm"] - gap) < 1e-9
    assert abs(c.value_mm - 2 * (0.05 - gap)) < 1e-9 and c.details["mobility_proven"] == "PROVEN"


def test_a_datum_feature_past_its_boundary_fails_and_a_far_hole_fails_proven(maker, tmp_path):
    plan, _, _ = _part(maker, tmp_path, datum=("internal", (30.0, 25.0), (0.0, 0.0), 9.98),
                       frames=("position dia 0.1 | A | D(M) | E",))
    (c,) = inspect_plan(plan).characteristics
    assert c.verdict == "FAIL" and "violate their boundary" in c.details["reason"]
    plan, _, _ = _part(maker, tmp_path, holes=(((90.0, 25.0), (0.12, 0.0)),))
    (c,) = inspect_plan(plan).characteristics
    assert abs(c.value_mm - 2 * (np.hypot(0.11, 0.02) - 0.03)) < 1e-9
    assert c.verdict == "FAIL" and c.value_mm - c.bound_mm < 1e-9


def test_boundary_diameter_from_the_plan(maker, tmp_path):
    plan, _, _ = _part(maker, tmp_path)
    plan.write_text(plan.read_text().replace('D = "D"', 'D = {feature = "D", boundary_diameter = 9.98}'))
    (c,) = inspect_plan(plan).characteristics
    (b,) = c.details["datum_boundaries"]
    assert abs(b["gap_mm"] - 0.04) < 1e-9
    assert abs(c.value_mm - 2 * (np.hypot(0.04, 0.02) - 0.04)) < 1e-9


def test_refused_by_name(maker, tmp_path):
    plan, _, _ = _part(maker, tmp_path, frames=("position dia 0.1 | A(M) | D | E",))
    with pytest.raises(FileFormatError, match="primary datum referenced RMB"):
        inspect_plan(plan)
    plan, _, _ = _part(maker, tmp_path, frames=("position dia 0.1 | A | E(M) | D",))
    with pytest.raises(FileFormatError, match="datum E: expected a cylinder along the primary"):
        inspect_plan(plan)
    plan, _, _ = _part(maker, tmp_path, frames=("perpendicularity dia 0.1 | A | D(M)",))
    with pytest.raises(FileFormatError, match="position only"):
        inspect_plan(plan)


def _disks_nearest(p, c1, r1, c2, r2):
    """Nearest point to ``p`` in the intersection of two disks (exact: the candidates are p itself, its
    projections onto each disk, and the circles' intersection points); None when they do not meet."""
    cands = [p]
    for c, r in ((c1, r1), (c2, r2)):
        d = p - c
        n = np.linalg.norm(d)
        cands.append(c + d * (r / n) if n > r else p)
    d = np.linalg.norm(c2 - c1)
    if abs(r1 - r2) <= d <= r1 + r2:
        a = (r1 ** 2 - r2 ** 2 + d ** 2) / (2 * d)
        h = np.sqrt(max(r1 ** 2 - a ** 2, 0.0))
        u = (c2 - c1) / d
        mid = c1 + a * u
        cands += [mid + h * np.array([-u[1], u[0]]), mid - h * np.array([-u[1], u[0]])]
    ok = [c for c in cands if np.linalg.norm(c - c1) <= r1 + 1e-15 and np.linalg.norm(c - c2) <= r2 + 1e-15]
    return min(ok, key=lambda c: np.linalg.norm(c - p)) if ok else None


def test_two_datum_holes_at_mmb_let_the_part_turn(maker, tmp_path):
    """A | D(M) | F(M): the part may shift and turn.  Truth: for each rotation the best translation is the
    nearest point of the two boundaries' disks (exact), minimised over the rotation (grid, then Brent)."""
    from scipy.optimize import minimize_scalar

    plan, _, _ = _part(maker, tmp_path, datum=("internal", (30.0, 25.0), (0.0, 0.0), 10.06),
                       tertiary_hole=((90.0, 25.0), (0.0, 0.0), 8.04), holes=(((110.0, 25.0), (0.0, 0.2)),),
                       frames=("position dia 0.1 | A | D(M) | F(M)", "position dia 0.1 | A | D | F"))
    mobile, rmb = inspect_plan(plan).characteristics
    assert abs(rmb.value_mm - 0.4) < 1e-9
    c_d, c_f, h, n_h = np.array([30.0, 25.0]), np.array([90.0, 25.0]), np.array([110.0, 25.2]), np.array([110.0, 25])

    def best(theta):
        r = np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
        a = r @ h - n_h
        t = _disks_nearest(-a, c_d - r @ c_d, 0.03, c_f - r @ c_f, 0.02)
        return np.inf if t is None else 2 * np.linalg.norm(a + t)

    grid = np.linspace(-1e-3, 1e-3, 4001)
    k = int(np.argmin([best(t) for t in grid]))
    truth = minimize_scalar(best, bounds=(grid[max(k - 1, 0)], grid[min(k + 1, 4000)]), method="bounded",
                            options={"xatol": 1e-15}).fun
    assert truth < 0.4 - 0.05  # the turn is worth more than the shifts alone
    assert abs(mobile.value_mm - truth) < 1e-9
    d = mobile.details
    assert d["scope"] == "local" and d["mobility_proven"] == "NOT PROVEN"
    assert d["datum_rotation_rad"] != 0.0 and 0 <= mobile.bound_mm <= mobile.value_mm
    assert [b["label"] for b in d["datum_boundaries"]] == ["D", "F"]


def test_pcmm_inspect_shows_the_modifier_and_the_datum_shift(maker, tmp_path):
    import json

    from pcmm_runner import run_pcmm

    plan, _, _ = _part(maker, tmp_path, holes=(((90.0, 25.0), (0.13, -0.02)),))
    done = run_pcmm("inspect", plan)
    assert done.returncode == 1, done.stderr  # 2 (0.12 - 0.03) = 0.18 > 0.1: FAIL
    row = next(line for line in done.stdout.splitlines() if line.startswith("pos H1 0"))
    assert "A|D(M)|E" in row and "FAIL" in row and "180.000000" in row
    data = json.loads(run_pcmm("inspect", plan, "--json").stdout)
    (c,) = data["characteristics"]
    assert c["datum_modifiers"] == ["RMB", "MMB", "RMB"] and c["mobility_proven"] == "PROVEN"
    assert np.allclose(c["datum_shift_mm"][:2], [-0.03, 0.0], atol=1e-9)


def test_datum_holes_too_far_apart_for_their_boundaries_fail(maker, tmp_path):
    # D and F 60.1 apart against 60 nominal: their boundaries' clearances (0.03 + 0.02) cannot take it up
    plan, _, _ = _part(maker, tmp_path, datum=("internal", (30.0, 25.0), (0.0, 0.0), 10.06),
                       tertiary_hole=((90.0, 25.0), (0.1, 0.0), 8.04), holes=(((110.0, 25.0), (0.0, 0.0)),),
                       frames=("position dia 0.1 | A | D(M) | F(M)",))
    (c,) = inspect_plan(plan).characteristics
    assert c.verdict == "FAIL" and c.details["reason"] == "no motion fits every datum boundary at once"
    assert c.details["feasible"] is False


def test_a_free_rotation_stays_free_with_a_secondary_at_mmb(maker, tmp_path):
    # A | D(M): the part may also turn about D; the best is no worse than with E holding the rotation
    plan, _, _ = _part(maker, tmp_path, holes=(((90.0, 25.0), (0.01, 0.06)),),
                       frames=("position dia 0.1 | A | D(M)", "position dia 0.1 | A | D(M) | E"))
    free, held = inspect_plan(plan).characteristics
    assert free.details["scope"] == "local" and free.value_mm <= held.value_mm + 1e-12
    # the deviation (0, 0.08) from D's axis is across the line D-H: turning about D removes it
    assert free.value_mm < 1e-6 and free.verdict == "PASS"


def test_tertiary_hole_at_mmb_after_a_secondary_face_moves_along_the_face_only(maker, tmp_path):
    # A | E | D(M): E holds y and the rotation, D's boundary lets x move.  D's actual axis is 0.02 off
    # across E (y), so of its 0.03 clearance only sqrt(0.03^2 - 0.02^2) is left along x
    plan, _, _ = _part(maker, tmp_path, holes=(((90.0, 25.0), (0.05, 0.0)),),
                       frames=("position dia 0.1 | A | E | D(M)",))
    (c,) = inspect_plan(plan).characteristics
    travel = np.sqrt(0.03 ** 2 - 0.02 ** 2)
    assert abs(c.value_mm - 2 * (0.04 - travel)) < 1e-9
    assert np.allclose(c.details["datum_shift_mm"][:2], [-travel, 0.0], atol=1e-9)
    assert c.details["mobility_proven"] == "PROVEN"


def test_bonus_and_datum_shift_together(maker, tmp_path):
    # hole at MMC (its 10.05 mating size gives 0.05 bonus) to a datum at MMB (0.03 clearance): 0.12 <= 0.15
    plan, _, _ = _part(maker, tmp_path, holes=(((90.0, 25.0), (0.10, -0.02)),),
                       frames=("position dia 0.1 MMC | A | D(M) | E", "position dia 0.1 MMC | A | D | E"))
    shifted, fixed = inspect_plan(plan).characteristics
    assert abs(shifted.value_mm - 0.12) < 1e-9 and abs(shifted.bonus_mm - 0.05) < 1e-8
    assert shifted.verdict == "PASS" and fixed.verdict == "FAIL" and abs(fixed.value_mm - 0.18) < 1e-9
