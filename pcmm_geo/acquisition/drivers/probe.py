"""Reader of the TP8 touch-probe state reported by the Arduino (thesis 3.4).

Two firmware modes are supported, both as text lines ended by ``\\r\\n`` (Arduino
``Serial.println``):

* ``"text"`` -- the original firmware: ``safe`` (no contact) or ``stop`` (contact).  The thesis
  reports that LabVIEW often received random characters instead, which left the machine in an
  unknown state and unable to move;
* ``"pin"`` -- the Arduino used as a DAQ: the level of the input pin, ``1`` or ``0``.  The thesis
  states 1 = not in contact, 0 = contact (the probe's contacts are in series, a deflection opens
  the circuit), so ``contact_level`` defaults to 0.

The reader discards everything that is not one whole valid token (garbled characters, boot
junk, half lines) and only accepts a state after ``confirm`` consecutive identical tokens, so
random characters can neither produce a state nor stall the reader forever (it times out).

Examples
--------
>>> parse_probe_token(b"stop\\r", mode="text"), parse_probe_token(b"1", mode="pin")
(True, False)
>>> parse_probe_token(b"s?op", mode="text") is None
True
"""

from __future__ import annotations

from dataclasses import dataclass

from pcmm_geo.acquisition.drivers._port import (
    LinkStatistics,
    PortDriver,
    SerialLike,
    flush_input,
    read_some,
)
from pcmm_geo.errors import DeviceTimeoutError, InvalidInputError

__all__ = ["ProbeReader", "ProbeState", "parse_probe_token"]

_MODES = ("text", "pin")
_MAX_LINE = 32


def parse_probe_token(line: bytes, *, mode: str, contact_level: int = 0) -> bool | None:
    """Contact state of one received line, or None when the line is not a valid token.

    Parameters
    ----------
    line : bytes
        One line without its ``\\n`` (a trailing ``\\r`` and surrounding blanks are ignored).
    mode : {"text", "pin"}
        Firmware mode.
    contact_level : {0, 1}
        Pin level that means contact in ``"pin"`` mode.

    Returns
    -------
    bool or None
        True for contact, False for no contact, None for anything else.

    Raises
    ------
    InvalidInputError
        Unknown mode or contact level.
    """
    if mode not in _MODES:
        raise InvalidInputError("mode", "'text' or 'pin'", repr(mode))
    if contact_level not in (0, 1):
        raise InvalidInputError("contact_level", "0 or 1", repr(contact_level))
    token = line.strip(b" \r\t")
    if mode == "text":
        return {b"safe": False, b"stop": True}.get(token)
    if token in (b"0", b"1"):
        return int(token) == contact_level
    return None


@dataclass(frozen=True)
class ProbeState:
    """A confirmed probe state.

    Attributes
    ----------
    contact : bool
        True when the probe touches the artefact (logged as ``probe = 1``, Table 3.2).
    token : str
        The received token (``"safe"``, ``"stop"``, ``"0"``, ``"1"``).
    discarded_lines : int
        Invalid lines thrown away while reading this state.
    """

    contact: bool
    token: str
    discarded_lines: int


class ProbeReader(PortDriver):
    """Reads the probe state from the Arduino's serial line.

    Parameters
    ----------
    port : str or serial-like object
        Port name / URL or an open port.
    mode : {"text", "pin"}
        Firmware mode (see module docstring).
    contact_level : {0, 1}
        Pin level meaning contact in pin mode (thesis: 0).
    confirm : int
        Consecutive identical valid tokens needed to accept a state.
    timeout : float
        Seconds to wait for a confirmed state.
    baudrate : int
        Default 9600.

    Examples
    --------
    >>> from pcmm_geo.acquisition.simulators.devices import ProbeSim
    >>> from pcmm_geo.acquisition.simulators.pty import PtyServer
    >>> with PtyServer([ProbeSim(lambda: True, mode="pin")]) as server:
    ...     with ProbeReader(server.port_names[0], mode="pin") as probe:
    ...         probe.read().contact
    True
    """

    def __init__(
        self,
        port: str | SerialLike,
        *,
        mode: str = "pin",
        contact_level: int = 0,
        confirm: int = 2,
        timeout: float = 0.5,
        baudrate: int = 9600,
        name: str = "probe",
    ) -> None:
        parse_probe_token(b"", mode=mode, contact_level=contact_level)  # validates both
        if not (isinstance(confirm, int) and confirm >= 1):
            raise InvalidInputError("confirm", "an integer >= 1", repr(confirm))
        self.mode = mode
        self.contact_level = contact_level
        self.confirm = confirm
        self.timeout = float(timeout)
        self.name = name
        self._attach(port, device=name, baudrate=baudrate, timeout=0.01)

    @property
    def statistics(self) -> LinkStatistics:
        """Reads, resyncs (discarded invalid lines), timeouts so far."""
        return self._counters.snapshot()

    def read(self) -> ProbeState:
        """Discard stale input and return the next confirmed state.

        Raises
        ------
        DeviceTimeoutError
            No ``confirm`` identical valid tokens in a row within ``timeout``.
        DeviceError
            The port failed.
        """
        self._counters.requests += 1
        flush_input(self._link, self.name)
        buffer = bytearray()
        first_fragment = True  # the bytes before the first newline may be half a line
        streak_state: bool | None = None
        streak_token = b""
        streak = 0
        discarded = 0
        deadline = self._clock() + self.timeout
        while True:
            if self._clock() >= deadline:
                self._counters.timeouts += 1
                raise DeviceTimeoutError(self.name, self.timeout, f"no {self.confirm} consistent probe states")
            buffer += read_some(self._link, 64, self.name)
            while b"\n" in buffer:
                line, _, rest = bytes(buffer).partition(b"\n")
                buffer[:] = rest
                if first_fragment:
                    first_fragment = False
                    if parse_probe_token(line, mode=self.mode, contact_level=self.contact_level) is None:
                        self._counters.discarded_bytes += len(line) + 1
                        continue
                state = parse_probe_token(line, mode=self.mode, contact_level=self.contact_level)
                if state is None:
                    discarded += 1
                    self._counters.resyncs += 1
                    self._counters.discarded_bytes += len(line) + 1
                    continue  # garbage between two equal tokens does not break the streak
                token = line.strip(b" \r\t")
                if streak and state == streak_state:
                    streak += 1
                else:
                    streak_state, streak_token, streak = state, token, 1
                if streak >= self.confirm:
                    return ProbeState(bool(streak_state), streak_token.decode("ascii"), discarded)
            if len(buffer) > _MAX_LINE:  # no newline for too long: garbage
                self._counters.resyncs += 1
                self._counters.discarded_bytes += len(buffer)
                discarded += 1
                buffer.clear()
