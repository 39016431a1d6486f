"""Arduino probe reader (text safe/stop and pin 0/1 modes) through pty simulators, every fault."""

from __future__ import annotations

import pytest

from pcmm_geo.acquisition.drivers.probe import ProbeReader, parse_probe_token
from pcmm_geo.acquisition.simulators.devices import ProbeSim
from pcmm_geo.acquisition.simulators.faults import FaultPlan
from pcmm_geo.errors import DeviceError, DeviceTimeoutError, InvalidInputError

# Reads that must succeed use a 2 s timeout: it only bounds a failure, and on a loaded machine the
# pty scheduling alone can delay a reply past a few hundred milliseconds.


def test_token_parsing() -> None:
    assert parse_probe_token(b"stop\r", mode="text") is True
    assert parse_probe_token(b"safe", mode="text") is False
    # thesis 3.4: pin 1 = not in contact, 0 = contact
    assert parse_probe_token(b"0\r", mode="pin") is True
    assert parse_probe_token(b"1", mode="pin") is False
    assert parse_probe_token(b"1", mode="pin", contact_level=1) is True
    for garbage in (b"sa\xfee", b"stopp", b"01", b"", b"safe stop"):
        assert parse_probe_token(garbage, mode="text") is None
        assert parse_probe_token(garbage, mode="pin") is None
    with pytest.raises(InvalidInputError, match="mode"):
        parse_probe_token(b"1", mode="serial")


@pytest.mark.parametrize("mode", ["text", "pin"])
@pytest.mark.parametrize("contact", [True, False])
def test_state_through_pty(serve, mode: str, contact: bool) -> None:
    server = serve(ProbeSim(lambda: contact, mode=mode))
    with ProbeReader(server.port_names[0], mode=mode, timeout=2.0) as probe:
        state = probe.read()
    assert state.contact is contact
    expected = {("text", True): "stop", ("text", False): "safe", ("pin", True): "0", ("pin", False): "1"}
    assert state.token == expected[(mode, contact)]


def test_boot_junk_is_discarded(serve) -> None:
    server = serve(ProbeSim(lambda: False, mode="text", boot_junk=b"\xf0\xf0\r\nsa\x13e\r\n"))
    with ProbeReader(server.port_names[0], mode="text", timeout=2.0) as probe:
        assert probe.read().contact is False


def test_garbled_lines_never_confirm_a_wrong_state(serve) -> None:
    sim = ProbeSim(lambda: False, mode="pin", faults=FaultPlan(1.0, ("garble",), seed=2), fault_window=0.008)
    server = serve(sim)
    with ProbeReader(server.port_names[0], mode="pin", timeout=2.0) as probe:
        states = [probe.read() for _ in range(10)]
        stats = probe.statistics
    assert all(s.contact is False for s in states)
    assert stats.resyncs >= 1


def test_dropped_bytes_fault(serve) -> None:
    sim = ProbeSim(lambda: True, mode="text", faults=FaultPlan(1.0, ("drop",), seed=3), fault_window=0.008)
    server = serve(sim)
    with ProbeReader(server.port_names[0], mode="text", timeout=2.0) as probe:
        assert all(probe.read().contact for _ in range(10))
        assert probe.statistics.resyncs >= 1


def test_random_characters_stall_into_a_timeout(serve) -> None:
    # thesis 3.4: LabVIEW received random characters instead of safe/stop; the reader must not
    # invent a state from them but report a timeout
    server = serve(ProbeSim(lambda: True, mode="text", faults=FaultPlan(1.0, ("error",), seed=4)))
    with ProbeReader(server.port_names[0], mode="text", timeout=0.15) as probe, pytest.raises(DeviceTimeoutError):
        probe.read()


def test_timeout_fault(serve) -> None:
    server = serve(ProbeSim(lambda: True, faults=FaultPlan(1.0, ("timeout",), seed=5), silence=1.0))
    with ProbeReader(server.port_names[0], timeout=0.1) as probe, pytest.raises(DeviceTimeoutError):
        probe.read()


def test_disconnect_fault(serve) -> None:
    sim = ProbeSim(lambda: True)
    server = serve(sim)
    with ProbeReader(server.port_names[0], timeout=0.2) as probe:
        assert probe.read().contact
        with sim.lock:  # the cable is pulled from now on
            sim.faults = FaultPlan(1.0, ("disconnect",), seed=6)
            sim._window_end = 0.0
        with pytest.raises(DeviceError) as info:
            probe.read()
            probe.read()
        assert info.value.code is None
