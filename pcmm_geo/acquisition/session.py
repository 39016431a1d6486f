"""Acquisition session: homing, the settling pre-sequence, moves with start/stop rows (thesis 3.5-3.6).

The seed's procedure (Appendix A, chapters 3 and 6) is:

1. home the three stages, move them to the start position (247 500 microsteps);
2. run the pre-sequence: each motor to its maximum and minimum height and back to the start,
   so that the tetrahedron starts from a more repeatable settled state (thesis 6, Table 6.7);
3. for every move: record the lasers and probe *before* the move (``start_stop = 1``), move,
   wait the settling time (seed: 2 x 1.3 s, thesis 3.5), record again (``start_stop = 0``);
4. once the probe touches the artefact, only a move of the same motor in the opposite
   direction (away from the artefact) is allowed (thesis 3.6); anything else is refused with
   :class:`~pcmm_geo.errors.InvalidInputError` before a byte is sent.

Every device call is retried, with exponential backoff, on transient failures (timeouts,
garbled/partial replies, busy replies, laser error values): up to ``max_retries`` times.  An
error reply with any other code (which a garbled byte may also fake) is retried up to
``max_refusals`` times: only a code that persists aborts the session, with a message saying how
many retries failed.  A failed port (disconnect) aborts at once.  Positions are only trusted
once two consecutive position queries agree, since a garbled data byte in a Zaber reply cannot
be detected otherwise.  Counters of retries, backoff, resyncs and timeouts end up in a frozen
:class:`SessionSummary`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

from pcmm_geo.acquisition.acqlog import AcquisitionLog, LogRow
from pcmm_geo.acquisition.drivers._port import LinkStatistics, is_transient
from pcmm_geo.errors import DeviceError, InvalidInputError

__all__ = ["AcquisitionSession", "MoveResult", "SessionConfig", "SessionSummary"]

T = TypeVar("T")
MOTORS = (1, 2, 3)


@dataclass(frozen=True)
class SessionConfig:
    """Settings of an acquisition session.

    Attributes
    ----------
    settle_time : float
        Wait after each move before the stop row, s (seed: 2 x 1.3 s = 2.6 s; tests ~0).
    start_position : int
        Start (and park) position of every motor, microsteps (seed: 247 500).
    presequence_span : int
        The pre-sequence moves each motor to ``start ± span`` microsteps (default 40 320 ~ 20 mm).
    max_retries : int
        Retries of one device call after transient failures.
    laser_samples : int
        Stream values per laser reading (median).
    position_checks : int
        Consecutive identical position replies needed to trust a position.
    backoff : float
        Wait before the first retry of a device call, s; doubled for each further retry.
    max_backoff : float
        Longest wait between two retries, s.
    max_refusals : int
        Retries of a call answered with a non-transient error code before giving up.

    Examples
    --------
    >>> SessionConfig(settle_time=0.0).start_position * 6.35 / 12800  # mm above home
    122.783203125
    """

    settle_time: float = 2.6
    start_position: int = 247_500
    presequence_span: int = 40_320
    max_retries: int = 8
    laser_samples: int = 5
    position_checks: int = 2
    backoff: float = 0.01
    max_backoff: float = 0.32
    max_refusals: int = 2

    def __post_init__(self) -> None:
        for name in ("settle_time", "backoff", "max_backoff"):
            if not (getattr(self, name) >= 0):
                raise InvalidInputError(name, "a non-negative number of seconds", repr(getattr(self, name)))
        for name in ("max_retries", "presequence_span", "start_position", "max_refusals"):
            if not (isinstance(getattr(self, name), int) and getattr(self, name) >= 0):
                raise InvalidInputError(name, "a non-negative integer", repr(getattr(self, name)))
        for name in ("laser_samples", "position_checks"):
            if not (isinstance(getattr(self, name), int) and getattr(self, name) >= 1):
                raise InvalidInputError(name, "an integer >= 1", repr(getattr(self, name)))


@dataclass(frozen=True)
class MoveResult:
    """One logged move: the rows before and after it and where the motor stopped."""

    motor: int
    direction: int
    target: int
    final: int
    contact: bool
    start_row: LogRow
    stop_row: LogRow


@dataclass(frozen=True)
class SessionSummary:
    """Counters of a session.

    Attributes
    ----------
    moves, rows, contacts, refused_moves : int
        Logged moves, rows written, moves that ended in probe contact, moves refused by the
        contact rule.
    retries : int
        Device calls repeated after a failure (or a disagreeing position reply).
    error_retries : int
        Of those, retries after the device reported an error code (busy, laser error value...).
    backoff : float
        Seconds spent waiting between retries.
    resyncs, timeouts, device_errors, discarded_bytes : int
        Summed over the drivers (see :class:`~pcmm_geo.acquisition.drivers._port.LinkStatistics`).
    requests : int
        Requests / reads issued by the drivers.
    elapsed : float
        Seconds since the session started.
    """

    moves: int
    rows: int
    contacts: int
    refused_moves: int
    retries: int
    error_retries: int
    backoff: float
    resyncs: int
    timeouts: int
    device_errors: int
    discarded_bytes: int
    requests: int
    elapsed: float

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return dict(self.__dict__)


class AcquisitionSession:
    """Drive the stages, read lasers and probe, and write Table 3.2 rows to a durable log.

    Parameters
    ----------
    motors : ZaberChain
        Driver of the chain (devices 1, 2, 3 = motors of columns a, b, c).
    lasers : sequence of LaserSensor
        Lasers a, b, c.
    probe : ProbeReader
    log : AcquisitionLog, optional
        Where rows go (None: rows are only returned).
    config : SessionConfig
    sleep : callable
        ``sleep(seconds)``, injectable for tests (settling and retry backoff).
    clock : callable
        ``clock() -> seconds``, for :attr:`SessionSummary.elapsed` (a simulated clock makes
        simulated sessions repeatable).

    Examples
    --------
    >>> from pcmm_geo.acquisition.drivers.lasers import LaserSensor
    >>> from pcmm_geo.acquisition.drivers.probe import ProbeReader
    >>> from pcmm_geo.acquisition.drivers.zaber import ZaberChain
    >>> from pcmm_geo.acquisition.simulators.cmm import SimulatedRig
    >>> with SimulatedRig() as rig:
    ...     motors = ZaberChain(rig.ports["zaber"])
    ...     lasers = [LaserSensor(rig.ports[f"laser_{arm}"], model="ILD1420" if arm == "c" else "ILD1302")
    ...               for arm in "abc"]
    ...     probe = ProbeReader(rig.ports["probe"])
    ...     session = AcquisitionSession(motors, lasers, probe, config=SessionConfig(settle_time=0.0))
    ...     session.prepare(presequence=False)
    ...     result = session.move(2, 4000)
    ...     for driver in (motors, *lasers, probe):
    ...         driver.close()
    >>> result.final, result.stop_row.start_stop, result.stop_row.pos_usteps
    (251500, 0, (247500, 251500, 247500))
    """

    def __init__(
        self,
        motors: Any,
        lasers: Sequence[Any],
        probe: Any,
        log: AcquisitionLog | None = None,
        config: SessionConfig | None = None,
        *,
        sleep: Callable[[float], None] = time.sleep,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        if len(lasers) != 3:
            raise InvalidInputError("lasers", "three laser drivers (a, b, c)", f"{len(lasers)}")
        self.motors = motors
        self.lasers = tuple(lasers)
        self.probe = probe
        self.log = log
        self.config = config or SessionConfig()
        self.sleep = sleep
        self.positions: dict[int, int] = {}
        self.contact_move: tuple[int, int] | None = None
        self.clock = clock
        self._started = clock()
        self._moves = self._rows = self._contacts = self._refused = self._retries = 0
        self._error_retries = 0
        self._backoff_total = 0.0

    # ------------------------------------------------------------------ plumbing
    def _call(self, function: Callable[..., T], *args: Any) -> T:
        """``function(*args)``, retried with exponential backoff; see the module documentation."""
        retries = refusals = 0
        while True:
            try:
                return function(*args)
            except DeviceError as error:
                code = getattr(error, "code", None)
                if is_transient(error):
                    exhausted = retries >= self.config.max_retries
                elif code is not None:  # a refusal, or a garbled reply that looks like one
                    refusals += 1
                    exhausted = refusals > self.config.max_refusals or retries >= self.config.max_retries
                else:
                    raise  # the port failed: nothing to retry
                if exhausted:
                    _note_persistent(error, retries)
                    raise
                retries += 1
                self._retries += 1
                if code is not None:
                    self._error_retries += 1
                wait = min(self.config.backoff * 2 ** (retries - 1), self.config.max_backoff)
                if wait > 0:
                    self._backoff_total += wait
                    self.sleep(wait)

    def confirmed_position(self, motor: int) -> int:
        """Query ``motor``'s position until ``position_checks`` consecutive replies agree."""
        previous: int | None = None
        streak = 0
        for _ in range(self.config.max_retries + self.config.position_checks):
            value = self._call(self.motors.position, motor)
            if previous is not None and value != previous:
                self._retries += 1  # disagreeing replies: ask again
            streak = streak + 1 if value == previous else 1
            previous = value
            if streak >= self.config.position_checks:
                self.positions[motor] = value
                return value
        raise DeviceError(f"zaber device {motor}", "position replies never agreed (garbled link?)")

    def _move_to(self, motor: int, target: int, *, stop_on_contact: bool) -> int:
        """Move absolutely and confirm; repeat the move if the stage is not where it should be."""
        for _ in range(self.config.max_retries + 1):
            self._call(self.motors.move_absolute, motor, target)
            final = self.confirmed_position(motor)
            if final == target:
                return final
            if stop_on_contact and self._call(self.probe.read).contact:
                return final
            self._retries += 1
        raise DeviceError(f"zaber device {motor}", f"did not reach {target} microsteps, stays at {final}")

    # ------------------------------------------------------------------ preparation
    def identify(self) -> dict[str, int]:
        """Product id (cmd 50) and maximum position (setting 44) of each stage, for the log header.

        protocols.md §5: the exact stage model fixes the microstep size; record it with the data.
        """
        found: dict[str, int] = {}
        for motor in MOTORS:
            found[f"zaber_{motor}_device_id"] = self._call(self.motors.device_id, motor)
            found[f"zaber_{motor}_max_position_usteps"] = self._call(self.motors.max_position, motor)
        return found

    def home(self) -> dict[int, int]:
        """Home all stages (one request to device 0), then confirm each position."""
        self._call(self.motors.home, 0)
        return {motor: self.confirmed_position(motor) for motor in MOTORS}

    def go_to_start(self) -> None:
        """Move every motor to the start position."""
        for motor in MOTORS:
            self._move_to(motor, self.config.start_position, stop_on_contact=False)

    def presequence(self) -> None:
        """The seed's settling pre-sequence: each motor to start + span, start - span, start (thesis 6)."""
        start, span = self.config.start_position, self.config.presequence_span
        for motor in MOTORS:
            for target in (start + span, max(start - span, 0), start):
                self._move_to(motor, target, stop_on_contact=False)

    def prepare(self, *, presequence: bool = True) -> None:
        """Home, go to the start position and (by default) run the pre-sequence."""
        self.home()
        self.go_to_start()
        if presequence:
            self.presequence()

    def restore(self, positions: Sequence[int]) -> None:
        """Move motors 1, 2, 3 to ``positions`` (microsteps), e.g. where a resumed log left them.

        Called after :meth:`prepare`: a continued log's next row then observes the pose its last
        row did, as ``pcmm process-log`` (which chains heights from row to row) requires.
        """
        if len(positions) != 3:
            raise InvalidInputError("positions", "three positions in microsteps (motors 1, 2, 3)", repr(positions))
        for motor, target in zip(MOTORS, positions, strict=True):
            self._move_to(motor, int(target), stop_on_contact=False)

    # ------------------------------------------------------------------ measuring
    def record(self, start_stop: int, motor: int, direction: int) -> LogRow:
        """Read lasers a, b, c and the probe, write one row (raw values as read) and return it."""
        for needed in MOTORS:
            if needed not in self.positions:
                self.confirmed_position(needed)
        readings = [self._call(laser.read, self.config.laser_samples) for laser in self.lasers]
        contact = self._call(self.probe.read).contact
        row = LogRow(
            start_stop, int(contact), motor, direction, *(r.distance for r in readings),
            pos_usteps=(self.positions[1], self.positions[2], self.positions[3]),
            laser_raw=(readings[0].raw, readings[1].raw, readings[2].raw),
        )
        if self.log is not None:
            row = self.log.append(row)
        self._rows += 1
        return row

    def check_move(self, motor: int, steps: int) -> int:
        """Validate a move against the contact rule; returns its direction (+1/-1).

        Raises
        ------
        InvalidInputError
            Bad motor / steps, or a move that is not away from the artefact after contact.
        """
        if motor not in MOTORS:
            raise InvalidInputError("motor", "1, 2 or 3", repr(motor))
        if isinstance(steps, bool) or not isinstance(steps, int) or steps == 0:
            raise InvalidInputError("steps", "a non-zero integer number of microsteps", repr(steps))
        direction = 1 if steps > 0 else -1
        if self.contact_move is not None:
            contact_motor, contact_direction = self.contact_move
            if motor != contact_motor or direction != -contact_direction:
                self._refused += 1
                raise InvalidInputError(
                    "move",
                    f"motor {contact_motor} direction {-contact_direction:+d} "
                    "(after probe contact only moves away from the artefact are allowed)",
                    f"motor {motor} direction {direction:+d}",
                )
        return direction

    def move(self, motor: int, steps: int) -> MoveResult:
        """Logged move of ``motor`` by ``steps`` microsteps: start row, move, settle, stop row.

        Raises
        ------
        InvalidInputError
            Refused by :meth:`check_move`.
        DeviceError
            A device kept failing after ``max_retries`` retries, or the port failed.
        """
        direction = self.check_move(motor, steps)
        if motor not in self.positions:
            self.confirmed_position(motor)
        start_row = self.record(1, motor, direction)
        target = self.positions[motor] + steps
        final = self._move_to(motor, target, stop_on_contact=True)
        if self.config.settle_time > 0:
            self.sleep(self.config.settle_time)
        stop_row = self.record(0, motor, direction)
        contact = bool(stop_row.probe)
        if contact:
            self._contacts += 1
            if self.contact_move is None:
                self.contact_move = (motor, direction)
        else:
            self.contact_move = None
        self._moves += 1
        return MoveResult(motor, direction, target, final, contact, start_row, stop_row)

    # ------------------------------------------------------------------ report
    def link_statistics(self) -> LinkStatistics:
        """Link counters summed over the five drivers."""
        total = LinkStatistics()
        for driver in (self.motors, *self.lasers, self.probe):
            total = total + driver.statistics
        return total

    def summary(self) -> SessionSummary:
        """Frozen counters of the session so far."""
        link = self.link_statistics()
        return SessionSummary(
            moves=self._moves, rows=self._rows, contacts=self._contacts, refused_moves=self._refused,
            retries=self._retries, error_retries=self._error_retries, backoff=round(self._backoff_total, 9),
            resyncs=link.resyncs, timeouts=link.timeouts, device_errors=link.device_errors,
            discarded_bytes=link.discarded_bytes, requests=link.requests, elapsed=self.clock() - self._started,
        )


def _note_persistent(error: DeviceError, retries: int) -> None:
    """Say in the error (message and ``retries`` field) how many retries failed before giving up."""
    text = f"{error}; persistent fault: {retries} {'retry' if retries == 1 else 'retries'} failed, giving up"
    error.args = (text,)
    error.message = text
    error.fields["retries"] = retries
    error.retries = retries  # type: ignore[attr-defined]
