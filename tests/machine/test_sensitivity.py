"""Sensitivity over the working cube: closed-form checks, a direct perturbation check, the 20:1 ratio."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.machine.analysis.sensitivity import sensitivity_over_cube, tip_jacobian
from pcmm_geo.machine.kinematics.model import RigidBodyMachine
from pcmm_geo.plots import plot_sensitivity


@pytest.fixture(scope="module")
def seed_sensitivity():
    return sensitivity_over_cube(RigidBodyMachine.from_dpkm(), points_per_axis=3)


def test_vertical_translation_closed_form(seed_sensitivity) -> None:
    # vertical columns: raising all three motors by 1 mm lifts the tip 1 mm and changes no laser
    lift = seed_sensitivity.tip_per_height @ np.ones(3)
    np.testing.assert_allclose(lift, np.tile([0.0, 0.0, 1.0], (27, 1)), atol=1e-7)
    np.testing.assert_allclose(seed_sensitivity.laser_per_height @ np.ones(3), 0.0, atol=1e-7)
    assert np.isinf(seed_sensitivity.path_ratio[2])


def test_level_pivots_are_a_laser_singularity(seed_sensitivity) -> None:
    # the cube centre is the reference pose with level pivots: pivot distances change only to
    # second order, so dL/dh = 0 there and along the vertical through it
    central = np.linalg.norm(seed_sensitivity.points[:, :2] - seed_sensitivity.centre[:2], axis=1) < 1e-6
    assert central.sum() == 3
    assert np.abs(seed_sensitivity.laser_per_height[central]).max() < 1e-6
    assert np.all(np.isinf(seed_sensitivity.laser_gain[central]))
    assert np.all(np.isfinite(seed_sensitivity.laser_gain[~central]))
    # second order: a 10 mm move of motor a from the level pose changes the lasers by far less than 1 mm
    machine = RigidBodyMachine.from_dpkm()
    level = machine.forward(heights=machine.reference_heights).lasers
    moved = machine.forward(heights=machine.reference_heights + np.array([10.0, 0.0, 0.0])).lasers
    assert np.abs(moved - level).max() < 0.5


def test_tip_per_laser_predicts_forward_from_lasers() -> None:
    machine = RigidBodyMachine.from_dpkm()
    heights = machine.reference_heights + np.array([[0.0, 50.0, -40.0]])
    jx, jl, tips, lasers = tip_jacobian(machine, heights)
    gain = jx[0] @ np.linalg.pinv(jl[0], rcond=1e-6)
    rng = np.random.default_rng(8)
    for _ in range(3):
        delta = rng.normal(0.0, 1e-3, 3)
        # consistent laser change: a height change that the lasers can see
        dh = np.linalg.pinv(jl[0], rcond=1e-6) @ delta
        true_lasers = machine.forward(heights=heights[0] + dh).lasers
        solved = machine.forward(lasers=true_lasers, heights_hint=heights[0])
        predicted = tips[0] + gain @ (true_lasers - lasers[0])
        assert np.linalg.norm(solved.tip - predicted) < 1e-3 * np.linalg.norm(solved.tip - tips[0]) + 1e-9


def test_probe_to_laser_ratio_matches_thesis_order(seed_sensitivity) -> None:
    # thesis 6.x: 100 mm of probe travel showed about 5 mm on the laser (20:1)
    assert seed_sensitivity.path_ratio[0] > 10.0 and seed_sensitivity.path_ratio[1] > 10.0
    finite = seed_sensitivity.laser_gain[np.isfinite(seed_sensitivity.laser_gain)]
    assert np.median(finite) > 2.0  # lasers of 0.05 mm give tip errors of 0.1 mm or worse
    summary = seed_sensitivity.summary()
    assert summary["laser_gain"]["infinite"] == 3 and summary["points"] == 27
    np.testing.assert_allclose(seed_sensitivity.tip_error, 0.05 * seed_sensitivity.laser_gain)


def test_plot_and_errors(tmp_path: Path, seed_sensitivity) -> None:
    out = plot_sensitivity(seed_sensitivity, tmp_path / "sens.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(FileExistsError):
        plot_sensitivity(seed_sensitivity, out)
    with pytest.raises(InvalidInputError, match="points_per_axis"):
        sensitivity_over_cube(points_per_axis=1)
    with pytest.raises(InvalidInputError, match="size"):
        sensitivity_over_cube(size=-1.0)
