"""Zaber T-series binary protocol: three daisy-chained T-LSR stages on one port (thesis 3.1).

Every instruction and every reply is a 6-byte packet ``device, command, data`` with ``data``
a signed 32-bit little-endian integer.  Device 0 addresses all devices and *each* replies
with its own number; motion commands reply when the motion has finished, with the final
position in microsteps; an error reply has command 255 and the error code as data.  A packet
whose bytes stop arriving for more than 10 ms is discarded (Zaber's 10 ms rule), which is how
this driver regains packet alignment after lost bytes.  Facts: docs/protocols.md §1.

Positions are microsteps on the wire; the T-LSR450B moves 0.49609375 µm per microstep at the
default resolution of 64 (6.35 mm lead / 12800), so the seed's park position of 247 500
microsteps is 122.78 mm above home.

Examples
--------
>>> encode_packet(1, MOVE_ABSOLUTE, 247500).hex(" ")
'01 14 cc c6 03 00'
>>> decode_packet(bytes.fromhex("03ff14000000"))
ZaberReply(device=3, command=255, data=20)
>>> round(247500 * T_LSR450B_MICROSTEP_MM, 4)
122.7832
"""

from __future__ import annotations

import struct
from collections.abc import Iterable
from dataclasses import dataclass

from pcmm_geo.acquisition.drivers._port import (
    LinkStatistics,
    PortDriver,
    SerialLike,
    flush_input,
    read_some,
    write_all,
)
from pcmm_geo.errors import DeviceError, DeviceProtocolError, DeviceTimeoutError, InvalidInputError

__all__ = [
    "ERROR",
    "ERROR_MEANINGS",
    "HOME",
    "MOVE_ABSOLUTE",
    "MOVE_RELATIVE",
    "PACKET_SIZE",
    "RETURN_CURRENT_POSITION",
    "RETURN_DEVICE_ID",
    "RETURN_SETTING",
    "SET_MAXIMUM_POSITION",
    "T_LSR450B_MICROSTEP_MM",
    "UNSOLICITED_COMMANDS",
    "ZaberChain",
    "ZaberReply",
    "decode_packet",
    "encode_packet",
]

PACKET_SIZE = 6
#: T-LSR450B microstep at the default resolution 64, mm (protocols.md §1.8)
T_LSR450B_MICROSTEP_MM = 0.49609375e-3
T_LSR450B_DEVICE_ID = 4452

RESET = 0
HOME = 1
RENUMBER = 2
MOVE_ABSOLUTE = 20
MOVE_RELATIVE = 21
STOP = 23
SET_MAXIMUM_POSITION = 44
RETURN_DEVICE_ID = 50
RETURN_SETTING = 53
ECHO_DATA = 55
RETURN_CURRENT_POSITION = 60
ERROR = 255
#: reply-only packets a device may send at any time (move tracking, limit active, manual move ...)
UNSOLICITED_COMMANDS = frozenset({8, 9, 10, 11, 12, 13})
MOTION_COMMANDS = frozenset({HOME, MOVE_ABSOLUTE, MOVE_RELATIVE, STOP})

#: meaning of the data of a command-255 reply (Zaber T-series error table, protocols.md §1.6)
ERROR_MEANINGS: dict[int, str] = {
    1: "cannot home (travelled too far without the home sensor: stall or slip)",
    2: "device number invalid",
    14: "supply voltage low",
    15: "supply voltage high",
    18: "stored position invalid",
    20: "move absolute: target out of range",
    21: "move relative: target out of range",
    22: "constant speed invalid",
    36: "peripheral id invalid",
    37: "microstep resolution invalid",
    38: "running current out of range",
    39: "hold current out of range",
    40: "device mode invalid",
    41: "home speed invalid",
    42: "target speed invalid",
    43: "acceleration invalid",
    44: "maximum position invalid",
    45: "current position invalid",
    47: "home offset invalid",
    48: "alias number invalid",
    53: "setting number invalid (Return Setting)",
    64: "command invalid for this firmware",
    65: "park state invalid",
    67: "temperature high",
    255: "busy: another command is running and cannot be pre-empted",
}

_INT32_MIN, _INT32_MAX = -(2**31), 2**31 - 1


@dataclass(frozen=True)
class ZaberReply:
    """One decoded 6-byte packet.

    Attributes
    ----------
    device : int
        Device number 0..255 (replies always carry the real number of the answering device).
    command : int
        Command number; 255 marks an error reply.
    data : int
        Signed 32-bit data (position in microsteps, setting value, error code).
    """

    device: int
    command: int
    data: int

    @property
    def is_error(self) -> bool:
        """True for an error reply (command 255)."""
        return self.command == ERROR


