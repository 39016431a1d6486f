"""Point files larger than memory: a lazy dask array read chunk by chunk when computed.

:func:`read_points_lazy` reads the head of the file (count, header, first data line: the
same checks as :func:`pcmm_geo.io.read_points`), then scans the rest once without parsing
it, to split it at line ends into chunks and count each chunk's rows (so that the array's
shape is known); each chunk is parsed by a dask task with the same block parser as the eager
reader.  A bad line is therefore found when the chunk that holds it is computed, and the
:class:`~pcmm_geo.errors.FileFormatError` names its line all the same; a file changed after
the array was made is refused rather than read half old, half new.

Needs the ``dask`` extra.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._optional import require
from pcmm_geo.errors import FileFormatError
from pcmm_geo.io._delimited import Layout, parse_block
from pcmm_geo.io._lines import iter_blocks

if TYPE_CHECKING:
    import dask.array

__all__ = ["CHUNK_BYTES", "read_points_lazy"]

FloatArray = NDArray[np.float64]
#: bytes of the file per dask chunk (about 2 million rows of a 33-byte scan row)
CHUNK_BYTES = 1 << 26


@dataclasses.dataclass(frozen=True)
class _Chunk:
    start: int
    stop: int
    first_line: int
    rows: int


def _data_rows(data: bytes) -> int:
    """Rows of a block of whole lines: lines that are neither blank nor ``#`` comments."""
    lines = data.count(b"\n")
    if b"#" not in data:
        squeezed = data.translate(None, b" \t\r")  # a blank line becomes an empty one
        if b"\n\n" not in squeezed and not squeezed.startswith(b"\n"):
            return lines
    texts = (line.decode("utf-8", "replace").strip() for line in data.split(b"\n")[:-1])
    return sum(1 for text in texts if text and not text.startswith("#"))


def _first_mark(data: bytes) -> str | None:
    """The first decimal mark (``.`` or ``,``) on a line that is not a comment, or None."""
    if b"#" in data:
        data = b"\n".join(line for line in data.split(b"\n") if not line.lstrip().startswith(b"#"))
    positions = [(data.find(mark), mark) for mark in (b".", b",")]
    found = [(p, m) for p, m in positions if p >= 0]
    return min(found)[1].decode() if found else None


def _scan(path: Path, start: int, first_line: int, layout: Layout, chunk_bytes: int,
          max_lines: int | None) -> list[_Chunk]:
    """Split the data at line ends into chunks of about ``chunk_bytes`` and count their rows."""
    from pcmm_geo.io._delimited import _limited

    chunks = []
    blocks = iter_blocks(path, start=start, first_line=first_line, block_bytes=chunk_bytes,
                         first_block_bytes=chunk_bytes)
    for block in _limited(blocks, max_lines):
        if layout.decimal is None and layout.separator != ",":
            layout.decimal = _first_mark(block.data)
        if block.data:
            stop = block.offset + len(block.data) - (0 if block.terminated else 1)
            chunks.append(_Chunk(block.offset, stop, block.first_line, _data_rows(block.data)))
    return chunks


def _stamp(path: Path) -> tuple[int, int]:
    status = os.stat(path)
    return status.st_size, status.st_mtime_ns


def _parse_chunk(path: str, chunk: _Chunk, layout: Layout, stamp: tuple[int, int]) -> FloatArray:
    """The rows of one chunk (a dask task); the file must be the one that was scanned."""
    if _stamp(Path(path)) != stamp:
        raise FileFormatError(path, "the file changed after it was opened for lazy reading; open it again")
    out = np.empty((chunk.rows, 3), dtype=np.float64)
    filled = 0
    own = dataclasses.replace(layout)  # tasks may run in threads: no shared state
    for block in iter_blocks(path, start=chunk.start, first_line=chunk.first_line, stop=chunk.stop):
        if not block.data:
            continue
        points = parse_block(path, block, own)
        if filled + len(points) > chunk.rows:
            raise FileFormatError(path, "the file changed after it was opened for lazy reading; open it again")
        out[filled:filled + len(points)] = points
        filled += len(points)
    if filled != chunk.rows:
        raise FileFormatError(path, "the file changed after it was opened for lazy reading; open it again")
    return out


