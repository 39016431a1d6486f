"""Writing output files whole or not at all, never replacing a file unless asked.

One file: the content goes to a temporary file in the target's folder, is flushed and
fsync'ed, and only then takes the target's name: with ``overwrite`` by ``os.replace``
(atomic on POSIX and Windows), without it by ``os.link`` (atomic, fails if the name exists).
A failure at any point leaves the target as it was and no temporary file behind.

All the files of one command (an :class:`OutputPlan`): every output is declared first with
its own overwrite permission and checked before any work (:meth:`OutputPlan.check`: no
existing file unless allowed, no two outputs naming one file, a folder that exists or can be
created, writable).  The work then runs inside :meth:`OutputPlan.transaction`: each file is
still written atomically as above, and the transaction keeps a journal of what this run wrote,
the folders it created and a hard-linked backup of every file it replaced.  If anything fails
(an exception, Ctrl-C), the run's new files and folders are removed and every replaced file is
put back, byte for byte; files the run did not write are never touched.  On success the
backups are deleted.  Inside a transaction the plan's permission for a declared path is what
counts, whatever ``overwrite`` a writer passes (see :func:`may_overwrite`): the command line's
per-output flags decide.  A writer that streams into its final path (the acquisition log)
claims it with :meth:`OutputTransaction.claim` and may ask to be kept on failure (rows that
were measured are a record, never deleted); the file such a log replaced is then put back
beside it under a visible name (``STEM.replaced-<id>.SUFFIX``), never left hidden.

Signals: the command line turns SIGTERM and SIGHUP into the exception Ctrl-C raises
(:mod:`pcmm_geo._signals`), so they roll back like any failure; creating a temporary file and
journaling it happen with signals held, so no temporary file escapes the journal.  The names of
temporary files and backups carry their owner (process and host), so that what a SIGKILL
leaves is found by the next run over the same output (:meth:`OutputPlan.recover`,
:mod:`pcmm_geo._leftovers`) and removed or restored, never while its owner still runs.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import tempfile
import uuid
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from pcmm_geo._signals import deferred
from pcmm_geo.errors import InvalidInputError, OutputExistsError

__all__ = [
    "OutputPlan",
    "OutputTransaction",
    "PlannedOutput",
    "atomic_output",
    "current_transaction",
    "fsync_folder",
    "may_overwrite",
    "write_atomic",
]

_ACTIVE: contextvars.ContextVar[OutputTransaction | None] = contextvars.ContextVar("pcmm_output_transaction",
                                                                                   default=None)


def _key(path: str | os.PathLike[str]) -> Path:
    """Absolute, symlink-resolved form of ``path`` (the file it names, whether or not it exists)."""
    return Path(os.path.realpath(os.fspath(path)))


@dataclass(frozen=True)
class PlannedOutput:
    """One declared output: where, under which option, and what may happen to an existing file.

    Attributes
    ----------
    path : pathlib.Path
    label : str
        How the user named it, e.g. ``"--plot"`` (used in messages).
    overwrite : bool
        An existing file may be replaced.
    append : bool
        An existing file is appended to (e.g. ``pcmm acquire --resume``), never replaced.
    folder : bool
        The output is a folder the command writes new files into (it may exist already).
    """

    path: Path
    label: str
    overwrite: bool = False
    append: bool = False
    folder: bool = False


class OutputPlan:
    """Every output file of one command, checked before any work and written all-or-nothing.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> plan = OutputPlan()
    >>> _ = plan.add(folder / "a.txt", label="--first")
    >>> _ = plan.add(folder / "sub" / "b.txt", label="--second")
    >>> plan.check()  # nothing exists yet, the folder is writable
    >>> try:
    ...     with plan.transaction():
    ...         _ = write_atomic(folder / "a.txt", "first\\n")
    ...         raise OSError("disk full while writing the second output")
    ... except OSError:
    ...     pass
    >>> sorted(p.name for p in folder.iterdir())  # the first output was removed again
    []
    """

    def __init__(self) -> None:
        self.outputs: list[PlannedOutput] = []
        #: what a rolled-back transaction kept or could not undo (one sentence each)
        self.notes: list[str] = []

    def add(self, path: str | os.PathLike[str], *, label: str, overwrite: bool = False,
            append: bool = False, folder: bool = False) -> PlannedOutput:
        """Declare an output (nothing is checked until :meth:`check`)."""
        planned = PlannedOutput(Path(path), label, bool(overwrite), bool(append), bool(folder))
        self.outputs.append(planned)
        return planned

    def find(self, path: str | os.PathLike[str]) -> PlannedOutput | None:
        """The declared output naming the same file as ``path``, or None."""
        key = _key(path)
        return next((out for out in self.outputs if _key(out.path) == key), None)

    def recover(self) -> list[str]:
        """Remove or restore what killed runs left next to the declared outputs (one sentence each).

        Temporary files and backups whose owner process is gone (SIGKILL, power cut) are dealt
        with as :mod:`pcmm_geo._leftovers` says; a live run's files are never touched.
        """
        from pcmm_geo._leftovers import recover

        notes: list[str] = []
        for out in self.outputs:
            if not out.folder:
                notes.extend(recover(out.path))
        return notes

    def check(self) -> None:
        """Refuse, before any work, an output that could not be written or would replace a file.

        Raises
        ------
        OutputExistsError
            An output exists and neither its overwrite nor append permission is given.
        InvalidInputError
            Two outputs name the same file, an output names a folder, or its folder cannot be
            created or written (a path component is a file, no permission, read-only).
        """
        seen: dict[Path, PlannedOutput] = {}
        for out in self.outputs:
            key = _key(out.path)
            what = f"{out.label} {out.path}"
            if key in seen:
                raise InvalidInputError(what, "a file no other output of the command names",
                                        f"the same file as {seen[key].label} {seen[key].path}")
            seen[key] = out
            if out.folder:
                _check_folder(out.path, what)
                continue
            if out.path.is_dir():
                raise InvalidInputError(what, "a file name", "an existing folder")
            if out.path.exists() and not (out.overwrite or out.append):
                raise OutputExistsError(str(out.path))
            _check_folder(out.path.parent if str(out.path.parent) else Path("."), what)

    @contextlib.contextmanager
    def transaction(self) -> Iterator[OutputTransaction]:
        """Run the work with a journal: commit on success, roll back on any exception (see the module)."""
        transaction = OutputTransaction(self)
        token = _ACTIVE.set(transaction)
        try:
            yield transaction
        except BaseException:
            self.notes = transaction.rollback()
            raise
        else:
            transaction.commit()
        finally:
            _ACTIVE.reset(token)


def _check_folder(folder: Path, what: str) -> None:
    """The nearest existing ancestor of ``folder`` must be a folder in which a file can be created."""
    existing = folder
    while not existing.exists():
        if existing.parent == existing:
            break
        existing = existing.parent
    if not existing.is_dir():
        raise InvalidInputError(what, "a path of folders", f"'{existing}', which is a file, not a folder")
    try:
        handle, name = tempfile.mkstemp(prefix=".pcmm-write-check-", dir=existing)
    except OSError as exc:
        raise InvalidInputError(what, "a path in a writable folder", f"{existing}: {exc.strerror or exc}") from exc
    os.close(handle)
    os.unlink(name)


@dataclass
class _Entry:
    path: Path
    backup: Path | None  # the replaced file, hard-linked aside; None: the file is new
    keep: Callable[[], str | None] | None = None
    identity: str = ""


class OutputTransaction:
    """Journal of one command's writes (made by :meth:`OutputPlan.transaction`; see the module)."""

    def __init__(self, plan: OutputPlan) -> None:
        self.plan = plan
        self._entries: dict[Path, _Entry] = {}
        self._created_folders: list[Path] = []
        self._temporaries: list[Path] = []

    def temporary(self, path: Path) -> None:
        """Journal a temporary file (removed on rollback if it is still there)."""
        self._temporaries.append(path)

    def overwrite_allowed(self, path: str | os.PathLike[str], overwrite: bool) -> bool:
        """The plan's permission for a declared ``path``; ``overwrite`` for any other path."""
        planned = self.plan.find(path)
        return overwrite if planned is None else planned.overwrite

    def make_folders(self, folder: Path) -> None:
        """Create ``folder`` and missing parents, remembering them for a rollback."""
        missing = []
        current = folder
        while not current.exists() and current.parent != current:
            missing.append(current)
            current = current.parent
        for created in reversed(missing):
            with contextlib.suppress(FileExistsError):
                created.mkdir()
                self._created_folders.append(created)

    def before_replace(self, target: Path) -> None:
        """Journal ``target`` before it is (re)written: hard-link an existing file aside the first time."""
        from pcmm_geo._leftovers import backup_name

        key = _key(target)
        if key in self._entries:
            return
        identity = uuid.uuid4().hex[:12]
        with deferred():  # the backup exists only with its journal entry
            backup = None
            if target.exists():
                backup = backup_name(target, identity)
                try:
                    os.link(target, backup)
                except OSError:  # no hard links here: a copy serves as well
                    import shutil

                    shutil.copy2(target, backup)
            self._entries[key] = _Entry(target, backup, identity=identity)

    def created(self, target: Path) -> None:
        """Journal ``target`` as new, just after this run created it (unless already journaled)."""
        self._entries.setdefault(_key(target), _Entry(target, None))

    def claim(self, path: str | os.PathLike[str], *, overwrite: bool = False) -> Path:
        """Prepare ``path`` for a writer that creates it itself (exclusively) and streams into it.

        Folders are created; an existing file that may be replaced is moved aside (restored on
        rollback, deleted on commit).

        Raises
        ------
        OutputExistsError
            ``path`` exists and may not be replaced.
        """
        target = Path(path)
        if target.exists() and not self.overwrite_allowed(target, overwrite):
            raise OutputExistsError(str(target))
        self.make_folders(target.parent if str(target.parent) else Path("."))
        with deferred():
            self.before_replace(target)
            if target.exists():
                os.unlink(target)  # its backup is a hard link (or copy): the content is safe
        return target

    def keep_on_failure(self, path: str | os.PathLike[str], reason: Callable[[], str | None], *,
                        header_bytes: int | None = None) -> None:
        """On rollback, keep ``path`` when ``reason()`` returns a sentence (e.g. "12 rows recorded").

        ``header_bytes``: the length of the file before its first record; with it, a run killed
        before it could roll back leaves a note so that the next run keeps the file if it grew
        beyond its header (:mod:`pcmm_geo._leftovers`).
        """
        entry = self._entries.get(_key(path))
        if entry is None:
            return
        entry.keep = reason
        if entry.backup is not None and header_bytes is not None:
            from pcmm_geo._leftovers import keep_note_name

            keep_note_name(entry.backup).write_text(f"{int(header_bytes)}\n")

    def commit(self) -> None:
        """Delete the backups of replaced files."""
        for entry in self._entries.values():
            if entry.backup is not None:
                self._drop_backup(entry.backup)

    @staticmethod
    def _drop_backup(backup: Path) -> None:
        from pcmm_geo._leftovers import keep_note_name

        for path in (keep_note_name(backup), backup):
            with contextlib.suppress(FileNotFoundError):
                path.unlink()

    def rollback(self) -> list[str]:
        """Undo this run's writes (module notes); returns sentences on what was kept or not undone."""
        from pcmm_geo._leftovers import keep_note_name, visible_name

        notes = []
        for temporary in self._temporaries:
            with contextlib.suppress(FileNotFoundError):
                temporary.unlink()
        for entry in reversed(list(self._entries.values())):
            kept = entry.keep() if entry.keep is not None else None
            try:
                if kept:
                    notes.append(f"kept {entry.path}: {kept}")
                    if entry.backup is not None:
                        visible = visible_name(entry.path, entry.identity)
                        os.replace(entry.backup, visible)
                        notes.append(f"the file it replaced is kept as {visible}")
                elif entry.backup is not None:
                    os.replace(entry.backup, entry.path)
                else:
                    with contextlib.suppress(FileNotFoundError):
                        entry.path.unlink()
                if entry.backup is not None:
                    with contextlib.suppress(FileNotFoundError):
                        keep_note_name(entry.backup).unlink()
            except OSError as exc:
                notes.append(f"could not undo the write of {entry.path}: {exc}")
        for folder in reversed(self._created_folders):
            with contextlib.suppress(OSError):  # a folder that is not empty stays
                folder.rmdir()
        return notes


