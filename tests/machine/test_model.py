"""Rigid-body model: forward/inverse against constructed poses, round trips, noise propagation."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.machine.kinematics.model import (
    ARMS,
    MODEL_SCHEMA,
    ColumnLine,
    RigidBodyMachine,
    SliderLine,
    Tetrahedron,
)

# Appendix E column slopes (h_i, n_i) of eqs 2.19-2.20: inclined columns
APPENDIX_E_SLOPES = {"a": (0.0075, 0.0201), "b": (0.0082, 0.0192), "c": (0.0069, 0.0153)}


def skewed_machine() -> RigidBodyMachine:
    """Seed-like machine whose slider lines miss the tip by millimetres, with scale errors and tilted columns."""
    seed = RigidBodyMachine.from_dpkm(column_slopes=APPENDIX_E_SLOPES)
    shifts = {"a": (1.5, -0.8, 0.3), "b": (-0.7, 1.9, -0.4), "c": (0.4, 0.6, 2.2)}
    tilts = {"a": (0.01, -0.02, 0.0), "b": (0.0, 0.015, 0.01), "c": (-0.012, 0.0, 0.02)}
    sliders = {}
    for arm in ARMS:
        s = seed.tetrahedron.sliders[arm]
        sliders[arm] = SliderLine(s.point + shifts[arm], s.direction + tilts[arm], 1.003, s.laser_offset - 1.0)
    tetra = Tetrahedron(sliders, [0.3, -0.2, -21.0])  # stylus below the apex
    return RigidBodyMachine(tetra, seed.columns, seed.reference_lasers, seed.reference_heights)


def constructed_case(seed: int = 3, count: int = 20):
    """Poses, lasers and a machine built *from* them: columns pass through the transformed joints."""
    rng = np.random.default_rng(seed)
    base = skewed_machine()
    rotations = Rotation.from_rotvec(rng.normal(0, 0.05, (count, 3))).as_matrix()
    translations = rng.uniform(-40, 40, (count, 3)) + np.array([0, 0, 100])
    lasers = rng.uniform(40, 90, (count, 3))
    joints = base.joints(lasers)  # (count, 3, 3) tetrahedron frame
    pivots = np.einsum("kij,kaj->kai", rotations, joints) + translations[:, None, :]
    tips = rotations @ base.tetrahedron.tip_center + translations
    return base, rotations, translations, lasers, pivots, tips


def test_slider_and_column_points_closed_form() -> None:
    line = SliderLine([1.0, 2.0, 3.0], [0.0, 3.0, 4.0], laser_scale=2.0, laser_offset=5.0)
    np.testing.assert_allclose(line.direction, [0.0, 0.6, 0.8])
    np.testing.assert_allclose(line.joint([0.0, 10.0]), [[1, 5, 7], [1, 17, 23]])
    column = ColumnLine([5.0, 0.0, 0.0], [0.0, 0.0, 2.0], encoder_scale=0.5)
    np.testing.assert_allclose(column.pivot(100.0), [5.0, 0.0, 50.0])


def test_from_dpkm_reproduces_table_3_1_geometry() -> None:
    machine = RigidBodyMachine.from_dpkm()
    dirs = {arm: machine.tetrahedron.sliders[arm].direction for arm in ARMS}
    for pair, beta in {"ab": 68.51, "bc": 68.73, "ca": 68.36}.items():
        angle = np.degrees(np.arccos(dirs[pair[0]] @ dirs[pair[1]]))
        assert angle == pytest.approx(beta, abs=1e-10)
    # slider lines meet at the tip: tip-to-joint = laser + 60 + d_i (Table 3.1)
    lasers = np.array([[10.0, 20.0, 30.0], [70.0, 50.0, 90.0]])
    expected = lasers + 60.0 + np.array([294.02, 289.90, 289.40])
    np.testing.assert_allclose(machine.tetrahedron.dead_distance(lasers), expected, atol=1e-12)
    # default reference: pivots level at 400 mm
    np.testing.assert_allclose(machine.reference_heights, 400.0, atol=1e-9)


def test_forward_recovers_constructed_pose_both_readings() -> None:
    base, rotations, translations, lasers, pivots, tips = constructed_case()
    # one machine per sample is not needed: give every column the same direction per arm and place its
    # foot so the known pivot sits at height reading 400 (inside the seed's column travel)
    for k in range(3):
        columns = {
            arm: ColumnLine(
                pivots[k, i] - 400.0 * 1.01 * base.columns[arm].direction, base.columns[arm].direction, 1.01
            )
            for i, arm in enumerate(ARMS)
        }
        machine = RigidBodyMachine(base.tetrahedron, columns, base.reference_lasers, np.full(3, 400.0))
        sol = machine.forward(lasers=lasers[k], heights=[400.0, 400.0, 400.0])
        assert sol.converged
        np.testing.assert_allclose(sol.tip, tips[k], atol=1e-9)
        np.testing.assert_allclose(sol.rotation, rotations[k], atol=1e-12)
        np.testing.assert_allclose(sol.translation, translations[k], atol=1e-9)
        assert np.abs(sol.residuals).max() < 1e-9
        # heights alone and lasers alone (columns inclined, so the common height is observable)
        by_heights = machine.forward(heights=[400.0, 400.0, 400.0], lasers_hint=lasers[k] + 3.0)
        np.testing.assert_allclose(by_heights.tip, tips[k], atol=1e-9)
        np.testing.assert_allclose(by_heights.lasers, lasers[k], atol=1e-9)
        by_lasers = machine.forward(lasers=lasers[k], heights_hint=[402.0, 398.0, 401.0])
        np.testing.assert_allclose(by_lasers.tip, tips[k], atol=1e-7)
        np.testing.assert_allclose(by_lasers.heights, 400.0, atol=1e-7)


def test_inverse_satisfies_closure_equations_over_working_cube() -> None:
    machine = skewed_machine()
    centre = machine.forward(heights=machine.reference_heights).tip
    grid = np.stack(np.meshgrid(*[np.linspace(-50, 50, 5)] * 3, indexing="ij"), axis=-1).reshape(-1, 3) + centre
    inv = machine.inverse(grid)
    assert inv.converged.all()
    joints = machine.joints(inv.lasers)
    moved = np.einsum("kij,kaj->kai", inv.rotation, joints) + inv.translation[:, None, :]
    assert np.abs(moved - machine.pivots(inv.heights)).max() < 1e-9
    tip = inv.rotation @ machine.tetrahedron.tip_center + inv.translation
    assert np.abs(tip - grid).max() < 1e-9
    np.testing.assert_allclose(np.linalg.det(inv.rotation), 1.0, atol=1e-12)


def test_round_trip_forward_inverse_skewed_lines() -> None:
    machine = skewed_machine()
    rng = np.random.default_rng(11)
    centre = machine.forward(heights=machine.reference_heights).tip
    tips = centre + rng.uniform(-50, 50, (200, 3))
    inv = machine.inverse(tips)
    both = machine.forward(lasers=inv.lasers, heights=inv.heights)
    assert both.converged.all()
    assert np.abs(both.tip - tips).max() < 1e-9
    heights_only = machine.forward(heights=inv.heights)
    assert np.abs(heights_only.tip - tips).max() < 1e-9
    lasers_only = machine.forward(lasers=inv.lasers, heights_hint=inv.heights + 1.0)
    assert np.abs(lasers_only.tip - tips).max() < 1e-6


def test_lasers_only_with_parallel_columns_fixes_tip_relative_to_pivots() -> None:
    machine = RigidBodyMachine.from_dpkm()  # vertical columns: a common height is invisible to lasers
    tips = machine.forward(heights=machine.reference_heights).tip + np.array([[20.0, -10.0, 15.0], [-30, 25, -40]])
    inv = machine.inverse(tips)
    sol = machine.forward(lasers=inv.lasers, heights_hint=inv.heights + 7.0)
    # the tetrahedron slid 7 mm up the columns, otherwise identical
    np.testing.assert_allclose(sol.tip - tips, [[0, 0, 7.0], [0, 0, 7.0]], atol=1e-9)
    np.testing.assert_allclose(sol.heights - inv.heights, 7.0, atol=1e-9)


def test_noise_propagation_matches_first_order_jacobian() -> None:
    machine = skewed_machine()
    centre = machine.forward(heights=machine.reference_heights).tip
    inv = machine.inverse(centre + np.array([15.0, -10.0, 5.0]))
    heights = inv.heights
    # first-order prediction: central differences of the tip with respect to each height reading
    step = 1e-4
    jac = np.empty((3, 3))
    for arm in range(3):
        delta = np.zeros(3)
        delta[arm] = step
        jac[:, arm] = (machine.forward(heights=heights + delta).tip - machine.forward(heights=heights - delta).tip) / (
            2 * step
        )
    sigma = 2e-3
    rng = np.random.default_rng(5)
    noise = rng.normal(0.0, sigma, (4000, 3))
    errors = machine.forward(heights=heights + noise).tip - inv.rotation @ machine.tetrahedron.tip_center - (
        inv.translation
    )
    empirical = np.cov(errors.T)
    predicted = sigma**2 * jac @ jac.T
    assert np.abs(errors.mean(axis=0)).max() < 5 * np.sqrt(np.diag(predicted).max() / 4000)
    np.testing.assert_allclose(np.sqrt(np.diag(empirical)), np.sqrt(np.diag(predicted)), rtol=0.06)
    # linear in sigma: the error of a single perturbation is J delta up to second order
    delta = np.array([0.01, -0.02, 0.015])
    one = machine.forward(heights=heights + delta).tip - machine.forward(heights=heights).tip
    assert np.linalg.norm(one - jac @ delta) < 1e-4 * np.linalg.norm(one)


def test_both_readings_weighted_least_squares() -> None:
    machine = skewed_machine()
    inv = machine.inverse(machine.forward(heights=machine.reference_heights).tip + np.array([5.0, 5.0, 5.0]))
    # inconsistent data: a laser disagrees by 0.05 mm.  Trusting the heights 1000x more (lasers 1e5x) gives the
    # heights-only solution; trusting the lasers gives the lasers-only (least-squares) solution.
    lasers = inv.lasers + np.array([0.05, 0.0, 0.0])
    # trusting the lasers 1e5x pushes the whole disagreement onto the heights (about 10 mm near level pivots,
    # far beyond the closure tolerance): an analysis of the weighting, hence check_limits=False
    trust_lasers = machine.forward(
        lasers=lasers, heights=inv.heights, laser_sigma=1e-8, height_sigma=1e-3, check_limits=False
    )
    trust_heights = machine.forward(lasers=lasers, heights=inv.heights, laser_sigma=1e-3, height_sigma=1e-6)
    heights_only = machine.forward(heights=inv.heights)
    lasers_only = machine.forward(lasers=lasers, heights_hint=inv.heights)
    np.testing.assert_allclose(trust_heights.tip, heights_only.tip, atol=1e-5)
    np.testing.assert_allclose(trust_heights.heights, inv.heights, atol=1e-6)
    np.testing.assert_allclose(trust_lasers.tip, lasers_only.tip, atol=1e-3)
    assert np.abs(trust_heights.residuals).max() > 0.01  # the disagreement shows in the closure
    assert np.abs(trust_heights.tip - trust_lasers.tip).max() > 0.05


def test_serialisation_round_trip() -> None:
    machine = skewed_machine()
    text = json.dumps(machine.to_dict())
    data = json.loads(text)
    assert data["schema"] == MODEL_SCHEMA
    again = RigidBodyMachine.from_dict(data)
    np.testing.assert_array_equal(again.tetrahedron.tip_center, machine.tetrahedron.tip_center)
    for arm in ARMS:
        np.testing.assert_array_equal(again.columns[arm].point, machine.columns[arm].point)
        assert again.tetrahedron.sliders[arm].laser_scale == machine.tetrahedron.sliders[arm].laser_scale
    with pytest.raises(InvalidInputError, match="schema"):
        RigidBodyMachine.from_dict({**data, "schema": "other/9"})
    with pytest.raises(InvalidInputError):
        RigidBodyMachine.from_dict({"schema": MODEL_SCHEMA})


def test_bad_input_raises_typed_errors() -> None:
    machine = RigidBodyMachine.from_dpkm()
    with pytest.raises(InvalidInputError, match="neither"):
        machine.forward()
    with pytest.raises(InvalidInputError, match=r"shape \(\.\.\., 3\)"):
        machine.forward(lasers=[1.0, 2.0])
    with pytest.raises(InvalidInputError, match="finite"):
        machine.forward(heights=[1.0, np.nan, 2.0])
    with pytest.raises(InvalidInputError, match="shape of lasers"):
        machine.forward(lasers=np.zeros((2, 3)), heights=np.zeros((3, 3)))
    with pytest.raises(InvalidInputError, match="laser_sigma"):
        machine.forward(lasers=[50.0, 50, 50], laser_sigma=0.0)
    with pytest.raises(InvalidInputError, match="non-zero direction"):
        SliderLine([0, 0, 0], [0, 0, 0])
    with pytest.raises(InvalidInputError, match="keys"):
        Tetrahedron({"a": SliderLine([0, 0, 0], [0, 0, 1])}, [0, 0, 0])
