"""SIGTERM and SIGHUP end a command the way Ctrl-C does; critical sections hold signals until they end.

A command run by :func:`pcmm_geo.cli.main` is wrapped in :func:`interrupt_on_signals`: SIGINT
(Ctrl-C), SIGTERM (``kill``, a service manager stopping, a batch system's time limit) and
SIGHUP (the terminal closing) raise :class:`Interrupted` (a :class:`KeyboardInterrupt`) in
the main thread, so that the one-shot outputs of the command roll back and a durable
acquisition log keeps its rows, whichever signal ended it.  Only the first signal raises:
later ones are held while the command cleans up (a second Ctrl-C must not cut a rollback in
half).  Inside :func:`deferred` (creating a temporary file and journaling it, writing one log
row) a signal is held and raised when the section ends, so such a step is done whole or not
at all.  A signal that was ignored when the command started stays ignored (``nohup`` ignores
SIGHUP).  Outside the command line nothing is installed: a library caller keeps its own
handlers.  SIGKILL cannot be caught; what it leaves is found by the next run
(:meth:`pcmm_geo._atomic.OutputPlan.recover`).

Examples
--------
>>> import os, signal
>>> with interrupt_on_signals():
...     try:
...         os.kill(os.getpid(), signal.SIGTERM)
...         for _ in range(10**6):  # the handler runs between two bytecodes
...             pass
...     except Interrupted as exc:
...         print(exc.name, exc.exit_code)
SIGTERM 143
"""

from __future__ import annotations

import contextlib
import signal
import sys
import threading
from collections.abc import Callable, Iterator

__all__ = ["HANDLED_SIGNALS", "Interrupted", "deferred", "guarded_command", "interrupt_on_signals", "interruption"]

#: the signals that end a command like Ctrl-C (SIGHUP only where the platform has it)
HANDLED_SIGNALS: tuple[int, ...] = tuple(
    getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name)
)


class Interrupted(KeyboardInterrupt):
    """The command was ended by a signal (``signum``, ``name``); exit code 128 + the signal number."""

    def __init__(self, signum: int) -> None:
        self.signum = int(signum)
        self.name = signal.Signals(signum).name
        super().__init__(self.name)

    @property
    def exit_code(self) -> int:
        """The shell's convention: 130 for SIGINT, 143 for SIGTERM, 129 for SIGHUP."""
        return 128 + self.signum


class _State:
    installed = False  # interrupt_on_signals is active
    raised = False  # one Interrupted was raised: hold the others
    signum: int | None = None  # the signal of that Interrupted
    depth = 0  # nesting of deferred sections
    pending: int | None = None


def _handler(signum: int, frame: object) -> None:
    if _State.raised or _State.depth > 0:
        if _State.pending is None:
            _State.pending = signum
        return
    _State.raised, _State.signum = True, signum
    raise Interrupted(signum)


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """Hold the handled signals inside the block; one that arrived is raised when the block ends."""
    _State.depth += 1
    try:
        yield
    finally:
        _State.depth -= 1
        if _State.depth == 0 and _State.installed and not _State.raised and _State.pending is not None:
            signum, _State.pending = _State.pending, None
            _State.raised, _State.signum = True, signum
            raise Interrupted(signum)


@contextlib.contextmanager
def interrupt_on_signals() -> Iterator[None]:
    """Within the block, SIGINT / SIGTERM / SIGHUP raise :class:`Interrupted` (main thread only)."""
    if threading.current_thread() is not threading.main_thread() or _State.installed:
        yield
        return
    previous = {signum: signal.getsignal(signum) for signum in HANDLED_SIGNALS}
    # a signal the caller ignores stays ignored (``nohup`` ignores SIGHUP, a shell's ``&`` SIGINT)
    previous = {signum: handler for signum, handler in previous.items() if handler is not signal.SIG_IGN}
    _State.installed, _State.raised, _State.pending, _State.signum = True, False, None, None
    for signum in previous:
        signal.signal(signum, _handler)
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        _State.installed, _State.raised, _State.pending, _State.signum = False, False, None, None


def interruption(error: BaseException) -> KeyboardInterrupt | None:
    """The interrupt that ``error`` stands for, or None.

    An interrupt raised inside a library can come out as another exception: an extension
    module's initialisation turns it into ``ImportError("initialization failed")``, a writer's
    clean-up that runs while it unwinds fails in its turn (``zlib.error`` from a half-written PDF
    stream).  Such an error is the interrupt when a :class:`KeyboardInterrupt` is in its chain
    (``__cause__`` / ``__context__``), or when :func:`interrupt_on_signals` raised an
    :class:`Interrupted` in this command (the chain may have been cut).

    Examples
    --------
    >>> try:
    ...     try:
    ...         raise KeyboardInterrupt
    ...     except KeyboardInterrupt as exc:
    ...         raise ImportError("initialization failed") from exc
    ... except ImportError as exc:
    ...     type(interruption(exc)).__name__
    'KeyboardInterrupt'
    >>> interruption(ValueError("plain")) is None
    True
    """
    pending, seen = [error], set()
    while pending:
        current = pending.pop()
        if current is None or id(current) in seen:
            continue
        if isinstance(current, KeyboardInterrupt):
            return current
        seen.add(id(current))
        pending += [current.__cause__, current.__context__]
    if _State.installed and _State.raised and _State.signum is not None:
        return Interrupted(_State.signum)
    return None


def guarded_command(body: Callable[[], int], name: str = "pcmm") -> int:
    """Run a whole command (``body``, argument parsing and imports included) inside :func:`interrupt_on_signals`.

    From the moment the entry point runs, an interrupt is one line on stderr (``pcmm: interrupted``)
    and exit 128 + signal (130 for Ctrl-C), also while the sub-commands load, before the command's
    own handling (which reports what its rollback kept) starts.  This module imports nothing heavy,
    so the handlers are in place within microseconds of the entry point.
    """
    with interrupt_on_signals():
        try:
            return body()
        except KeyboardInterrupt as exc:
            by = f" by {exc.name}" if isinstance(exc, Interrupted) and exc.name != "SIGINT" else ""
            print(f"{name}: interrupted{by}", file=sys.stderr)
            return exc.exit_code if isinstance(exc, Interrupted) else 130
