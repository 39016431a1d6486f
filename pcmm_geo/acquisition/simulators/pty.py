"""Pseudo-terminal server: simulated devices on real ttys (``os.openpty``), one thread for all.

Each device gets a master/slave pair; the slave is put in raw mode (``tty.setraw``) so binary
bytes pass the kernel's tty layer untouched, and its path (``/dev/pts/N``) is what a driver
opens.  The server thread multiplexes every master with ``select``: bytes written by a driver
go to :meth:`SimulatedDevice.on_receive`; whatever :meth:`SimulatedDevice.pending` returns is
written back (non-blocking: if the driver does not read and the tty buffer is full, output is
dropped and counted, as a UART would overrun).  Stop it with :meth:`PtyServer.close` or use it
as a context manager: the thread is joined and every descriptor closed.
"""

from __future__ import annotations

import os
import select
import threading
import time
from collections.abc import Sequence

from pcmm_geo.errors import DeviceError, InvalidInputError

__all__ = ["PtyServer", "SimulatedDevice", "VirtualClock", "VirtualPort"]

_IDLE_WAIT = 0.05  # s, longest select wait when no device has anything due


class SimulatedDevice:
    """Base class of a simulated serial device (subclasses override the hooks).

    Attributes
    ----------
    name : str
        Device name.
    disconnect_requested : bool
        Set by the device to make the server close its master end (a pulled cable).
    overflow_bytes : int
        Output bytes dropped because the tty buffer was full.
    """

    name = "device"

    def __init__(self) -> None:
        self.disconnect_requested = False
        self.overflow_bytes = 0
        self.lock = threading.RLock()

    def on_receive(self, data: bytes, now: float) -> None:
        """Bytes written by the driver (called in the server thread)."""

    def pending(self, now: float) -> bytes:
        """Bytes to send now (called in the server thread after every wake-up)."""
        return b""

    def next_due(self, now: float) -> float | None:
        """Monotonic time at which :meth:`pending` may next have output (None: only on input)."""
        return None


class _Endpoint:
    def __init__(self, device: SimulatedDevice) -> None:
        import tty

        self.device = device
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        os.set_blocking(self.master, False)
        self.port_name = os.ttyname(self.slave)
        self.open = True

    def hang_up(self) -> None:
        if self.open:
            self.open = False
            os.close(self.master)

    def close(self) -> None:
        self.hang_up()
        if self.slave >= 0:
            os.close(self.slave)
            self.slave = -1


class PtyServer:
    """Serve simulated devices on pseudo-terminals from one background thread.

    Parameters
    ----------
    devices : sequence of SimulatedDevice
        Devices to serve; ``port_names[i]`` is the tty of ``devices[i]``.

    Raises
    ------
    InvalidInputError
        No devices, or an object that is not a :class:`SimulatedDevice`.
    DeviceError
        Pseudo-terminals are not available (non-POSIX system).

    Examples
    --------
    >>> from pcmm_geo.acquisition.simulators.devices import ZaberChainSim
    >>> with PtyServer([ZaberChainSim()]) as server:
    ...     server.port_names[0].startswith("/dev/")
    True
    """

    def __init__(self, devices: Sequence[SimulatedDevice]) -> None:
        if not devices or not all(isinstance(d, SimulatedDevice) for d in devices):
            raise InvalidInputError("devices", "a non-empty sequence of SimulatedDevice", repr(devices))
        if not hasattr(os, "openpty"):
            raise DeviceError("simulator", "pseudo-terminals (os.openpty) are not available on this system")
        self.devices = list(devices)
        #: exceptions raised inside simulated devices (the device is hung up; drivers then see a dead port)
        self.failures: list[Exception] = []
        self._endpoints: list[_Endpoint] = []
        try:
            for device in self.devices:
                self._endpoints.append(_Endpoint(device))
            self._wake_read, self._wake_write = os.pipe()
        except BaseException:
            for endpoint in self._endpoints:
                endpoint.close()
            raise
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="pcmm-pty-sim", daemon=True)
        self._thread.start()

    @property
    def port_names(self) -> list[str]:
        """tty paths to open, in device order."""
        return [e.port_name for e in self._endpoints]

    def close(self) -> None:
        """Stop the thread and close every descriptor (idempotent)."""
        if self._stop.is_set():
            return
        self._stop.set()
        os.write(self._wake_write, b"x")
        self._thread.join(timeout=5.0)
        for endpoint in self._endpoints:
            endpoint.close()
        os.close(self._wake_read)
        os.close(self._wake_write)

    def __enter__(self) -> PtyServer:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def _serve(self) -> None:
        while not self._stop.is_set():
            now = time.monotonic()
            dues = [d for e in self._endpoints if e.open and (d := e.device.next_due(now)) is not None]
            wait = max(0.0, min([*dues, now + _IDLE_WAIT]) - now)
            readable = [e.master for e in self._endpoints if e.open]
            ready, _, _ = select.select([*readable, self._wake_read], [], [], wait)
            if self._stop.is_set():
                return
            now = time.monotonic()
            for endpoint in self._endpoints:
                if not endpoint.open:
                    continue
                try:
                    if endpoint.master in ready:
                        try:
                            data = os.read(endpoint.master, 4096)
                        except OSError:  # EIO: no slave open at the moment
                            data = b""
                        if data:
                            with endpoint.device.lock:
                                endpoint.device.on_receive(data, now)
                    self._flush(endpoint, now)
                except Exception as exc:  # a bug in a simulated device: record it, hang up that device
                    self.failures.append(exc)
                    endpoint.hang_up()

    @staticmethod
    def _flush(endpoint: _Endpoint, now: float) -> None:
        device = endpoint.device
        with device.lock:
            out = device.pending(now)
            hang_up = device.disconnect_requested
        if out:
            try:
                written = os.write(endpoint.master, out)
            except (BlockingIOError, OSError):
                written = 0
            device.overflow_bytes += len(out) - written
        if hang_up:
            endpoint.hang_up()


