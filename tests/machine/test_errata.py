"""DESIGN.md errata 1-4 and 9: the printed seed forms fail, the corrected ones are exact."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.machine.kinematics.dpkm import APPENDIX_E, dpkm_probe
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
    return RigidBodyMachine(Tetrahedron(sliders, seed.tetrahedron.tip_centre), seed.columns,
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
    arms = joints - machine.tetrahedron.tip_centre
    p_a, p_b = arms[0], arms[1]
    correct = np.degrees(np.arccos(p_a @ p_b / (np.linalg.norm(p_a) * np.linalg.norm(p_b))))
    assert correct == pytest.approx(68.51, abs=1e-9)  # Table 3.1 beta_ab
    printed_quotient = p_a @ p_b / np.linalg.norm(p_a - p_b)  # eq 7.4 as printed: not a cosine
    assert printed_quotient > 1.0
