"""Durable, append-only acquisition log (seed Table 3.2 rows plus raw device values).

File layout (UTF-8, ``\\n`` line ends)::

    # pcmm_geo acquisition log
    # schema: pcmm_geo.acqlog/1
    # created_utc: 2026-11-23T03:40:00.000Z
    # software: pcmm_geo 0.1.0
    # unit.laser_a: mm from the laser's start of range, as decoded from laser_a_raw (no correction)
    # ... configuration entries ``# key: value`` ...
    start_stop,probe,motor,direction,laser_a,laser_b,laser_c,seq,t_utc,pos_a_usteps,...
    1,0,2,1,49.472,54.228,67.480,0,2026-11-23T03:40:01.250Z,247500,...

The first seven columns are exactly thesis Table 3.2 (``start_stop`` 1 = reading before the
move, 0 = after it; ``probe`` 1 = contact; ``motor`` 1|2|3; ``direction`` +1/-1; lasers in mm);
the rest keep the raw values (Zaber microsteps, laser counts), a sequence number and the UTC
time, so a run can be re-processed later.  Values are written as read, before any correction.

One session at a time: an open log holds an exclusive ``flock``
(:mod:`pcmm_geo.acquisition.loglock`); a second session on it is refused at once. Durability: every
row is one ``write``, ``flush``, ``os.fsync``, with Ctrl-C, SIGTERM and SIGHUP held until it is on
disk (:func:`pcmm_geo._signals.deferred`): an interrupted run keeps each row whole. A new file is
created exclusively (never overwriting unless asked), its directory fsync'ed. Reopening
checks the whole file: a partial last line (a crash mid-row) raises
:class:`~pcmm_geo.errors.LogIntegrityError` unless ``repair=True``, in which case it is cut off
and the cut is reported in :class:`LogRecovery` and as a ``# truncated_bytes`` comment.

Examples
--------
>>> import tempfile, pathlib
>>> path = pathlib.Path(tempfile.mkdtemp()) / "run.csv"
>>> with AcquisitionLog.create(path, {"settle_s": "0"}) as log:
...     row = log.append(LogRow(1, 0, 2, 1, 49.5, 54.25, 67.5, pos_usteps=(247500, 247500, 247500)))
>>> contents = read_log(path)
>>> contents.rows[0].motor, contents.rows[0].laser_b, contents.metadata["settle_s"]
(2, 54.25, '0')
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import IO, Any

from pcmm_geo._atomic import current_transaction, fsync_folder
from pcmm_geo._signals import deferred
from pcmm_geo.acquisition.loglock import check_unlocked, lock_handle
from pcmm_geo.errors import InvalidInputError, LogIntegrityError, OutputExistsError

__all__ = [
    "COLUMN_UNITS",
    "LOG_COLUMNS",
    "LOG_SCHEMA",
    "TABLE_3_2_COLUMNS",
    "AcquisitionLog",
    "LogContents",
    "LogRecovery",
    "LogRow",
    "export_table_3_2",
    "read_log",
    "utc_now",
]

LOG_SCHEMA = "pcmm_geo.acqlog/1"
TABLE_3_2_COLUMNS = ("start_stop", "probe", "motor", "direction", "laser_a", "laser_b", "laser_c")
EXTRA_COLUMNS = (
    "seq", "t_utc", "pos_a_usteps", "pos_b_usteps", "pos_c_usteps", "laser_a_raw", "laser_b_raw", "laser_c_raw",
)
LOG_COLUMNS = TABLE_3_2_COLUMNS + EXTRA_COLUMNS
COLUMN_UNITS: dict[str, str] = {
    "start_stop": "1 = reading before the move, 0 = after it (thesis Table 3.2)",
    "probe": "1 = probe in contact, 0 = free",
    "motor": "motor moved, 1|2|3 (columns a|b|c)",
    "direction": "+1 up, -1 down (sign of the move)",
    "laser_a": "mm from the laser's start of range, decoded from laser_a_raw, no correction",
    "laser_b": "mm from the laser's start of range, decoded from laser_b_raw, no correction",
    "laser_c": "mm from the laser's start of range, decoded from laser_c_raw, no correction",
    "seq": "row number from 0",
    "t_utc": "ISO 8601 UTC time of the reading",
    "pos_a_usteps": "Zaber position of motor 1, microsteps",
    "pos_b_usteps": "Zaber position of motor 2, microsteps",
    "pos_c_usteps": "Zaber position of motor 3, microsteps",
    "laser_a_raw": "sensor output value, counts",
    "laser_b_raw": "sensor output value, counts",
    "laser_c_raw": "sensor output value, counts",
}
_TITLE = b"# pcmm_geo acquisition log\n"
_COLUMN_LINE = (",".join(LOG_COLUMNS) + "\n").encode()
_INT_COLUMNS = {"start_stop", "probe", "motor", "direction", "seq", *EXTRA_COLUMNS[2:]}


def utc_now() -> str:
    """Current UTC time as ISO 8601 with milliseconds and ``Z``."""
    return datetime.now(UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


@dataclass(frozen=True)
class LogRow:
    """One log row: the seven Table 3.2 fields plus raw values.

    Attributes
    ----------
    start_stop, probe, motor, direction : int
        Table 3.2 flags (1/0, 1/0, 1..3, +1/-1).
    laser_a, laser_b, laser_c : float
        Laser readings, mm from the start of range.
    pos_usteps : tuple of int
        Zaber positions of motors 1, 2, 3, microsteps.
    laser_raw : tuple of int
        Raw laser values a, b, c (counts); -1 when not available.
    seq : int
        Row number (set by :meth:`AcquisitionLog.append` when -1).
    t_utc : str
        Time of the reading (set when empty).
    """

    start_stop: int
    probe: int
    motor: int
    direction: int
    laser_a: float
    laser_b: float
    laser_c: float
    pos_usteps: tuple[int, int, int] = (0, 0, 0)
    laser_raw: tuple[int, int, int] = (-1, -1, -1)
    seq: int = -1
    t_utc: str = ""

    def __post_init__(self) -> None:
        for name, allowed in (("start_stop", (0, 1)), ("probe", (0, 1)), ("motor", (1, 2, 3)), ("direction", (-1, 1))):
            if getattr(self, name) not in allowed:
                raise InvalidInputError(name, f"one of {allowed}", repr(getattr(self, name)))
        for name in ("laser_a", "laser_b", "laser_c"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or value != value or value in (float("inf"), float("-inf")):
                raise InvalidInputError(name, "a finite number of mm", repr(value))
        if len(self.pos_usteps) != 3 or len(self.laser_raw) != 3:
            raise InvalidInputError("pos_usteps/laser_raw", "three values each", f"{self.pos_usteps}/{self.laser_raw}")

    def cells(self) -> list[str]:
        """The row as CSV cells in :data:`LOG_COLUMNS` order (floats in shortest round-trip form)."""
        return [
            str(self.start_stop), str(self.probe), str(self.motor), str(self.direction),
            repr(float(self.laser_a)), repr(float(self.laser_b)), repr(float(self.laser_c)),
            str(self.seq), self.t_utc,
            *(str(int(p)) for p in self.pos_usteps), *(str(int(r)) for r in self.laser_raw),
        ]

    @classmethod
    def from_cells(cls, cells: list[str]) -> LogRow:
        """Parse CSV cells in :data:`LOG_COLUMNS` order (ValueError on bad numbers)."""
        ints = [int(cells[i]) for i in range(4)]
        lasers = [float(cells[i]) for i in range(4, 7)]
        return cls(
            *ints, *lasers,
            pos_usteps=(int(cells[9]), int(cells[10]), int(cells[11])),
            laser_raw=(int(cells[12]), int(cells[13]), int(cells[14])),
            seq=int(cells[7]), t_utc=cells[8],
        )


@dataclass(frozen=True)
class LogRecovery:
    """What reopening a log found.

    Attributes
    ----------
    path : str
    rows : int
        Whole data rows in the file.
    truncated : bool
        A partial last line was found (and cut off when repairing).
    dropped_bytes : int
        Length of that partial line, bytes.
    dropped_text : str
        The partial line itself (for the record).
    header_completed_bytes : int
        Bytes of a torn column line restored when repairing (0: the header was whole); only a
        column line torn after a provably whole comment header is restored (see
        :meth:`AcquisitionLog.check_resumable`).
    """

    path: str
    rows: int
    truncated: bool
    dropped_bytes: int
    dropped_text: str
    header_completed_bytes: int = 0


@dataclass(frozen=True)
class LogContents:
    """A parsed log: ``metadata`` (all ``# key: value`` lines; later ones win), ``rows``, ``recovery``."""

    metadata: dict[str, str]
    columns: tuple[str, ...]
    rows: tuple[LogRow, ...]
    recovery: LogRecovery = field(repr=False)


def _scan(path: Path) -> tuple[dict[str, str], tuple[str, ...], list[LogRow], bytes, int]:
    """Parse ``path``; returns metadata, columns, rows, the partial tail and the byte length of whole lines."""
    data = path.read_bytes()
    whole_end = data.rfind(b"\n") + 1
    tail = data[whole_end:]
    metadata: dict[str, str] = {}
    columns: tuple[str, ...] = ()
    rows: list[LogRow] = []
    for number, raw_line in enumerate(data[:whole_end].split(b"\n")[:-1], start=1):
        try:
            line = raw_line.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise LogIntegrityError(str(path), f"line is not UTF-8: {exc}", number) from exc
        if line.startswith("#"):
            key, sep, value = line[1:].partition(":")
            if sep:
                metadata[key.strip()] = value.strip()
            continue
        cells = line.split(",")
        if not columns:
            columns = tuple(cells)
            if columns != LOG_COLUMNS:
                expected = ",".join(LOG_COLUMNS)
                raise LogIntegrityError(str(path), f"expected column header {expected}, got {line}", number)
            continue
        if len(cells) != len(LOG_COLUMNS):
            raise LogIntegrityError(str(path), f"expected {len(LOG_COLUMNS)} cells, got {len(cells)}", number)
        try:
            rows.append(LogRow.from_cells(cells))
        except ValueError as exc:
            raise LogIntegrityError(str(path), f"row is not a whole numeric row: {exc}", number) from exc
    if not columns:
        comments = data[:whole_end].count(b"\n")
        if data.startswith(_TITLE) or _TITLE.startswith(data):  # our header, torn (an empty file too)
            raise LogIntegrityError(
                str(path), f"incomplete header: the file ends after {comments} comment lines without the column "
                "line (torn while the log was created); no row was recorded, start a new log", comments + 1)
        raise LogIntegrityError(str(path), "no column header line: not an acquisition log", comments + 1)
    return metadata, columns, rows, tail, whole_end


def _comment_entries(entries: Mapping[str, Any], name: str) -> dict[str, str]:
    """``entries`` as text, checked for ``# key: value`` lines (InvalidInputError naming ``name[key]``)."""
    checked = {}
    for key, value in entries.items():
        if any(c in str(key) for c in "\n\r:") or any(c in str(value) for c in "\n\r"):
            raise InvalidInputError(f"{name}[{key!r}]", "a one-line key without ':' and a one-line value", str(value))
        checked[str(key)] = str(value)
    return checked


def _torn_column_line(data: bytes) -> int:
    """Bytes missing from a column line torn at its end, when the rest of the header is provably whole.

    The header (comment lines, then the column line) is written by one ``write``; a tail that
    is a non-empty strict prefix of the column line therefore follows every comment line whole,
    and the schema line fixes what the column line is.  Returns 0 in any other case.
    """
    whole_end = data.rfind(b"\n") + 1
    tail, lines = data[whole_end:], data[:whole_end].split(b"\n")[:-1]
    provable = (
        bool(tail) and _COLUMN_LINE.startswith(tail) and data.startswith(_TITLE)
        and all(line.startswith(b"#") for line in lines) and f"# schema: {LOG_SCHEMA}".encode() in lines
    )
    return len(_COLUMN_LINE) - len(tail) if provable else 0


def read_log(path: str | os.PathLike[str], *, allow_partial: bool = False) -> LogContents:
    """Read and validate a log.

    Parameters
    ----------
    path : path-like
    allow_partial : bool
        Accept (and report in ``recovery``) a partial last line instead of raising.

    Raises
    ------
    LogIntegrityError
        Wrong header, a damaged row, or a partial last line (unless ``allow_partial``).
    FileNotFoundError
        No such file.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "torn.csv"
    >>> AcquisitionLog.create(path).close()
    >>> with open(path, "a") as handle:
    ...     _ = handle.write("1,0,2")
    >>> read_log(path, allow_partial=True).recovery.dropped_bytes
    5
    """
    path = Path(path)
    metadata, columns, rows, tail, _ = _scan(path)
    if tail and not allow_partial:
        raise LogIntegrityError(str(path), f"partial last row ({len(tail)} bytes without a line end)", len(rows) + 1)
    recovery = LogRecovery(str(path), len(rows), bool(tail), len(tail), tail.decode("utf-8", "replace"))
    return LogContents(metadata, columns, tuple(rows), recovery)


class AcquisitionLog:
    """Append-only, fsync'ed CSV log: :meth:`AcquisitionLog.create` makes one, :meth:`AcquisitionLog.resume` reopens it.

    Attributes
    ----------
    path : pathlib.Path
    recovery : LogRecovery
        What reopening found (all zero for a new log).
    rows_written : int
        Whole rows in the file (including those of earlier sessions).
    """

    def __init__(self, path: Path, handle: IO[str], recovery: LogRecovery) -> None:
        self.path = path
        self._handle: IO[str] | None = handle
        self.recovery = recovery
        self.rows_written = recovery.rows

    @classmethod
    def create(
        cls, path: str | os.PathLike[str], metadata: Mapping[str, Any] | None = None, *, overwrite: bool = False
    ) -> AcquisitionLog:
        """Create a new log with its metadata header.

        Parameters
        ----------
        path : path-like
        metadata : mapping, optional
            Configuration written as ``# key: value`` lines (no newlines in keys/values).
        overwrite : bool
            Replace an existing file (default False: refuse).

        Raises
        ------
        OutputExistsError
            The file exists and ``overwrite`` is False.
        InvalidInputError
            A metadata key or value containing a line break, or a key with ``:``.
        """
        from pcmm_geo import __version__

        path = Path(path)
        entries = {"schema": LOG_SCHEMA, "created_utc": utc_now(), "software": f"pcmm_geo {__version__}"}
        entries.update({f"unit.{k}": v for k, v in COLUMN_UNITS.items()})
        entries.update(_comment_entries(metadata or {}, "metadata"))
        header = "# pcmm_geo acquisition log\n" + "".join(f"# {k}: {v}\n" for k, v in entries.items())
        header += ",".join(LOG_COLUMNS) + "\n"
        check_unlocked(path)  # a log another session appends to is not replaced under it
        transaction = current_transaction()
        if transaction is not None:  # a command's outputs: an allowed old file is moved aside, restorable
            transaction.claim(path, overwrite=overwrite)
            overwrite = False
        path.parent.mkdir(parents=True, exist_ok=True)  # README: missing folders are created
        try:
            handle = open(path, "w" if overwrite else "x", encoding="utf-8", newline="")
        except FileExistsError as exc:
            raise OutputExistsError(str(path)) from exc
        lock_handle(handle, path)  # held until close: one session per log (pcmm_geo.acquisition.loglock)
        log = cls(path, handle, LogRecovery(str(path), 0, False, 0, ""))
        log._write(header)
        if transaction is not None:  # measured rows are a record: a failing (or killed) command keeps them
            transaction.keep_on_failure(path, log._kept_rows, header_bytes=len(header.encode("utf-8")))
        fsync_folder(path.parent)
        return log

    def _kept_rows(self) -> str | None:
        """Why a failing command keeps this log (it holds measured rows), or None (nothing recorded)."""
        new = self.rows_written - self.recovery.rows
        return f"{new} measured row(s) are a record (continue it with --resume)" if new > 0 else None

    @staticmethod
    def check_resumable(path: str | os.PathLike[str], *, repair: bool = False) -> LogRecovery:
        """Check, without changing the file, that :meth:`resume` would accept it; returns what it found.

        Raises
        ------
        LogIntegrityError
            As :meth:`resume`.
        FileNotFoundError
            No such file.
        """
        path = Path(path)
        completed = _torn_column_line(path.read_bytes()) if repair else 0
        if completed:
            return LogRecovery(str(path), 0, False, 0, "", completed)
        _, _, rows, tail, _ = _scan(path)
        if tail and not repair:
            raise LogIntegrityError(
                str(path), f"partial last row ({len(tail)} bytes without a line end); resume with repair to cut it",
                len(rows) + 1,
            )
        return LogRecovery(str(path), len(rows), bool(tail), len(tail), tail.decode("utf-8", "replace"))

    @classmethod
    def resume(cls, path: str | os.PathLike[str], *, repair: bool = False) -> AcquisitionLog:
        """Reopen an existing log to append to it after checking every line.

        A partial last line raises unless ``repair``; then it is cut off (fsync'ed), reported in
        :attr:`recovery` and recorded as ``# truncated_bytes: N`` before new rows.  A header torn
        while the log was created is refused (no row was recorded yet), except, with
        ``repair``, a column line torn after the whole comment header: being fixed by the
        schema it is completed (``# header_completed_bytes: N``).

        Raises
        ------
        LogIntegrityError
            Damaged header/rows, an incomplete header, a partial last line without ``repair``, or another
            session holds the log.
        FileNotFoundError
            No such file.
        """
        path = Path(path)
        if not path.exists():  # appending would create it
            raise FileNotFoundError(2, "No such file or directory", str(path))
        handle = open(path, "a", encoding="utf-8", newline="")
        try:  # locked before it is read: another session cannot append between the check and the first row
            lock_handle(handle, path)
            recovery = cls.check_resumable(path, repair=repair)
            if recovery.truncated or recovery.header_completed_bytes:  # cut a torn row / finish the column line
                with open(path, "r+b") as raw:
                    raw.truncate(path.stat().st_size - recovery.dropped_bytes)
                    raw.seek(0, os.SEEK_END)
                    raw.write(_COLUMN_LINE[len(_COLUMN_LINE) - recovery.header_completed_bytes:])
                    raw.flush()
                    os.fsync(raw.fileno())
            _scan(path)  # the repaired file reads whole
        except BaseException:
            handle.close()
            raise
        log = cls(path, handle, recovery)
        note = f"# resumed_utc: {utc_now()}\n"
        if recovery.truncated:
            note += f"# truncated_bytes: {recovery.dropped_bytes}\n"
        if recovery.header_completed_bytes:
            note += f"# header_completed_bytes: {recovery.header_completed_bytes}\n"
        log._write(note)
        return log

    def note(self, entries: Mapping[str, Any]) -> None:
        """Record ``# key: value`` lines between rows (durably; one-line keys without ``:`` and values)."""
        self._write("".join(f"# {key}: {value}\n" for key, value in _comment_entries(entries, "entries").items()))

    def append(self, row: LogRow) -> LogRow:
        """Write one row durably (single write, flush, fsync); fills ``seq`` and ``t_utc`` if unset.

        Returns
        -------
        LogRow
            The row as written.

        Raises
        ------
        LogIntegrityError
            The log is closed.
        """
        if row.seq < 0 or not row.t_utc:
            row = LogRow(
                row.start_stop, row.probe, row.motor, row.direction, row.laser_a, row.laser_b, row.laser_c,
                row.pos_usteps, row.laser_raw, self.rows_written if row.seq < 0 else row.seq, row.t_utc or utc_now(),
            )
        with deferred():  # the row and its count together
            self._write(",".join(row.cells()) + "\n")
            self.rows_written += 1
        return row

    def _write(self, text: str) -> None:
        if self._handle is None:
            raise LogIntegrityError(str(self.path), "log is closed")
        with deferred():  # Ctrl-C / SIGTERM / SIGHUP wait until the row is on disk whole
            self._handle.write(text)
            self._handle.flush()
            os.fsync(self._handle.fileno())

    def close(self) -> None:
        """Close the file (idempotent)."""
        if self._handle is not None:
            self._handle.close()
            self._handle = None

    def __enter__(self) -> AcquisitionLog:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def export_table_3_2(
    source: str | os.PathLike[str], destination: str | os.PathLike[str], *, overwrite: bool = False
) -> Path:
    """Write the plain seed Table 3.2 view of a log (7 columns, no comments) to a new file.

    This is a derived file for tools that read only
    ``start_stop,probe,motor,direction,laser_a,laser_b,laser_c`` (e.g.
    :func:`pcmm_geo.machine.analysis.logproc.read_log`); the original log is not touched.

    Raises
    ------
    LogIntegrityError
        The source is damaged (partial or bad row).
    OutputExistsError
        The destination exists and ``overwrite`` is False.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> with AcquisitionLog.create(folder / "run.csv") as log:
    ...     _ = log.append(LogRow(1, 0, 3, -1, 49.5, 54.25, 67.5))
    >>> print(export_table_3_2(folder / "run.csv", folder / "table.csv").read_text(), end="")
    start_stop,probe,motor,direction,laser_a,laser_b,laser_c
    1,0,3,-1,49.5,54.25,67.5
    """
    contents = read_log(source)
    destination = Path(destination)
    lines = [",".join(TABLE_3_2_COLUMNS)] + [",".join(row.cells()[: len(TABLE_3_2_COLUMNS)]) for row in contents.rows]
    from pcmm_geo._atomic import write_atomic

    return write_atomic(destination, "\n".join(lines) + "\n", overwrite=overwrite)

