"""Zaber T-series binary driver through the pty simulator: golden frames, replies, every fault."""

from __future__ import annotations

import time

import pytest

from pcmm_geo.acquisition.drivers import zaber
from pcmm_geo.acquisition.drivers._port import is_transient
from pcmm_geo.acquisition.simulators.devices import ZaberChainSim
from pcmm_geo.acquisition.simulators.faults import FaultPlan
from pcmm_geo.acquisition.simulators.pty import SimulatedDevice
from pcmm_geo.errors import DeviceError, DeviceTimeoutError, InvalidInputError

# golden frames of protocols.md §1.2 (little-endian int32 data)
GOLDEN = [
    ((0, 1, 0), "00 01 00 00 00 00"),
    ((1, 20, 247500), "01 14 CC C6 03 00"),
    ((2, 21, -1000), "02 15 18 FC FF FF"),
    ((1, 53, 44), "01 35 2C 00 00 00"),
    ((3, 255, 20), "03 FF 14 00 00 00"),
]


@pytest.mark.parametrize(("fields", "frame"), GOLDEN)
def test_golden_frames_encode_and_decode(fields: tuple[int, int, int], frame: str) -> None:
    assert zaber.encode_packet(*fields) == bytes.fromhex(frame)
    assert zaber.decode_packet(bytes.fromhex(frame)) == zaber.ZaberReply(*fields)


def test_microstep_conversion_matches_lead_screw() -> None:
    # T-LSR450B: 6.35 mm lead / (200 steps x 64 microsteps); seed park position 247 500
    assert zaber.T_LSR450B_MICROSTEP_MM == pytest.approx(6.35 / 12800, rel=1e-15)
    assert 247500 * zaber.T_LSR450B_MICROSTEP_MM == pytest.approx(122.783203125, abs=1e-12)


def test_encode_rejects_out_of_range_fields() -> None:
    with pytest.raises(InvalidInputError, match="data: expected an integer"):
        zaber.encode_packet(1, 20, 2**31)
    with pytest.raises(InvalidInputError, match="device"):
        zaber.encode_packet(256, 1)


def _chain(server, **kwargs) -> zaber.ZaberChain:
    return zaber.ZaberChain(server.port_names[0], timeout=0.15, move_timeout=0.3, **kwargs)


def test_move_transcript_through_pty(serve) -> None:
    sim = ZaberChainSim(initial_positions={2: 5000})
    server = serve(sim)
    with _chain(server) as chain:
        assert chain.move_absolute(1, 247500) == 247500
        assert chain.move_relative(2, -1000) == 4000
    # bytes the stages received are exactly the golden instruction frames, and the replies
    # carry the final positions little-endian (247500 = 0x0003C6CC, 4000 = 0x00000FA0)
    assert sim.received == [bytes.fromhex("01 14 CC C6 03 00"), bytes.fromhex("02 15 18 FC FF FF")]
    assert sim.sent == [bytes.fromhex("01 14 CC C6 03 00"), bytes.fromhex("02 15 A0 0F 00 00")]


def test_relative_move_out_of_range_is_error_21(serve) -> None:
    server = serve(ZaberChainSim())
    with _chain(server) as chain, pytest.raises(DeviceError) as info:
        chain.move_relative(2, -1000)
    assert info.value.code == 21
    assert "move relative: target out of range" in str(info.value)
    assert not is_transient(info.value)


def test_home_all_collects_one_reply_per_device(serve) -> None:
    sim = ZaberChainSim(initial_positions={1: 5, 2: 600, 3: 70000})
    server = serve(sim)
    with _chain(server) as chain:
        assert chain.home() == {1: 0, 2: 0, 3: 0}
        chain.move_absolute(3, 1234)
        assert chain.positions() == {1: 0, 2: 0, 3: 1234}
        assert chain.position_mm(3) == pytest.approx(1234 * 0.49609375e-3)
    assert sim.received[0] == bytes.fromhex("00 01 00 00 00 00")


def test_settings_and_identity(serve) -> None:
    server = serve(ZaberChainSim(max_position=907087))
    with _chain(server) as chain:
        assert chain.max_position(2) == 907087  # Return Setting replies with command 44
        assert chain.device_id(1) == 4452
        with pytest.raises(DeviceError) as info:
            chain.move_absolute(1, 907088)
        assert info.value.code == 20


def test_unsolicited_replies_are_skipped(serve) -> None:
    server = serve(ZaberChainSim(unsolicited_every=1))
    with _chain(server) as chain:
        assert chain.move_absolute(2, 5000) == 5000
        assert chain.position(2) == 5000
        assert [r.command for r in chain.unsolicited] == [10, 10]


def test_accepts_an_open_port_and_leaves_it_open(serve) -> None:
    import serial

    server = serve(ZaberChainSim())
    with serial.Serial(server.port_names[0], 9600, timeout=0.01) as port:
        chain = zaber.ZaberChain(port, timeout=0.15)
        assert chain.move_absolute(1, 42) == 42
        chain.close()
        assert port.is_open


