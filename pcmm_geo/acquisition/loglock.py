"""One session at a time on an acquisition log: an exclusive ``flock`` held while the log is open.

Two sessions appending to one log would interleave their rows (repeated ``seq`` numbers, rows of
two machines' states mixed).  :class:`~pcmm_geo.acquisition.acqlog.AcquisitionLog` therefore
takes an exclusive, non-blocking ``flock`` on the file it appends to as soon as it opens it and
holds it until it closes: a second session on the same log is refused at once
(:class:`~pcmm_geo.errors.LogIntegrityError` naming the log), never queued.  The kernel drops a
``flock`` when the process that holds it ends, however it ends (``kill -9`` too), so a killed
session leaves no stale lock behind and no lock file to clean up.  :func:`check_unlocked`
looks without taking the lock (``pcmm acquire`` refuses a busy log before homing the stages).

Where ``fcntl`` does not exist (Windows) logs are not locked; the platform's own sharing rules
apply.  ``flock`` locks are advisory: they keep pcmm sessions apart, not other programs.

Examples
--------
>>> import tempfile, pathlib
>>> path = pathlib.Path(tempfile.mkdtemp()) / "run.csv"
>>> first = open(path, "a")
>>> lock_handle(first, path)
>>> second = open(path, "a")
>>> try:
...     lock_handle(second, path)
... except Exception as exc:
...     print(type(exc).__name__)
LogIntegrityError
>>> second.close(); first.close()
>>> check_unlocked(path)  # the lock went with the handle
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import IO, Any

from pcmm_geo.errors import LogIntegrityError

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]

__all__ = ["check_unlocked", "lock_handle"]


def _busy(path: str | os.PathLike[str]) -> LogIntegrityError:
    return LogIntegrityError(str(path), "in use by another acquisition session (the log is locked); wait until it "
                             "ends, or write to another log")


def lock_handle(handle: IO[Any], path: str | os.PathLike[str]) -> None:
    """Take the exclusive lock of the log open as ``handle`` (held until the handle closes).

    Raises
    ------
    LogIntegrityError
        Another open handle (another session) holds it.
    """
    if fcntl is None:  # pragma: no cover - Windows
        return
    try:
        fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError as exc:
        raise _busy(path) from exc


def check_unlocked(path: str | os.PathLike[str]) -> None:
    """Raise when an existing log at ``path`` is held by a session; a missing file is not locked.

    Raises
    ------
    LogIntegrityError
        Another session holds the log's lock.
    """
    if fcntl is None or not Path(path).is_file():
        return
    try:
        descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError:
        return  # unreadable: whoever opens it next reports why
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError as exc:
        raise _busy(path) from exc
    finally:
        os.close(descriptor)  # closing releases a lock taken here
