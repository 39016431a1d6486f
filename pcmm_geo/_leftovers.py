"""What a killed run leaves next to its outputs, and putting it right on the next run.

A run writes each output through a hidden temporary file next to it and, when it replaces a
file, keeps a hidden hard-linked backup of the old one until it succeeds
(:mod:`pcmm_geo._atomic`).  Ctrl-C, SIGTERM and SIGHUP roll these back
(:mod:`pcmm_geo._signals`); SIGKILL, a power cut or a crash cannot, so every such file
carries its owner in its name -- process id, process start time and a hash of the host name
(:func:`owner_tag`) -- and the next run over the same output (:func:`recover`) deals with
those whose owner is gone:

- ``.NAME-<owner>-XXXXXXXX.tmp.SUFFIX`` (an unfinished temporary file): removed;
- ``.NAME.<owner>-<id>.replaced`` (the old file of an unfinished replacement): put back under
  NAME, unless the run was writing a durable log (a ``.NAME.<owner>-<id>.keep`` note says how
  long its header was) that holds rows: then the log stays, a record, and the old file is put
  back beside it under a visible name, ``STEM.replaced-<id>.SUFFIX``;
- a backup identical to the file it backs up (the run died before replacing it): removed.

Files of a run that is still alive -- the owner's process exists with the same start time --
are never touched, nor files from another host (whose processes cannot be checked); each
action is reported in one sentence.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
import socket
from pathlib import Path

__all__ = ["backup_name", "keep_note_name", "owner_tag", "recover", "temporary_prefix", "visible_name"]

_OWNER = r"(?P<pid>\d+)-(?P<start>\d+)-(?P<host>[0-9a-f]{8})"


def _start_ticks(pid: int) -> int:
    """The process's start time in clock ticks since boot (Linux /proc), 0 where unknown."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return 0
    return int(stat.rsplit(")", 1)[1].split()[19])


def _host() -> str:
    return hashlib.sha256(socket.gethostname().encode()).hexdigest()[:8]


def owner_tag() -> str:
    """``PID-START-HOST`` of this process (see the module)."""
    pid = os.getpid()
    return f"{pid}-{_start_ticks(pid)}-{_host()}"


def temporary_prefix(target: Path) -> str:
    """Prefix of the temporary files of ``target`` written by this process."""
    return f".{target.stem}-{owner_tag()}-"


def backup_name(target: Path, identity: str) -> Path:
    """The hidden backup of ``target`` replaced by this process (``identity``: a few hex digits)."""
    return target.with_name(f".{target.name}.{owner_tag()}-{identity}.replaced")


def keep_note_name(backup: Path) -> Path:
    """The note that marks ``backup``'s target as a durable log (its header length inside)."""
    return backup.with_name(backup.name.removesuffix(".replaced") + ".keep")


def visible_name(target: Path, identity: str) -> Path:
    """Where the replaced file of a kept log is put back: ``STEM.replaced-<identity>.SUFFIX``."""
    return target.with_name(f"{target.stem}.replaced-{identity}{target.suffix}")


def _alive(pid: int, start: int, host: str) -> bool:
    """Whether the owner may still be running (True when it cannot be ruled out)."""
    if host != _host():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process with that id
        pass
    except OSError:  # pragma: no cover - platforms without signal 0
        return True
    ticks = _start_ticks(pid)
    return ticks == 0 or start == 0 or ticks == start


def _size(path: Path) -> int:
    try:
        return path.stat().st_size
    except OSError:
        return -1


def recover(target: Path) -> list[str]:
    """Remove or restore what dead runs left for ``target``; one sentence per action (see the module)."""
    folder = target.parent if str(target.parent) else Path(".")
    try:
        names = os.listdir(folder)
    except OSError:
        return []
    temporary = re.compile(rf"\.{re.escape(target.stem)}-{_OWNER}-[A-Za-z0-9_]+\.tmp{re.escape(target.suffix)}")
    backup = re.compile(rf"\.{re.escape(target.name)}\.{_OWNER}-(?P<id>[0-9a-f]+)\.replaced")
    note = re.compile(rf"\.{re.escape(target.name)}\.{_OWNER}-(?P<id>[0-9a-f]+)\.keep")
    notes: list[str] = []
    for name in sorted(names):
        found = temporary.fullmatch(name)
        if found and not _alive(int(found["pid"]), int(found["start"]), found["host"]):
            with contextlib.suppress(FileNotFoundError):
                (folder / name).unlink()
                notes.append(f"removed {folder / name}, a temporary file left by an interrupted run "
                             f"(process {found['pid']})")
            continue
        found = backup.fullmatch(name)
        if found and not _alive(int(found["pid"]), int(found["start"]), found["host"]):
            notes.append(_restore(target, folder / name, found["id"]))
    for name in sorted(names):  # a note whose backup is gone (restored, then the run died again)
        found = note.fullmatch(name)
        if found and not (folder / (name.removesuffix(".keep") + ".replaced")).exists() and not _alive(
                int(found["pid"]), int(found["start"]), found["host"]):
            with contextlib.suppress(FileNotFoundError):
                (folder / name).unlink()
    return notes


def _restore(target: Path, backup: Path, identity: str) -> str:
    note = keep_note_name(backup)
    try:
        header = int(note.read_text().strip() or -1)
    except (OSError, ValueError):
        header = None
    try:
        same = target.exists() and os.path.samefile(target, backup)
    except OSError:
        same = False
    try:
        if same:  # the run died before replacing the file: the backup is a second name of it
            backup.unlink()
            message = f"removed {backup}, an unused backup of {target} left by an interrupted run"
        elif header is not None and _size(target) > header:  # a durable log with rows: a record, kept
            visible = visible_name(target, identity)
            os.replace(backup, visible)
            message = (f"kept {target}, the log an interrupted run was writing (continue it with --resume); "
                       f"the file it replaced is restored as {visible}")
        else:  # an unfinished replacement: the old file comes back
            os.replace(backup, target)
            message = f"restored {target} from the backup left by an interrupted run (its unfinished output dropped)"
    except OSError as exc:
        return f"could not restore {target} from {backup}: {exc}"
    with contextlib.suppress(FileNotFoundError):
        note.unlink()
    return message