class VirtualClock:
    """Simulated time (s) for :class:`VirtualPort`: it only moves when a driver waits or sleeps.

    Callable like ``time.monotonic``; :meth:`sleep` replaces ``time.sleep``.  Driving drivers and
    simulated devices from one such clock makes a simulated session independent of the host's
    speed and scheduling: the same seed gives the same bytes, faults, retries and rows.

    Examples
    --------
    >>> clock = VirtualClock()
    >>> clock.sleep(2.5)
    >>> clock()
    2.5
    """

    def __init__(self, start: float = 0.0) -> None:
        self.now = float(start)

    def __call__(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        """Advance the clock by ``seconds`` (negative values count as 0)."""
        self.now += max(0.0, float(seconds))

    def advance_to(self, when: float) -> None:
        """Move the clock forward to ``when`` (never backwards)."""
        self.now = max(self.now, float(when))


class VirtualPort:
    """An in-process serial-like port serving one :class:`SimulatedDevice` on a :class:`VirtualClock`.

    Drivers accept it wherever they accept an open pyserial port; they read the time from its
    ``clock`` attribute.  ``read`` returns the bytes the device has produced by the current
    simulated time; when there are none it lets simulated time pass (up to ``timeout``) until
    the device's next output.  Each byte read costs ``byte_time`` seconds (the line's speed),
    so simulated time always moves on.  No thread, no wall-clock: deterministic by design.

    Parameters
    ----------
    device : SimulatedDevice
    clock : VirtualClock
        Shared by every port of one simulated machine (and the session's sleeps).
    byte_time : float
        Seconds per byte (default: 10 bits at 115 200 Bd).
    name : str
        Shown by ``str(port)``.

    Examples
    --------
    >>> from pcmm_geo.acquisition.simulators.devices import ZaberChainSim
    >>> from pcmm_geo.acquisition.drivers.zaber import ZaberChain
    >>> clock = VirtualClock()
    >>> port = VirtualPort(ZaberChainSim(initial_positions={1: 1234}), clock, name="zaber")
    >>> ZaberChain(port).position(1), str(port)
    (1234, 'virtual:zaber')
    """

    def __init__(self, device: SimulatedDevice, clock: VirtualClock, *, byte_time: float = 10 / 115_200,
                 name: str = "") -> None:
        self.device = device
        self.clock = clock
        self.byte_time = float(byte_time)
        self.name = name or device.name
        self.timeout: float | None = 0.0
        self._input = bytearray()
        self._dead = False
        self.is_open = True

    def __str__(self) -> str:
        return f"virtual:{self.name}"

    def _collect(self) -> None:
        if self._dead:
            return
        out = self.device.pending(self.clock.now)
        if out:
            self._input += out
        if self.device.disconnect_requested:
            self._dead = True

    def _check_open(self) -> None:
        if not self.is_open:
            raise OSError(f"{self}: port closed")
        if self._dead and not self._input:
            raise OSError(5, f"{self}: device hung up (simulated disconnect)")

    def write(self, data: bytes) -> int:
        self._check_open()
        self.device.on_receive(bytes(data), self.clock.now)
        self.clock.sleep(len(data) * self.byte_time)
        self._collect()
        return len(data)

    def read(self, size: int = 1) -> bytes:
        self._check_open()
        self._collect()
        limit = self.clock.now + (self.timeout or 0.0)
        while not self._input and not self._dead and self.clock.now < limit:
            due = self.device.next_due(self.clock.now)
            self.clock.advance_to(limit if due is None else min(max(due, self.clock.now + 1e-9), limit))
            self._collect()
        out = bytes(self._input[:size])
        del self._input[:size]
        self.clock.sleep(len(out) * self.byte_time)
        return out

    def reset_input_buffer(self) -> None:
        self._check_open()
        self._collect()
        self._input.clear()

    def close(self) -> None:
        self.is_open = False
