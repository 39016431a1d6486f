"""Level-start logs (issues 16i, 22): the datum holds the start heights, the direction picks the branch.

At level every pivot distance is stationary in the heights, so a pivot moved from there has a
mirror (same lasers) on the other side; the recorded motor direction tells them apart.
"""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.errors import IllConditionedWarning
from pcmm_geo.machine.analysis.logproc import MeasurementLog, process_log, synthesise_log
from pcmm_geo.machine.kinematics.model import RigidBodyMachine

LEVEL_MOVES = [
    [(1, 1.5, False), (2, 30.0, False)],  # the reproduction (was ConvergenceError "pose of log row 1")
    [(1, -1.5, False), (2, 30.0, False)],
    [(2, -0.2, False), (3, 5.0, True)],
    [(3, 3.0, False), (1, -3.0, True)],
    [(1, -10.0, True)],
]


def true_heights(start: np.ndarray, moves: list[tuple[int, float, bool]]) -> np.ndarray:
    rows, current = [], start.copy()
    for motor, change, _ in moves:
        rows.append(current.copy())
        current = current.copy()
        current[motor - 1] += change
        rows.append(current.copy())
    return np.array(rows)


@pytest.mark.parametrize("moves", LEVEL_MOVES)
def test_level_start_processes_exactly(moves) -> None:
    machine = RigidBodyMachine.from_dpkm()
    log = synthesise_log(machine, machine.reference_heights, moves)
    out = process_log(machine, log, max_tip_uncertainty=np.inf)
    truth = true_heights(machine.reference_heights, moves)
    assert np.abs(out.heights - truth).max() < 1e-6
    assert np.abs(out.tips - machine.forward(heights=truth).tip).max() < 1e-6
    assert out.converged.all() and out.direction_consistent.all() and not out.inconsistent.any()


def test_level_start_without_direction_is_flagged_ambiguous() -> None:
    """Direction 0 (unknown): the lasers cannot tell a move down from level from the same move up.

    Before issue 22 one of the two mirror images was returned silently; now the row is flagged,
    with the other branch's tip distance in its stated bound (and a warning), never refused.
    """
    machine = RigidBodyMachine.from_dpkm()
    log = synthesise_log(machine, machine.reference_heights, [(1, -10.0, False)])
    blind = MeasurementLog(log.start_stop, log.probe, log.motor, np.zeros_like(log.direction), log.lasers)
    with pytest.warns(IllConditionedWarning, match="1 of 2 log rows are ambiguous"):
        out = process_log(machine, blind, max_tip_uncertainty=np.inf)
    assert abs(abs(out.heights[1, 0] - 400.0) - 10.0) < 1e-6  # one of the two mirror images, 10 mm from level
    assert np.abs(out.heights[1, 1:] - 400.0).max() < 1e-6
    mirror = machine.forward(heights=[800.0 - out.heights[1, 0], 400.0, 400.0]).tip
    assert out.ambiguous.tolist() == [False, True]
    assert out.ambiguity[1] >= np.linalg.norm(mirror - out.tips[1]) - 1e-6  # the mirror, and the noise about it
    assert out.bound[1] >= out.ambiguity[1] and not out.inconsistent.any()
    # with the recorded direction the same lasers are not ambiguous
    assert not process_log(machine, log, max_tip_uncertainty=np.inf).ambiguous.any()


def test_level_first_row_keeps_the_datum() -> None:
    """The first row at level: the lasers barely see any height; the datum is kept and the solve converges."""
    machine = RigidBodyMachine.from_dpkm()
    log = synthesise_log(machine, machine.reference_heights, [(2, 10.0, False)])
    out = process_log(machine, log, max_tip_uncertainty=np.inf)
    assert out.converged[0]
    assert np.abs(out.heights[0] - machine.reference_heights).max() < 1e-6
