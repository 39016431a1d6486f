"""Log-row kinematics in pivot distances (issue 22): lasers, tips and their derivatives against independent truth.

Truth: the rigid-body forward kinematics of the pose solver (nine closure equations, a different
formulation), and central differences of it for every derivative.
"""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.machine.analysis.logproc.geometry import (
    GEOMETRY_PARAMETERS,
    joint_distances,
    lasers_for_heights,
    pivot_distances,
    row_kinematics,
)
from pcmm_geo.machine.kinematics.model import ColumnLine, RigidBodyMachine, SliderLine, Tetrahedron

SLOPES = {"a": (0.0075, 0.0201), "b": (0.0082, 0.0192), "c": (0.0069, 0.0153)}


def skewed_machine() -> RigidBodyMachine:
    """Slider lines that miss the tip and each other, laser scales != 1, tilted columns, encoder scales != 1."""
    seed = RigidBodyMachine.from_dpkm(column_slopes=SLOPES)
    rng = np.random.default_rng(5)
    sliders = {}
    for arm, scale in zip("abc", (1.02, 0.97, 1.01), strict=True):
        line = seed.tetrahedron.sliders[arm]
        sliders[arm] = SliderLine(line.point + rng.normal(0, 5, 3), line.direction + rng.normal(0, 0.02, 3), scale,
                                  line.laser_offset)
    columns = {arm: ColumnLine(seed.columns[arm].point, seed.columns[arm].direction, e)
               for arm, e in zip("abc", (0.9991, 1.0008, 1.0002), strict=True)}
    tetrahedron = Tetrahedron(sliders, seed.tetrahedron.tip_center + np.array([1.0, -2.0, 0.5]))
    provisional = RigidBodyMachine(tetrahedron, columns, seed.reference_lasers, seed.reference_heights)
    reference = provisional.forward(heights=seed.reference_heights, check_limits=False)
    return RigidBodyMachine(tetrahedron, columns, reference.lasers, seed.reference_heights)


MACHINES = {"dpkm": RigidBodyMachine.from_dpkm(), "skewed": skewed_machine()}


def heights_for(machine: RigidBodyMachine) -> np.ndarray:
    rng = np.random.default_rng(3)
    offsets = np.vstack([[0.0, 0.0, 0.0], [0.0, 60.0, -50.0], [3.0, -2.0, 1.0], rng.uniform(-40, 40, (5, 3))])
    return machine.reference_heights + offsets


def test_order_of_geometry_parameters_is_the_calibration_files() -> None:
    from pcmm_geo.uncertainty.calibration import MODEL_PARAMETERS

    assert GEOMETRY_PARAMETERS == MODEL_PARAMETERS


@pytest.mark.parametrize("name", MACHINES)
def test_lasers_and_tips_agree_with_the_pose_solver(name: str) -> None:
    machine = MACHINES[name]
    heights = heights_for(machine)
    truth = machine.forward(heights=heights, check_limits=False)
    start = np.broadcast_to(machine.reference_lasers, heights.shape).copy()
    kinematics = row_kinematics(machine.geometry, heights, start)
    assert kinematics.converged.all()
    np.testing.assert_allclose(kinematics.lasers, truth.lasers, atol=1e-9)
    np.testing.assert_allclose(kinematics.tips, truth.tip, atol=1e-9)
    # the distance condition is the loop closure: joint and pivot triangles are congruent
    d, _ = joint_distances(machine.geometry, truth.lasers)
    D, _ = pivot_distances(machine.geometry, heights)
    np.testing.assert_allclose(d, D, atol=1e-9)


