"""The simulated micro-CMM: kinematics mapping, gauge-block contact, the seed's defects."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.acquisition.simulators.cmm import GaugeBlock, SimulatedMicroCMM
from pcmm_geo.errors import InvalidInputError

MICROSTEP = 6.35 / 12800


def _forward(cmm: SimulatedMicroCMM, positions) -> object:
    machine = cmm.machine
    heights = machine.reference_heights + (np.asarray(positions, dtype=float) - 247500) * MICROSTEP
    return machine.forward(heights=heights, lasers_hint=machine.reference_lasers)


def test_gauge_block_clearance_closed_form() -> None:
    block = GaugeBlock.aligned([10.0, 0.0, 0.0], size=[9.0, 100.0, 35.0])
    assert block.clearance([10.0 + 4.5 + 2.0, 3.0, -1.0]) == pytest.approx(2.0)
    assert block.clearance([10.0, 0.0, 17.5 + 0.25]) == pytest.approx(0.25)
    assert block.clearance([10.0, 0.0, 0.0]) == pytest.approx(-4.5)
    with pytest.raises(InvalidInputError, match="gauge block"):
        GaugeBlock.aligned([0.0, 0.0], size=[1.0, 1.0, 1.0])


def test_motor_positions_map_to_model_heights() -> None:
    cmm = SimulatedMicroCMM()
    start = _forward(cmm, [247500, 247500, 247500])
    np.testing.assert_allclose(cmm.true_lasers, start.lasers, atol=1e-9)
    assert cmm.move(3, 247500, 257500) == 257500
    moved = _forward(cmm, [247500, 247500, 257500])
    np.testing.assert_allclose(cmm.true_lasers, moved.lasers, atol=1e-9)
    np.testing.assert_allclose(cmm.tip, moved.tip, atol=1e-9)
    assert not cmm.contact()


def test_dead_spot_of_about_four_mm() -> None:
    cmm = SimulatedMicroCMM(dead_spot=4.0)
    before = cmm.true_lasers
    three_mm = round(3.0 / MICROSTEP)
    cmm.move(1, 247500, 247500 + three_mm)
    np.testing.assert_allclose(cmm.true_lasers, before, atol=1e-9)  # the tetrahedron has not moved yet
    without_play = _forward(cmm, [247500 + three_mm, 247500, 247500]).lasers
    assert np.max(np.abs(without_play - before)) > 1e-3  # a rigid machine would have moved
    five_mm = round(5.0 / MICROSTEP)
    cmm.move(1, 247500 + three_mm, 247500 + five_mm)
    expected = _forward(cmm, [247500 + five_mm, 247500, 247500])
    np.testing.assert_allclose(cmm.true_lasers, expected.lasers, atol=1e-9)


def test_settling_scatter_within_seed_range() -> None:
    cmm = SimulatedMicroCMM(settle_scatter=0.45, seed=7)
    offsets = []
    for k in range(40):
        cmm.move(2, 247500 + 1000 * (k % 2), 247500 + 1000 * ((k + 1) % 2))
        offsets.append([cmm.laser(i) - cmm.true_lasers[i] for i in range(3)])
    offsets_arr = np.array(offsets)
    assert np.all(np.abs(offsets_arr) <= 0.225 + 1e-12)
    assert np.all(np.ptp(offsets_arr, axis=0) > 0.3)  # Table 6.7: ranges of 0.29-0.45 mm


def test_laser_noise_is_seeded_gaussian() -> None:
    first = SimulatedMicroCMM(laser_noise=0.002, seed=3)
    second = SimulatedMicroCMM(laser_noise=0.002, seed=3)
    a = np.array([first.laser(0) for _ in range(4000)])
    b = np.array([second.laser(0) for _ in range(4000)])
    np.testing.assert_array_equal(a, b)
    assert np.std(a) == pytest.approx(0.002, rel=0.05)
    assert np.mean(a) == pytest.approx(first.true_lasers[0], abs=1e-4)


def test_move_into_block_stops_at_contact_and_deeper_moves_are_blocked() -> None:
    cmm = SimulatedMicroCMM()
    cmm.place_gauge_block(cmm.block_next_to_tip(gap=0.5))
    final = cmm.move(1, 247500, 247500 + 20000)
    assert 247500 < final < 267500 and cmm.contact()
    assert cmm.move(1, final, final + 5000) == final  # pushing further does not move
    assert cmm.move(1, final, final - 5000) == final - 5000 and not cmm.contact()


def test_retreat_inside_the_dead_spot_keeps_the_contact() -> None:
    # seed ch. 6: the tetrahedron only follows a pivot after ~4 mm, so a 2 mm retreat does not free the probe
    cmm = SimulatedMicroCMM(dead_spot=4.0)
    cmm.place_gauge_block(cmm.block_next_to_tip(gap=0.5))
    final = cmm.move(1, 247500, 247500 + round(8.0 / MICROSTEP))
    assert cmm.contact()
    two_mm = round(2.0 / MICROSTEP)
    assert cmm.move(1, final, final - two_mm) == final - two_mm and cmm.contact()
    assert cmm.move(1, final - two_mm, final - 3 * two_mm) == final - 3 * two_mm and not cmm.contact()