def encode_packet(device: int, command: int, data: int = 0) -> bytes:
    """Encode one instruction as 6 bytes ``device, command, data (int32 little-endian)``.

    Parameters
    ----------
    device : int
        0 (all devices) .. 255.
    command : int
        0 .. 255.
    data : int
        Signed 32-bit value.

    Returns
    -------
    bytes
        Exactly 6 bytes.

    Raises
    ------
    InvalidInputError
        A field outside its range or not an integer.

    Examples
    --------
    >>> encode_packet(2, MOVE_RELATIVE, -1000).hex(" ")
    '02 15 18 fc ff ff'
    >>> encode_packet(0, HOME).hex(" ")
    '00 01 00 00 00 00'
    """
    for name, value, low, high in (
        ("device", device, 0, 255),
        ("command", command, 0, 255),
        ("data", data, _INT32_MIN, _INT32_MAX),
    ):
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            raise InvalidInputError(name, f"an integer in [{low}, {high}]", repr(value))
    return struct.pack("<BBi", device, command, data)


def decode_packet(packet: bytes) -> ZaberReply:
    """Decode exactly 6 bytes into a :class:`ZaberReply`.

    Raises
    ------
    DeviceProtocolError
        Not exactly 6 bytes.

    Examples
    --------
    >>> decode_packet(encode_packet(1, RETURN_CURRENT_POSITION, 123456)).data
    123456
    """
    if len(packet) != PACKET_SIZE:
        raise DeviceProtocolError("zaber", f"expected a {PACKET_SIZE}-byte packet, got {len(packet)} bytes")
    device, command, data = struct.unpack("<BBi", bytes(packet))
    return ZaberReply(device, command, data)


