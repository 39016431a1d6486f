"""Durable transcript of I++ DME sessions, and the measured points read back from it.

One JSON object per line (UTF-8, ``\\n``).  The first line is the header (``schema``,
``created_utc``, ``software``, the server's settings); every later line is a record with
``seq``, ``t_s`` (seconds since the server started), ``utc``, ``conn`` (connection number)
and ``kind``:

``connect`` / ``disconnect`` / ``rejected``
    a client came, went (``reason``) or was turned away;
``in`` / ``out``
    a command line as received (``line``; bytes outside printable ASCII as ``\\xNN``) and a
    response line as sent;
``move``
    a motion of the tip centre (``from_mm``, ``to_mm``, machine frame; ``collision``) and the
    readings after it (``lasers_mm``, ``heights_mm``: the quantities of a seed Table 3.2 row);
``point``
    a probing: the point as reported (``reported_mm`` in the client's system ``csy``) and in
    the machine frame (``point_mm``, ``tip_mm``), the readings latched at contact
    (``lasers_mm``, ``heights_mm`` -- the quantities of a seed Table 3.2 row), the tip
    uncertainty, ``poorly_resolved``, and the simulation's truth (``true_tip_mm``); or the
    refusal (``error``, ``detail``);
``error``
    the server's detail of an error it answered (``number``, ``detail``; the wire carries the
    spec's text only);
``fault``
    an unexpected failure inside the server, answered with 0511 (the session goes on).

Durability as the acquisition log (:mod:`pcmm_geo.acquisition.acqlog`): a new file is created
exclusively (its folder fsync'ed), each record is one ``write``, ``flush`` and ``os.fsync`` with
signals held, so a crash leaves whole lines only; :func:`read_transcript` refuses a torn last
line unless asked to ignore it.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Mapping
from datetime import UTC, datetime
from pathlib import Path
from typing import IO, Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._atomic import fsync_folder
from pcmm_geo._records import record
from pcmm_geo._signals import deferred
from pcmm_geo.errors import FileFormatError, LogIntegrityError, OutputExistsError

__all__ = ["TRANSCRIPT_SCHEMA", "MeasuredPoints", "Transcript", "measured_points", "read_transcript",
           "write_points_csv"]

TRANSCRIPT_SCHEMA = "pcmm_geo.ippdme-transcript/1"
#: largest transcript line read back (bytes); a command line is at most 64 KiB, escaped up to 4x
_MAX_RECORD_BYTES = 1 << 20
#: largest transcript read back (bytes)
_MAX_FILE_BYTES = 1 << 31


def _utc() -> str:
    return datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%S.%f")[:-3] + "Z"


def _line(obj: Mapping[str, Any]) -> str:
    return json.dumps(obj, separators=(",", ":"), allow_nan=True) + "\n"


class Transcript:
    """Append-only, fsync'ed JSON-lines transcript (see the module notes); ``None`` path: records are dropped."""

    def __init__(self, path: str | os.PathLike[str] | None, settings: Mapping[str, Any], *,
                 overwrite: bool = False) -> None:
        self.path = None if path is None else Path(path)
        self._handle: IO[str] | None = None
        self._seq = 0
        self._t0 = time.monotonic()
        if self.path is None:
            return
        from pcmm_geo import __version__
        from pcmm_geo._atomic import current_transaction

        transaction = current_transaction()
        if transaction is not None:  # a command's output: an allowed old file is moved aside, restorable
            transaction.claim(self.path, overwrite=overwrite)
            overwrite = False
        self.path.parent.mkdir(parents=True, exist_ok=True)
        flags = os.O_WRONLY | os.O_CREAT | (os.O_TRUNC if overwrite else os.O_EXCL)
        try:
            fd = os.open(self.path, flags, 0o644)
        except FileExistsError:
            raise OutputExistsError(str(self.path)) from None
        self._handle = os.fdopen(fd, "w", encoding="utf-8", newline="\n")
        header = {"schema": TRANSCRIPT_SCHEMA, "created_utc": _utc(), "software": f"pcmm_geo {__version__}",
                  "settings": dict(settings)}
        self._write(header)
        if transaction is not None:  # session records are a record: a failing command keeps them
            transaction.keep_on_failure(self.path, self._kept, header_bytes=len(_line(header).encode("utf-8")))
        fsync_folder(self.path.parent)

    def _kept(self) -> str | None:
        return f"{self._seq} session records" if self._seq else None

    def _write(self, obj: Mapping[str, Any]) -> None:
        assert self._handle is not None
        text = _line(obj)
        with deferred():
            self._handle.write(text)
            self._handle.flush()
            os.fsync(self._handle.fileno())

    def record(self, conn: int, kind: str, **fields: Any) -> None:
        """Append one record (a whole line on disk when this returns)."""
        self._seq += 1
        if self._handle is None:
            return
        self._write({"seq": self._seq, "t_s": round(time.monotonic() - self._t0, 6), "utc": _utc(),
                     "conn": conn, "kind": kind, **fields})

    def close(self) -> None:
        if self._handle is not None:
            self._handle.close()
            self._handle = None


