"""Batched kinematics against the machine's own solver; the virtual CMM against closed forms and the GUM."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.machine.kinematics.model import ColumnLine, RigidBodyMachine, SliderLine, Tetrahedron
from pcmm_geo.uncertainty.kinematics import BatchGeometry, forward_batch
from pcmm_geo.uncertainty.tasks import distance_task, gauge_block_task, sphere_task
from pcmm_geo.uncertainty.virtual_cmm import ThermalInputs, VirtualCMM


@pytest.fixture(scope="module")
def machine() -> RigidBodyMachine:
    return RigidBodyMachine.from_dpkm()


@pytest.fixture(scope="module")
def center(machine: RigidBodyMachine) -> np.ndarray:
    return np.asarray(machine.forward(heights=machine.reference_heights, lasers_hint=machine.reference_lasers).tip)


def _machine_of(geometry: BatchGeometry, t: int, like: RigidBodyMachine) -> RigidBodyMachine:
    sliders = {arm: SliderLine(geometry.slider_points[t, k], geometry.slider_directions[t, k],
                               geometry.laser_scale[t, k], geometry.laser_offset[t, k]) for k, arm in enumerate("abc")}
    columns = {arm: ColumnLine(geometry.column_points[t, k], geometry.column_directions[t, k],
                               geometry.encoder_scale[t, k]) for k, arm in enumerate("abc")}
    return RigidBodyMachine(Tetrahedron(sliders, geometry.tip_center[t]), columns, like.reference_lasers,
                            like.reference_heights)


@pytest.mark.parametrize(("size", "tolerance"), [(1e-3, 1e-7), (1e-4, 1e-9)])
def test_forward_batch_matches_the_machine_solver(machine: RigidBodyMachine, center: np.ndarray, size: float,
                                                  tolerance: float) -> None:
    """Each trial's tips equal RigidBodyMachine.forward of that trial's machine; the chord method's
    difference is second order in the perturbation (1 um -> 1e-8 mm)."""
    rng = np.random.default_rng(1)
    targets = center + rng.normal(0.0, 20.0, (6, 3))
    inverse = machine.inverse(targets)
    trials = 4
    geometry = BatchGeometry.repeat(machine, trials)
    geometry = dataclasses.replace(
        geometry,
        slider_points=geometry.slider_points + rng.normal(0.0, size, (trials, 3, 3)),
        laser_scale=geometry.laser_scale * (1.0 + rng.normal(0.0, size / 100.0, (trials, 3))),
        tip_center=geometry.tip_center + rng.normal(0.0, size, (trials, 3)),
        column_points=geometry.column_points + rng.normal(0.0, size, (trials, 3, 3)),
    )
    lasers = inverse.lasers + rng.normal(0.0, size / 2, (trials, 6, 3))
    heights = inverse.heights + rng.normal(0.0, size / 5, (trials, 6, 3))
    batch = forward_batch(machine, geometry, lasers, heights, laser_sigma=5e-4, height_sigma=2e-4,
                          nominal_lasers=inverse.lasers, nominal_heights=inverse.heights)
    assert batch.converged.all()
    for t in range(trials):
        single = _machine_of(geometry, t, machine).forward(lasers[t], heights[t], laser_sigma=5e-4,
                                                           height_sigma=2e-4)
        np.testing.assert_allclose(batch.tip[t], single.tip, atol=tolerance, rtol=0)


def test_tasks_evaluate_their_nominal(center: np.ndarray) -> None:
    for task, nominal in ((gauge_block_task(100.0, center), 100.0), (sphere_task(20.0, center), 20.0),
                          (distance_task(30.0, center), 30.0)):
        assert task.evaluate(task.contacts[None])[0] == pytest.approx(nominal, abs=1e-9)
    with pytest.raises(InvalidInputError, match="points_per_face"):
        gauge_block_task(100.0, center, points_per_face=2)


def test_reading_noise_only_matches_the_gum(machine: RigidBodyMachine, center: np.ndarray) -> None:
    vcmm = VirtualCMM(machine, 1.0, None, laser_sigma=5e-4, encoder_sigma=2e-4)
    result = vcmm.evaluate(gauge_block_task(100.0, center), seed=3, trials=10_000)
    assert result.result.value == pytest.approx(100.0, abs=5e-6)
    assert result.gum is not None
    assert result.result.expanded_uncertainty == pytest.approx(result.gum.expanded_uncertainty, rel=0.05)
    names = [entry.name for entry in result.result.budget]
    assert names == ["laser_noise", "encoder_noise"]
    # the budget's variances add up to the total for this (linear) model
    total = sum(entry.contribution**2 for entry in result.result.budget)
    assert total == pytest.approx(result.result.standard_uncertainty**2, rel=0.05)


def test_workpiece_temperature_closed_form(machine: RigidBodyMachine, center: np.ndarray) -> None:
    """Only the gauge block's temperature uncertain: u(L) = L alpha u(T) / (1 + alpha dT) (GUM, exact here)."""
    thermal = ThermalInputs(workpiece_temperature=20.5, workpiece_temperature_u=0.2)
    vcmm = VirtualCMM(machine, 1.0, None, laser_sigma=1e-9, encoder_sigma=1e-9, thermal=thermal)
    result = vcmm.evaluate(gauge_block_task(100.0, center), seed=5, trials=10_000)
    expected = 100.0 * thermal.alpha_workpiece * 0.2 / (1.0 + thermal.alpha_workpiece * 0.5)
    assert result.gum is not None
    assert result.gum.budget[-1].name == "thermal_workpiece"
    assert result.gum.budget[-1].contribution == pytest.approx(expected, rel=1e-3)
    assert result.result.budget[-1].contribution == pytest.approx(expected, rel=0.03)


