"""Reading and writing point files.

Text formats (read without any heavy dependency):

- CSV / TXT / XYZ: three (or more) numeric columns separated by commas, semicolons,
  spaces or tabs, with or without a header line; ``#`` comment lines are skipped.
  With a header, columns named ``x, y, z`` are used wherever they stand.
- NIST ``.ds``: first line the point count, then one point per line.

Text files, and ASCII PLY / PCD, are streamed: the head of the file (count, header, first
data line) is read and checked first, then the rows are parsed block by block into one
preallocated ``(N, 3)`` array (:mod:`pcmm_geo.io._delimited`), so that reading takes little
more memory than the points themselves and a wrong file is refused at its first bad line.
Binary PLY / PCD are read through open3d, E57 through pye57 (:mod:`pcmm_geo.io.clouds`).
A file larger than memory is read lazily by :func:`pcmm_geo.io.read_points_lazy`.
Writers never replace an existing file unless ``overwrite=True``.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._optional import require
from pcmm_geo.errors import FileFormatError, InvalidInputError, OutputExistsError
from pcmm_geo.io._lines import excerpt

if TYPE_CHECKING:
    from pcmm_geo.io._delimited import Layout

__all__ = ["read_points", "write_points", "POINT_CLOUD_SUFFIXES", "TEXT_SUFFIXES"]

FloatArray = NDArray[np.float64]
TEXT_SUFFIXES = (".csv", ".txt", ".xyz", ".ds", ".dat", ".asc", "")
POINT_CLOUD_SUFFIXES = (".ply", ".pcd")


def read_points(path: str | Path, *, decimal: str | None = None) -> FloatArray:
    """Read points ``(N, 3)`` (mm) from a text or point-cloud file.

    A text file whose first line starts with ``XYZIJK`` is a PC-DMIS export
    (:func:`~pcmm_geo.io.cmm.read_pcdmis_xyzijk`: inch unless it says ``METRIC``; its normals
    are dropped here).  Other text files use one field separator throughout: ``;``, tab, ``,`` (spaces around it
    allowed: ``1.5, 2.5, 3.5``) or spaces.  The decimal mark is ``.`` or, in files separated
    by ``;``, tabs or spaces, ``,`` (the usual layout of European CMM and spreadsheet
    exports: ``12,5;3,25;7,75``): with such a separator a comma can only be a decimal mark,
    and with ``decimal=None`` the first number that has a mark decides it for the file.  A
    file that mixes marks or separators, or a line whose fields cannot be read one way only
    (``12,5,3`` where ``,`` is the decimal mark; ``1,5, 2,5, 3,5``), is refused rather than
    guessed, naming the line.  Digits are ASCII only (``float`` would also read full-width
    or Arabic-Indic digits).

    Parameters
    ----------
    path : str or Path
        ``.csv``, ``.txt``, ``.xyz``, ``.dat``, ``.asc``, ``.ds`` (NIST), ``.ply``, ``.pcd``
        or ``.e57`` (coordinates in metres, returned in mm; extra ``e57``).
    decimal : {None, ".", ","}, optional
        The decimal mark of a text file; None detects it.

    Returns
    -------
    ndarray, shape (N, 3)

    Raises
    ------
    FileFormatError
        Unknown suffix, non-numeric or non-finite values, an ambiguous number format, rows
        of different lengths, fewer than three columns, a NIST count that does not match,
        binary or non-UTF-8 content, or an empty file; the message names the file and line.
    InvalidInputError
        ``decimal`` is not None, "." or ",".
    OSError
        The file cannot be read.

    Examples
    --------
    >>> import tempfile, os
    >>> path = os.path.join(tempfile.mkdtemp(), "pts.csv")
    >>> _ = open(path, "w").write("x,y,z\\n1,2,3\\n4,5,6\\n")
    >>> read_points(path).tolist()
    [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]
    >>> _ = open(path, "w").write("x;y;z\\n12;3;7\\n12,5;3,25;7,75\\n")
    >>> read_points(path).tolist()
    [[12.0, 3.0, 7.0], [12.5, 3.25, 7.75]]
    >>> _ = open(path, "w").write("x;y;z\\n12;3;7\\n12,5;3.25;7,75\\n")
    >>> try:
    ...     read_points(path)
    ... except FileFormatError as exc:
    ...     print(exc.line, exc.reason)
    3 decimal point in '3.25', but this file uses decimal commas
    """
    if decimal not in (None, ".", ","):
        raise InvalidInputError("decimal", "None, '.' or ','", repr(decimal))
    file = Path(path)
    suffix = file.suffix.lower()
    if suffix in POINT_CLOUD_SUFFIXES:
        from pcmm_geo.io.clouds import read_cloud

        return read_cloud(file)
    if suffix == ".e57":
        from pcmm_geo.io.clouds import read_e57

        return read_e57(file)
    if suffix not in TEXT_SUFFIXES:
        raise FileFormatError(str(file), f"expected one of {', '.join(TEXT_SUFFIXES[:-1] + POINT_CLOUD_SUFFIXES)}"
                              ", .e57")
    from pcmm_geo.io.cmm.pcdmis import is_pcdmis_xyzijk, read_pcdmis_xyzijk

    if is_pcdmis_xyzijk(file):  # a PC-DMIS export: its own header, inch unless METRIC
        return read_pcdmis_xyzijk(file).points
    return _read_text(file, decimal)


def _read_text(file: Path, decimal: str | None) -> FloatArray:
    from pcmm_geo.io._delimited import read_rows

    head = scan_head(file, decimal)
    points = read_rows(file, head.data_offset, head.data_line, head.layout)
    if head.expected_count is not None and head.expected_count != len(points):
        raise FileFormatError(str(file), f"header announces {head.expected_count} points, found {len(points)}", line=1)
    return points


@dataclass(frozen=True)
class TextHead:
    """What precedes the numbers of a text point file, read without reading the rest.

    Attributes
    ----------
    layout : Layout
        Separator, decimal mark, fields a row and the x, y, z columns.
    data_offset, data_line : int
        Byte offset and line number of the first data line.
    expected_count : int or None
        The point count of a NIST ``.ds`` file (its first line).
    """

    layout: Layout
    data_offset: int
    data_line: int
    expected_count: int | None


def _head_lines(file: Path) -> Iterator[tuple[int, str, int]]:
    """``(line_number, stripped text, byte offset)`` of the lines that are neither blank nor comments."""
    from pcmm_geo.io._lines import decode_block, iter_blocks

    for block in iter_blocks(file):
        offset = block.offset
        for number, text in decode_block(file, block):
            stripped = text.strip()
            if stripped and not stripped.startswith("#"):
                yield number, stripped, offset
            offset = block.data.index(b"\n", offset - block.offset) + 1 + block.offset


def scan_head(file: Path, decimal: str | None) -> TextHead:
    """The point count line (NIST), the header and the layout of the first data line (see :func:`read_points`).

    Raises
    ------
    FileFormatError
        No data line, a header without x, y, z, a header that does not match the data, an
        ambiguous first data line; the message names the line.
    """
    from pcmm_geo.io._delimited import Layout, looks_numeric

    lines = _head_lines(file)
    first = next(lines, None)
    if first is None:
        raise FileFormatError(str(file), "no points in the file")
    expected_count: int | None = None
    if re.fullmatch(r"[0-9]{1,12}", first[1]):  # NIST .ds: point count first
        expected_count = int(first[1])
        first = next(lines, None)
    header: tuple[int, str, int] | None = None
    if first is not None and not looks_numeric(first[1]):
        header, first = first, next(lines, None)
    lines.close()
    if first is None:
        if header is not None and not {"x", "y", "z"} <= _header_tokens(header[1]):
            raise FileFormatError(str(file), f"header without x, y, z columns: {excerpt(header[1])}", line=header[0])
        raise FileFormatError(str(file), "no points in the file (a header only)" if header or expected_count is not None
                              else "no points in the file")
    number, text, offset = first
    layout = Layout.detect(str(file), number, text, decimal)
    if header is not None:
        layout.columns = _xyz_columns(layout, header[0], header[1])
    elif layout.width < 3:
        raise FileFormatError(str(file), f"expected at least 3 columns, got {layout.width}", line=number)
    return TextHead(layout, offset, number, expected_count)


def _header_tokens(text: str) -> set[str]:
    """Lower-case column names of a header line, whatever its separator."""
    return {t.strip('"').lower() for t in re.split(r"[,;\s]+", text) if t}


def _xyz_columns(layout: Layout, line: int, text: str) -> tuple[int, int, int]:
    """Indices of the x, y, z columns named by the header ``text`` (split like the data)."""
    from pcmm_geo.io._delimited import SEPARATOR_NAMES

    names = layout.header_names(text)
    if len(names) != layout.width and {"x", "y", "z"} <= _header_tokens(text):
        raise FileFormatError(
            layout.file, f"header has {len(names)} columns separated by {SEPARATOR_NAMES[layout.separator]}, "
            f"the first data line {layout.width}: {excerpt(text)}", line=line,
        )
    if not {"x", "y", "z"} <= set(names):
        raise FileFormatError(layout.file, f"header without x, y, z columns: {excerpt(text)}", line=line)
    return names.index("x"), names.index("y"), names.index("z")


def write_points(path: str | Path, points: ArrayLike, *, overwrite: bool = False) -> Path:
    """Write points ``(N, 3)`` as CSV (``x,y,z`` header, shortest exact repr) or PLY/PCD.

    CSV and PLY (binary, double precision) keep every digit; open3d writes PCD in
    single precision (relative error up to 6e-8, i.e. 6e-5 mm at 1000 mm): prefer CSV
    or PLY for measurement data.

    Raises
    ------
    OutputExistsError
        The file exists and ``overwrite`` is False.
    InvalidInputError
        Points not of shape (N, 3) or not finite.
    """
    file = Path(path)
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InvalidInputError("points", "shape (N, 3)", f"shape {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise InvalidInputError("points", "finite coordinates", "NaN or inf")
    from pcmm_geo._atomic import atomic_output, write_atomic

    if file.exists() and not overwrite:
        raise OutputExistsError(str(file))
    suffix = file.suffix.lower()
    if suffix in POINT_CLOUD_SUFFIXES:
        o3d = require("open3d")

        cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts))
        with atomic_output(file, overwrite=overwrite) as temporary:
            # binary keeps full double precision (open3d's ASCII writer rounds to 6 digits)
            if not o3d.io.write_point_cloud(str(temporary), cloud, write_ascii=False):
                raise OSError(f"{file}: open3d could not write the point cloud")
        return file

    def rows(stream: IO[bytes]) -> None:  # in slices: no text of the whole file in memory
        stream.write(b"x,y,z\n")
        for start in range(0, len(pts), 65_536):
            rows = pts[start:start + 65_536].tolist()
            stream.write("".join(f"{x!r},{y!r},{z!r}\n" for x, y, z in rows).encode("ascii"))

    return write_atomic(file, rows, overwrite=overwrite)
