"""Simulated devices of the micro-CMM: Zaber chain, ILD1302 / ILD1420 streams, Arduino probe.

They speak the same bytes as the real devices (protocol facts: docs/protocols.md) and
are served on pseudo-terminals by :class:`~pcmm_geo.acquisition.simulators.pty.PtyServer`.
Faults come from a seeded :class:`~pcmm_geo.acquisition.simulators.faults.FaultPlan`.
"""

from __future__ import annotations

from collections.abc import Callable

from pcmm_geo.acquisition.drivers import zaber
from pcmm_geo.acquisition.drivers.lasers import (
    ILD1302_FULL_SCALE,
    ILD1420_FULL_SCALE,
    encode_ild1302,
    encode_ild1420,
    ild1302_from_mm,
    ild1420_from_mm,
)
from pcmm_geo.acquisition.simulators.faults import FaultPlan
from pcmm_geo.acquisition.simulators.pty import SimulatedDevice
from pcmm_geo.errors import InvalidInputError

__all__ = ["LaserStreamSim", "ProbeSim", "ZaberChainSim"]

#: ``mover(device, start, target) -> final`` microsteps; lets the micro-CMM stop a move at contact
Mover = Callable[[int, int, int], int]

_T_LSR450B_MAX_POSITION = 907_087  # 450 mm / 0.49609375 µm (protocols.md §1.8, derived)


class ZaberChainSim(SimulatedDevice):
    """A chain of Zaber T-series stages (binary protocol, firmware 5 behaviour).

    Parameters
    ----------
    devices : int
        Number of stages (numbered 1..devices).
    max_position : int
        Maximum position, microsteps (Return Setting 44); targets beyond it get error 20/21.
    faults : FaultPlan, optional
        Faults drawn once per reply.
    mover : callable, optional
        ``mover(device, start, target) -> final``; default reaches the target.
    unsolicited_every : int
        If > 0, a manual-move-tracking packet (cmd 10) precedes every n-th reply.
    device_id : int
        Product id returned by command 50 (4452 = T-LSR450B).

    Attributes
    ----------
    positions : dict int -> int
        Current positions, microsteps.
    received : list of bytes
        Every whole instruction packet received (for transcript tests).
    sent : list of bytes
        Every reply as intended before faults were applied.
    """

    name = "zaber"

    def __init__(
        self,
        devices: int = 3,
        *,
        max_position: int = _T_LSR450B_MAX_POSITION,
        faults: FaultPlan | None = None,
        mover: Mover | None = None,
        unsolicited_every: int = 0,
        device_id: int = zaber.T_LSR450B_DEVICE_ID,
        initial_positions: dict[int, int] | None = None,
    ) -> None:
        super().__init__()
        if not 1 <= devices <= 254:
            raise InvalidInputError("devices", "a number of stages in [1, 254]", repr(devices))
        self.positions = {d: 0 for d in range(1, devices + 1)}
        if initial_positions:
            self.positions.update(initial_positions)
        self.max_position = int(max_position)
        self.faults = faults or FaultPlan(0.0)
        self.mover = mover
        self.unsolicited_every = unsolicited_every
        self.device_id = device_id
        self.received: list[bytes] = []
        self.sent: list[bytes] = []
        self._buffer = bytearray()
        self._last_byte = 0.0
        self._out = bytearray()
        self._replies = 0

    def on_receive(self, data: bytes, now: float) -> None:
        if self._buffer and now - self._last_byte > 0.010:  # 10 ms rule: stale partial packet
            self._buffer.clear()
        self._buffer += data
        self._last_byte = now
        while len(self._buffer) >= zaber.PACKET_SIZE:
            packet = bytes(self._buffer[: zaber.PACKET_SIZE])
            del self._buffer[: zaber.PACKET_SIZE]
            self.received.append(packet)
            self._handle(zaber.decode_packet(packet))

    def pending(self, now: float) -> bytes:
        out = bytes(self._out)
        self._out.clear()
        return out

    def _handle(self, request: zaber.ZaberReply) -> None:
        if request.device == 0:
            targets = list(self.positions)
        elif request.device in self.positions:
            targets = [request.device]
        else:
            return  # nobody with that number on the chain: silence
        for device in targets:
            fault = self.faults.draw()
            if fault == "disconnect":
                self.disconnect_requested = True
                return
            if fault == "error":
                reply = zaber.encode_packet(device, zaber.ERROR, 255)  # busy; not executed
            else:
                result = self._execute(device, request.command, request.data)
                if result is None:
                    continue
                reply = zaber.encode_packet(device, *result)
            self.sent.append(reply)
            self._replies += 1
            if self.unsolicited_every and self._replies % self.unsolicited_every == 0:
                self._out += zaber.encode_packet(device, 10, self.positions[device])
            if fault == "garble":
                reply = self.faults.garble(reply)
            elif fault == "drop":
                reply = self.faults.drop(reply, keep_prefix=True)
            elif fault == "timeout":
                reply = b""
            self._out += reply

    def _execute(self, device: int, command: int, data: int) -> tuple[int, int] | None:
        position = self.positions[device]
        if command == zaber.RESET:
            return None
        if command == zaber.HOME:
            self.positions[device] = 0
            return command, 0
        if command in (zaber.MOVE_ABSOLUTE, zaber.MOVE_RELATIVE):
            target = data if command == zaber.MOVE_ABSOLUTE else position + data
            if not 0 <= target <= self.max_position:
                return zaber.ERROR, command  # error 20 / 21: target out of range
            final = self.mover(device, position, target) if self.mover else target
            self.positions[device] = final
            return command, final
        if command == zaber.STOP:
            return command, position
        if command == zaber.RETURN_CURRENT_POSITION:
            return command, position
        if command == zaber.RETURN_DEVICE_ID:
            return command, self.device_id
        if command == zaber.ECHO_DATA:
            return command, data
        if command == zaber.RETURN_SETTING:
            settings = {zaber.SET_MAXIMUM_POSITION: self.max_position, 37: 64}
            if data in settings:
                return data, settings[data]
            return zaber.ERROR, zaber.RETURN_SETTING
        if command == zaber.RENUMBER:
            return command, device
        return zaber.ERROR, 64  # command invalid for this firmware