def test_device_error_fault_is_busy_and_not_executed(serve) -> None:
    sim = ZaberChainSim(faults=FaultPlan(1.0, ("error",), seed=1))
    server = serve(sim)
    with _chain(server) as chain, pytest.raises(DeviceError) as info:
        chain.move_absolute(1, 1000)
    assert info.value.code == 255 and "busy" in info.value.reason
    assert is_transient(info.value)
    assert sim.positions[1] == 0
    assert chain.statistics.device_errors == 1


def test_timeout_fault_raises_timeout(serve) -> None:
    server = serve(ZaberChainSim(faults=FaultPlan(1.0, ("timeout",), seed=2)))
    with _chain(server) as chain:
        start = time.monotonic()
        with pytest.raises(DeviceTimeoutError) as info:
            chain.position(1)
        assert time.monotonic() - start >= 0.15
        assert info.value.timeout == pytest.approx(0.15)
        assert chain.statistics.timeouts == 1


def test_dropped_bytes_fault_discards_partial_packet(serve) -> None:
    plan = FaultPlan(1.0, ("drop",), seed=5)
    server = serve(ZaberChainSim(faults=plan))
    with _chain(server) as chain:
        for _ in range(4):
            with pytest.raises(DeviceTimeoutError):
                chain.position(1)
        stats = chain.statistics
    assert stats.timeouts == 4
    # every non-empty partial reply was discarded (10 ms rule or deadline), never taken as a reply
    assert stats.discarded_bytes > 0 and stats.resyncs >= 1


class _ScriptedDevice(SimulatedDevice):
    """Answers every request with a scripted list of (delay, bytes) chunks."""

    def __init__(self, script: list[tuple[float, bytes]]) -> None:
        super().__init__()
        self.script = script
        self.queue: list[tuple[float, bytes]] = []

    def on_receive(self, data: bytes, now: float) -> None:
        self.queue = [(now + delay, chunk) for delay, chunk in self.script]

    def next_due(self, now: float) -> float | None:
        return self.queue[0][0] if self.queue else None

    def pending(self, now: float) -> bytes:
        out = b""
        while self.queue and self.queue[0][0] <= now:
            out += self.queue.pop(0)[1]
        return out


def test_partial_packet_older_than_10_ms_is_dropped(serve) -> None:
    reply = zaber.encode_packet(1, zaber.RETURN_CURRENT_POSITION, 777)
    server = serve(_ScriptedDevice([(0.0, reply[:3]), (0.05, reply)]))
    with _chain(server) as chain:
        assert chain.position(1) == 777
        stats = chain.statistics
    assert (stats.resyncs, stats.discarded_bytes) == (1, 3)


def test_garbled_device_byte_is_resynchronised(serve) -> None:
    good = zaber.encode_packet(2, zaber.RETURN_CURRENT_POSITION, 31337)
    garbled = bytes([0x42]) + good[1:]  # a reply from "device 66": not ours
    server = serve(_ScriptedDevice([(0.0, garbled + good)]))
    with _chain(server) as chain:
        assert chain.position(2) == 31337
        assert chain.statistics.resyncs == 1


def test_garble_fault_never_yields_foreign_reply(serve) -> None:
    sim = ZaberChainSim(faults=FaultPlan(1.0, ("garble",), seed=11), initial_positions={1: 1000})
    server = serve(sim)
    outcomes = {"value": 0, "error": 0}
    with _chain(server) as chain:
        for _ in range(12):
            try:
                chain.position(1)
                outcomes["value"] += 1
            except DeviceError as exc:
                assert is_transient(exc) or exc.code is not None
                outcomes["error"] += 1
        stats = chain.statistics
    # a flipped device/command byte makes the packet foreign (resync + timeout); only a flipped
    # data byte passes, which the session catches by asking twice
    assert outcomes["error"] >= 1 and stats.resyncs + stats.device_errors >= 1
    assert outcomes["value"] + outcomes["error"] == 12


def test_disconnect_fault_is_a_permanent_device_error(serve) -> None:
    server = serve(ZaberChainSim(faults=FaultPlan(1.0, ("disconnect",), seed=0)))
    with _chain(server) as chain:
        with pytest.raises(DeviceError) as info:
            chain.position(1)
            chain.position(1)  # the first request may still time out before the hang-up is seen
        assert info.value.code is None or isinstance(info.value, DeviceTimeoutError)
        with pytest.raises(DeviceError) as again:
            chain.position(1)
        assert again.value.code is None and not is_transient(again.value)
        assert "disconnected" in str(again.value)


def test_unknown_device_rejected_before_sending(serve) -> None:
    sim = ZaberChainSim()
    server = serve(sim)
    with _chain(server) as chain, pytest.raises(InvalidInputError, match="device: expected one of"):
        chain.position(4)
    assert sim.received == []


class _BrokenDevice(SimulatedDevice):
    def on_receive(self, data: bytes, now: float) -> None:
        raise RuntimeError("simulated firmware bug")


def test_a_failing_simulator_is_reported_not_hidden() -> None:
    from pcmm_geo.acquisition.simulators.pty import PtyServer

    with PtyServer([_BrokenDevice()]) as server, _chain(server) as chain:
        with pytest.raises(DeviceError):
            chain.position(1)
            chain.position(1)
        assert [str(f) for f in server.failures] == ["simulated firmware bug"]