def read_transcript(path: str | os.PathLike[str], *, allow_partial: bool = False) -> tuple[dict[str, Any],
                                                                                           list[dict[str, Any]]]:
    """``(header, records)`` of a transcript; a torn last line raises unless ``allow_partial`` (then dropped).

    Raises
    ------
    FileFormatError
        Not a transcript (schema), a line that is not a JSON object, a line or file over the bounds.
    LogIntegrityError
        The last line has no line end (a crash while writing it) and ``allow_partial`` is False.
    """
    file = Path(path)
    if file.stat().st_size > _MAX_FILE_BYTES:
        raise FileFormatError(str(file), f"larger than {_MAX_FILE_BYTES} bytes")
    records: list[dict[str, Any]] = []
    header: dict[str, Any] | None = None
    with open(file, "rb") as handle:
        for number, raw in enumerate(iter(lambda: handle.readline(_MAX_RECORD_BYTES + 1), b""), start=1):
            if len(raw) > _MAX_RECORD_BYTES:
                raise FileFormatError(str(file), f"line longer than {_MAX_RECORD_BYTES} bytes", line=number)
            if not raw.endswith(b"\n"):
                if allow_partial:
                    break
                raise LogIntegrityError(str(file), "the last line is incomplete (a crash while writing it?)",
                                        line=number)
            try:
                obj = json.loads(raw.decode("utf-8"))
            except (UnicodeDecodeError, ValueError, RecursionError) as exc:
                raise FileFormatError(str(file), f"not a JSON line ({type(exc).__name__})", line=number) from None
            if not isinstance(obj, dict):
                raise FileFormatError(str(file), "expected a JSON object", line=number)
            if header is None:
                if obj.get("schema") != TRANSCRIPT_SCHEMA:
                    raise FileFormatError(str(file), f"expected schema {TRANSCRIPT_SCHEMA!r}", line=number)
                header = obj
            else:
                records.append(obj)
    if header is None:
        raise FileFormatError(str(file), "empty file: no transcript header")
    return header, records


@record
class MeasuredPoints:
    """Points probed in a transcript: ``points`` (N, 3) mm as reported, with ``tags``, ``csy``, ``poorly_resolved``."""

    points: NDArray[np.float64]
    tags: tuple[str, ...]
    csy: tuple[str, ...]
    poorly_resolved: NDArray[np.bool_]
    refused: int


def measured_points(records: list[dict[str, Any]], *, conn: int | None = None) -> MeasuredPoints:
    """The reported points of a transcript's ``point`` records (of connection ``conn``, default all), in order."""
    rows, tags, csy, flags, refused = [], [], [], [], 0
    for rec in records:
        if rec.get("kind") != "point" or (conn is not None and rec.get("conn") != conn):
            continue
        if "error" in rec:
            refused += 1
            continue
        point = rec.get("reported_mm")
        if not (isinstance(point, list) and len(point) == 3):
            raise FileFormatError("transcript", f"point record {rec.get('seq')} has no reported_mm")
        rows.append([float(v) for v in point])
        tags.append(str(rec.get("tag", "")))
        csy.append(str(rec.get("csy", "")))
        flags.append(bool(rec.get("poorly_resolved", False)))
    return MeasuredPoints(np.asarray(rows, dtype=float).reshape(-1, 3), tuple(tags), tuple(csy),
                          np.asarray(flags, dtype=bool), refused)


def write_points_csv(path: str | os.PathLike[str], points: NDArray[np.float64], *, overwrite: bool = False) -> Path:
    """Write an ``x,y,z`` header and rows (mm, 9 decimals) for :func:`pcmm_geo.io.read_points` and ``pcmm fit``."""
    from pcmm_geo._atomic import write_atomic

    text = "x,y,z\n" + "".join(f"{x:.9f},{y:.9f},{z:.9f}\n" for x, y, z in np.asarray(points, float).reshape(-1, 3))
    return write_atomic(Path(path), text, overwrite=overwrite)