class LaserStreamSim(SimulatedDevice):
    """A streaming optoNCDT sensor (ILD1302 2-byte or ILD1420 3-byte format).

    Parameters
    ----------
    distance : callable
        ``distance() -> mm`` from the start of range (None: no target, error value streamed).
    model : {"ILD1302", "ILD1420"}
    measuring_range : float
        MR, mm.
    rate_hz : float
        Values per second.
    chunk_period : float
        Seconds between writes (values are written in chunks).
    faults : FaultPlan, optional
        One draw per fault window.
    fault_window : float
        Seconds a fault lasts (silence: ``silence`` seconds).
    silence : float
        Length of a "timeout" fault, s (make it longer than the driver's timeout).
    start_mid_frame : bool
        Begin the stream with half a value, as when a reader joins a running stream.
    """

    def __init__(
        self,
        distance: Callable[[], float | None],
        *,
        model: str = "ILD1302",
        measuring_range: float = 200.0,
        rate_hz: float = 1000.0,
        chunk_period: float = 0.004,
        faults: FaultPlan | None = None,
        fault_window: float = 0.05,
        silence: float = 0.3,
        start_mid_frame: bool = True,
        name: str = "laser",
    ) -> None:
        super().__init__()
        if model not in ("ILD1302", "ILD1420"):
            raise InvalidInputError("model", "'ILD1302' or 'ILD1420'", repr(model))
        self.name = name
        self.distance = distance
        self.model = model
        self.measuring_range = measuring_range
        self.rate_hz = rate_hz
        self.chunk_period = chunk_period
        self.faults = faults or FaultPlan(0.0)
        self.fault_window = fault_window
        self.silence = silence
        self._next = 0.0
        self._window_end = 0.0
        self._fault: str | None = None
        self._fault_fresh = False
        self._first_chunk = start_mid_frame
        self._carry = 0.0
        self._line = bytearray()
        self._reply = bytearray()
        self.commands: list[str] = []

    def on_receive(self, data: bytes, now: float) -> None:
        """ILD1420: ASCII command lines; the reply goes out between two whole values."""
        if self.model != "ILD1420":
            return
        for byte in data:
            if byte in (0x0D, 0x0A):
                if self._line:
                    command = self._line.decode("ascii", "replace").strip()
                    self.commands.append(command)
                    self._reply += self.respond(command)
                    self._line.clear()
            else:
                self._line.append(byte)

    def respond(self, command: str) -> bytes:
        """Reply of the simulated ILD1420 to one command (simulated content, ends with ``\\r\\n->``)."""
        if command.upper() == "GETINFO":
            text = (
                f"Name:             ILD1420-{self.measuring_range:g} (simulated)\r\n"
                f"Serial:           00000000\r\nMeasuring range:  {self.measuring_range:g} mm\r\n"
            )
        else:
            text = "E999 unknown command (simulator)\r\n"
        return text.encode("ascii") + b"->"

    def next_due(self, now: float) -> float | None:
        return self._next

    def _raw(self, fault: str | None) -> int:
        distance = None if fault == "error" else self.distance()
        if self.model == "ILD1302":
            if distance is None:
                return 16370  # no object detected
            return min(max(ild1302_from_mm(distance, self.measuring_range), 0), ILD1302_FULL_SCALE)
        if distance is None:
            return 262076  # no peak
        return min(max(ild1420_from_mm(distance, self.measuring_range), 0), ILD1420_FULL_SCALE)

    def pending(self, now: float) -> bytes:
        if now < self._next:
            return b""
        if now >= self._window_end:
            self._fault = self.faults.draw()
            self._fault_fresh = True
            self._window_end = now + (self.silence if self._fault == "timeout" else self.fault_window)
        self._next = now + self.chunk_period
        fault = self._fault
        if fault == "disconnect":
            self.disconnect_requested = True
            return b""
        if fault == "timeout":
            return b""
        self._carry += self.rate_hz * self.chunk_period
        count = max(1, int(self._carry))
        self._carry -= count
        raw = self._raw(fault)
        if self.model == "ILD1302":
            chunk = encode_ild1302(raw) * count
        else:
            chunk = b"".join(encode_ild1420(raw, first=i == 0) for i in range(count))
        if self._first_chunk:
            self._first_chunk = False
            chunk = chunk[1:]
        if self._fault_fresh and fault in ("garble", "drop"):
            chunk = self.faults.garble(chunk) if fault == "garble" else self.faults.drop(chunk)
        self._fault_fresh = False
        if self._reply:  # text goes out between two whole values
            chunk += bytes(self._reply)
            self._reply.clear()
        return chunk


