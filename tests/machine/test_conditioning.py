"""Predicted tip uncertainty of poses (``analysis.conditioning``) against independent truth.

Truths: central differences of :meth:`RigidBodyMachine.forward` (the Jacobians); a seeded Monte Carlo of
the one-height least-squares problem solved with the forward kinematics (the height and tip u); the
processing's own stated u on one-move logs; the exact mirror of a pivot about two level ones (the
mirror branch); the start map's rule on a hand-made map.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.machine.analysis.conditioning import pose_conditioning
from pcmm_geo.machine.analysis.conditioning_maps import (
    CONDITIONED_START_OFFSETS,
    StartMap,
    choose_start,
    start_map,
    workspace_map,
)
from pcmm_geo.machine.analysis.logproc import process_log, synthesise_log
from pcmm_geo.machine.kinematics.model import RigidBodyMachine

MACHINE = RigidBodyMachine.from_dpkm()
POSES = MACHINE.reference_heights + np.array([[0.0, 60.0, -60.0], [70.0, -70.0, 0.0], [-30.0, 25.0, 80.0],
                                                [12.0, -40.0, 5.0]])


def test_jacobians_agree_with_central_differences_of_the_forward_kinematics() -> None:
    conditioning = pose_conditioning(MACHINE, POSES)
    step = 1e-3
    for arm in range(3):
        shift = np.zeros(3)
        shift[arm] = step
        up = MACHINE.forward(heights=POSES + shift)
        down = MACHINE.forward(heights=POSES - shift)
        np.testing.assert_allclose(conditioning.laser_per_height[:, :, arm], (up.lasers - down.lasers) / (2 * step),
                                   atol=1e-7)
        np.testing.assert_allclose(conditioning.tip_per_height[:, :, arm], (up.tip - down.tip) / (2 * step),
                                   atol=1e-7)
    forward = MACHINE.forward(heights=POSES)
    np.testing.assert_allclose(conditioning.lasers, forward.lasers, atol=1e-9)
    np.testing.assert_allclose(conditioning.tips, forward.tip, atol=1e-9)


def test_height_and_tip_u_agree_with_a_monte_carlo_of_the_one_height_solve() -> None:
    """Noise of the processing's sigmas on one row's lasers; pivot ``arm``'s height solved by Gauss-Newton with the
    forward kinematics (others held): the spread of the height and of the tip against the prediction."""
    rng = np.random.default_rng(36)
    pose = POSES[2]
    conditioning = pose_conditioning(MACHINE, pose)
    sigmas = conditioning.laser_sigmas
    trials = 600
    for arm in range(3):
        lasers = conditioning.lasers[0] + rng.normal(0.0, sigmas, size=(trials, 3))
        heights = np.repeat(pose[None, :], trials, axis=0)
        for _ in range(3):  # Gauss-Newton: the problem is nearly linear over a few sigma
            shift = np.zeros(3)
            shift[arm] = 1e-3
            now = MACHINE.forward(heights=heights).lasers
            gain = (MACHINE.forward(heights=heights + shift).lasers - MACHINE.forward(heights=heights - shift).lasers
                    ) / 2e-3
            weighted = gain / sigmas**2
            heights[:, arm] += np.sum(weighted * (lasers - now), axis=1) / np.sum(weighted * gain, axis=1)
        tips = MACHINE.forward(heights=heights).tip
        spread = np.std(heights[:, arm], ddof=1)
        tip_spread = np.sqrt(np.sum(np.var(tips, axis=0, ddof=1)))
        # the standard deviation of 600 samples is within 10 % of sigma with probability > 99.5 % (SE 2.9 %)
        assert 0.9 < spread / conditioning.height_u[0, arm] < 1.1, (arm, spread, conditioning.height_u[0, arm])
        assert 0.9 < tip_spread / conditioning.move_tip_u[0, arm] < 1.1, (arm, tip_spread)


@pytest.mark.parametrize("arm", range(3))
def test_move_tip_u_is_the_u_the_processing_states_after_one_move(arm: int) -> None:
    start = POSES[1]
    log = synthesise_log(MACHINE, start, [(arm + 1, 4.0, True)])
    out = process_log(MACHINE, log, initial_heights=start)
    after = start.copy()
    after[arm] += 4.0
    predicted = pose_conditioning(MACHINE, after).move_tip_u[0, arm]
    assert out.tip_uncertainty[1] == pytest.approx(predicted, rel=1e-6)
    assert out.tip_uncertainty[0] == 0.0  # the datum itself


def test_level_pose_is_blind_and_its_tip_u_grows_as_the_inverse_of_the_distance_from_level() -> None:
    near = pose_conditioning(MACHINE, MACHINE.reference_heights + np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 0.1]]))
    # D^2 = b^2 + dh^2: the lasers' gain by a height is proportional to dh, so u is proportional to 1 / dh
    assert near.tip_u[1] / near.tip_u[0] == pytest.approx(10.0, rel=0.01)
    assert near.tip_u[0] > 5.0
    exact = pose_conditioning(MACHINE, MACHINE.reference_heights)
    assert exact.tip_u[0] > 1e6  # no laser sees a height at the level pose (numerically infinite)


def test_mirror_of_a_pivot_about_two_level_ones_is_exact() -> None:
    """Pivots a and b level: c at level + d and at level - d give the same pivot distances, hence the same lasers."""
    d = 15.0
    pose = MACHINE.reference_heights + np.array([0.0, 0.0, d])
    mirrored = MACHINE.reference_heights + np.array([0.0, 0.0, -d])
    conditioning = pose_conditioning(MACHINE, pose)
    assert conditioning.mirror_heights[0, 2] == pytest.approx(mirrored[2], abs=1e-6)
    assert conditioning.mirror_chi[0, 2] < 1e-3 and conditioning.ambiguous[0]
    expected = np.linalg.norm(MACHINE.forward(heights=mirrored).tip - MACHINE.forward(heights=pose).tip)
    assert conditioning.mirror_distance[0, 2] == pytest.approx(expected, rel=1e-6)
    np.testing.assert_allclose(MACHINE.forward(heights=mirrored).lasers, conditioning.lasers[0], atol=1e-6)


def test_mirror_chi_is_the_laser_misfit_of_the_other_branch() -> None:
    """Off level the other branch fits only approximately: its height and chi against the local minima of a
    brute-force scan of the laser misfit (forward kinematics), away from the true height."""
    for offsets, arm in (((0.0, 2.0, 30.0), 2), ((0.0, 4.0, 12.0), 2), ((25.0, 0.0, 3.0), 0)):
        pose = MACHINE.reference_heights + np.array(offsets)
        conditioning = pose_conditioning(MACHINE, pose)
        scan = np.repeat(pose[None, :], 6001, axis=0)
        scan[:, arm] = pose[arm] + np.linspace(-90.0, 90.0, 6001)
        lasers = MACHINE.forward(heights=scan, check_limits=False).lasers
        chi = np.sqrt(np.sum(((lasers - conditioning.lasers[0]) / conditioning.laser_sigmas) ** 2, axis=1))
        interior = np.flatnonzero((chi[1:-1] < chi[:-2]) & (chi[1:-1] < chi[2:])) + 1
        others = interior[np.abs(scan[interior, arm] - pose[arm]) > 1.0]
        best = others[np.argmin(chi[others])]
        assert conditioning.mirror_heights[0, arm] == pytest.approx(scan[best, arm], abs=0.5), offsets
        # the quartic is in squared distances, linearised at the measured lasers: first order in the misfit
        assert conditioning.mirror_chi[0, arm] == pytest.approx(chi[best], rel=0.05), offsets
        assert conditioning.mirror_chi[0, arm] > conditioning.critical  # a few mm off level: told apart


def test_pose_from_a_commanded_tip_and_bad_input() -> None:
    tip = MACHINE.forward(heights=POSES[0]).tip
    by_tip = pose_conditioning(MACHINE, tips=tip)
    np.testing.assert_allclose(by_tip.heights[0], POSES[0], atol=1e-6)
    assert by_tip.tip_u[0] == pytest.approx(pose_conditioning(MACHINE, POSES[0]).tip_u[0], rel=1e-6)
    with pytest.raises(InvalidInputError, match="heights/tips"):
        pose_conditioning(MACHINE)
    with pytest.raises(InvalidInputError, match="lasers"):
        pose_conditioning(MACHINE, POSES, lasers=np.zeros((2, 3)))


def _map(box_tip_u, ratio, separation, tilt) -> StartMap:
    shape = np.shape(box_tip_u)
    offsets = np.arange(np.prod(shape) * 3, dtype=float).reshape(*shape, 3)
    return StartMap(axis=np.arange(shape[0], dtype=float), offsets=offsets, start_tip_u=np.asarray(box_tip_u),
                    box_tip_u=np.asarray(box_tip_u, dtype=float), box_ambiguity_ratio=np.asarray(ratio, dtype=float),
                    box_separation=np.asarray(separation, dtype=float), tilt=np.asarray(tilt, dtype=float), span=20.0)


def test_choose_start_takes_the_least_tilted_start_that_meets_the_target() -> None:
    found = _map([[0.05, 0.09], [0.095, np.inf]], [[5.0, 5.0], [5.0, 5.0]], [[30.0, 30.0], [30.0, 30.0]],
                 [[200.0, 120.0], [120.0, 80.0]])
    # [1, 1] is the least tilted but unreachable; [0, 1] and [1, 0] tie in tilt: the better conditioned one
    np.testing.assert_array_equal(choose_start(found, 0.1), found.offsets[0, 1])
    np.testing.assert_array_equal(choose_start(found, 0.06), found.offsets[0, 0])  # only it meets 0.06 mm
    np.testing.assert_array_equal(choose_start(found, 0.01), found.offsets[0, 0])  # none does: the best
    ambiguous = _map([[0.05, 0.09]], [[0.5, 5.0]], [[30.0, 30.0]], [[80.0, 120.0]])
    np.testing.assert_array_equal(choose_start(ambiguous, 0.1), ambiguous.offsets[0, 1])
    crossing = _map([[0.05, 0.09]], [[5.0, 5.0]], [[-10.0, 30.0]], [[80.0, 120.0]])  # a pair can be level
    np.testing.assert_array_equal(choose_start(crossing, 0.1), crossing.offsets[0, 1])
    with pytest.raises(InvalidInputError, match="start map"):
        choose_start(_map([[np.inf]], [[5.0]], [[30.0]], [[80.0]]))


def test_the_default_start_is_the_one_the_seed_machines_map_picks() -> None:
    found = start_map(MACHINE)
    np.testing.assert_array_equal(choose_start(found), CONDITIONED_START_OFFSETS)
    index = np.argwhere(np.all(found.offsets == CONDITIONED_START_OFFSETS, axis=-1))[0]
    assert found.box_tip_u[tuple(index)] <= 0.1 and found.box_separation[tuple(index)] >= 20.0
    level = np.argwhere(np.all(found.offsets == 0.0, axis=-1))[0]
    assert not found.eligible[tuple(level)] and found.start_tip_u[tuple(level)] > 1e6  # the thesis' start


def test_workspace_map_marks_the_level_pose_and_the_unreachable_corners() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        found = workspace_map(MACHINE, size=300.0, points=5)
    assert found.tip_u[2, 2] > 1e3  # the reference tip: the level pose
    assert np.isnan(found.tip_u).any() and np.isfinite(found.tip_u).sum() >= 9
    reachable = np.isfinite(found.tip_u) & (found.tip_u < 1e3)  # the level pose is numerically infinite
    recomputed = pose_conditioning(MACHINE, found.heights[reachable]).tip_u
    np.testing.assert_allclose(found.tip_u[reachable], recomputed, rtol=1e-6)
