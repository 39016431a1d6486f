"""Workspace, travel and laser-range limits of the rigid-body model (issue 16 part 3).

Truth used here: the thesis' figures (450 mm column travel, 200 mm laser range from a 60 mm start
of range, park position 247 500 microsteps of 6.35 mm / 12 800 above home), readings constructed by
the inverse kinematics, and closed-form arm spans (``laser + 60 + d_i``).
"""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest
from pcmm_runner import run_pcmm

from pcmm_geo.errors import InconsistentMeasurementError, InvalidInputError, NoRealSolutionError, OutOfRangeError
from pcmm_geo.machine.kinematics.dpkm import TABLE_3_1_DEAD_DISTANCE
from pcmm_geo.machine.kinematics.limits import (
    COLUMN_TRAVEL,
    LASER_MEASURING_RANGE,
    PARK_ABOVE_HOME,
    MachineLimits,
    arm_spans,
)
from pcmm_geo.machine.kinematics.model import RigidBodyMachine

SEED = RigidBodyMachine.from_dpkm()
LOW = 400.0 - 247_500 * 6.35 / 12_800  # the seed's reference heights (400 mm) sit at the park position
HIGH = LOW + 450.0


def reference_tip() -> np.ndarray:
    return SEED.forward(heights=SEED.reference_heights).tip


def test_seed_limits_are_the_thesis_figures() -> None:
    assert COLUMN_TRAVEL == 450.0 and LASER_MEASURING_RANGE == 200.0
    assert PARK_ABOVE_HOME == pytest.approx(122.783203125, abs=1e-12)
    np.testing.assert_allclose(SEED.limits.height_travel, [[LOW, HIGH]] * 3, atol=1e-12)
    np.testing.assert_allclose(SEED.limits.laser_range, [[0.0, 200.0]] * 3, atol=0)
    # arm length = laser + 60 + d_i: the span over the laser range is [60 + d, 260 + d]
    spans = arm_spans(SEED.geometry, SEED.limits)
    dead = np.array([TABLE_3_1_DEAD_DISTANCE[arm] for arm in "abc"])
    np.testing.assert_allclose(spans, np.column_stack([60.0 + dead, 260.0 + dead]), atol=1e-9)


@pytest.mark.parametrize("height", [5000.0, -5000.0, HIGH + 1e-6, LOW - 1e-6])
def test_heights_outside_the_travel_raise(height: float) -> None:
    with pytest.raises(OutOfRangeError) as info:
        SEED.forward(heights=[height, 400.0, 400.0])
    assert info.value.quantity.startswith("heights[0] (column a")
    assert info.value.low == pytest.approx(LOW, abs=1e-9) and info.value.high == pytest.approx(HIGH, abs=1e-9)
    assert info.value.value == pytest.approx(height, abs=1e-6) and info.value.index == (0,)


def test_heights_at_the_travel_ends_are_accepted_and_move_the_tip_by_the_travel() -> None:
    bottom = SEED.forward(heights=[LOW] * 3)
    top = SEED.forward(heights=[HIGH] * 3)
    assert bottom.converged and top.converged
    # vertical columns: the level tetrahedron slides 450 mm, its lasers do not change
    np.testing.assert_allclose(top.tip - bottom.tip, [0.0, 0.0, 450.0], atol=1e-9)
    np.testing.assert_allclose(top.lasers, SEED.reference_lasers, atol=1e-9)


def test_heights_within_travel_whose_pose_needs_a_laser_beyond_its_range_raise() -> None:
    with pytest.raises(OutOfRangeError) as info:
        SEED.forward(heights=[300.0, 700.0, 300.0])
    assert "implied by the heights" in info.value.quantity and info.value.high == 200.0
    unchecked = SEED.forward(heights=[300.0, 700.0, 300.0], check_limits=False)
    assert unchecked.lasers.max() > 200.0 and unchecked.converged  # a real pose, beyond the lasers


@pytest.mark.parametrize("tip", [[2000.0, 0.0, 90.0], [0.0, 0.0, 2000.0], [0.0, 0.0, -2000.0], [0.0, 0.0, 600.0]])
def test_targets_outside_the_workspace_raise(tip: list[float]) -> None:
    with pytest.raises(OutOfRangeError) as info:
        SEED.inverse(tip)
    assert "tip" in info.value.quantity


