"""PC-DMIS XYZIJK text files: points with their surface normals.

The layout PC-DMIS documents for its XYZ files: the first line holds ``XYZIJK`` in columns 1-6
and, for metric data, ``METRIC`` in columns 11-16 (without it the numbers are inches, by the
format's definition); every further line holds comma-separated numbers, per PC-DMIS

=======  ===========================================================
numbers  meaning
=======  ===========================================================
3        x, y, z (a point without a vector)
5        x, y, z and two unused numbers (a point without a vector)
6        x, y, z, i, j, k (a point with its vector)
8        x, y, z, i, j, k and two unused numbers (a point with its vector)
4, 7     a circle (x, y, z[, i, j, k], diameter): not a point, refused
=======  ===========================================================

:func:`read_pcdmis_xyzijk` returns a :class:`~pcmm_geo.io.cmm.MeasuredPointSet` in mm with
the unit normals, ``compensated=None`` (the format does not say whether the points are probe
centers or surface points: the user must).  Either every point has a vector or none has one.
A last line without a line end is refused (a file cut inside a number: ``11.113`` would read as
``11.1``); a file cut exactly at a line end cannot be told from a complete one (the format has
no end marker).
:func:`is_pcdmis_xyzijk` tells such a file by its first line (for
:func:`pcmm_geo.io.read_points`, which returns the points alone).  The file is streamed.

Examples
--------
>>> import pathlib, tempfile
>>> path = pathlib.Path(tempfile.mkdtemp()) / "scan.xyz"
>>> _ = path.write_text("XYZIJK    METRIC\\n1.0,2.0,3.0,0,0,1\\n4.0,5.0,6.0,1,0,0\\n")
>>> points = read_pcdmis_xyzijk(path)
>>> points.points.tolist(), points.normals.tolist(), points.compensated
([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]], [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]], None)
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from pcmm_geo.errors import FileFormatError
from pcmm_geo.io._lines import decode_block, iter_blocks, open_regular, text_codec
from pcmm_geo.io._text import excerpt, parse_decimal
from pcmm_geo.io.cmm.model import MeasuredPointSet

__all__ = ["is_pcdmis_xyzijk", "read_pcdmis_xyzijk"]

_INCH = 25.4
_UNIT_TOLERANCE = 1e-4
_BLOCK = 65536


def is_pcdmis_xyzijk(path: str | Path) -> bool:
    """True when the file's first line starts with ``XYZIJK`` (a PC-DMIS XYZ file)."""
    try:
        with open_regular(path) as stream:
            head = stream.read(9)
    except (OSError, ValueError):  # missing, a folder, a FIFO: the reader that follows names it
        return False
    return head.removeprefix(b"\xef\xbb\xbf").startswith(b"XYZIJK")


def _lines(path: str | Path, encoding: str) -> Iterator[tuple[int, str]]:
    """The file's lines; a last line without a line end is refused (the file was cut inside a point)."""
    codec = text_codec(path, encoding)
    for block in iter_blocks(path):
        lines = decode_block(path, block, encoding=codec)
        if block.last and not block.terminated and lines and lines[-1][1].strip():
            number, text = lines[-1]
            raise FileFormatError(str(path), "the file ends in the middle of a line (no line end after it): its last "
                                  f"point may be cut short: {excerpt(text)}", number)
        yield from lines


def read_pcdmis_xyzijk(path: str | Path, *, encoding: str = "utf-8") -> MeasuredPointSet:
    """Read a PC-DMIS XYZIJK file (see the module docstring).

    Parameters
    ----------
    path : str or Path
    encoding : str
        Text encoding (an ASCII-compatible one; PC-DMIS writes ASCII).

    Returns
    -------
    MeasuredPointSet
        ``id=None``, points ``(N, 3)`` in mm, ``normals`` ``(N, 3)`` or None, ``compensated=None``.

    Raises
    ------
    FileFormatError
        No ``XYZIJK`` first line, a line with a number count that is not a point, mixed lines with
        and without vectors, a non-unit vector, a field that is not a number, no points -- naming
        file and line.
    FileNotFoundError
        The file does not exist.
    """
    name = str(path)
    lines = _lines(path, encoding)
    first = next(lines, None)
    if first is None or not first[1].startswith("XYZIJK"):
        raise FileFormatError(name, "expected 'XYZIJK' in columns 1-6 of the first line (a PC-DMIS XYZ file), got "
                              f"{excerpt(first[1]) if first else 'an empty file'}", 1)
    header = first[1]
    metric = header[10:16] == "METRIC"
    if not metric and header[6:].strip():
        raise FileFormatError(name, f"first line: expected 'METRIC' in columns 11-16 or nothing, got "
                              f"{excerpt(header[6:].strip())}", 1)
    factor = 1.0 if metric else _INCH
    blocks: list[np.ndarray] = []
    block = np.empty((_BLOCK, 6))
    filled = 0
    with_vectors: bool | None = None
    first_kind_line = 0
    for number, text in lines:
        if not text.strip():
            continue
        fields = text.split(",")
        count = len(fields)
        if count in (4, 7):
            raise FileFormatError(name, f"{count} numbers: PC-DMIS reads this line as a circle (with a diameter), "
                                  "not a point", number)
        if count not in (3, 5, 6, 8):
            raise FileFormatError(name, f"expected 3, 5, 6 or 8 comma-separated numbers, got {count}", number)
        values = []
        for field in fields[: 6 if count >= 6 else 3]:
            try:
                value = parse_decimal(field)
            except ValueError:
                raise FileFormatError(name, f"expected a number, got {excerpt(field.strip())}", number) from None
            if not math.isfinite(value):
                raise FileFormatError(name, f"expected a finite number, got {excerpt(field.strip())}", number)
            values.append(value)
        has_vector = count >= 6
        if with_vectors is None:
            with_vectors, first_kind_line = has_vector, number
        elif has_vector != with_vectors:
            raise FileFormatError(name, f"a point {'with' if has_vector else 'without'} a vector after points "
                                  f"{'with' if with_vectors else 'without'} one (line {first_kind_line}); the "
                                  "normals would be incomplete", number)
        if has_vector:
            length = math.hypot(values[3], values[4], values[5])  # no overflow: 1e308 gives 1e308
            if abs(length - 1.0) > _UNIT_TOLERANCE:
                raise FileFormatError(name, f"vector {values[3]:g}, {values[4]:g}, {values[5]:g} has length "
                                      f"{length:.6g}, expected a unit vector", number)
        else:
            values += [0.0, 0.0, 0.0]
        block[filled] = values
        filled += 1
        if filled == _BLOCK:
            blocks.append(block)
            block, filled = np.empty((_BLOCK, 6)), 0
    blocks.append(block[:filled])
    data = np.concatenate(blocks) if len(blocks) > 1 else blocks[0]
    if len(data) == 0:
        raise FileFormatError(name, "holds no points")
    with np.errstate(over="ignore"):
        points = data[:, :3] * factor if factor != 1.0 else data[:, :3].copy()
    if not np.isfinite(points).all():
        row = int(np.flatnonzero(~np.isfinite(points).all(axis=1))[0])
        raise FileFormatError(name, f"point {row + 1}: a coordinate overflows the float range when converted to mm")
    return MeasuredPointSet(id=None, points=points, normals=data[:, 3:].copy() if with_vectors else None,
                            compensated=None)
