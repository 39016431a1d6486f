"""b_in (eq 7.5): minimum over a laser sweep when one is given; what Table 7.1's b_in needs."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.machine.calibration import calibrate_tetrahedron
from pcmm_geo.machine.calibration.noise import synthesise_probings
from pcmm_geo.machine.calibration.seed import APPENDIX_C, TABLE_7_1, appendix_cd_files
from pcmm_geo.machine.kinematics.model import SliderLine, Tetrahedron

ARMS = ("a", "b", "c")
PAIRS = ("ab", "bc", "ca")
CALIBRATION = np.array([[50.0, 130.0, 135.0], [25.0, 60.0, 70.0], [12.0, 8.0, 9.0]])


def meeting_tetrahedron() -> tuple[Tetrahedron, list[np.ndarray], list[float]]:
    """Slider lines through the tip (the seed's design), unit laser scale: eq 7.5 is then exact."""
    directions = [np.array([-0.66, 0.0, 0.75]), np.array([0.33, 0.57, 0.75]), np.array([0.33, -0.57, 0.75])]
    directions = [w / np.linalg.norm(w) for w in directions]
    offsets = [371.0, 365.0, 372.5]
    tip = np.array([10.0, -5.0, 3.0])
    sliders = {arm: SliderLine(tip, directions[k], 1.0, offsets[k]) for k, arm in enumerate(ARMS)}
    return Tetrahedron(sliders, tip), directions, offsets


def joint_distances(lasers: np.ndarray, directions: list[np.ndarray], offsets: list[float]) -> np.ndarray:
    """Distances between the joints of each pair (M, 3) from the geometry (tip at the origin)."""
    joints = np.stack([(lasers[:, k] + offsets[k])[:, None] * directions[k] for k in range(3)], axis=1)
    return np.stack([np.linalg.norm(joints[:, k] - joints[:, (k + 1) % 3], axis=1) for k in range(3)], axis=1)


def test_b_in_is_the_minimum_over_the_sweep_not_over_the_calibration_positions():
    tetrahedron, directions, offsets = meeting_tetrahedron()
    probings = synthesise_probings(tetrahedron, CALIBRATION, points_per_ball=10)
    # a sweep reaching lower readings than any calibration position (and rows in between)
    sweep = np.array([[40.0, 40.0, 40.0], [5.0, 30.0, 2.0], [2.0, 1.5, 1.0], [90.0, 1.0, 60.0], [60.0, 60.0, 60.0]])
    without = calibrate_tetrahedron(probings, CALIBRATION)
    with_sweep = calibrate_tetrahedron(probings, CALIBRATION, laser_sweep=sweep)
    at_positions = joint_distances(CALIBRATION, directions, offsets)
    over_sweep = joint_distances(sweep, directions, offsets)
    for k, pair in enumerate(PAIRS):
        assert without.b_in[pair] == pytest.approx(at_positions[:, k].min(), abs=1e-6)
        assert without.b_in_sweep_index[pair] == int(np.argmin(at_positions[:, k]))
        assert with_sweep.b_in[pair] == pytest.approx(over_sweep[:, k].min(), abs=1e-6)
        assert with_sweep.b_in_sweep_index[pair] == int(np.argmin(over_sweep[:, k]))
        assert with_sweep.b_in[pair] < without.b_in[pair] - 1.0  # the sweep went lower
    np.testing.assert_array_equal(with_sweep.sweep, sweep)
    # d and beta do not depend on the sweep
    assert with_sweep.dead_distance == without.dead_distance and with_sweep.beta == without.beta


def test_table_7_1_b_in_needs_the_unprinted_sweep():
    """Eq 7.5 at Appendix C's two laser readings, by hand from Table 7.1's d and beta.

    Both calibration positions give 423-428 mm (position 2) and 529-577 mm (position 1);
    Table 7.1's 454-462 mm lie in between: a minimum over a sweep whose lowest readings lay
    between the two positions (thesis 7.2), which the thesis does not print.
    """
    cal = calibrate_tetrahedron(*appendix_cd_files())
    lasers = APPENDIX_C["lasers"]
    for k, (arm, pair) in enumerate(zip(ARMS, PAIRS, strict=True)):
        nxt = ARMS[(k + 1) % 3]
        d_i, beta_deg, b_table = TABLE_7_1[arm]
        length_i = lasers[:, k] + 60.0 + d_i
        length_n = lasers[:, (k + 1) % 3] + 60.0 + TABLE_7_1[nxt][0]
        by_hand = np.sqrt(length_i**2 + length_n**2 - 2 * length_i * length_n * np.cos(np.radians(beta_deg)))
        # Table 7.1 rounds d and beta to 0.01: that moves b by less than 0.05 mm
        assert cal.b_in[pair] == pytest.approx(by_hand.min(), abs=0.05)
        assert cal.b_in_sweep_index[pair] == 1  # the smaller readings of position 2
        assert by_hand[1] < b_table < by_hand[0]
        assert 25.0 < b_table - cal.b_in[pair] < 40.0  # not reproducible from the calibration readings alone
