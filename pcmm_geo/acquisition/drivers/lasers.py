"""Micro-Epsilon optoNCDT laser sensors: ILD1302 (lasers a, b) and ILD1420 (laser c) streams.

Both sensors stream binary values continuously; this module decodes the streams with frame
resynchronisation and converts raw counts to millimetres (docs/protocols.md §2):

* **ILD1302** (ILD1402-family format, assumed until checked on the rig): 14-bit values in two
  bytes, the first with bit 7 set (``1 D13..D7``), the second with bit 7 clear (``0 D6..D0``);
  ``x = (raw * 1.02 / 16368 - 0.01) * MR``; raw 16370..16383 are error codes.
* **ILD1420**: 18-bit values in three bytes L, M, H tagged by their two top bits
  (``00 D5..D0``, ``01 D11..D6``, ``1x D17..D12``); ``x = (raw * 1.02 / 65520 - 0.01) * MR``;
  raw 262075..262082 are error values.

``x`` is the distance from the start of the measuring range (SMR); the seed's lasers have
MR = 200 mm and SMR = 60 mm, so the distance from the sensor window is ``60 + x``.  The laser
reading used by the kinematics (thesis eqs 2.3-2.8, Table 3.2) is ``x``.

The ILD1420 also takes ASCII commands on the same line (reply ended by the prompt ``->``,
errors as ``Exxx text``); :meth:`LaserSensor.command` / :meth:`LaserSensor.get_info` send them
and separate the reply from the binary values still streaming.

Examples
--------
>>> encode_ild1302(8184).hex(" "), round(ild1302_to_mm(8184), 6)
('bf 78', 100.0)
>>> encode_ild1420(32760, first=True).hex(" "), round(ild1420_to_mm(32760), 6)
('38 7f 87', 100.0)
"""

from __future__ import annotations

from dataclasses import dataclass

from pcmm_geo.acquisition.drivers._port import (
    LinkStatistics,
    PortDriver,
    SerialLike,
    flush_input,
    read_some,
    write_all,
)
from pcmm_geo.errors import DeviceError, DeviceTimeoutError, InvalidInputError

__all__ = [
    "ILD1302_ERRORS",
    "ILD1420_ERRORS",
    "Ild1302Decoder",
    "Ild1420Decoder",
    "LaserReading",
    "LaserSensor",
    "encode_ild1302",
    "encode_ild1420",
    "ild1302_from_mm",
    "ild1302_to_mm",
    "ild1420_from_mm",
    "ild1420_to_mm",
]

MEASURING_RANGE_MM = 200.0  # seed: 200 mm lasers
START_OF_RANGE_MM = 60.0  # seed: start of measuring range
ILD1302_FULL_SCALE = 16368
ILD1420_FULL_SCALE = 65520

#: ILD1302/1402 digital error codes (protocols.md §2.2)
ILD1302_ERRORS: dict[int, str] = {
    16370: "no object detected",
    16372: "object too close (before start of range)",
    16374: "object too far (after end of range)",
    16376: "target cannot be evaluated",
    16378: "external laser off",
    16380: "sensor in trigger mode / target moving towards sensor",
}
#: ILD1420 error values (protocols.md §2.3)
ILD1420_ERRORS: dict[int, str] = {
    262075: "data amount too big for the baud rate",
    262076: "no peak detected",
    262077: "peak before the measuring range",
    262078: "peak after the measuring range",
    262080: "value cannot be calculated",
    262081: "peak too wide",
    262082: "laser off",
}


def ild1302_to_mm(raw: int, measuring_range: float = MEASURING_RANGE_MM) -> float:
    """ILD1302 raw count -> mm from the start of range: ``(raw * 1.02 / 16368 - 0.01) * MR``."""
    return (raw * 1.02 / ILD1302_FULL_SCALE - 0.01) * measuring_range


def ild1302_from_mm(distance: float, measuring_range: float = MEASURING_RANGE_MM) -> int:
    """Inverse of :func:`ild1302_to_mm`, rounded to a whole count."""
    return round((distance / measuring_range + 0.01) * ILD1302_FULL_SCALE / 1.02)


def ild1420_to_mm(raw: int, measuring_range: float = MEASURING_RANGE_MM) -> float:
    """ILD1420 raw value -> mm from the start of range: ``(raw * 1.02 / 65520 - 0.01) * MR``."""
    return (raw * 1.02 / ILD1420_FULL_SCALE - 0.01) * measuring_range


