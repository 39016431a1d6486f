"""Seed probe model (eqs 4.10-4.17) and the physical thermal model of the micro-CMM."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pcmm_geo.errors import InvalidInputError, NoRealSolutionError
from pcmm_geo.thermal import (
    MEMBERS,
    ThermalMachineGeometry,
    expand_frame,
    physical_tip,
    physical_tip_displacement,
    seed_delta_l,
    seed_probe_error,
    thermal_sensitivity_table,
    trilaterate,
)

ALPHA = 23.1e-6
HALF_SPAN = 265.0 * math.sqrt(0.75)
PIVOTS = np.array([[-265.0, 0.0, 400.0], [132.5, HALF_SPAN, 400.0], [132.5, -HALF_SPAN, 400.0]])


def test_seed_model_no_change_is_identity() -> None:
    res = seed_probe_error([12.0, -30.0, 90.0], PIVOTS)
    np.testing.assert_allclose(res.displacement, 0.0, atol=1e-12)


def test_seed_model_vertical_is_mean_column_growth() -> None:
    pivots = PIVOTS.copy()
    pivots[:, 2] = [401.0, 387.3, 381.4]
    res = seed_probe_error([0.0, 0.0, 90.0], pivots, column_temperatures=[21.0, 22.0, 20.0])
    expected = ALPHA * (401.0 * 1 + 387.3 * 2 + 381.4 * 0) / 3
    assert res.displacement[2] == pytest.approx(expected, abs=1e-13)
    np.testing.assert_allclose(res.displacement[:2], 0.0, atol=1e-12)


def test_seed_model_symmetric_arms_cancel_at_centre() -> None:
    # probe on the symmetry axis: the three arms push radially and their average cancels
    res = seed_probe_error([0.0, 0.0, 86.0], PIVOTS, arm_temperatures=[21.0, 21.0, 21.0])
    np.testing.assert_allclose(res.displacement, 0.0, atol=1e-10)


def test_seed_model_single_arm_reach() -> None:
    # arm a only: its plan reach grows from h to sqrt(l'^2 - delta^2); the average moves by a third
    probe = np.array([0.0, 0.0, 86.0])
    res = seed_probe_error(probe, PIVOTS, arm_temperatures=[22.0, 20.0, 20.0])
    length = math.dist(probe, PIVOTS[0])
    drop = 400.0 - 86.0
    reach = math.sqrt((length * (1 + 2 * ALPHA)) ** 2 - drop**2)
    assert res.displacement[0] == pytest.approx((reach - 265.0) / 3, abs=1e-12)
    assert res.displacement[1] == pytest.approx(0.0, abs=1e-12)


def test_trilaterate_known_point() -> None:
    target = np.array([15.035, -206.091, 79.681])
    centres = np.array([[148.59, 3.37, 400.99], [-253.75, -220.11, 387.25], [140.74, -454.53, 381.44]])
    radii = np.linalg.norm(centres - target, axis=1)
    np.testing.assert_allclose(trilaterate(centres, radii, [0, 0, 0]), target, atol=1e-10)
    mirror = trilaterate(centres, radii, [0, 0, 800])
    assert mirror[2] > 400  # the other branch
    with pytest.raises(NoRealSolutionError, match="do not meet"):
        trilaterate(centres, radii * 0.1, [0, 0, 0])


def test_physical_zero_change() -> None:
    geo = ThermalMachineGeometry()
    d = physical_tip_displacement(geo, [30.0, -40.0, 60.0], [400.0, 380.0, 390.0])
    np.testing.assert_allclose(d, 0.0, atol=1e-10)


def test_physical_uniform_temperature_is_similarity() -> None:
    # all members +dT, same alpha: the machine scales by (1 + a dT) about pinned corner A (z = 0) and
    # turns about the z axis through A so that B keeps its y; the tip follows the same similarity.
    geo = ThermalMachineGeometry()
    tip = np.array([25.0, -30.0, 70.0])
    heights = np.array([390.0, 400.0, 410.0])
    dt = 5.0
    moved = physical_tip(
        geo, tip, heights, frame_temperatures=[20 + dt] * 3, column_temperatures=[20 + dt] * 3,
        arm_temperatures=[20 + dt] * 3,
    )
    scale = 1 + ALPHA * dt
    a = np.array([-650 / math.sqrt(3), 0.0])
    b = np.array([650 / (2 * math.sqrt(3)), 325.0])
    # rotation angle phi with a_y + scale * (sin(phi) (b-a)_x + cos(phi) (b-a)_y) = 325
    rel = b - a
    phi = math.asin(325.0 / (scale * math.hypot(*rel))) - math.atan2(rel[1], rel[0])
    rot = np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])
    expected_xy = a + scale * rot @ (tip[:2] - a)
    np.testing.assert_allclose(moved[:2], expected_xy, atol=1e-10)
    assert moved[2] == pytest.approx(scale * tip[2], abs=1e-10)
    # consistency with the frame model: B moved to the same place
    frame = expand_frame([20 + dt] * 3)
    np.testing.assert_allclose(frame.b, a + scale * rot @ rel, atol=1e-10)


def test_physical_equal_columns_lift_tip() -> None:
    geo = ThermalMachineGeometry()
    tip = np.array([20.0, 35.0, 50.0])
    d = physical_tip_displacement(geo, tip, [370.0] * 3, column_temperatures=[23.0] * 3)
    np.testing.assert_allclose(d, [0.0, 0.0, ALPHA * 370.0 * 3], atol=1e-11)
    # the seed model agrees for this case
    seed = seed_probe_error(tip, np.column_stack([geo.column_xy, [370.0] * 3]), column_temperatures=[23.0] * 3)
    np.testing.assert_allclose(seed.displacement, d, atol=1e-11)


def test_physical_matches_linearisation() -> None:
    # first order: u_k . (dp - dP_k) = dL_k, u_k the unit vector pivot -> tip (independent linear solve)
    geo = ThermalMachineGeometry()
    tip = np.array([-20.0, 15.0, 110.0])
    heights = np.array([405.0, 420.0, 398.0])
    pivots = np.column_stack([geo.column_xy, heights])
    units = (tip - pivots) / np.linalg.norm(tip - pivots, axis=1)[:, None]
    lengths = np.linalg.norm(tip - pivots, axis=1)
    d_col = np.array([0.5, -0.3, 0.2])
    d_arm = np.array([-0.4, 0.1, 0.6])
    rhs = units[:, 2] * ALPHA * heights * d_col + ALPHA * lengths * d_arm
    linear = np.linalg.solve(units, rhs)
    exact = physical_tip_displacement(
        geo, tip, heights, column_temperatures=20 + d_col, arm_temperatures=20 + d_arm
    )
    assert np.linalg.norm(exact - linear) < 1e-3 * np.linalg.norm(linear)
    assert np.linalg.norm(linear) > 1e-3  # micrometres, not nothing


def test_sensitivity_table() -> None:
    table = thermal_sensitivity_table(points_per_axis=2)
    assert table.members == MEMBERS
    assert table.positions.shape == (8, 3)
    assert table.displacement_um_per_k.shape == (9, 8, 3)
    summary = {row["member"]: row for row in table.summary()}
    # by symmetry of the default geometry, arms b and c (and columns b and c) behave alike
    assert summary["arm_b"]["max_um_per_k"] == pytest.approx(summary["arm_c"]["max_um_per_k"], rel=1e-6)
    # a single column: linear closed form u_k . dp = u_kz * alpha * z_k at every grid point
    geo = ThermalMachineGeometry()
    for k, tip in enumerate(table.positions):
        heights = np.full(3, tip[2] + geo.pivot_drop)
        pivots = np.column_stack([geo.column_xy, heights])
        units = (tip - pivots) / np.linalg.norm(tip - pivots, axis=1)[:, None]
        rhs = np.zeros(3)
        rhs[0] = units[0, 2] * ALPHA * heights[0]
        linear_um = np.linalg.solve(units, rhs) * 1000
        np.testing.assert_allclose(table.displacement_um_per_k[3, k], linear_um, atol=1e-3)


def test_bad_input() -> None:
    geo = ThermalMachineGeometry()
    with pytest.raises(InvalidInputError, match="shape"):
        physical_tip(geo, [0.0, 0.0], [400.0] * 3)
    with pytest.raises(InvalidInputError, match="points_per_axis"):
        thermal_sensitivity_table(points_per_axis=0)
    with pytest.raises(InvalidInputError, match="shape"):
        seed_probe_error([0, 0, 0], PIVOTS[:2])


def test_table_4_2_vertical_row() -> None:
    # Appendix E inputs: pivot heights z1..z3 and the column lines x = h z + g - erx, y = n z + m - ery
    z = np.array([400.9875133, 387.2532227, 381.4428078])
    x = np.array([0.0075 * z[0] + 148.59 + 0.1601968, 0.0082 * z[1] - 253.75 + 0.12512656,
                  0.0069 * z[2] + 140.74 - 0.271252905109806])
    y = np.array([0.0201 * z[0] + 3.3691 - 0.095144219864, 0.0192 * z[1] - 220.11 + 0.059912,
                  0.0153 * z[2] - 454.53 - 0.031501548041])
    probe = np.array([80.007, -98.917, 126.673])  # Table 4.2, 20 C row
    res = seed_probe_error(probe, np.column_stack([x, y, z]), column_temperatures=[21.0] * 3)
    # eq 4.1 on the mean pivot height reproduces the table's 21 C z (126.682); its "difference" row
    # (0.011) disagrees with its own two rows (0.009)
    assert probe[2] + res.displacement[2] == pytest.approx(126.682, abs=5e-4)  # printed to 3 decimals
    assert res.displacement[2] == pytest.approx(ALPHA * z.mean(), rel=1e-12)
    # the seed's alpha*10*dT would leave z at 126.673
    assert probe[2] + float(np.mean(seed_delta_l(z, 20.0, 21.0))) == pytest.approx(126.673, abs=5e-4)
