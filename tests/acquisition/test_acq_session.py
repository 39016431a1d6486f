"""Acquisition session on the simulated micro-CMM: rows, contact rule, pre-sequence, 20 % faults."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.acquisition.acqlog import AcquisitionLog, read_log
from pcmm_geo.acquisition.drivers import zaber
from pcmm_geo.acquisition.drivers.lasers import LaserSensor
from pcmm_geo.acquisition.drivers.probe import ProbeReader
from pcmm_geo.acquisition.drivers.zaber import ZaberChain
from pcmm_geo.acquisition.session import AcquisitionSession, SessionConfig
from pcmm_geo.acquisition.simulators.cmm import SimulatedRig
from pcmm_geo.acquisition.simulators.faults import FaultPlan
from pcmm_geo.errors import DeviceError, InvalidInputError

MICROSTEP = 6.35 / 12800  # mm, T-LSR450B
COUNT_1302 = 200 * 1.02 / 16368  # one ILD1302 count, mm
PROGRAMME = [(2, 3000), (3, -2500), (1, 3000), (1, -3000), (2, -3000), (1, 4000), (1, -4000), (3, 2500)]


@contextlib.contextmanager
def rig_session(
    log_path: Path | None = None, **rig_options: object
) -> Iterator[tuple[SimulatedRig, AcquisitionSession]]:
    slept: list[float] = []
    with contextlib.ExitStack() as stack:
        rig = stack.enter_context(SimulatedRig(silence=0.12, **rig_options))  # type: ignore[arg-type]
        motors = stack.enter_context(ZaberChain(rig.ports["zaber"], timeout=0.05, move_timeout=0.1))
        lasers = [
            stack.enter_context(LaserSensor(rig.ports[f"laser_{arm}"], model="ILD1420" if arm == "c" else "ILD1302",
                                            name=f"laser_{arm}", timeout=0.06))
            for arm in "abc"
        ]
        probe = stack.enter_context(ProbeReader(rig.ports["probe"], timeout=0.06))
        log = stack.enter_context(AcquisitionLog.create(log_path)) if log_path else None
        session = AcquisitionSession(motors, lasers, probe, log, SessionConfig(settle_time=0.25), sleep=slept.append)
        session.slept = slept  # type: ignore[attr-defined]
        yield rig, session
        assert rig.server.failures == []


def _expected_lasers(rig: SimulatedRig, positions: tuple[int, int, int]) -> np.ndarray:
    machine = rig.cmm.machine
    heights = machine.reference_heights + (np.asarray(positions) - 247500) * MICROSTEP
    return machine.forward(heights=heights, lasers_hint=machine.reference_lasers).lasers


def _clearance(block, tip: np.ndarray) -> float:
    return float(np.max(np.abs(tip - block.centre) - block.size / 2))


def test_prepare_homes_and_runs_the_presequence(tmp_path: Path) -> None:
    with rig_session() as (rig, session):
        session.prepare()
        moves = [zaber.decode_packet(p) for p in rig.zaber.received]
        assert moves[0] == zaber.ZaberReply(0, zaber.HOME, 0)
        targets = [(m.device, m.data) for m in moves if m.command == zaber.MOVE_ABSOLUTE]
        start, span = 247500, 40320
        expected = [(d, start) for d in (1, 2, 3)]
        for device in (1, 2, 3):
            expected += [(device, start + span), (device, start - span), (device, start)]
        assert targets == expected
        assert session.positions == {1: start, 2: start, 3: start}


def test_moves_write_start_and_stop_rows_matching_the_model(tmp_path: Path) -> None:
    path = tmp_path / "run.csv"
    with rig_session(path) as (rig, session):
        session.prepare(presequence=False)
        result = session.move(2, 3000)
        second = session.move(3, -2500)
        assert session.slept == [0.25, 0.25]
    rows = read_log(path).rows
    assert [(r.start_stop, r.motor, r.direction) for r in rows] == [(1, 2, 1), (0, 2, 1), (1, 3, -1), (0, 3, -1)]
    assert rows[1].pos_usteps == (247500, 250500, 247500) and rows[3].pos_usteps == (247500, 250500, 245000)
    assert rows[1] == result.stop_row and rows[2] == second.start_row
    for row in rows:
        expected = _expected_lasers(rig, row.pos_usteps)
        measured = np.array([row.laser_a, row.laser_b, row.laser_c])
        assert np.all(np.abs(measured - expected) <= COUNT_1302 / 2 + 1e-9)
        assert row.probe == 0


def test_contact_stops_the_move_and_only_retreat_is_allowed(tmp_path: Path) -> None:
    with rig_session() as (rig, session):
        session.prepare(presequence=False)
        block = rig.place_gauge_block(gap=0.5)
        result = None
        for _ in range(10):
            result = session.move(1, 3000)
            if result.contact:
                break
        assert result is not None and result.contact
        assert result.final != result.target  # stopped early by the probe
        machine = rig.cmm.machine
        positions = np.array([result.final, 247500, 247500])
        before = positions - np.array([1, 0, 0])
        tips = machine.forward(
            heights=machine.reference_heights + (np.stack([positions, before]) - 247500) * MICROSTEP,
            lasers_hint=machine.reference_lasers,
        ).tip
        assert _clearance(block, tips[0]) <= 1.0 < _clearance(block, tips[1])  # first touching microstep
        sent_before = len(rig.zaber.received)
        for motor, steps in ((2, 1000), (1, 500), (3, -1000)):
            with pytest.raises(InvalidInputError, match="only moves away from the artefact"):
                session.move(motor, steps)
        assert len(rig.zaber.received) == sent_before  # refused before anything was sent
        retreat = session.move(1, -3000)
        assert not retreat.contact and session.contact_move is None
        assert session.summary().refused_moves == 3 and session.summary().contacts == 1


def _run(path: Path, fault_rate: float) -> tuple[object, dict[str, int]]:
    with rig_session(path, fault_rate=fault_rate, seed=20) as (rig, session):
        session.prepare()
        rig.place_gauge_block(gap=0.5)
        for motor, steps in PROGRAMME:
            if session.contact_move is not None and session.contact_move[0] != motor:
                continue
            session.move(motor, steps)
        return session.summary(), rig.injected_faults


def test_twenty_percent_faults_complete_with_whole_rows(tmp_path: Path) -> None:
    clean_summary, _ = _run(tmp_path / "clean.csv", 0.0)
    summary, injected = _run(tmp_path / "faulty.csv", 0.2)
    clean, faulty = read_log(tmp_path / "clean.csv").rows, read_log(tmp_path / "faulty.csv").rows  # strict
    assert clean_summary.contacts >= 1  # type: ignore[attr-defined]
    assert len(faulty) == len(clean) == 2 * summary.moves  # type: ignore[attr-defined]
    assert sum(injected.values()) >= 20
    assert summary.retries >= 10 and summary.resyncs >= 1 and summary.timeouts >= 1  # type: ignore[attr-defined]
    for good, bad in zip(clean, faulty, strict=True):
        assert (bad.start_stop, bad.probe, bad.motor, bad.direction) == (good.start_stop, good.probe, good.motor,
                                                                          good.direction)
        assert bad.pos_usteps == good.pos_usteps
        for arm in ("laser_a", "laser_b", "laser_c"):
            assert np.isfinite(getattr(bad, arm)) and abs(getattr(bad, arm) - getattr(good, arm)) <= COUNT_1302


def test_disconnect_aborts_with_a_device_error_and_whole_rows(tmp_path: Path) -> None:
    path = tmp_path / "run.csv"
    with rig_session(path) as (rig, session):
        session.prepare(presequence=False)
        session.move(2, 1000)
        with rig.zaber.lock:
            rig.zaber.faults = FaultPlan(1.0, ("disconnect",), seed=0)
        with pytest.raises(DeviceError) as info:
            session.move(2, 1000)
        assert info.value.code is None
    rows = read_log(path).rows
    assert [r.start_stop for r in rows] == [1, 0, 1]


def test_bad_moves_and_configuration_rejected() -> None:
    with pytest.raises(InvalidInputError, match="settle_time"):
        SessionConfig(settle_time=-1.0)
    with rig_session() as (_, session):
        with pytest.raises(InvalidInputError, match="motor"):
            session.move(4, 100)
        with pytest.raises(InvalidInputError, match="steps"):
            session.move(1, 0)
