"""DESIGN.md errata 1-4 and 9 and docs/errata.md F7-F11, F13: the printed seed forms fail, the corrected ones hold."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.machine.calibration import calibrate_tetrahedron
from pcmm_geo.machine.calibration.probings import read_probings
from pcmm_geo.machine.calibration.seed import (
    APPENDIX_C,
    APPENDIX_D,
    TABLE_7_1,
    appendix_cd_files,
    reconstruct_appendix_cd,
)
from pcmm_geo.machine.kinematics.dpkm import APPENDIX_E, _eliminate, dpkm_probe
from pcmm_geo.machine.kinematics.model import ARMS, RigidBodyMachine, SliderLine, Tetrahedron
from pcmm_geo.machine.kinematics.seed_forms import seed_probe_roots_as_printed
from pcmm_geo.machine.kinematics.trilateration import trilaterate

# a consistent configuration: pivot a at 400 mm (z_a != 0 matters for erratum 4), probe below; the frame
# is shifted 60 mm in y because erratum 1 (the sign of 2 y_a) vanishes when pivot a sits on y = 0
SHIFT = np.array([0.0, 60.0, 0.0])
PIVOTS = np.array([[-265.0, 3.0, 400.0], [128.0, 232.0, 385.0], [131.0, -228.0, 392.0]]) + SHIFT
TIP = np.array([14.0, -9.0, 75.0]) + SHIFT
LENGTHS = np.linalg.norm(PIVOTS - TIP, axis=1)
FIXED = {"eq_2_17_as_printed": False, "eq_2_21_as_printed": False, "appendix_e_root": False, "absolute_heights": False}


def sphere_misfit(point: np.ndarray) -> float:
    return float(np.abs(np.linalg.norm(PIVOTS - point, axis=1) - LENGTHS).max())


def best_root_error(**flags: bool) -> float:
    roots, disc = seed_probe_roots_as_printed(PIVOTS, LENGTHS, **{**FIXED, **flags})
    if disc < 0:
        return float("inf")
    return min(sphere_misfit(root.real) for root in roots)


def test_all_errata_fixed_reproduce_the_true_point() -> None:
    roots, disc = seed_probe_roots_as_printed(PIVOTS, LENGTHS, **FIXED)
    assert disc > 0
    assert min(np.linalg.norm(root.real - TIP) for root in roots) < 1e-9
    np.testing.assert_allclose(dpkm_probe(PIVOTS, LENGTHS).point, TIP, atol=1e-9)


@pytest.mark.parametrize(
    "flag", ["eq_2_17_as_printed", "eq_2_21_as_printed", "appendix_e_root", "absolute_heights"]
)
def test_each_printed_form_breaks_the_sphere_equations(flag: str) -> None:
    assert best_root_error(**{flag: True}) > 1.0  # mm: no root of the printed form lies on the three spheres


def test_erratum_4_appendix_e_no_real_solution() -> None:
    # Appendix E's code: eqs 2.17 and 2.21 right, but absolute heights fed to a z_a = 0 derivation
    roots, disc = seed_probe_roots_as_printed(
        APPENDIX_E["pivots"], APPENDIX_E["lengths"], eq_2_17_as_printed=False, eq_2_21_as_printed=False,
        appendix_e_root=False, absolute_heights=True,
    )
    assert disc == pytest.approx(-2.9e5, rel=0.02)
    assert np.all(np.abs(roots.imag[:, 1]) > 1.0)  # genuinely complex
    # Table 4.2, 20 degC: (80.007, -98.917, 126.673) is the real part of that complex root
    np.testing.assert_allclose(roots[0].real, [80.007, -98.917, 126.673], atol=0.04)
    np.testing.assert_allclose(roots[1].real, roots[0].real, atol=1e-9)
    # the correct trilateration of the same pivots and lengths: lower root
    np.testing.assert_allclose(dpkm_probe(APPENDIX_E["pivots"], APPENDIX_E["lengths"]).point,
                               [15.035, -206.091, 79.681], atol=5e-4)
    np.testing.assert_allclose(trilaterate(APPENDIX_E["pivots"], APPENDIX_E["lengths"]).point,
                               [15.035, -206.091, 79.681], atol=5e-4)


def test_erratum_3_root_with_minus_one_is_not_table_4_2() -> None:
    roots, _ = seed_probe_roots_as_printed(
        APPENDIX_E["pivots"], APPENDIX_E["lengths"], eq_2_17_as_printed=False, eq_2_21_as_printed=False,
        appendix_e_root=True, absolute_heights=True,
    )
    # with the printed "-1" the real part is far from Table 4.2 -> the original code used -l (= -v)
    assert np.linalg.norm(roots[0].real - [80.007, -98.917, 126.673]) > 50.0


def skewed_seed(offset_mm: float) -> RigidBodyMachine:
    """Seed geometry whose slider lines are moved sideways by ``offset_mm``: they no longer meet the tip."""
    seed = RigidBodyMachine.from_dpkm()
    sliders = {}
    for k, arm in enumerate(ARMS):
        s = seed.tetrahedron.sliders[arm]
        sideways = np.cross(s.direction, np.eye(3)[k])
        sideways /= np.linalg.norm(sideways)
        sliders[arm] = SliderLine(s.point + offset_mm * sideways, s.direction, s.laser_scale, s.laser_offset)
    return RigidBodyMachine(Tetrahedron(sliders, seed.tetrahedron.tip_center), seed.columns,
                            seed.reference_lasers, seed.reference_heights)


def test_erratum_9_dead_distance_depends_on_slider_position() -> None:
    machine = skewed_seed(5.0)
    lasers = np.linspace(0.0, 200.0, 5)[:, None] * np.ones(3)
    dead = machine.tetrahedron.dead_distance(lasers) - lasers - 60.0  # seed "dead distance" per position
    # closed form: sqrt(s^2 + 5^2) - laser - 60, with s = laser + 60 + d: varies with the laser
    s = lasers + machine.tetrahedron.sliders["a"].laser_offset - 0 * lasers
    np.testing.assert_allclose(dead[:, 0], np.sqrt(s[:, 0] ** 2 + 25.0) - lasers[:, 0] - 60.0, atol=1e-9)
    assert np.ptp(dead[:, 0]) > 1e-3
    # the rigid-body model stays exact, the sphere model with any constant dead distance does not
    centre = machine.forward(heights=machine.reference_heights).tip
    tips = centre + np.random.default_rng(9).uniform(-50, 50, (100, 3))
    inv = machine.inverse(tips)
    assert np.abs(machine.forward(lasers=inv.lasers, heights=inv.heights).tip - tips).max() < 1e-9
    mean_dead = machine.tetrahedron.dead_distance(inv.lasers).mean(axis=0) - inv.lasers.mean(axis=0)
    spheres = trilaterate(machine.pivots(inv.heights), inv.lasers + mean_dead).point
    assert np.abs(spheres - tips).max() > 1e-3


def test_erratum_6_angle_between_arms() -> None:
    # arm vectors P_i = joint_i - tip of the seed geometry at mid-range lasers
    machine = RigidBodyMachine.from_dpkm()
    joints = machine.joints([100.0, 100.0, 100.0])
    arms = joints - machine.tetrahedron.tip_center
    p_a, p_b = arms[0], arms[1]
    correct = np.degrees(np.arccos(p_a @ p_b / (np.linalg.norm(p_a) * np.linalg.norm(p_b))))
    assert correct == pytest.approx(68.51, abs=1e-9)  # Table 3.1 beta_ab
    printed_quotient = p_a @ p_b / np.linalg.norm(p_a - p_b)  # eq 7.4 as printed: not a cosine
    assert printed_quotient > 1.0


# ---------------------------------------------------------------------------------------------------------
# Further findings F7-F9: eqs 2.12-2.17 transcribed in the thesis' notation (i = a, in = b, ip = c, heights
# relative to pivot i as eqs 2.3-2.4 define them).  Each flag puts back one printed expression; without flags
# the forms are the ones derived from the sphere equations (docs/errata.md F7-F9).
PRINTED_CH2 = ("eq_2_12", "eq_2_13", "eq_2_15", "eq_2_17_2DF")


def thesis_eqs_2_9_to_2_18(pivots: np.ndarray, lengths: np.ndarray, printed: tuple[str, ...] = (),
                           z_ip_sign: float = 1.0) -> tuple[np.ndarray, dict[str, float]]:
    """Both roots of eqs 2.9-2.18 (eq 2.11 z = F - D y, eq 2.14 as printed); ``z_ip_sign=-1`` reverses z_ip."""
    p = np.array(pivots, dtype=float)
    datum = p[0, 2]
    p[:, 2] -= datum
    c_i, c_n, c_p = lengths**2 - np.sum(p**2, axis=1)  # eq 2.21 corrected (erratum 2)
    (x_i, y_i, _), (x_n, y_n, z_n), (x_p, y_p, z_p) = p
    z_p *= z_ip_sign
    if "eq_2_12" in printed:
        a = ((c_n - c_i) / (2 * z_n) - (c_i - c_p) / (2 * z_p)) / ((x_i - x_p) / z_p - (x_n - x_i) / z_n)
    else:
        a = ((c_n - c_i) / (2 * z_n) - (c_p - c_i) / (2 * z_p)) / ((x_p - x_i) / z_p - (x_n - x_i) / z_n)
    if "eq_2_13" in printed:
        b = ((y_i - y_n) / z_p - (y_p - y_i) / z_n) / ((x_i - x_p) / z_p - (x_n - x_i) / z_n)
    else:
        b = ((y_p - y_i) / z_p - (y_n - y_i) / z_n) / ((x_p - x_i) / z_p - (x_n - x_i) / z_n)
    d = (y_n - y_i) / z_n - b * (x_n - x_i) / z_n  # eq 2.14
    if "eq_2_15" in printed:
        f = a * (x_n - x_i) / z_n - (c_n - c_i) / (2 * z_n)
    else:
        f = -a * (x_n - x_i) / z_n - (c_n - c_i) / (2 * z_n)
    u = 1 + b**2 + d**2
    v = (2.0 if "eq_2_17_2DF" in printed else -2.0) * d * f + 2 * x_i * b - 2 * a * b - 2 * y_i
    w = a**2 + f**2 - 2 * x_i * a - c_i
    disc = v**2 - 4 * u * w
    ys = (-v + np.array([1.0, -1.0]) * np.sqrt(complex(disc))) / (2 * u)
    roots = np.array([[a - b * y, y, f - d * y + datum] for y in ys])
    return roots, {"A": a, "B": b, "D": d, "F": f, "discriminant": disc}


def test_f7_f9_derived_forms_reproduce_the_point_and_match_appendix_e() -> None:
    roots, coef = thesis_eqs_2_9_to_2_18(PIVOTS, LENGTHS)
    assert coef["discriminant"] > 0
    assert min(np.linalg.norm(root.real - TIP) for root in roots) < 1e-9
    # pcmm_geo's elimination (dpkm._eliminate: Appendix E lines 67-70 with erratum 4 fixed) is the same
    relative = PIVOTS.copy()
    relative[:, 2] -= PIVOTS[0, 2]
    a_code, b_code, d_code, f_code, _ = _eliminate(relative, LENGTHS, -1.0)
    assert (a_code, b_code, f_code) == pytest.approx((coef["A"], coef["B"], coef["F"]), rel=1e-12)
    assert d_code == pytest.approx(-coef["D"], rel=1e-12)  # Appendix E's D is minus eq 2.14's (z = F + D y)


@pytest.mark.parametrize("printed", PRINTED_CH2)
def test_f7_f9_each_printed_expression_breaks_the_sphere_equations(printed: str) -> None:
    roots, coef = thesis_eqs_2_9_to_2_18(PIVOTS, LENGTHS, (printed,))
    misfit = np.inf if coef["discriminant"] < 0 else min(sphere_misfit(root.real) for root in roots)
    assert misfit > 1.0  # mm: no root of the printed form lies on the three spheres


def test_f7_eqs_2_12_2_13_are_written_for_the_opposite_sign_of_z_ip() -> None:
    _, derived = thesis_eqs_2_9_to_2_18(PIVOTS, LENGTHS)
    # printed eq 2.12 is the derived A with z_ip = z_i - z_ip (against eq 2.4: z_ip = z_i + dz_ip) ...
    _, printed = thesis_eqs_2_9_to_2_18(PIVOTS, LENGTHS, ("eq_2_12",), z_ip_sign=-1.0)
    assert printed["A"] == pytest.approx(derived["A"], rel=1e-12)
    # ... and printed eq 2.13 is the derived B with that z_ip and y_in, y_ip swapped back
    swapped = PIVOTS[[0, 2, 1]].copy()
    swapped[:, [0, 2]] = PIVOTS[:, [0, 2]]  # exchange only the y of pivots b (in) and c (ip)
    _, printed_b = thesis_eqs_2_9_to_2_18(swapped, LENGTHS, ("eq_2_13",), z_ip_sign=-1.0)
    assert printed_b["B"] == pytest.approx(derived["B"], rel=1e-12)
    # with the z_ip of eq 2.4 the printed A is simply wrong
    _, as_printed = thesis_eqs_2_9_to_2_18(PIVOTS, LENGTHS, ("eq_2_12",))
    assert abs(as_printed["A"] - derived["A"]) > 1.0


# ---------------------------------------------------------------------------------------------------------
# F10: eq 7.3 prints L = l + d; Appendix C lines 83-88 compute d = |P_i - P_0| - l - 60 and Table 7.1's d is
# the mean of those (thesis 7.3: "the dead distance excludes ... 60 mm").


def test_f10_eq_7_3_needs_the_60_mm_start_of_range() -> None:
    # Table 7.1's d is the mean of Appendix D's D1 rows (printed independently)
    table = np.array([TABLE_7_1[arm][0] for arm in "abc"])
    np.testing.assert_allclose(APPENDIX_D["D1"].mean(axis=0), table, atol=0.005)
    # the tip-to-joint distances of the rebuilt CMM data are l + 60 + D1, not l + D1 (printed eq 7.3)
    features = read_probings(appendix_cd_files()[0])
    reach = np.linalg.norm(features.centers() - features.tip.center, axis=2)
    np.testing.assert_allclose(reach - APPENDIX_C["lasers"] - APPENDIX_D["D1"], 60.0, atol=6e-5)
    # pcmm_geo: laser_start_of_range=60 (default) gives Table 7.1; the printed eq 7.3 (no start of range)
    # gives d 60 mm larger than the thesis reports
    cal = calibrate_tetrahedron(*appendix_cd_files())
    printed = calibrate_tetrahedron(*appendix_cd_files(), laser_start_of_range=0.0)
    for k, arm in enumerate("abc"):
        assert cal.dead_distance[arm] == pytest.approx(table[k], abs=0.01)
        assert printed.dead_distance[arm] - table[k] == pytest.approx(60.0, abs=0.01)


# ---------------------------------------------------------------------------------------------------------
# F11: Table 6.8's header reads l/h, eq 6.3 defines ratio = dh/dl; the thesis geometry settles which.
TABLE_6_8 = np.array([[5.03, 6.20, 5.53], [5.12, 6.31, 5.58], [5.39, 6.34, 5.61], [5.39, 6.30, 5.58],
                      [5.56, 6.41, 5.65]])


def test_f11_table_6_8_holds_height_over_laser() -> None:
    machine = RigidBodyMachine.from_dpkm()
    ratios = []
    # one pivot raised 100 mm, the others at 400 mm (thesis 6.3: 0-100 mm); starts inside the column travel
    # (277.22-727.22 mm, machine.limits)
    for start in (280.0, 300.0, 320.0):
        for k in range(3):
            before, after = np.full(3, 400.0), np.full(3, 400.0)
            before[k], after[k] = start, start + 100.0
            delta_l = machine.forward(heights=after).lasers[k] - machine.forward(heights=before).lasers[k]
            ratios.append(abs(100.0 / delta_l))
    # a pivot moves 3.8-9.2 times as far as its laser: dh/dl >> 1, so l/h (header) would be 0.11-0.26
    assert 2.5 < min(ratios) and max(ratios) < 10.0
    assert np.all(TABLE_6_8 > 1.0)  # the printed values are > 1: they are dh/dl (eq 6.3), not l/h
    assert min(ratios) < TABLE_6_8.min() and TABLE_6_8.max() < max(ratios)
    assert max(1.0 / r for r in ratios) < 0.4  # what an l/h column would hold


# ---------------------------------------------------------------------------------------------------------
# F13: Appendix C's probe2 against D1, D2 and Beta (frame-independent check).


def test_f13_probe2_is_not_the_theoretical_probe_point_of_d2() -> None:
    rebuilt = reconstruct_appendix_cd()
    lasers, probe2 = APPENDIX_C["lasers"], APPENDIX_C["probe2"]
    # Appendix C lines 29-39 move the tip to the origin and lines 106-111 use probe2 in that frame
    assert np.linalg.norm(probe2) == pytest.approx(302.147, abs=1e-3)
    # the joints relative to the tip are fixed by D1 and Beta (up to rotation and reflection, which keep every
    # distance); the points at the printed D2 distances from the three joints of one position are two:
    for k, near, far in ((0, 38.868, 692.485), (1, 38.868, 548.555)):
        found = trilaterate(rebuilt.centers[k], APPENDIX_D["D2"][k] + lasers[k] + 60.0)
        distances = sorted(float(np.linalg.norm(point)) for point in (found.lower, found.upper))
        assert distances == pytest.approx([near, far], abs=1e-3)
        assert min(abs(d - np.linalg.norm(probe2)) for d in distances) > 240.0
    # evaluated with probe2, lines 106-111 would print D2 201-304 mm larger (v1 as printed) ...
    printed_frame = rebuilt.centers * np.array([1.0, 1.0, -1.0])
    excess = np.linalg.norm(printed_frame - probe2, axis=2) - lasers - 60.0 - APPENDIX_D["D2"]
    assert 200.0 < excess.min() and excess.max() < 305.0
    # ... and in the machine's axes (v1 with z reversed) 150 mm smaller to 66 mm larger: neither frame fits
    excess = np.linalg.norm(rebuilt.centers - probe2, axis=2) - lasers - 60.0 - APPENDIX_D["D2"]
    assert excess.min() < -145.0 and excess.max() > 60.0
    # the theoretical point that does fit D2 is the rebuild's (and pcmm_geo's eq 7.2 point, 2e-3 mm away)
    assert np.linalg.norm(rebuilt.theoretical_probe) == pytest.approx(38.868, abs=1e-3)