def ild1420_from_mm(distance: float, measuring_range: float = MEASURING_RANGE_MM) -> int:
    """Inverse of :func:`ild1420_to_mm`, rounded to a whole count."""
    return round((distance / measuring_range + 0.01) * ILD1420_FULL_SCALE / 1.02)


def encode_ild1302(raw: int) -> bytes:
    """Two bytes of one ILD1302 value: ``1 D13..D7`` then ``0 D6..D0``.

    Raises
    ------
    InvalidInputError
        ``raw`` outside 0..16383.

    Examples
    --------
    >>> encode_ild1302(2099).hex(" ")
    '90 33'
    """
    if not 0 <= raw <= 0x3FFF:
        raise InvalidInputError("raw", "an ILD1302 count in [0, 16383]", repr(raw))
    return bytes((0x80 | (raw >> 7), raw & 0x7F))


def encode_ild1420(raw: int, *, first: bool = True) -> bytes:
    """Three bytes L, M, H of one ILD1420 value (H tagged ``10`` for the first value of a block, else ``11``).

    Raises
    ------
    InvalidInputError
        ``raw`` outside 0..262143.

    Examples
    --------
    >>> encode_ild1420(32760, first=False).hex(" ")
    '38 7f c7'
    """
    if not 0 <= raw <= 0x3FFFF:
        raise InvalidInputError("raw", "an ILD1420 value in [0, 262143]", repr(raw))
    high_tag = 0x80 if first else 0xC0
    return bytes((raw & 0x3F, 0x40 | ((raw >> 6) & 0x3F), high_tag | (raw >> 12)))


class _StreamDecoder:
    """Common bookkeeping of the frame decoders (counts of discarded bytes and resyncs)."""

    def __init__(self) -> None:
        self.values_decoded = 0
        self.resyncs = 0
        self.discarded_bytes = 0
        self.leading_bytes = 0  # discarded before the first whole value (joining mid-frame)
        self._pending = bytearray()
        self._aligned = False

    def reset(self) -> None:
        """Forget partial frames (after flushing the port); counters are kept."""
        self._pending.clear()
        self._aligned = False

    def _drop(self, count: int) -> None:
        if count <= 0:
            return
        if self._aligned:
            self.resyncs += 1
            self.discarded_bytes += count
        else:
            self.leading_bytes += count

    def _value(self, raw: int, out: list[int]) -> None:
        self._aligned = True
        self.values_decoded += 1
        out.append(raw)


class Ild1302Decoder(_StreamDecoder):
    """Decodes the ILD1302 2-byte stream; a byte with bit 7 set always starts a value.

    Examples
    --------
    >>> decoder = Ild1302Decoder()
    >>> decoder.feed(bytes([0x78]) + encode_ild1302(8184) + encode_ild1302(100))
    [8184, 100]
    >>> decoder.leading_bytes, decoder.resyncs
    (1, 0)
    """

    def feed(self, data: bytes) -> list[int]:
        """Decode ``data``; returns the whole raw values found, in order."""
        out: list[int] = []
        for byte in data:
            if byte & 0x80:
                self._drop(len(self._pending))  # a start byte whose partner was lost
                self._pending[:] = bytes((byte,))
            elif self._pending:
                self._value(((self._pending[0] & 0x7F) << 7) | byte, out)
                self._pending.clear()
            else:
                self._drop(1)  # low byte without its high byte
        return out


class Ild1420Decoder(_StreamDecoder):
    """Decodes the ILD1420 3-byte L, M, H stream using the two tag bits of every byte.

    Examples
    --------
    >>> decoder = Ild1420Decoder()
    >>> decoder.feed(bytes([0x87]) + encode_ild1420(32760) + encode_ild1420(5, first=False))
    [32760, 5]
    """

    def feed(self, data: bytes) -> list[int]:
        """Decode ``data``; returns the whole raw values found, in order."""
        out: list[int] = []
        for byte in data:
            tag = byte >> 6
            if tag == 0:  # L starts a value
                self._drop(len(self._pending))
                self._pending[:] = bytes((byte,))
            elif tag == 1 and len(self._pending) == 1:
                self._pending.append(byte)
            elif tag >= 2 and len(self._pending) == 2:
                low, mid = self._pending
                self._value(((byte & 0x3F) << 12) | ((mid & 0x3F) << 6) | (low & 0x3F), out)
                self._pending.clear()
            else:
                self._drop(len(self._pending) + 1)
                self._pending.clear()
        return out


