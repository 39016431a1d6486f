"""ILD1302 / ILD1420 stream decoding and the laser driver through pty simulators, every fault."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pcmm_geo.acquisition.drivers import lasers
from pcmm_geo.acquisition.drivers._port import is_transient
from pcmm_geo.acquisition.simulators.devices import LaserStreamSim
from pcmm_geo.acquisition.simulators.faults import FaultPlan
from pcmm_geo.errors import DeviceError, DeviceTimeoutError, InvalidInputError

# one count in mm for MR = 200: 200 * 1.02 / full scale
COUNT_1302 = 200 * 1.02 / 16368
COUNT_1420 = 200 * 1.02 / 65520


def test_ild1302_golden_values() -> None:
    # protocols.md §2.2: raw 8184 -> BF 78 -> 100.000 mm (MR 200); ILD1700 manual: 2099 -> 90 33
    assert lasers.encode_ild1302(8184) == bytes.fromhex("BF 78")
    assert lasers.encode_ild1302(2099) == bytes.fromhex("90 33")
    assert lasers.ild1302_to_mm(8184) == pytest.approx((8184 * 1.02 / 16368 - 0.01) * 200, abs=0)
    assert lasers.ild1302_to_mm(8184) == pytest.approx(100.0, abs=1e-12)
    # start of range: (raw*1.02/16368 - 0.01) = 0 at raw = 160.47 -> 161 is the first count in range
    assert lasers.ild1302_to_mm(160) < 0 < lasers.ild1302_to_mm(161)


def test_ild1420_golden_values() -> None:
    # protocols.md §2.3: d = 100 mm, MR = 200 -> raw 32760 -> bytes 38 7F 87 (first value of a block)
    assert lasers.ild1420_from_mm(100.0) == 32760
    assert lasers.encode_ild1420(32760) == bytes.fromhex("38 7F 87")
    assert lasers.encode_ild1420(32760, first=False) == bytes.fromhex("38 7F C7")
    assert lasers.ild1420_to_mm(32760) == pytest.approx(100.0, abs=1e-12)


def test_encoders_reject_out_of_range() -> None:
    with pytest.raises(InvalidInputError, match="raw"):
        lasers.encode_ild1302(16384)
    with pytest.raises(InvalidInputError, match="raw"):
        lasers.encode_ild1420(-1)


def test_ild1302_decoder_resynchronises() -> None:
    decoder = lasers.Ild1302Decoder()
    stream = lasers.encode_ild1302(1000) + lasers.encode_ild1302(2000) + lasers.encode_ild1302(3000)
    # join mid-frame (first byte is a low byte), then lose the low byte of 2000
    damaged = stream[1:2] + stream[2:3] + stream[4:]
    assert decoder.feed(damaged) == [3000]
    assert decoder.leading_bytes == 2  # the orphan low byte and the high byte of 2000
    assert decoder.resyncs == 0  # nothing was aligned yet
    decoder.reset()
    assert decoder.feed(stream[:3]) == [1000]
    assert decoder.feed(stream[4:]) == [3000]  # low byte of 2000 lost across feeds
    assert decoder.resyncs == 1 and decoder.discarded_bytes == 1


def test_ild1420_decoder_resynchronises() -> None:
    decoder = lasers.Ild1420Decoder()
    values = [5, 70000, 262076]
    stream = b"".join(lasers.encode_ild1420(v, first=i == 0) for i, v in enumerate(values))
    assert decoder.feed(stream[2:]) == [70000, 262076]  # joined at the H byte of the first value
    assert decoder.feed(stream[:1] + stream[3:]) == [70000, 262076]  # M, H of value 1 lost
    assert decoder.resyncs == 1 and decoder.discarded_bytes == 1


@pytest.mark.parametrize(("model", "count"), [("ILD1302", COUNT_1302), ("ILD1420", COUNT_1420)])
def test_reading_through_pty(serve, model: str, count: float) -> None:
    server = serve(LaserStreamSim(lambda: 37.5, model=model))
    with lasers.LaserSensor(server.port_names[0], model=model, timeout=0.3) as sensor:
        reading = sensor.read()
    assert abs(reading.distance - 37.5) <= count / 2 + 1e-12
    assert reading.absolute_distance == pytest.approx(60.0 + reading.distance)
    assert reading.spread == 0.0 and reading.samples == 5


@pytest.mark.parametrize(("model", "code", "meaning"), [
    ("ILD1302", 16370, "no object detected"), ("ILD1420", 262076, "no peak detected"),
])
def test_error_values_raise_device_error(serve, model: str, code: int, meaning: str) -> None:
    server = serve(LaserStreamSim(lambda: None, model=model))
    with lasers.LaserSensor(server.port_names[0], model=model, name="laser_c", timeout=0.3) as sensor:
        with pytest.raises(DeviceError) as info:
            sensor.read()
    assert info.value.code == code and meaning in str(info.value) and "laser_c" in str(info.value)
    assert is_transient(info.value)


def test_error_fault(serve) -> None:
    server = serve(LaserStreamSim(lambda: 20.0, faults=FaultPlan(1.0, ("error",), seed=1)))
    with lasers.LaserSensor(server.port_names[0], timeout=0.3) as sensor, pytest.raises(DeviceError) as info:
        sensor.read()
    assert info.value.code == 16370


def test_timeout_fault(serve) -> None:
    server = serve(LaserStreamSim(lambda: 20.0, faults=FaultPlan(1.0, ("timeout",), seed=1), silence=1.0))
    with lasers.LaserSensor(server.port_names[0], timeout=0.1) as sensor, pytest.raises(DeviceTimeoutError):
        sensor.read()


@pytest.mark.parametrize("model", ["ILD1302", "ILD1420"])
def test_dropped_bytes_fault_is_resynchronised(serve, model: str) -> None:
    sim = LaserStreamSim(lambda: 150.25, model=model, faults=FaultPlan(1.0, ("drop",), seed=4), fault_window=0.005)
    server = serve(sim)
    with lasers.LaserSensor(server.port_names[0], model=model, timeout=0.3, samples=15) as sensor:
        readings = [sensor.read() for _ in range(3)]
        stats = sensor.statistics
    assert all(abs(r.distance - 150.25) < 0.02 for r in readings)
    assert stats.resyncs >= 1 and stats.discarded_bytes >= 1


def test_garbled_bytes_fault_is_rejected_by_the_median(serve) -> None:
    sim = LaserStreamSim(lambda: 80.0, faults=FaultPlan(1.0, ("garble",), seed=9), fault_window=0.005)
    server = serve(sim)
    with lasers.LaserSensor(server.port_names[0], timeout=0.3, samples=9) as sensor:
        readings = [sensor.read() for _ in range(5)]
    assert all(abs(r.distance - 80.0) <= COUNT_1302 for r in readings)
    assert sim.faults.counts["garble"] >= 5


def test_disconnect_fault(serve) -> None:
    sim = LaserStreamSim(lambda: 20.0)
    server = serve(sim)
    with lasers.LaserSensor(server.port_names[0], timeout=0.2) as sensor:
        assert abs(sensor.read().distance - 20.0) <= COUNT_1302
        with sim.lock:  # the cable is pulled from now on
            sim.faults = FaultPlan(1.0, ("disconnect",), seed=1)
            sim._window_end = 0.0
        with pytest.raises(DeviceError) as info:
            sensor.read()
            sensor.read()
        assert info.value.code is None and not is_transient(info.value)


def test_bad_configuration_rejected() -> None:
    with pytest.raises(InvalidInputError, match="model"):
        lasers.LaserSensor("loop://", model="ILD2300")
    with pytest.raises(InvalidInputError, match="samples"):
        lasers.LaserSensor("loop://", samples=0)


def test_simulator_stream_transcript() -> None:
    # the bytes a reader receives at 100 mm: golden ILD1420 frame, then "additional value" frames
    sim = LaserStreamSim(lambda: 100.0, model="ILD1420", start_mid_frame=False, rate_hz=750, chunk_period=0.004)
    chunk = sim.pending(now=1.0)
    assert chunk == bytes.fromhex("38 7F 87 38 7F C7 38 7F C7")
    sim1302 = LaserStreamSim(lambda: 100.0, model="ILD1302", start_mid_frame=True, rate_hz=500, chunk_period=0.004)
    assert sim1302.pending(now=1.0) == bytes.fromhex("78 BF 78")  # joined mid-frame


@settings(max_examples=60, deadline=None)
@given(
    values=st.lists(st.integers(0, 16383), min_size=6, max_size=40),
    drop=st.integers(0, 10_000),
)
def test_single_dropped_byte_never_invents_a_value(values: list[int], drop: int) -> None:
    stream = b"".join(lasers.encode_ild1302(v) for v in values)
    index = drop % len(stream)
    decoded = lasers.Ild1302Decoder().feed(stream[:index] + stream[index + 1 :])
    assert len(decoded) == len(values) - 1
    assert decoded == values[: index // 2] + values[index // 2 + 1 :]


@settings(max_examples=60, deadline=None)
@given(
    values=st.lists(st.integers(0, 0x3FFFF), min_size=6, max_size=40),
    drop=st.integers(0, 10_000),
)
def test_ild1420_single_dropped_byte_never_invents_a_value(values: list[int], drop: int) -> None:
    stream = b"".join(lasers.encode_ild1420(v, first=i == 0) for i, v in enumerate(values))
    index = drop % len(stream)
    decoded = lasers.Ild1420Decoder().feed(stream[:index] + stream[index + 1 :])
    assert decoded == values[: index // 3] + values[index // 3 + 1 :]


def test_ild1420_ascii_command_while_streaming(serve) -> None:
    sim = LaserStreamSim(lambda: 12.5, model="ILD1420", rate_hz=4000)
    server = serve(sim)
    with lasers.LaserSensor(server.port_names[0], model="ILD1420", timeout=0.3) as sensor:
        info = sensor.get_info()
        assert info["Measuring range"] == "200 mm" and info["Name"].startswith("ILD1420-200")
        with pytest.raises(DeviceError) as refused:
            sensor.command("NOSUCHCOMMAND")
        assert refused.value.code == 999 and not is_transient(refused.value)
        assert abs(sensor.read().distance - 12.5) <= COUNT_1420  # the stream is still decoded
    assert sim.commands == ["GETINFO", "NOSUCHCOMMAND"]
    with lasers.LaserSensor("loop://", model="ILD1302") as other, pytest.raises(InvalidInputError, match="model"):
        other.command("GETINFO")