def test_far_target_distance_is_reported_against_the_arm_span() -> None:
    with pytest.raises(OutOfRangeError) as info:
        SEED.inverse([2000.0, 0.0, 90.0])
    assert info.value.quantity == "distance of tip from column a"
    # closest point of column a's travel segment (x = -268.15, y = 0.77, z in [277.2, 727.2]) to the target
    expected = np.hypot(np.hypot(2000.0 + 268.1534609325, 0.77453872875), LOW - 90.0)
    assert info.value.value == pytest.approx(expected, abs=1e-6)
    assert info.value.high == pytest.approx(260.0 + TABLE_3_1_DEAD_DISTANCE["a"], abs=1e-9)


def test_unchecked_inverse_of_an_unreachable_target_never_says_converged() -> None:
    far = SEED.inverse([2000.0, 0.0, 90.0], check_limits=False)
    assert not far.converged
    high = SEED.inverse([0.0, 0.0, 2000.0], check_limits=False)  # solvable equations, outside the travel
    assert high.converged and high.heights.min() > HIGH


def test_unreachable_lasers_are_out_of_range_or_inconsistent() -> None:
    with pytest.raises(OutOfRangeError) as info:
        SEED.forward(lasers=[250.0, 250.0, 250.0])
    assert info.value.quantity.startswith("lasers[0] (laser a measuring range)") and info.value.high == 200.0
    # in range, but no pose has all three arms this long: the solve would move the lasers by ~150 mm
    with pytest.raises(InconsistentMeasurementError) as bad:
        SEED.forward(lasers=[200.0, 200.0, 200.0])
    assert bad.value.residual > 100.0 and bad.value.tolerance == 0.25
    unchecked = SEED.forward(lasers=[200.0, 200.0, 200.0], check_limits=False)
    assert not unchecked.converged
    assert np.abs(unchecked.lasers - 200.0).max() > 100.0  # what the old code silently returned


def test_closure_tolerance_separates_consistent_from_inconsistent_readings() -> None:
    inv = SEED.inverse(reference_tip() + np.array([10.0, -15.0, 5.0]))
    ok = SEED.forward(lasers=inv.lasers + np.array([0.05, 0.0, 0.0]), heights=inv.heights)  # the lasers' accuracy
    assert ok.converged and 0.0 < np.abs(ok.residuals).max() < 0.25
    with pytest.raises(InconsistentMeasurementError) as info:
        SEED.forward(lasers=inv.lasers + np.array([5.0, 0.0, 0.0]), heights=inv.heights)
    assert info.value.residual > 0.25 and "lasers and heights" in info.value.what


def test_batch_errors_name_the_offending_index() -> None:
    tips = reference_tip() + np.zeros((4, 2, 3))
    inv = SEED.inverse(tips)
    heights = inv.heights.copy()
    heights[3, 1, 2] = 5000.0
    with pytest.raises(OutOfRangeError) as info:
        SEED.forward(heights=heights)
    assert info.value.index == (3, 1, 2) and info.value.quantity.startswith("heights[3, 1, 2] (column c")
    lasers = inv.lasers.copy()
    lasers[2, 0, 1] += 3.0
    with pytest.raises(InconsistentMeasurementError) as bad:
        SEED.forward(lasers=lasers, heights=inv.heights)
    assert bad.value.index == (2, 0) and "[2, 0]" in bad.value.what
    targets = tips.copy()
    targets[1, 1] = [2000.0, 0.0, 90.0]
    with pytest.raises(OutOfRangeError) as far:
        SEED.inverse(targets)
    assert far.value.index == (1, 1) and "tip[1, 1]" in far.value.quantity


def test_readings_exactly_on_the_limits_are_accepted() -> None:
    tips = reference_tip() + np.array([[30.0, -20.0, 40.0], [-25.0, 35.0, -10.0], [5.0, 5.0, 100.0]])
    inv = SEED.inverse(tips)
    limits = MachineLimits(
        height_travel=np.column_stack([inv.heights.min(0), inv.heights.max(0)]),
        laser_range=np.column_stack([inv.lasers.min(0), inv.lasers.max(0)]),
    )
    tight = RigidBodyMachine(SEED.tetrahedron, SEED.columns, SEED.reference_lasers, SEED.reference_heights, limits)
    both = tight.forward(lasers=inv.lasers, heights=inv.heights)
    np.testing.assert_allclose(both.tip, tips, atol=1e-9)
    np.testing.assert_allclose(tight.inverse(tips).heights, inv.heights, atol=1e-9)
    nudged = inv.lasers.copy()
    nudged[np.unravel_index(np.argmax(inv.lasers), inv.lasers.shape)] += 1e-6
    with pytest.raises(OutOfRangeError):
        tight.forward(lasers=nudged, heights=inv.heights)