@dataclass(frozen=True)
class LaserReading:
    """One laser reading: the median of several consecutive stream values.

    Attributes
    ----------
    raw : int
        Median raw count (as transmitted, before any conversion).
    distance : float
        Distance from the start of the measuring range, mm (the value logged as ``laser_x``).
    absolute_distance : float
        Distance from the sensor window, mm (``start_of_range + distance``).
    samples : int
        Number of values the median was taken over.
    spread : float
        Max - min of those values, mm (settling / noise indicator).
    """

    raw: int
    distance: float
    absolute_distance: float
    samples: int
    spread: float


class LaserSensor(PortDriver):
    """Driver of one streaming optoNCDT sensor (model ``"ILD1302"`` or ``"ILD1420"``).

    Parameters
    ----------
    port : str or serial-like object
        Port name / URL or an open port.
    model : {"ILD1302", "ILD1420"}
        Output format.
    name : str
        Name used in error messages (``"laser_a"``).
    measuring_range, start_of_range : float
        MR and SMR, mm (seed: 200 and 60).
    samples : int
        Values per reading (the median is reported).
    timeout : float
        Seconds to wait for enough valid values.
    baudrate : int, optional
        Default 115200 (ILD1302) or 921600 (ILD1420).

    Examples
    --------
    >>> from pcmm_geo.acquisition.simulators.devices import LaserStreamSim
    >>> from pcmm_geo.acquisition.simulators.pty import PtyServer
    >>> sim = LaserStreamSim(lambda: 42.0, model="ILD1302")
    >>> with PtyServer([sim]) as server, LaserSensor(server.port_names[0]) as laser:
    ...     round(laser.read().distance, 2)
    42.0
    """

    def __init__(
        self,
        port: str | SerialLike,
        *,
        model: str = "ILD1302",
        name: str = "laser",
        measuring_range: float = MEASURING_RANGE_MM,
        start_of_range: float = START_OF_RANGE_MM,
        samples: int = 5,
        timeout: float = 0.5,
        baudrate: int | None = None,
    ) -> None:
        if model not in ("ILD1302", "ILD1420"):
            raise InvalidInputError("model", "'ILD1302' or 'ILD1420'", repr(model))
        if not (isinstance(samples, int) and samples >= 1):
            raise InvalidInputError("samples", "an integer >= 1", repr(samples))
        if not (measuring_range > 0 and timeout > 0):
            raise InvalidInputError("measuring_range/timeout", "positive numbers", f"{measuring_range}/{timeout}")
        self.model = model
        self.name = name
        self.measuring_range = float(measuring_range)
        self.start_of_range = float(start_of_range)
        self.samples = samples
        self.timeout = float(timeout)
        if baudrate is None:
            baudrate = 115200 if model == "ILD1302" else 921600
        self._decoder: _StreamDecoder = Ild1302Decoder() if model == "ILD1302" else Ild1420Decoder()
        self._errors = ILD1302_ERRORS if model == "ILD1302" else ILD1420_ERRORS
        self._error_floor = 16370 if model == "ILD1302" else 262075
        self._attach(port, device=name, baudrate=baudrate, timeout=0.01)

    @property
    def statistics(self) -> LinkStatistics:
        """Reads, resyncs, timeouts and error values so far."""
        counters = self._counters
        return LinkStatistics(
            counters.requests, self._decoder.resyncs, counters.timeouts, counters.device_errors,
            self._decoder.discarded_bytes,
        )

    def to_mm(self, raw: int) -> float:
        """Raw count -> mm from the start of range for this model and measuring range."""
        if self.model == "ILD1302":
            return ild1302_to_mm(raw, self.measuring_range)
        return ild1420_to_mm(raw, self.measuring_range)

    def command(self, text: str, *, timeout: float | None = None) -> list[str]:
        """ILD1420 only: send an ASCII command line and return the reply lines (prompt ``->`` removed).

        The sensor may keep streaming while it answers; binary values are recognised (an L byte,
        an M byte, then a byte with bit 7 set, which text never contains) and skipped, assuming the
        sensor inserts its text between whole values.  Before sending, the reader waits for the end
        of a value so that the tail of a value cut by the flush is not taken for text.

        Raises
        ------
        InvalidInputError
            Not an ILD1420, or a command that is not one printable ASCII line.
        DeviceError
            The sensor answered ``Exxx ...`` (``code`` = xxx) or the port failed.
        DeviceTimeoutError
            No prompt within ``timeout``.
        """
        if self.model != "ILD1420":
            raise InvalidInputError("model", "'ILD1420' for ASCII commands", repr(self.model))
        if not text or not text.isascii() or not text.isprintable():
            raise InvalidInputError("command", "one line of printable ASCII", repr(text))
        wait = self.timeout if timeout is None else timeout
        self._counters.requests += 1
        flush_input(self._link, self.name)
        self._align_to_value_end()
        write_all(self._link, text.encode("ascii") + b"\r\n", self.name)
        deadline = self._clock() + wait
        pending = bytearray()
        reply = bytearray()
        while b"->" not in reply:
            if self._clock() >= deadline:
                self._counters.timeouts += 1
                raise DeviceTimeoutError(self.name, wait, f"no prompt after {text!r}")
            pending += read_some(self._link, 256, self.name)
            index = 0
            while index < len(pending):
                byte = pending[index]
                whole_value = index + 2 < len(pending) and pending[index + 1] >> 6 == 1 and pending[index + 2] & 0x80
                if byte >> 6 == 0 and whole_value:
                    index += 3  # a whole binary value
                elif byte >> 6 == 0 and index + 2 >= len(pending) and (
                    index + 1 == len(pending) or pending[index + 1] >> 6 == 1
                ):
                    break  # may be the start of a value: wait for more bytes
                else:
                    if not byte & 0x80:
                        reply.append(byte)
                    index += 1
            del pending[:index]
            if b"->" in reply and pending:  # text held back as a possible value start
                reply += bytes(b for b in pending if not b & 0x80)
        lines = [line.strip() for line in reply.decode("ascii", "replace").split("->")[0].splitlines()]
        lines = [line for line in lines if line]
        for line in lines:
            code = line[1:].split(" ", 1)[0]
            if line.startswith("E") and code.isdigit():
                self._counters.device_errors += 1
                raise DeviceError(self.name, f"command {text!r} refused: {line}", int(code))
        return lines

    def get_info(self) -> dict[str, str]:
        """ILD1420 ``GETINFO``: ``{"Name": ..., "Measuring range": ..., ...}`` from ``key: value`` lines."""
        info: dict[str, str] = {}
        for line in self.command("GETINFO"):
            key, sep, value = line.partition(":")
            if sep:
                info[key.strip()] = value.strip()
        return info

    def _align_to_value_end(self) -> None:
        """Consume stream bytes up to the end of a value (a byte with bit 7 set); give up after 20 ms of silence."""
        deadline = self._clock() + 0.02
        while self._clock() < deadline:
            chunk = read_some(self._link, 1, self.name)
            if chunk and chunk[0] & 0x80:
                return
            if chunk:
                deadline = self._clock() + 0.02

    def read(self, samples: int | None = None) -> LaserReading:
        """Discard stale bytes, then take the median of ``samples`` fresh values.

        Error values are skipped; if as many error values as wanted samples arrive before
        enough valid ones, the sensor's error is raised.

        Raises
        ------
        DeviceError
            Persistent error value (``code`` = the raw error value, ``reason`` its meaning) or a
            failed port.
        DeviceTimeoutError
            Not enough valid values within ``timeout``.
        """
        wanted = self.samples if samples is None else samples
        if not (isinstance(wanted, int) and wanted >= 1):
            raise InvalidInputError("samples", "an integer >= 1", repr(wanted))
        self._counters.requests += 1
        flush_input(self._link, self.name)
        self._decoder.reset()
        values: list[int] = []
        errors: list[int] = []
        deadline = self._clock() + self.timeout
        while len(values) < wanted:
            if self._clock() >= deadline:
                self._counters.timeouts += 1
                raise DeviceTimeoutError(self.name, self.timeout, f"fewer than {wanted} valid values")
            for raw in self._decoder.feed(read_some(self._link, 64, self.name)):
                if raw >= self._error_floor:
                    errors.append(raw)
                else:
                    values.append(raw)
            if len(errors) >= wanted and len(values) < wanted:
                self._counters.device_errors += 1
                code = errors[-1]
                raise DeviceError(self.name, self._errors.get(code, "sensor error value"), code)
        chosen = sorted(values[:wanted])
        median_raw = chosen[(wanted - 1) // 2]
        distance = self.to_mm(median_raw)
        return LaserReading(
            raw=median_raw,
            distance=distance,
            absolute_distance=self.start_of_range + distance,
            samples=wanted,
            spread=self.to_mm(chosen[-1]) - self.to_mm(chosen[0]),
        )
