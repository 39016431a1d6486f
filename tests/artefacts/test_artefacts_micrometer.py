"""Micrometer-stage test (thesis 8.1-8.2, Table 8.1)."""

from __future__ import annotations

import math
from importlib.resources import files

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pcmm_geo.artefacts import evaluate_stage_test, read_micrometer_csv, stage_pairs
from pcmm_geo.errors import InvalidInputError

# Table 8.1: pairs 1-2, 2-3, 3-4, 1-3, 1-4
MEASURED = [19.11, 8.69, 8.11, 27.76, 35.87]
CALCULATED = [20.72, 11.28, 8.37, 31.55, 39.59]
TABLE_ERROR = [1.61, 2.59, 0.27, 3.78, 3.73]


def planar_points(d12: float, d23: float, d34: float, d13: float, d14: float) -> np.ndarray:
    """Four points in a plane with the given five distances (hand construction by circle intersections)."""
    p3x = (d13**2 - d23**2 + d12**2) / (2 * d12)
    p3 = np.array([p3x, math.sqrt(d13**2 - p3x**2)])
    dist = float(np.linalg.norm(p3))
    along = (d14**2 - d34**2 + dist**2) / (2 * dist)
    across = math.sqrt(max(d14**2 - along**2, 0.0))
    ex = p3 / dist
    p4 = along * ex + across * np.array([-ex[1], ex[0]])
    return np.c_[np.array([[0.0, 0.0], [d12, 0.0], p3, p4]), np.zeros(4)]


def test_reproduces_table_8_1() -> None:
    stage = planar_points(*MEASURED[:3], *MEASURED[3:])
    turn = Rotation.from_euler("xyz", [10, 20, 30], degrees=True)
    cmm = turn.apply(planar_points(*CALCULATED[:3], *CALCULATED[3:]))
    result = evaluate_stage_test(stage, cmm + np.array([15.0, -206.0, 80.0]))
    assert [p.label for p in result.pairs] == ["1-2", "2-3", "3-4", "1-3", "1-4"]
    np.testing.assert_allclose([p.stage_distance for p in result.pairs], MEASURED, atol=2e-6)
    np.testing.assert_allclose([p.cmm_distance for p in result.pairs], CALCULATED, atol=1e-9)
    # the table's error row, up to the rounding of its distances (3.78 vs 3.79 etc.)
    np.testing.assert_allclose([p.error for p in result.pairs], TABLE_ERROR, atol=0.0101)
    assert result.max_abs_error == pytest.approx(31.55 - 27.76, abs=2e-6)


def test_rigid_motion_gives_zero_error() -> None:
    rng = np.random.default_rng(8)
    stage = rng.uniform(0, 50, (6, 3))
    cmm = Rotation.from_rotvec([0.3, -0.2, 1.1]).apply(stage) + np.array([100.0, 5.0, -3.0])
    result = evaluate_stage_test(stage, cmm, pairs="all")
    assert len(result.pairs) == 15
    assert result.max_abs_error < 1e-12


def test_pairs_and_errors() -> None:
    assert stage_pairs(3, "consecutive") == [(0, 1), (1, 2)]
    assert stage_pairs(5) == [(0, 1), (1, 2), (2, 3), (3, 4), (0, 2), (0, 3), (0, 4)]
    with pytest.raises(InvalidInputError, match="pairs"):
        stage_pairs(3, "some")
    with pytest.raises(InvalidInputError, match="shape"):
        evaluate_stage_test(np.eye(3), np.eye(3)[:2])


def test_example_file() -> None:
    stage, cmm, labels = read_micrometer_csv(files("pcmm_geo") / "data/examples/micrometer_stage.csv")
    result = evaluate_stage_test(stage, cmm, labels=labels)
    np.testing.assert_allclose([p.cmm_distance for p in result.pairs], CALCULATED, atol=2e-5)
    np.testing.assert_allclose([p.stage_distance for p in result.pairs], MEASURED, atol=2e-5)