def current_transaction() -> OutputTransaction | None:
    """The transaction of the running command, or None outside one."""
    return _ACTIVE.get()


def may_overwrite(path: str | os.PathLike[str], overwrite: bool = False) -> bool:
    """Whether ``path`` may be replaced: the running transaction's permission, else ``overwrite``.

    Examples
    --------
    >>> may_overwrite("plot.png", overwrite=False)
    False
    >>> plan = OutputPlan()
    >>> _ = plan.add("plot.png", label="--plot", overwrite=True)
    >>> with plan.transaction():
    ...     may_overwrite("plot.png"), may_overwrite("other.png")
    (True, False)
    """
    transaction = _ACTIVE.get()
    return overwrite if transaction is None else transaction.overwrite_allowed(path, overwrite)


@contextlib.contextmanager
def atomic_output(path: str | Path, *, overwrite: bool = False) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success it becomes ``path`` (see the module notes).

    Raises
    ------
    OutputExistsError
        ``path`` exists (before or after the content is written) and ``overwrite`` is False.

    Examples
    --------
    >>> import os, tempfile
    >>> target = os.path.join(tempfile.mkdtemp(), "out.txt")
    >>> with atomic_output(target) as temporary:
    ...     _ = temporary.write_text("whole\\n")
    >>> open(target).read()
    'whole\\n'
    >>> try:
    ...     with atomic_output(target) as temporary:
    ...         _ = temporary.write_text("other\\n")
    ... except OutputExistsError:
    ...     print(open(target).read().strip())
    whole
    """
    target = Path(path)
    transaction = _ACTIVE.get()
    overwrite = may_overwrite(target, overwrite)
    if target.exists() and not overwrite:
        raise OutputExistsError(str(target))
    folder = target.parent if str(target.parent) else Path(".")
    if transaction is not None:
        transaction.make_folders(folder)
    else:
        folder.mkdir(parents=True, exist_ok=True)
    from pcmm_geo._leftovers import temporary_prefix

    temporary: Path | None = None
    try:
        with deferred():  # the temporary file exists only with its journal entry
            handle, name = tempfile.mkstemp(prefix=temporary_prefix(target), suffix=f".tmp{target.suffix}",
                                            dir=folder)
            temporary = Path(name)
            if transaction is not None:
                transaction.temporary(temporary)
            os.close(handle)
        os.chmod(temporary, 0o666 & ~_umask())  # mkstemp makes 0600; give the file the usual permissions
        yield temporary
        with open(temporary, "rb+") as stream:
            os.fsync(stream.fileno())
        with deferred():  # the new name and its journal entry together
            if overwrite:
                if transaction is not None:
                    transaction.before_replace(target)
                os.replace(temporary, target)
            else:
                try:
                    os.link(temporary, target)
                except FileExistsError:
                    raise OutputExistsError(str(target)) from None
                except OSError:  # no hard links on this file system: check, then rename
                    if target.exists():
                        raise OutputExistsError(str(target)) from None
                    os.replace(temporary, target)
                if transaction is not None:
                    transaction.created(target)
    finally:
        if temporary is not None:
            with contextlib.suppress(FileNotFoundError):
                temporary.unlink()


def fsync_folder(folder: str | os.PathLike[str]) -> None:
    """fsync a folder so that a new file's entry survives a power cut (POSIX; a no-op where unsupported)."""
    try:
        handle = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(handle)
    except OSError:
        pass
    finally:
        os.close(handle)


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def write_atomic(path: str | Path, content: bytes | str | Callable[[IO[bytes]], None], *,
                 overwrite: bool = False) -> Path:
    """Write ``content`` (bytes, UTF-8 text, or a callable writing to a binary stream) to ``path`` whole.

    Raises
    ------
    OutputExistsError
        ``path`` exists and ``overwrite`` is False.
    """
    target = Path(path)
    with atomic_output(target, overwrite=overwrite) as temporary, open(temporary, "wb") as stream:
        if callable(content):
            content(stream)
        else:
            stream.write(content.encode("utf-8") if isinstance(content, str) else content)
    return target
