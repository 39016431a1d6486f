"""The library side of ``pcmm acquire``: open_session and the seeded move programme on the simulated rig."""

from __future__ import annotations

import contextlib
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.acquisition.acqlog import AcquisitionLog, read_log
from pcmm_geo.acquisition.programme import DEVICE_PORTS, open_session, run_random_programme
from pcmm_geo.acquisition.simulators.cmm import SimulatedMicroCMM, SimulatedRig
from pcmm_geo.errors import InvalidInputError

MICROSTEP = 6.35 / 12800  # mm, T-LSR450B


def _run(path: Path, moves: int, seed: int) -> tuple[list, list[int], dict[int, int]]:
    done: list[int] = []
    with contextlib.ExitStack() as stack:
        rig = stack.enter_context(SimulatedRig(SimulatedMicroCMM(seed=seed), seed=seed, silence=0.12))
        session = open_session(rig.ports, stack, timeout=0.06, move_timeout=0.2, settle_time=0.0)
        session.log = stack.enter_context(AcquisitionLog.create(path, {"test": "programme"}))
        session.prepare(presequence=False)
        rig.place_gauge_block(0.5)
        run_random_programme(session, moves, step_mm=3.0, seed=seed, on_move=done.append)
        positions = dict(session.positions)
        assert rig.server.failures == []
    return list(read_log(path).rows), done, positions


def test_programme_writes_start_and_stop_rows_within_the_span_and_obeys_the_contact_rule(tmp_path: Path) -> None:
    moves = 12
    rows, done, positions = _run(tmp_path / "run.csv", moves, seed=4)
    assert done == list(range(1, moves + 1))
    assert len(rows) == 2 * moves
    assert [row.start_stop for row in rows] == [1, 0] * moves
    step_max = round(3.0 / MICROSTEP)
    start, span = 247_500, 40_320
    for k in range(moves):
        before, after = rows[2 * k], rows[2 * k + 1]
        assert (before.motor, before.direction) == (after.motor, after.direction)
        moved = np.subtract(after.pos_usteps, before.pos_usteps)
        assert np.count_nonzero(moved) <= 1
        assert abs(int(moved.sum())) <= step_max
        assert all(abs(p - start) <= span + step_max for p in after.pos_usteps)
        if before.probe == 1 and k > 0:  # touching: only the retreat of the motor that touched
            previous = rows[2 * k - 1]
            assert (before.motor, before.direction) == (previous.motor, -previous.direction)
    assert positions == dict(zip((1, 2, 3), rows[-1].pos_usteps, strict=True))
    assert any(row.probe == 1 for row in rows)  # the programme reached the gauge block: the rule was exercised


def test_the_programme_is_seeded(tmp_path: Path) -> None:
    first, _, _ = _run(tmp_path / "a.csv", 5, seed=7)
    second, _, _ = _run(tmp_path / "b.csv", 5, seed=7)
    def key(rows: list) -> list:
        return [(r.motor, r.direction, r.pos_usteps) for r in rows]

    assert key(first) == key(second)


def test_open_session_names_missing_ports() -> None:
    with contextlib.ExitStack() as stack, pytest.raises(InvalidInputError, match="laser_b"):
        open_session({name: "loop://" for name in DEVICE_PORTS if name != "laser_b"}, stack)
