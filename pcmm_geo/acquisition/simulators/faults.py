"""Seeded fault injection for the device simulators.

A :class:`FaultPlan` decides, for each reply (request/response devices) or each fault window
(streaming devices), whether a fault happens and which one:

``"garble"``
    one byte of the reply / stream chunk has random bits flipped;
``"drop"``
    bytes are lost (a reply arrives incomplete; one byte of a stream chunk vanishes);
``"timeout"``
    no reply at all / the stream falls silent for a while;
``"error"``
    the device answers with an error (Zaber: code 255 busy, the command is not executed;
    lasers: error values; probe: a line of random characters as in thesis 3.4);
``"disconnect"``
    the simulator closes its end of the pseudo-terminal for good.

Examples
--------
>>> plan = FaultPlan(rate=1.0, kinds=("drop",), seed=3)
>>> plan.draw(), plan.counts["drop"]
('drop', 1)
>>> FaultPlan(rate=0.0, seed=1).draw() is None
True
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from pcmm_geo.errors import InvalidInputError

__all__ = ["FAULT_KINDS", "RECOVERABLE_FAULTS", "FaultPlan"]

FAULT_KINDS = ("garble", "drop", "timeout", "error", "disconnect")
#: the faults a session can recover from by retrying (everything but a disconnect)
RECOVERABLE_FAULTS = ("garble", "drop", "timeout", "error")


class FaultPlan:
    """Seeded generator of faults.

    Parameters
    ----------
    rate : float
        Probability in [0, 1] that a reply / window is faulty.
    kinds : iterable of str
        Fault kinds to choose from (uniformly), a subset of :data:`FAULT_KINDS`.
    seed : int
        Seed of the random generator (``numpy.random.default_rng``).

    Attributes
    ----------
    counts : dict str -> int
        How many faults of each kind were injected.
    """

    def __init__(self, rate: float = 0.0, kinds: Iterable[str] = RECOVERABLE_FAULTS, seed: int = 0) -> None:
        if not (isinstance(rate, (int, float)) and 0.0 <= rate <= 1.0):
            raise InvalidInputError("rate", "a probability in [0, 1]", repr(rate))
        self.kinds = tuple(kinds)
        unknown = [k for k in self.kinds if k not in FAULT_KINDS]
        if unknown or not self.kinds:
            raise InvalidInputError("kinds", f"a non-empty subset of {FAULT_KINDS}", repr(self.kinds))
        self.rate = float(rate)
        self.rng = np.random.default_rng(seed)
        self.counts: dict[str, int] = dict.fromkeys(FAULT_KINDS, 0)

    @property
    def total(self) -> int:
        """Number of faults injected so far."""
        return sum(self.counts.values())

    def draw(self) -> str | None:
        """The fault for the next reply / window, or None."""
        if self.rate <= 0.0 or self.rng.random() >= self.rate:
            return None
        kind = self.kinds[int(self.rng.integers(len(self.kinds)))]
        self.counts[kind] += 1
        return kind

    def garble(self, data: bytes) -> bytes:
        """``data`` with one random byte XOR-ed by a random non-zero mask."""
        if not data:
            return data
        out = bytearray(data)
        index = int(self.rng.integers(len(out)))
        out[index] ^= int(self.rng.integers(1, 256))
        return bytes(out)

    def drop(self, data: bytes, *, keep_prefix: bool = False) -> bytes:
        """``data`` with bytes lost: a random-length prefix (``keep_prefix``) or one random byte removed."""
        if not data:
            return data
        if keep_prefix:
            return data[: int(self.rng.integers(len(data)))]
        index = int(self.rng.integers(len(data)))
        return data[:index] + data[index + 1 :]

    def junk(self, length: int) -> bytes:
        """``length`` random printable-or-not bytes without a newline."""
        values = self.rng.integers(0, 256, size=length)
        return bytes(int(v) if v != 0x0A else 0x3F for v in values)