def test_round_trip_inside_the_workspace_to_1e9() -> None:
    rng = np.random.default_rng(16)
    tips = reference_tip() + rng.uniform(-50.0, 50.0, (300, 3))
    inv = SEED.inverse(tips)
    assert inv.converged.all()
    for solution in (SEED.forward(lasers=inv.lasers, heights=inv.heights), SEED.forward(heights=inv.heights)):
        assert solution.converged.all()
        assert np.abs(solution.tip - tips).max() < 1e-9


def test_thesis_working_volume_lies_inside_the_workspace() -> None:
    """The thesis' 100 x 100 x 100 mm working volume (thesis 2.6.3) around the reference tip is reachable."""
    grid = np.stack(np.meshgrid(*[np.linspace(-50.0, 50.0, 5)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    inv = SEED.inverse(reference_tip() + grid)
    assert inv.converged.all()
    assert inv.lasers.min() > 0.0 and inv.lasers.max() < 200.0


def test_limits_serialise_with_the_machine_and_old_files_get_the_default() -> None:
    custom = MachineLimits(height_travel=[[0.0, 450.0], [1.0, 451.0], [2.0, 452.0]], laser_range=[-1.0, 201.0],
                           closure_tolerance=0.1)
    machine = RigidBodyMachine(SEED.tetrahedron, SEED.columns, SEED.reference_lasers, SEED.reference_heights, custom)
    again = RigidBodyMachine.from_dict(json.loads(json.dumps(machine.to_dict())))
    assert again.limits == custom
    old = machine.to_dict()
    del old["limits"]
    assert RigidBodyMachine.from_dict(old).limits == MachineLimits.seed()
    # calibration files wrote their machine with placeholder reference heights 0: same default
    assert RigidBodyMachine.from_dict({**old, "reference_heights": [0.0, 0.0, 0.0]}).limits == MachineLimits.seed()
    broken = {**machine.to_dict(), "limits": {"height_travel": [5.0, 1.0], "laser_range": [0.0, 200.0]}}
    with pytest.raises(InvalidInputError, match="height_travel"):
        RigidBodyMachine.from_dict(broken)
    with pytest.raises(InvalidInputError, match="closure_tolerance"):
        MachineLimits(height_travel=[0.0, 450.0], closure_tolerance=0.0)


def test_inverse_failure_without_a_reach_violation_is_no_real_solution() -> None:
    # the tip inside every arm's reach but with the three arms unable to meet there: the target sits
    # on column a's line, where arm a would have to be shorter than its shortest length
    limits = MachineLimits(height_travel=[-1e4, 1e4], laser_range=[-1e4, 1e4])
    loose = RigidBodyMachine(SEED.tetrahedron, SEED.columns, SEED.reference_lasers, SEED.reference_heights, limits)
    with pytest.raises(NoRealSolutionError) as info:
        loose.inverse([5000.0, 5000.0, 90.0])
    assert info.value.index == ()


def run_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return run_pcmm("kinematics", *args)


@pytest.mark.parametrize(
    ("args", "text"),
    [
        (["forward", "--heights-mm", "5000", "5000", "5000"],
         "heights[0] (column a travel) [3 readings outside]: expected a value in [277.216796875, 727.216796875] mm"),
        (["forward", "--lasers-mm", "250", "250", "250"], "expected a value in [0.0, 200.0] mm, got 250.0 mm"),
        (["forward", "--lasers-mm", "200", "200", "200"], "exceeds the tolerance 0.25 mm"),
        (["inverse", "--tip-mm", "2000", "0", "90"], "distance of tip from column a: expected a value in "
                                                  "[354.02, 554.02] mm"),
    ],
)
def test_cli_refuses_with_exit_2_and_one_line(args: list[str], text: str) -> None:
    proc = run_cli(*args)
    assert proc.returncode == 2 and proc.stdout == ""
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and text in lines[0], proc.stderr


def test_dpkm_arm_lengths_refuse_lasers_outside_the_measuring_range() -> None:
    from pcmm_geo.machine.kinematics.dpkm import arm_lengths

    lasers = np.array([[0.0, 100.0, 200.0], [10.0, 200.5, 30.0]])
    with pytest.raises(OutOfRangeError) as info:
        arm_lengths(lasers, TABLE_3_1_DEAD_DISTANCE)
    assert info.value.index == (1, 1) and info.value.high == 200.0
    # the ends of the range are inside; the check can be switched off for analyses
    np.testing.assert_allclose(arm_lengths(lasers[0], TABLE_3_1_DEAD_DISTANCE), [354.02, 449.90, 549.40], atol=1e-12)
    assert arm_lengths(lasers, TABLE_3_1_DEAD_DISTANCE, measuring_range=None)[1, 1] == pytest.approx(550.40)
