"""One client's I++ DME session: the two queues, the error state machine, motion in time.

Lines arrive from :mod:`pcmm_geo.ippdme.server`.  Each well-tagged line is acknowledged
(``&``) at once; event methods (``...E``: AbortE, GetErrStatusE, OnMoveReportE, GetPropE) run
immediately (fast queue), the others wait in a bounded queue and run one at a time, so their
data and completion lines keep the order of the commands (spec §6.2.3).  A refused command
answers ``! Error(...)`` then ``%``.

Error state (spec §6.2.5, §6.3.1.5): after an error of severity >= 2, or after AbortE, only
ClearAllErrors, GetErrStatusE, GetXtdErrStatus and EndSession run; anything else is refused
with 0514.  Outside a session only StartSession and EndSession run (0508 otherwise).

The machine is a :class:`~pcmm_geo.ippdme.machine.MachineBackend` (the simulated micro-CMM or
the real one on its drivers, :mod:`pcmm_geo.ippdme.drivers`).  Simulated motion takes
``length / speed * time_scale`` seconds of wall time (``time_scale`` 0: instant)
in steps of at most 50 ms, during which OnMoveReportE daemons report and AbortE stops the
machine where it is.  A client that vanishes mid-move leaves the machine where it stopped.
"""

from __future__ import annotations

import asyncio
import math
import threading
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np

from pcmm_geo.ippdme.commands import HANDLERS, KNOWN_METHODS, CommandError
from pcmm_geo.ippdme.machine import MachineBackend, MoveRefused
from pcmm_geo.ippdme.protocol import ERRORS, SERVER_TAG, Command, ProtocolError, format_error, parse_command
from pcmm_geo.ippdme.state import CoordinateSystems, ToolSet

__all__ = ["FAST_METHODS", "QUEUE_LIMIT", "ServerState", "Session"]

#: methods run on arrival (fast queue); AbortE is handled by the session itself
FAST_METHODS = frozenset({"AbortE", "GetErrStatusE", "OnMoveReportE", "GetPropE"})
#: commands accepted (acknowledged) but not yet run; a fuller queue delays the next Ack (spec §6.2.3)
QUEUE_LIMIT = 64
_ALLOWED_IN_ERROR = frozenset({"ClearAllErrors", "GetErrStatusE", "GetXtdErrStatus", "EndSession", "AbortE"})
_STEP_S = 0.05
T = TypeVar("T")
_ERROR_MEMORY = 20


class Aborted(Exception):
    """The running command was stopped by AbortE."""


@dataclass
class ServerState:
    """What outlives a session: the machine, the tools, the coordinate systems."""

    machine: MachineBackend
    tools: ToolSet
    csy: CoordinateSystems

    @classmethod
    def create(cls, machine: MachineBackend) -> ServerState:
        return cls(machine, ToolSet(float(machine.model.tip_radius)), CoordinateSystems())


