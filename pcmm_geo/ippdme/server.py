"""The asyncio TCP server: one client at a time, bounded lines, every line in the transcript.

* Lines end in CR LF (a bare LF is accepted); a line over
  :data:`~pcmm_geo.ippdme.protocol.MAX_LINE_BYTES` gets ``E0000 ! Error(3, 0008, ...)`` and the
  connection is closed (the rest of such a line cannot be trusted to be a command).
* One client holds the server at a time: a second connection gets
  ``E0000 ! Error(3, 0008, ...)`` and is closed; the first session goes on.
* A client that stops reading is dropped when a response cannot be written within
  ``write_timeout`` seconds; a flood fills the bounded command queue, after which the server
  stops reading (its Acks are delayed, spec §6.2.3) until the queue drains.
* When a client goes (closed, reset, dropped), its running command is cancelled where it is
  (a move stops at its current position), its daemons stop and the session ends; the machine
  state (position, homed, tool, coordinate system) stays as it was.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
from collections.abc import Callable
from typing import Any

from pcmm_geo.ippdme.protocol import MAX_LINE_BYTES, SERVER_TAG, format_error
from pcmm_geo.ippdme.session import ServerState, Session
from pcmm_geo.ippdme.transcript import Transcript

__all__ = ["DEFAULT_PORT", "DmeServer", "ServerThread"]

#: the I++ DME application port (spec §6.1)
DEFAULT_PORT = 1294


def _printable(raw: bytes) -> str:
    return "".join(chr(b) if 32 <= b <= 126 and b != 92 else f"\\x{b:02x}" for b in raw)


class DmeServer:
    """I++ DME server in front of a :class:`~pcmm_geo.ippdme.session.ServerState`.

    Parameters
    ----------
    state : ServerState
    transcript : Transcript
    time_scale : float
        Wall seconds per second of simulated motion (0: instant).
    write_timeout : float
        Seconds a response may wait for a client that does not read before it is dropped.
    """

    def __init__(self, state: ServerState, transcript: Transcript, *, time_scale: float = 1.0,
                 write_timeout: float = 10.0) -> None:
        self.state = state
        self.transcript = transcript
        self.time_scale = time_scale
        self.write_timeout = write_timeout
        self._holder: int | None = None
        self._connections = 0
        self.server: asyncio.base_events.Server | None = None

    async def start(self, host: str = "127.0.0.1", port: int = DEFAULT_PORT) -> int:
        """Listen on ``host``:``port`` (0: any free port); returns the bound port."""
        self.server = await asyncio.start_server(self._client, host, port, limit=MAX_LINE_BYTES + 2)
        return int(self.server.sockets[0].getsockname()[1])

    async def close(self) -> None:
        if self.server is not None:
            self.server.close()
            await self.server.wait_closed()

    async def _client(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self._connections += 1
        conn = self._connections
        peer = str(writer.get_extra_info("peername"))
        if self._holder is not None:
            self.transcript.record(conn, "rejected", peer=peer, holder=self._holder)
            line = format_error(SERVER_TAG, 8, "Connect")  # another client holds the server
            with contextlib.suppress(Exception):
                writer.write(line.encode("ascii") + b"\r\n")
                await asyncio.wait_for(writer.drain(), 2.0)
            await self._close(writer)
            return
        self._holder = conn
        self.transcript.record(conn, "connect", peer=peer)

        async def send(line: str) -> None:
            self.transcript.record(conn, "out", line=line)
            writer.write(line.encode("ascii") + b"\r\n")
            await asyncio.wait_for(writer.drain(), self.write_timeout)

        def record(kind: str, **fields: Any) -> None:
            self.transcript.record(conn, kind, **fields)

        session = Session(self.state, send, record, self.time_scale)
        worker = asyncio.create_task(session.worker())
        reason = "closed by the client"
        try:
            reason = await self._read_loop(conn, reader, session, send, worker)
        except (TimeoutError, ConnectionError, OSError) as exc:
            reason = f"dropped: {type(exc).__name__}"
        except asyncio.CancelledError:  # the server is stopping: end this client quietly
            reason = "server stopped"
        finally:
            worker.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await worker
            session.end()
            self._holder = None
            self.transcript.record(conn, "disconnect", reason=reason,
                                   position_mm=self.state.machine.position.tolist(), homed=self.state.machine.homed)
            await self._close(writer)

    async def _read_loop(self, conn: int, reader: asyncio.StreamReader, session: Session,
                         send: Callable[[str], Any], worker: asyncio.Task[None]) -> str:
        while True:
            read = asyncio.ensure_future(reader.readuntil(b"\n"))
            try:
                done, _ = await asyncio.wait({read, worker}, return_when=asyncio.FIRST_COMPLETED)
            except asyncio.CancelledError:
                read.cancel()
                raise
            if worker in done:  # the worker died (a client that does not read): drop the connection
                read.cancel()
                exc = None if worker.cancelled() else worker.exception()
                return f"dropped: {type(exc).__name__ if exc else 'worker ended'}"
            try:
                raw = read.result()
            except asyncio.IncompleteReadError as exc:
                if exc.partial:
                    self.transcript.record(conn, "in", line=_printable(exc.partial), complete=False)
                return "closed by the client"
            except asyncio.LimitOverrunError:
                self.transcript.record(conn, "error", number=8, detail=f"line longer than {MAX_LINE_BYTES} bytes")
                await send(format_error(SERVER_TAG, 8, "Server"))
                return "closed: line too long"
            raw = raw[:-1]
            if raw.endswith(b"\r"):
                raw = raw[:-1]
            self.transcript.record(conn, "in", line=_printable(raw))
            received = asyncio.ensure_future(session.receive(raw))  # may wait for room in the command queue
            try:
                await asyncio.wait({received, worker}, return_when=asyncio.FIRST_COMPLETED)
            except asyncio.CancelledError:
                received.cancel()
                raise
            if not received.done():  # the worker died while the queue was full: drop the connection
                received.cancel()
                exc = None if worker.cancelled() else worker.exception()
                return f"dropped: {type(exc).__name__ if exc else 'worker ended'}"
            received.result()

    @staticmethod
    async def _close(writer: asyncio.StreamWriter) -> None:
        with contextlib.suppress(Exception):
            writer.close()
            await asyncio.wait_for(writer.wait_closed(), 2.0)


class ServerThread:
    """Run a :class:`DmeServer` on its own event loop in a background thread (tests, notebooks).

    >>> # with ServerThread(state, transcript) as server: connect to ("127.0.0.1", server.port)
    """

    def __init__(self, state: ServerState, transcript: Transcript, *, host: str = "127.0.0.1", port: int = 0,
                 time_scale: float = 0.0, write_timeout: float = 10.0) -> None:
        self.dme = DmeServer(state, transcript, time_scale=time_scale, write_timeout=write_timeout)
        self.host = host
        self._port = port
        self.port = 0
        self._loop = asyncio.new_event_loop()
        self._ready = threading.Event()
        self._thread = threading.Thread(target=self._run, name="ippdme-server", daemon=True)
        self._error: BaseException | None = None

    def _run(self) -> None:
        asyncio.set_event_loop(self._loop)
        try:
            self.port = self._loop.run_until_complete(self.dme.start(self.host, self._port))
        except BaseException as exc:  # reported to the starting thread
            self._error = exc
            self._ready.set()
            return
        self._ready.set()
        self._loop.run_forever()
        self._loop.run_until_complete(self.dme.close())
        pending = [t for t in asyncio.all_tasks(self._loop) if not t.done()]
        for task in pending:
            task.cancel()
        self._loop.run_until_complete(asyncio.gather(*pending, return_exceptions=True))
        self._loop.close()

    def __enter__(self) -> ServerThread:
        self._thread.start()
        self._ready.wait(30.0)
        if self._error is not None:
            raise self._error
        return self

    async def _shutdown(self) -> None:
        """Stop listening, end every client task (each closes its connection), on the server's loop."""
        await self.dme.close()
        tasks = [t for t in asyncio.all_tasks() if t is not asyncio.current_task()]
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)

    def __exit__(self, *exc_info: object) -> None:
        if self._loop.is_running():
            done = asyncio.run_coroutine_threadsafe(self._shutdown(), self._loop)
            with contextlib.suppress(Exception):
                done.result(10.0)
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(30.0)
