"""Thermal expansion of the rigid-body machine model against the closed-form physical model."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pcmm_geo.machine.kinematics.model import ColumnLine, MachineLimits, RigidBodyMachine, SliderLine, Tetrahedron
from pcmm_geo.thermal import (
    ThermalMachineGeometry,
    deform_triangle,
    expand_rigid_body_machine,
    frame_corners,
    physical_tip_displacement,
    rigid_body_tip_displacement,
)

SIDE = 265.0 * math.sqrt(3.0)  # the column triangle of ThermalMachineGeometry's default columns


def machine_for(geometry: ThermalMachineGeometry, tip: np.ndarray, heights: np.ndarray) -> RigidBodyMachine:
    """Vertical columns on the geometry's column feet (base z = 0), arms meeting at the tip.

    The "laser reading" of this model is the whole arm length (no offset), so its laser range is the
    seed's 200 mm range moved to the arm lengths around the reference.
    """
    pivots = np.column_stack([geometry.column_xy, heights])
    lengths = np.linalg.norm(pivots - tip, axis=1)
    sliders = {
        arm: SliderLine(point=tip, direction=(pivots[k] - tip) / lengths[k]) for k, arm in enumerate("abc")
    }
    columns = {arm: ColumnLine(point=[*geometry.column_xy[k], 0.0], direction=[0.0, 0.0, 1.0])
               for k, arm in enumerate("abc")}
    return RigidBodyMachine(
        tetrahedron=Tetrahedron(sliders=sliders, tip_center=tip),
        columns=columns,
        reference_lasers=lengths,
        reference_heights=heights,
        limits=MachineLimits(height_travel=[-450.0, 450.0], laser_range=[lengths.min() - 100, lengths.max() + 100]),
    )


def test_deform_triangle_is_eqs_4_4_to_4_9() -> None:
    nominal = frame_corners(650.0, 650.0, 650.0).corners
    rng = np.random.default_rng(44)
    for _ in range(20):
        sides = 650.0 + rng.uniform(-2.0, 2.0, 3)
        np.testing.assert_allclose(deform_triangle(nominal, sides), frame_corners(*sides).corners, atol=1e-10)


@pytest.mark.parametrize("readings", ["heights", "lasers"])
def test_uniform_temperature_matches_closed_form(readings: str) -> None:
    # every member +3 K: the whole machine follows a similarity, whichever readings are held
    geometry = ThermalMachineGeometry(frame_sides=np.full(3, SIDE))
    tip = np.array([18.0, -25.0, 60.0])
    heights = np.array([380.0, 395.0, 410.0])
    warm = {"frame_temperatures": [23.0] * 3, "column_temperatures": [23.0] * 3, "arm_temperatures": [23.0] * 3}
    closed = physical_tip_displacement(geometry, tip, heights, **warm)
    rigid = rigid_body_tip_displacement(machine_for(geometry, tip, heights), tip, readings=readings, **warm)
    assert np.linalg.norm(closed) > 1e-3
    np.testing.assert_allclose(rigid, closed, atol=1e-9)


def test_equal_column_growth_lifts_rigid_tetrahedron() -> None:
    geometry = ThermalMachineGeometry(frame_sides=np.full(3, SIDE))
    tip = np.array([-10.0, 30.0, 75.0])
    heights = np.full(3, 400.0)
    warm = {"column_temperatures": [22.0] * 3}
    closed = physical_tip_displacement(geometry, tip, heights, **warm)
    np.testing.assert_allclose(closed, [0.0, 0.0, 23.1e-6 * 2 * 400.0], atol=1e-11)
    rigid = rigid_body_tip_displacement(machine_for(geometry, tip, heights), tip, **warm)
    np.testing.assert_allclose(rigid, closed, atol=1e-9)


def test_arm_expansion_with_heights_held_does_not_move_the_tip() -> None:
    # slider lines scaled about the tip are the same lines: the rigid body stays, only lasers change
    geometry = ThermalMachineGeometry(frame_sides=np.full(3, SIDE))
    tip = np.array([5.0, 5.0, 90.0])
    heights = np.array([390.0, 400.0, 405.0])
    machine = machine_for(geometry, tip, heights)
    held = rigid_body_tip_displacement(machine, tip, arm_temperatures=[25.0, 18.0, 21.0])
    np.testing.assert_allclose(held, 0.0, atol=1e-9)
    moved = rigid_body_tip_displacement(machine, tip, readings="lasers", arm_temperatures=[25.0, 18.0, 21.0])
    assert np.linalg.norm(moved) > 1e-3


def test_expanded_machine_fields() -> None:
    machine = RigidBodyMachine.from_dpkm()
    hot = expand_rigid_body_machine(machine, arm_temperatures=[21.0, 20.0, 20.0], column_base_heights=[-50.0] * 3,
                                    column_temperatures=[22.0, 20.0, 20.0])
    cold_a, hot_a = machine.tetrahedron.sliders["a"], hot.tetrahedron.sliders["a"]
    assert hot_a.laser_offset == pytest.approx(cold_a.laser_offset * (1 + 23.1e-6), rel=1e-15)
    # the column's fixed end (reading -50) does not move
    np.testing.assert_allclose(hot.columns["a"].pivot(-50.0), machine.columns["a"].pivot(-50.0), atol=1e-12)
    grown = hot.columns["a"].pivot(350.0) - machine.columns["a"].pivot(350.0)
    assert np.linalg.norm(grown) == pytest.approx(23.1e-6 * 2 * 400.0 * machine.columns["a"].encoder_scale, rel=1e-9)
    cold_b, hot_b = machine.tetrahedron.sliders["b"], hot.tetrahedron.sliders["b"]
    np.testing.assert_array_equal(hot_b.point, cold_b.point)
    assert (hot_b.laser_scale, hot_b.laser_offset) == (cold_b.laser_scale, cold_b.laser_offset)