class ZaberChain(PortDriver):
    """Driver of daisy-chained Zaber T-series stages speaking the binary protocol.

    Parameters
    ----------
    port : str or serial-like object
        Port name / pyserial URL (opened at 9600 8N1) or an open port object.
    devices : iterable of int
        Device numbers in the chain (default 1, 2, 3 = motors of columns a, b, c).
    microstep_mm : float
        Length of one microstep, mm (default T-LSR450B; read ``device_id`` on a real rig).
    timeout : float
        Seconds to wait for the reply of a non-motion command.
    move_timeout : float
        Seconds to wait for the reply of a motion command (the reply comes when it has finished).
    packet_gap : float
        A partial packet older than this (s) is discarded (Zaber's 10 ms rule).

    Examples
    --------
    >>> from pcmm_geo.acquisition.simulators.devices import ZaberChainSim
    >>> from pcmm_geo.acquisition.simulators.pty import PtyServer
    >>> with PtyServer([ZaberChainSim()]) as server, ZaberChain(server.port_names[0]) as chain:
    ...     chain.move_absolute(1, 247500)
    247500
    """

    def __init__(
        self,
        port: str | SerialLike,
        *,
        devices: Iterable[int] = (1, 2, 3),
        microstep_mm: float = T_LSR450B_MICROSTEP_MM,
        timeout: float = 0.5,
        move_timeout: float = 60.0,
        packet_gap: float = 0.010,
        baudrate: int = 9600,
    ) -> None:
        self.devices: tuple[int, ...] = tuple(int(d) for d in devices)
        if not self.devices or any(not 1 <= d <= 254 for d in self.devices) or len(set(self.devices)) != len(
            self.devices
        ):
            raise InvalidInputError("devices", "distinct device numbers in [1, 254]", repr(self.devices))
        if not (microstep_mm > 0):
            raise InvalidInputError("microstep_mm", "a positive length in mm", repr(microstep_mm))
        if not (move_timeout > 0 and packet_gap > 0):
            raise InvalidInputError("move_timeout/packet_gap", "positive seconds", f"{move_timeout}/{packet_gap}")
        self.microstep_mm = float(microstep_mm)
        self.timeout = float(timeout)
        self.move_timeout = float(move_timeout)
        self.packet_gap = float(packet_gap)
        self._attach(port, device="zaber", baudrate=baudrate, timeout=packet_gap)
        self.unsolicited: list[ZaberReply] = []
    @property
    def statistics(self) -> LinkStatistics:
        """Counters of requests, resyncs, timeouts and error replies so far."""
        return self._counters.snapshot()

    # ------------------------------------------------------------------ units
    def to_mm(self, microsteps: int) -> float:
        """Microsteps -> mm."""
        return microsteps * self.microstep_mm

    def to_microsteps(self, millimetres: float) -> int:
        """mm -> nearest whole microstep."""
        return round(millimetres / self.microstep_mm)

    # ------------------------------------------------------------------ requests
    def request(self, device: int, command: int, data: int = 0, *, reply_command: int | None = None) -> ZaberReply:
        """Send one instruction to one device and return its reply.

        Parameters
        ----------
        device : int
            A device of the chain (not 0; use :meth:`request_all`).
        command, data : int
            Instruction.
        reply_command : int, optional
            Command number the reply carries (default ``command``; Return Setting replies
            with the setting's number).

        Raises
        ------
        DeviceError
            Error reply (``code`` = Zaber error code) or a failed port.
        DeviceTimeoutError
            No complete matching reply in time.
        """
        if device not in self.devices:
            raise InvalidInputError("device", f"one of {self.devices}", repr(device))
        replies = self._exchange(device, command, data, {device}, reply_command)
        return replies[device]

    def request_all(self, command: int, data: int = 0) -> dict[int, ZaberReply]:
        """Send to device 0 (all) and collect one reply from every device, matched by device byte."""
        return self._exchange(0, command, data, set(self.devices), None)

    def _exchange(
        self, device: int, command: int, data: int, expected: set[int], reply_command: int | None
    ) -> dict[int, ZaberReply]:
        packet = encode_packet(device, command, data)
        flush_input(self._link, "zaber")  # stale replies of an earlier timed-out request
        self._counters.requests += 1
        write_all(self._link, packet, "zaber")
        wanted = command if reply_command is None else reply_command
        timeout = self.move_timeout if command in MOTION_COMMANDS else self.timeout
        deadline = self._clock() + timeout
        replies: dict[int, ZaberReply] = {}
        buffer = bytearray()
        last_byte = self._clock()
        while len(replies) < len(expected):
            now = self._clock()
            if now >= deadline:
                if buffer:
                    self._discard(buffer)
                self._counters.timeouts += 1
                missing = sorted(expected - set(replies))
                raise DeviceTimeoutError(f"zaber device(s) {missing}", timeout, f"no reply to command {command}")
            chunk = read_some(self._link, PACKET_SIZE - len(buffer), "zaber")
            now = self._clock()
            if chunk:
                buffer += chunk
                last_byte = now
            elif buffer and now - last_byte >= self.packet_gap:
                self._discard(buffer)  # 10 ms rule: a partial packet is dropped
            if len(buffer) < PACKET_SIZE:
                continue
            reply = decode_packet(bytes(buffer))
            buffer.clear()
            if reply.command in UNSOLICITED_COMMANDS:
                self.unsolicited.append(reply)
                continue
            if reply.device in expected and reply.command == ERROR:
                self._counters.device_errors += 1
                meaning = ERROR_MEANINGS.get(reply.data, "unknown error code")
                raise DeviceError(f"zaber device {reply.device}", meaning, reply.data)
            if reply.device in expected and reply.command == wanted and reply.device not in replies:
                replies[reply.device] = reply
            else:  # not ours: garbled or out of step; drop it and keep listening
                self._counters.resyncs += 1
                self._counters.discarded_bytes += PACKET_SIZE
        return replies

    def _discard(self, buffer: bytearray) -> None:
        self._counters.resyncs += 1
        self._counters.discarded_bytes += len(buffer)
        buffer.clear()

    # ------------------------------------------------------------------ commands
    def home(self, device: int = 0) -> dict[int, int]:
        """Home one device, or all (device 0); returns ``{device: final position (microsteps)}``."""
        if device == 0:
            return {d: r.data for d, r in self.request_all(HOME).items()}
        return {device: self.request(device, HOME).data}

    def move_absolute(self, device: int, position: int) -> int:
        """Move to ``position`` microsteps; returns the final position reported when it stops."""
        return self.request(device, MOVE_ABSOLUTE, position).data

    def move_relative(self, device: int, delta: int) -> int:
        """Move by ``delta`` microsteps; returns the final position."""
        return self.request(device, MOVE_RELATIVE, delta).data

    def position(self, device: int) -> int:
        """Current position of ``device``, microsteps (Return Current Position, cmd 60)."""
        return self.request(device, RETURN_CURRENT_POSITION).data

    def positions(self) -> dict[int, int]:
        """Current positions of all devices (one request to device 0)."""
        return {d: r.data for d, r in self.request_all(RETURN_CURRENT_POSITION).items()}

    def position_mm(self, device: int) -> float:
        """Current position of ``device``, mm from home."""
        return self.to_mm(self.position(device))

    def device_id(self, device: int) -> int:
        """Product id (cmd 50), e.g. 4452 for a T-LSR450B."""
        return self.request(device, RETURN_DEVICE_ID).data

    def max_position(self, device: int) -> int:
        """Maximum position setting (Return Setting 44), microsteps."""
        return self.request(device, RETURN_SETTING, SET_MAXIMUM_POSITION, reply_command=SET_MAXIMUM_POSITION).data