class ProbeSim(SimulatedDevice):
    """The Arduino reporting the probe state as text lines every ``period`` seconds.

    Parameters
    ----------
    contact : callable
        ``contact() -> bool``.
    mode : {"text", "pin"}
        ``safe``/``stop`` lines or pin levels ``1``/``0``.
    contact_level : {0, 1}
        Pin level sent for contact (thesis 3.4: 0).
    period : float
        Seconds between lines.
    boot_junk : bytes
        Sent first, as a board resetting on open may do (e.g. ``b"\\xf0\\xf0\\r"``).
    faults : FaultPlan, optional
        One draw per fault window ("error" sends a line of random characters).
    """

    name = "probe"

    def __init__(
        self,
        contact: Callable[[], bool],
        *,
        mode: str = "pin",
        contact_level: int = 0,
        period: float = 0.004,
        boot_junk: bytes = b"",
        faults: FaultPlan | None = None,
        fault_window: float = 0.05,
        silence: float = 0.3,
    ) -> None:
        super().__init__()
        if mode not in ("text", "pin"):
            raise InvalidInputError("mode", "'text' or 'pin'", repr(mode))
        self.contact = contact
        self.mode = mode
        self.contact_level = contact_level
        self.period = period
        self.faults = faults or FaultPlan(0.0)
        self.fault_window = fault_window
        self.silence = silence
        self._junk = boot_junk
        self._next = 0.0
        self._window_end = 0.0
        self._fault: str | None = None
        self._fault_fresh = False

    def next_due(self, now: float) -> float | None:
        return self._next

    def line(self, contact: bool) -> bytes:
        """The line the firmware prints for a state."""
        if self.mode == "text":
            return b"stop\r\n" if contact else b"safe\r\n"
        level = self.contact_level if contact else 1 - self.contact_level
        return f"{level}\r\n".encode("ascii")

    def pending(self, now: float) -> bytes:
        if now < self._next:
            return b""
        self._next = now + self.period
        if self._junk:
            junk, self._junk = self._junk, b""
            return junk
        if now >= self._window_end:
            self._fault = self.faults.draw()
            self._fault_fresh = True
            self._window_end = now + (self.silence if self._fault == "timeout" else self.fault_window)
        fault, fresh = self._fault, self._fault_fresh
        self._fault_fresh = False
        if fault == "disconnect":
            self.disconnect_requested = True
            return b""
        if fault == "timeout":
            return b""
        line = self.line(bool(self.contact()))
        if fresh and fault == "garble":
            return self.faults.garble(line[:-2]) + b"\r\n"
        if fresh and fault == "drop":
            return self.faults.drop(line)
        if fault == "error":
            return self.faults.junk(4) + b"\r\n"
        return line
