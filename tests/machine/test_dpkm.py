"""Seed DPKM (eqs 2.3-2.21, corrected) against trilateration and the rigid-body model."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError, NoRealSolutionError
from pcmm_geo.machine.kinematics.dpkm import (
    APPENDIX_D_COLUMN_POINTS,
    TABLE_3_1_BETA_DEG,
    TABLE_3_1_DEAD_DISTANCE,
    arm_lengths,
    column_pivots,
    dpkm_probe,
    height_difference,
    pivot_distance,
    relative_pivot_heights,
    sphere_constants,
    tetrahedron_directions,
)
from pcmm_geo.machine.kinematics.model import RigidBodyMachine
from pcmm_geo.machine.kinematics.trilateration import trilaterate

APPENDIX_E_SLOPES = {"a": (0.0075, 0.0201), "b": (0.0082, 0.0192), "c": (0.0069, 0.0153)}


def test_closed_forms() -> None:
    assert float(pivot_distance(3.0, 4.0, np.pi / 2)) == pytest.approx(5.0, abs=1e-12)
    assert float(pivot_distance(1.0, 1.0, np.pi / 3)) == pytest.approx(1.0, abs=1e-12)  # equilateral
    assert float(height_difference(5.0, 12.0, np.pi / 2, 5.0)) == pytest.approx(12.0, abs=1e-12)  # 5-12-13
    np.testing.assert_allclose(arm_lengths([0.0, 10.0, 20.0], TABLE_3_1_DEAD_DISTANCE), [354.02, 359.90, 369.40])
    # eq 2.21 corrected: c = l^2 - |p|^2 ; for |p| = 3, l = 5 -> 16
    np.testing.assert_allclose(sphere_constants([[[0.0, 0.0, 3.0]] * 3], [[5.0, 5.0, 5.0]]), [[16.0] * 3])
    pivots = column_pivots([100.0, 200.0, 300.0], [[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]], [[0.01, 0.02]] * 3)
    np.testing.assert_allclose(pivots, [[2.0, 4.0, 100.0], [5.0, 8.0, 200.0], [8.0, 12.0, 300.0]])


def test_dpkm_matches_trilateration_on_random_configurations() -> None:
    rng = np.random.default_rng(2)
    count = 400
    nominal = np.array([[-265.0, 0.0, 0.0], [132.0, 230.0, 0.0], [133.0, -229.0, 0.0]])
    pivots = nominal + rng.uniform(-20, 20, (count, 3, 3))
    pivots[..., 2] += 400.0 + rng.uniform(-60, 60, (count, 3))
    tips = rng.uniform(-50, 50, (count, 3)) + np.array([0.0, 0.0, 80.0])
    lengths = np.linalg.norm(pivots - tips[:, None, :], axis=-1)
    probe = dpkm_probe(pivots, lengths)
    np.testing.assert_allclose(probe.point, tips, atol=1e-8)
    np.testing.assert_allclose(probe.upper, trilaterate(pivots, lengths).upper, atol=1e-7)
    assert np.all(probe.discriminant > 0)


def test_dpkm_agrees_with_rigid_body_model_where_lines_meet() -> None:
    for slopes in (None, APPENDIX_E_SLOPES):
        machine = RigidBodyMachine.from_dpkm(column_slopes=slopes)
        centre = machine.forward(heights=machine.reference_heights).tip
        rng = np.random.default_rng(4)
        tips = centre + rng.uniform(-50, 50, (300, 3))
        inv = machine.inverse(tips)
        lengths = arm_lengths(inv.lasers, TABLE_3_1_DEAD_DISTANCE)
        if slopes is None:
            intercepts = np.array([APPENDIX_D_COLUMN_POINTS[arm] for arm in "abc"])
            pivots = column_pivots(inv.heights, intercepts, np.zeros((3, 2)))
        else:  # eqs 2.19-2.20 with the Appendix E slopes and the Appendix D intercepts
            intercepts = np.array([APPENDIX_D_COLUMN_POINTS[arm] for arm in "abc"])
            pivots = column_pivots(inv.heights, intercepts, np.array([APPENDIX_E_SLOPES[arm] for arm in "abc"]))
        np.testing.assert_allclose(pivots, machine.pivots(inv.heights), atol=1e-9)
        probe = dpkm_probe(pivots, lengths)
        assert np.abs(probe.point - tips).max() < 1e-9
        # and the forward model from the same readings
        assert np.abs(machine.forward(lasers=inv.lasers, heights=inv.heights).tip - probe.point).max() < 1e-9


def test_pivot_heights_from_lasers_eqs_2_3_to_2_8() -> None:
    machine = RigidBodyMachine.from_dpkm()  # vertical columns: b_in is the column spacing
    base = {
        pair: float(np.linalg.norm(np.subtract(APPENDIX_D_COLUMN_POINTS[pair[0]], APPENDIX_D_COLUMN_POINTS[pair[1]])))
        for pair in ("ab", "bc", "ca")
    }
    centre = machine.forward(heights=machine.reference_heights).tip
    tips = centre + np.array([[30.0, -20.0, 10.0], [-40.0, 35.0, -25.0], [10.0, 45.0, 40.0]])
    inv = machine.inverse(tips)
    lengths = arm_lengths(inv.lasers, TABLE_3_1_DEAD_DISTANCE)
    true_relative = inv.heights - inv.heights[:, :1]
    signs = np.stack([np.sign(true_relative[:, 1]), np.sign(-true_relative[:, 2])], axis=1)
    heights, closure = relative_pivot_heights(lengths, TABLE_3_1_BETA_DEG, base, signs)
    np.testing.assert_allclose(heights, true_relative, atol=1e-9)
    np.testing.assert_allclose(closure, 0.0, atol=1e-9)


def test_tetrahedron_directions_orientation() -> None:
    w = tetrahedron_directions(TABLE_3_1_BETA_DEG)
    assert np.all(w[:, 2] > 0)  # joints above the tip
    assert np.linalg.det(w) < 0  # a, b, c clockwise seen from above
    assert w[0, 0] < 0 and abs(w[0, 1]) < 1e-12
    with pytest.raises(DegenerateGeometryError):
        tetrahedron_directions({"ab": 170.0, "bc": 170.0, "ca": 170.0})


def test_errors() -> None:
    with pytest.raises(NoRealSolutionError) as info:
        height_difference(100.0, 100.0, np.radians(60.0), 150.0)  # pivots 100 apart, xy spacing 150
    assert info.value.discriminant == pytest.approx(100.0**2 - 150.0**2)
    level = np.array([[-265.0, 0.0, 400.0], [132.0, 230.0, 400.0], [133.0, -229.0, 390.0]])
    with pytest.raises(DegenerateGeometryError, match="level"):
        dpkm_probe(level, [420.0, 420.0, 420.0])
    far = np.array([[-265.0, 0.0, 400.0], [132.0, 230.0, 410.0], [133.0, -229.0, 390.0]])
    with pytest.raises(NoRealSolutionError) as short:
        dpkm_probe(far, [100.0, 100.0, 100.0])
    assert short.value.discriminant < 0
    with pytest.raises(InvalidInputError):
        dpkm_probe(far[:2], [1.0, 1.0])
    with pytest.raises(InvalidInputError, match="signs"):
        relative_pivot_heights([400.0] * 3, TABLE_3_1_BETA_DEG, {"ab": 1, "bc": 1, "ca": 1}, [1, 0])
