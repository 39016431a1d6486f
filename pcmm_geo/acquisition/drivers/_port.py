"""Serial-port plumbing shared by the drivers: opening, reading with deadlines, counters.

Drivers accept either a port name (``"/dev/ttyUSB0"``, ``"COM11"``, any pyserial URL such as
``"loop://"``) or an object that behaves like an open :class:`serial.Serial` (``read``,
``write``, ``reset_input_buffer``, ``timeout``).  pyserial's ``SerialException`` (an
``OSError``) is translated into :class:`~pcmm_geo.errors.DeviceError` here, so callers only see
the pcmm_geo error tree.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol, Self

from pcmm_geo._optional import require
from pcmm_geo.errors import DeviceError, DeviceProtocolError, DeviceTimeoutError, InvalidInputError

__all__ = ["LinkCounters", "LinkStatistics", "SerialLike", "is_transient", "link_clock", "open_port"]

#: reason text of the DeviceError raised when the port itself fails (cable pulled, pty closed)
DISCONNECTED = "port disconnected or failed"


class SerialLike(Protocol):
    """The part of :class:`serial.Serial` the drivers use."""

    timeout: float | None

    def read(self, size: int = 1) -> bytes: ...

    def write(self, data: bytes) -> int | None: ...

    def reset_input_buffer(self) -> None: ...

    def close(self) -> None: ...


@dataclass(frozen=True)
class LinkStatistics:
    """Snapshot of a driver's link counters.

    Attributes
    ----------
    requests : int
        Requests sent (or reads started, for streaming devices).
    resyncs : int
        Times bytes were discarded to regain frame / packet alignment.
    timeouts : int
        Reads that ended without the expected data.
    device_errors : int
        Error replies / error values reported by the device.
    discarded_bytes : int
        Bytes thrown away while resynchronising.
    """

    requests: int = 0
    resyncs: int = 0
    timeouts: int = 0
    device_errors: int = 0
    discarded_bytes: int = 0

    def __add__(self, other: LinkStatistics) -> LinkStatistics:
        return LinkStatistics(
            self.requests + other.requests,
            self.resyncs + other.resyncs,
            self.timeouts + other.timeouts,
            self.device_errors + other.device_errors,
            self.discarded_bytes + other.discarded_bytes,
        )


class LinkCounters:
    """Mutable counters kept by one driver; :meth:`snapshot` freezes them."""

    def __init__(self) -> None:
        self.requests = 0
        self.resyncs = 0
        self.timeouts = 0
        self.device_errors = 0
        self.discarded_bytes = 0

    def snapshot(self) -> LinkStatistics:
        """Frozen copy of the counters."""
        return LinkStatistics(self.requests, self.resyncs, self.timeouts, self.device_errors, self.discarded_bytes)


def open_port(port: str | SerialLike, *, device: str, baudrate: int, timeout: float) -> tuple[SerialLike, bool]:
    """Open ``port`` (name or URL) with 8N1 framing, or adopt an already-open port object.

    Parameters
    ----------
    port : str or serial-like object
        Port name / pyserial URL, or an open port (used as is; its ``timeout`` is set).
    device : str
        Device name for error messages.
    baudrate : int
        Bits per second (ignored for an adopted port object).
    timeout : float
        Read timeout of a single ``read`` call, seconds (> 0).

    Returns
    -------
    (port, owned) : tuple
        The port object and whether this call opened it (and the driver must close it).

    Raises
    ------
    InvalidInputError
        Non-positive timeout or a port argument of the wrong type.
    DeviceError
        The port cannot be opened.

    Examples
    --------
    >>> link, owned = open_port("loop://", device="demo", baudrate=9600, timeout=0.05)
    >>> owned, link.write(b"x"), link.read(1)
    (True, 1, b'x')
    >>> link.close()
    """
    if not (timeout > 0):
        raise InvalidInputError("timeout", "a positive number of seconds", repr(timeout))
    if isinstance(port, str):
        serial = require("serial")

        try:
            link = serial.serial_for_url(
                port, baudrate=baudrate, bytesize=8, parity="N", stopbits=1, timeout=timeout, exclusive=None
            )
        except (serial.SerialException, OSError, ValueError) as exc:
            raise DeviceError(device, f"cannot open port {port!r}: {exc}") from exc
        return link, True
    for attribute in ("read", "write", "reset_input_buffer"):
        if not callable(getattr(port, attribute, None)):
            raise InvalidInputError("port", "a port name or an open pyserial-like port", type(port).__name__)
    port.timeout = timeout
    return port, False


def _port_failures() -> tuple[type[BaseException], ...]:
    """Exception types meaning "the port failed": OSError (SerialException) and termios.error."""
    try:
        import termios
    except ImportError:  # pragma: no cover - not POSIX
        return (OSError,)
    return (OSError, termios.error)


def read_some(link: SerialLike, size: int, device: str) -> bytes:
    """``link.read(size)`` with pyserial failures mapped to :class:`DeviceError` (code None)."""
    try:
        return link.read(size)
    except _port_failures() as exc:  # serial.SerialException derives from OSError
        raise DeviceError(device, f"{DISCONNECTED}: {exc}") from exc


def write_all(link: SerialLike, data: bytes, device: str) -> None:
    """``link.write(data)`` with failures mapped to :class:`DeviceError`."""
    try:
        link.write(data)
    except _port_failures() as exc:
        raise DeviceError(device, f"{DISCONNECTED}: {exc}") from exc


def flush_input(link: SerialLike, device: str) -> None:
    """Discard bytes waiting in the input buffer (stale stream data)."""
    try:
        link.reset_input_buffer()
    except _port_failures() as exc:
        raise DeviceError(device, f"{DISCONNECTED}: {exc}") from exc


def link_clock(link: object) -> Callable[[], float]:
    """The clock a driver measures its deadlines with: the port's ``clock`` if it has one, else ``time.monotonic``.

    Simulated ports (:class:`~pcmm_geo.acquisition.simulators.pty.VirtualPort`) carry a simulated
    clock so that timeouts depend on simulated time, not on the host's speed.
    """
    clock = getattr(link, "clock", None)
    return clock if callable(clock) else time.monotonic


def deadline_after(seconds: float) -> float:
    """Monotonic time ``seconds`` from now."""
    return time.monotonic() + seconds


def is_transient(error: BaseException) -> bool:
    """Whether retrying the same request may succeed.

    Timeouts, protocol (framing) errors, a Zaber "busy" reply (code 255) and the error values a
    laser sensor streams (no target, out of range: codes 16370-16383 and 262075-262082) are
    transient; a failed port (``code`` None) or a refused command (e.g. code 20, target out of
    range) is not.

    Examples
    --------
    >>> is_transient(DeviceTimeoutError("zaber", 0.1)), is_transient(DeviceError("zaber", "gone"))
    (True, False)
    """
    if isinstance(error, (DeviceTimeoutError, DeviceProtocolError)):
        return True
    if not isinstance(error, DeviceError):
        return False
    code = getattr(error, "code", None)
    return code is not None and (code == 255 or 16370 <= code <= 16383 or 262075 <= code <= 262082)


class PortDriver:
    """Life cycle shared by the device drivers: the link, its clock and its counters.

    A driver calls :meth:`_attach` once in its constructor; the port is closed by :meth:`close`
    (or the ``with`` block) only if the driver opened it from a name, never when it was handed a
    port object.
    """

    _link: SerialLike
    _owned: bool
    _clock: Callable[[], float]
    _counters: LinkCounters

    def _attach(self, port: str | SerialLike, *, device: str, baudrate: int, timeout: float) -> None:
        self._link, self._owned = open_port(port, device=device, baudrate=baudrate, timeout=timeout)
        self._clock = link_clock(self._link)
        self._counters = LinkCounters()

    def close(self) -> None:
        """Close the port if this driver opened it."""
        if self._owned:
            self._link.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
