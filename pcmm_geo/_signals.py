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
import threading
from collections.abc import Iterator

__all__ = ["HANDLED_SIGNALS", "Interrupted", "deferred", "interrupt_on_signals"]

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
    depth = 0  # nesting of deferred sections
    pending: int | None = None


def _handler(signum: int, frame: object) -> None:
    if _State.raised or _State.depth > 0:
        if _State.pending is None:
            _State.pending = signum
        return
    _State.raised = True
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
            _State.raised = True
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
    _State.installed, _State.raised, _State.pending = True, False, None
    for signum in previous:
        signal.signal(signum, _handler)
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        _State.installed, _State.raised, _State.pending = False, False, None