class Session:
    """The protocol state of one connection (see the module notes).

    Parameters
    ----------
    state : ServerState
    send : callable
        ``await send(line)`` writes one response line (without terminator).
    record : callable
        ``record(kind, **fields)`` appends to the transcript.
    time_scale : float
        Wall seconds per simulated second of motion (0: moves are instant).
    """

    def __init__(self, state: ServerState, send: Callable[[str], Awaitable[None]],
                 record: Callable[..., None], time_scale: float = 1.0) -> None:
        self.state = state
        self.machine = state.machine
        self.tools = state.tools
        self._send = send
        self.record = record
        self.time_scale = float(time_scale)
        self.active = False
        self.error_severity = 0
        self.errors: list[tuple[int, str]] = []
        self.aborted = False
        self.user_enabled = False
        self.report_items = ["X", "Y", "Z"]
        self.daemons: dict[str, tuple[float, float, list[str]]] = {}
        self.queue: asyncio.Queue[Command] = asyncio.Queue(maxsize=QUEUE_LIMIT)
        self._abort = asyncio.Event()
        self._aborting = False
        self._busy = False
        self._daemon_marks: dict[str, tuple[float, np.ndarray]] = {}

    # ------------------------------------------------------------------ session state
    def begin(self) -> None:
        self.active = True
        self.clear_errors()
        self.report_items = ["X", "Y", "Z"]
        self.daemons.clear()

    def end(self) -> None:
        self.active = False
        self.daemons.clear()

    def clear_errors(self) -> None:
        self.error_severity = 0
        self.errors.clear()
        self.aborted = False

    # ------------------------------------------------------------------ output
    async def data(self, cmd: Command, text: str) -> None:
        await self._send(f"{cmd.tag} # {text}")

    async def warn(self, cmd: Command, number: int, detail: str = "") -> None:
        """Send an error line without stopping the command (severity 0 or 1 warnings such as 0504)."""
        self._note(number, detail)
        await self._send(format_error(cmd.tag, number, cmd.method))

    def _note(self, number: int, detail: str) -> None:
        """Keep an error for GetXtdErrStatus, enter the error state (severity >= 2), transcript the detail."""
        severity, text = ERRORS.get(number, (3, "Error"))
        if detail:
            self.record("error", number=number, detail=detail[:500])
        if severity >= 2:
            self.error_severity = max(self.error_severity, severity)
        self.errors = ([*self.errors, (number, text)])[-_ERROR_MEMORY:]

    # ------------------------------------------------------------------ input
    async def receive(self, raw: bytes) -> None:
        """Handle one received line (terminator removed)."""
        try:
            cmd = parse_command(raw)
        except ProtocolError as exc:
            tag = exc.tag or SERVER_TAG
            if exc.tag:
                await self._send(f"{tag} &")
            self._note(exc.number, exc.detail)
            await self._send(format_error(tag, exc.number, exc.method))
            if exc.tag:
                await self._send(f"{tag} %")
            return
        await self._send(f"{cmd.tag} &")
        if cmd.method in FAST_METHODS:
            await self.run(cmd)
        else:
            await self.queue.put(cmd)

    async def worker(self) -> None:
        """Run the normal queue until cancelled."""
        while True:
            cmd = await self.queue.get()
            self._busy = True
            try:
                if self._aborting:
                    await self._send(format_error(cmd.tag, 6, cmd.method))
                    await self._send(f"{cmd.tag} %")
                else:
                    await self.run(cmd)
            finally:
                self._busy = False
                self.queue.task_done()

    def _context_error(self, cmd: Command) -> CommandError | None:
        if not self.active and cmd.method not in ("StartSession", "EndSession"):
            return CommandError(508, "no session is active (StartSession first)")
        if cmd.method not in HANDLERS and cmd.method != "AbortE":
            return CommandError(501 if cmd.method in KNOWN_METHODS else 507, cmd.method)
        if cmd.is_event and not cmd.method.endswith("E"):
            return CommandError(8, "an event tag is only for event methods (...E)")
        if (self.aborted or self.error_severity >= 2) and cmd.method not in _ALLOWED_IN_ERROR:
            return CommandError(514)
        return None

    async def run(self, cmd: Command) -> None:
        """Execute one acknowledged command: data lines, then error or nothing, then ``%``."""
        error = self._context_error(cmd)
        if error is None:
            try:
                if cmd.method == "AbortE":
                    await self._abort_all()
                else:
                    await HANDLERS[cmd.method](self, cmd)
            except CommandError as exc:
                error = exc
            except Aborted:
                error = CommandError(6)
            except MoveRefused as exc:
                error = CommandError(exc.number, exc.detail)
            except (TimeoutError, ConnectionError, asyncio.CancelledError):
                raise
            except Exception as exc:  # a fault of the server itself: answered, recorded, the session goes on
                self.record("fault", method=cmd.method, error=f"{type(exc).__name__}: {exc}"[:500])
                error = CommandError(511, type(exc).__name__)
        if error is not None:
            self._note(error.number, error.detail)
            await self._send(format_error(cmd.tag, error.number, cmd.method))
        await self._send(f"{cmd.tag} %")

    async def _abort_all(self) -> None:
        """AbortE: stop the motion and the running command, refuse the pending ones, then require ClearAllErrors."""
        self._aborting = True
        self._abort.set()
        try:
            for _ in range(2000):  # at most ~10 s; each pending command answers at once
                if self.queue.empty() and not self._busy:
                    break
                await asyncio.sleep(0.005)
        finally:
            self._aborting = False
            self._abort.clear()
        self.aborted = True

    # ------------------------------------------------------------------ motion
    async def travel(self, target: np.ndarray, speed: float, *, check: bool = True) -> None:
        """Move the tip centre in a straight line to ``target`` (machine frame) at ``speed`` mm/s (the backend's move).

        With ``check``: refuse a path that leaves the workspace (2500, no motion) and stop at
        the first contact with a workpiece (2504 Collision).
        """
        await self.machine.travel(self, np.asarray(target, dtype=float), speed, check=check)

    async def wait(self, seconds: float) -> None:
        """Let ``seconds`` of machine time pass (probing search), abortable."""
        here = self.machine.position.copy()
        await self.motion(here, here, 1.0, duration=seconds)

    async def motion(self, start: np.ndarray, end: np.ndarray, speed: float, duration: float | None = None) -> None:
        """Simulated motion from ``start`` to ``end`` in ``time_scale``-scaled time: reports, abortable (Aborted)."""
        length = float(np.linalg.norm(end - start))
        if duration is None:
            duration = length / speed if speed > 0 else 0.0
        duration *= self.time_scale
        loop = asyncio.get_running_loop()
        t0 = loop.time()
        self._daemon_marks = {tag: (t0, start.copy()) for tag in self.daemons}
        while True:
            elapsed = loop.time() - t0
            fraction = 1.0 if duration <= 0 else min(1.0, elapsed / duration)
            self.machine.position = start + fraction * (end - start)
            await self._report(loop.time())
            if fraction >= 1.0:
                return
            if self._abort.is_set():
                raise Aborted
            await asyncio.sleep(min(_STEP_S, max(duration - elapsed, 0.0)))

    async def run_blocking(self, function: Callable[[threading.Event], T], *, poll_s: float = 0.02) -> T:
        """Run ``function(stop)`` (blocking device I/O) in a worker thread while the session stays responsive.

        OnMoveReportE daemons report the machine's position meanwhile; AbortE sets ``stop`` (the
        function ends at its next safe point, e.g. after the current step of a stepped move) and
        raises :class:`Aborted` once it has returned; a cancelled session (client gone) sets
        ``stop`` too and leaves the thread to finish its step (the backend's lock keeps the next
        command waiting until it has).
        """
        stop = threading.Event()
        loop = asyncio.get_running_loop()
        self._daemon_marks = {tag: (loop.time(), self.machine.position.copy()) for tag in self.daemons}
        future = asyncio.ensure_future(asyncio.to_thread(function, stop))
        try:
            while not future.done():
                await asyncio.wait({future}, timeout=poll_s)
                await self._report(loop.time())
                if self._abort.is_set() and not stop.is_set():
                    stop.set()
        except asyncio.CancelledError:
            stop.set()
            raise
        result = future.result()
        if stop.is_set():
            raise Aborted
        return result

    async def _report(self, now: float) -> None:
        for tag, (interval, distance, items) in list(self.daemons.items()):
            last_time, last_pos = self._daemon_marks.get(tag, (-math.inf, self.machine.position))
            moved = float(np.linalg.norm(self.machine.position - last_pos))
            if now - last_time >= 0.1 and (now - last_time >= interval or moved >= distance):
                from pcmm_geo.ippdme.commands import format_position

                await self._send(f"{tag} # {format_position(self, items, self.machine.position)}")
                self._daemon_marks[tag] = (now, self.machine.position.copy())

    # ------------------------------------------------------------------ transcript
    def record_probe(self, cmd: Command, result: Any, refused: MoveRefused | None) -> None:
        """Transcript entry of a probing: machine-frame result, the point as reported, or the refusal."""
        if result is None:
            assert refused is not None
            self.record("point", tag=cmd.tag, error=refused.number, detail=refused.detail)
            return
        csy = self.state.csy
        self.record("point", tag=cmd.tag, csy=csy.active, reported_mm=csy.to_client(result.point).tolist(),
                    reported_ijk=csy.direction_to_client(result.direction).tolist(), **result.to_dict())