def test_arm_temperature_scales_lengths(machine: RigidBodyMachine, center: np.ndarray) -> None:
    """Arms 1 K warmer all together (alpha uncertainty x 1 K) act like a scale error of the lasers."""
    thermal = ThermalInputs(machine_temperature=21.0, alpha_machine_u=2e-6)
    vcmm = VirtualCMM(machine, 1.0, None, laser_sigma=1e-9, encoder_sigma=1e-9, thermal=thermal)
    gum = vcmm.gum(distance_task(50.0, center))
    machine_line = {entry.name: entry.contribution for entry in gum.budget}["thermal_machine"]
    assert 1e-6 < machine_line < 1e-3  # a real, sub-micrometre-to-micrometre effect


def test_bad_settings(machine: RigidBodyMachine) -> None:
    with pytest.raises(InvalidInputError, match="laser_sigma"):
        VirtualCMM(machine, 1.0, None, laser_sigma=0.0)
    with pytest.raises(InvalidInputError, match="calibration_covariance"):
        VirtualCMM(machine, 1.0, np.eye(3))
    with pytest.raises(InvalidInputError, match="workpiece_temperature_u"):
        ThermalInputs(workpiece_temperature_u=-1.0)


def test_machine_thermal_draws_match_the_thermal_package(machine: RigidBodyMachine, center: np.ndarray) -> None:
    """One deterministic thermal draw equals pcmm_geo.thermal.expand_rigid_body_machine + forward kinematics."""
    from pcmm_geo.thermal import expand_rigid_body_machine

    thermal = ThermalInputs(arm_temperature_u=1.0, column_temperature_u=1.0)
    vcmm = VirtualCMM(machine, 1.0, None, laser_sigma=5e-4, encoder_sigma=2e-4, thermal=thermal)
    task = distance_task(60.0, center)
    z = np.array([[0.8, -0.5, 0.3, 1.2, -0.7, 0.4, 0.0]])  # arm a, b, c; column a, b, c; common alpha term
    value = vcmm.evaluate_draws(task, {"thermal_machine": z})[0]
    warm = expand_rigid_body_machine(machine, arm_temperatures=20.0 + z[0, 0:3], column_temperatures=20.0 + z[0, 3:6])
    lasers, heights = vcmm.nominal_readings(task)
    tips = warm.forward(lasers, heights, laser_sigma=5e-4, height_sigma=2e-4).tip
    expected = task.evaluate((tips - 1.0 * task.normals)[None])[0]
    # 1 K on 400 mm aluminium moves the joints by ~9 um: the chord method's second-order difference is ~4e-8 mm
    assert value == pytest.approx(expected, abs=1e-7)
    assert abs(value - 60.0) > 1e-4  # a real thermal effect, not a no-op