@pytest.mark.parametrize("name", MACHINES)
def test_height_derivatives_against_central_differences(name: str) -> None:
    machine = MACHINES[name]
    heights = heights_for(machine)[1:]  # not the level pose itself (the lasers' derivative vanishes there)
    start = np.broadcast_to(machine.reference_lasers, heights.shape).copy()
    kinematics = row_kinematics(machine.geometry, heights, start)
    step = 1e-3
    for arm in range(3):
        shift = np.zeros(3)
        shift[arm] = step
        up = machine.forward(heights=heights + shift, check_limits=False)
        down = machine.forward(heights=heights - shift, check_limits=False)
        np.testing.assert_allclose(kinematics.laser_gain[:, :, arm], (up.lasers - down.lasers) / (2 * step),
                                   atol=1e-7)
        np.testing.assert_allclose(kinematics.tip_gain[:, :, arm], (up.tip - down.tip) / (2 * step), atol=1e-7)
    # parallel vertical columns: a common lift moves no laser and lifts the tip by as much
    if name == "dpkm":
        np.testing.assert_allclose(kinematics.laser_gain.sum(axis=2), 0.0, atol=1e-12)
        np.testing.assert_allclose(kinematics.tip_gain.sum(axis=2), np.tile([0.0, 0.0, 1.0], (len(heights), 1)),
                                   atol=1e-12)


def _perturbed(machine: RigidBodyMachine, index: int, delta: float) -> RigidBodyMachine:
    """The machine with one of GEOMETRY_PARAMETERS changed by ``delta`` (direction not renormalised)."""
    from dataclasses import replace

    sliders = dict(machine.tetrahedron.sliders)
    tip = machine.tetrahedron.tip_center.copy()
    if index < 24:
        arm, part = "abc"[index // 8], index % 8
        line = sliders[arm]
        point, direction = line.point.copy(), line.direction.copy()
        scale, offset = line.laser_scale, line.laser_offset
        if part < 3:
            point[part] += delta
        elif part < 6:
            direction[part - 3] += delta
        elif part == 6:
            scale += delta
        else:
            offset += delta
        sliders[arm] = SliderLine(point, direction, scale, offset)
        if 3 <= part < 6:  # SliderLine normalises: keep the raw direction, as the derivative assumes
            object.__setattr__(sliders[arm], "direction", direction)
    elif index < 27:
        tip[index - 24] += delta
    return replace(machine, tetrahedron=Tetrahedron(sliders, tip))


@pytest.mark.parametrize("name", MACHINES)
def test_geometry_derivatives_against_central_differences(name: str) -> None:
    machine = MACHINES[name]
    heights = heights_for(machine)[1:4]
    start = np.broadcast_to(machine.reference_lasers, heights.shape).copy()
    kinematics = row_kinematics(machine.geometry, heights, start, geometry_gains=True)
    assert kinematics.laser_geometry_gain is not None and kinematics.tip_geometry_gain is not None
    for index, name_ in enumerate(GEOMETRY_PARAMETERS[:27]):
        step = 1e-6 if "direction" in name_ or "scale" in name_ else 1e-3
        up = row_kinematics(_perturbed(machine, index, step).geometry, heights, start)
        down = row_kinematics(_perturbed(machine, index, -step).geometry, heights, start)
        scale = 1.0 if step == 1e-3 else 200.0  # per unit of a direction component or scale: lever ~ 100s of mm
        np.testing.assert_allclose(kinematics.laser_geometry_gain[:, :, index], (up.lasers - down.lasers) / (2 * step),
                                   atol=1e-6 * scale, err_msg=name_)
        np.testing.assert_allclose(kinematics.tip_geometry_gain[:, :, index], (up.tips - down.tips) / (2 * step),
                                   atol=1e-6 * scale, err_msg=name_)
    np.testing.assert_array_equal(kinematics.tip_geometry_gain[:, :, 27], 0.0)  # tip radius


def test_lasers_for_unreachable_heights_do_not_converge() -> None:
    machine = RigidBodyMachine.from_dpkm()
    heights = machine.reference_heights + np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 2000.0]])
    _, converged = lasers_for_heights(machine.geometry, heights, np.tile(machine.reference_lasers, (2, 1)))
    assert converged.tolist() == [True, False]