def read_points_lazy(path: str | Path, *, decimal: str | None = None,
                     chunk_bytes: int = CHUNK_BYTES) -> dask.array.Array:
    """A lazy ``(N, 3)`` dask array (mm) of a text point file or ASCII PLY / PCD too large for memory.

    Same formats, rules and refusals as :func:`pcmm_geo.io.read_points` (which returns a
    numpy array); binary PLY / PCD and E57 are read by that function only.  The head of the
    file is checked now; the rest is scanned once (split at line ends, rows counted, nothing
    parsed) and parsed chunk by chunk when the array is computed.

    Parameters
    ----------
    path : str or Path
    decimal : {None, ".", ","}, optional
        The decimal mark of a text file; None detects it.
    chunk_bytes : int
        Bytes of the file per chunk of the array.

    Returns
    -------
    dask.array.Array, shape (N, 3), float64

    Raises
    ------
    FileFormatError
        Now: a bad head (count, header, first data line), a binary or E57 file, a count that
        does not match.  When computed: the first bad line of a chunk, named; a file changed
        since.
    MissingDependencyError
        dask is not installed (extra ``dask``).

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "scan.csv")
    >>> _ = open(path, "w").write("x;y;z\\n1;2;3\\n4,5;5;6\\n7;8;9,25\\n")
    >>> lazy = read_points_lazy(path, chunk_bytes=8)
    >>> lazy.shape, lazy.numblocks
    ((3, 3), (3, 1))
    >>> lazy.sum(axis=0).compute().tolist()
    [12.5, 15.0, 18.25]
    >>> _ = open(path, "w").write("x;y;z\\n1;2;3\\n4,5;5;6\\n7.5;8;9\\n")
    >>> try:
    ...     read_points_lazy(path).compute()
    ... except FileFormatError as exc:
    ...     print(exc.line, exc.reason)
    4 decimal point in '7.5', but this file uses decimal commas
    """
    da = require("dask.array", purpose="read_points_lazy")
    dask = require("dask")
    from pcmm_geo.io.points import POINT_CLOUD_SUFFIXES, TEXT_SUFFIXES, scan_head

    if decimal not in (None, ".", ","):
        from pcmm_geo.errors import InvalidInputError

        raise InvalidInputError("decimal", "None, '.' or ','", repr(decimal))
    file = Path(path)
    suffix = file.suffix.lower()
    expected: int | None
    max_lines: int | None = None
    if suffix in POINT_CLOUD_SUFFIXES:
        from pcmm_geo.io.clouds import cloud_text_body

        body = cloud_text_body(file)
        if body is None:
            raise FileFormatError(str(file), "a binary point cloud: read it with read_points (lazy reading "
                                  "takes text point files and ASCII PLY / PCD)")
        layout, start, line, expected, max_lines = body.layout, body.offset, body.line, body.count, body.count
    elif suffix in TEXT_SUFFIXES:
        head = scan_head(file, decimal)
        layout, start, line, expected = head.layout, head.data_offset, head.data_line, head.expected_count
    else:
        raise FileFormatError(str(file), f"expected one of {', '.join(TEXT_SUFFIXES[:-1] + POINT_CLOUD_SUFFIXES)} "
                              "for lazy reading")
    stamp = _stamp(file)
    chunks = _scan(file, start, line, layout, chunk_bytes, max_lines)
    total = sum(c.rows for c in chunks)
    if expected is not None and expected != total:
        raise FileFormatError(str(file), f"header announces {expected} points, found {total}",
                              line=1 if suffix in TEXT_SUFFIXES else None)
    parse = dask.delayed(_parse_chunk, pure=True)
    parts: list[Any] = [da.from_delayed(parse(str(file), chunk, layout, stamp), shape=(chunk.rows, 3),
                                        dtype=np.float64) for chunk in chunks if chunk.rows]
    if not parts:
        raise FileFormatError(str(file), "no points in the file")
    return da.concatenate(parts, axis=0) if len(parts) > 1 else parts[0]
