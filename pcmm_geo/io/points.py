"""Reading and writing point files.

Text formats (read without any heavy dependency):

- CSV / TXT / XYZ: three (or more) numeric columns separated by commas, semicolons,
  spaces or tabs, with or without a header line; ``#`` comment lines are skipped.
  With a header, columns named ``x, y, z`` are used wherever they stand.
- NIST ``.ds``: first line the point count, then one point per line.

Point clouds ``.ply`` and ``.pcd`` are read and written through open3d (imported on
first use).  Writers never replace an existing file unless ``overwrite=True``.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._optional import require
from pcmm_geo.errors import FileFormatError, InvalidInputError, OutputExistsError
from pcmm_geo.io._text import excerpt

__all__ = ["read_points", "write_points", "POINT_CLOUD_SUFFIXES", "TEXT_SUFFIXES"]

FloatArray = NDArray[np.float64]
TEXT_SUFFIXES = (".csv", ".txt", ".xyz", ".ds", ".dat", ".asc", "")
POINT_CLOUD_SUFFIXES = (".ply", ".pcd")


def read_points(path: str | Path, *, decimal: str | None = None) -> FloatArray:
    """Read points ``(N, 3)`` (mm) from a text or point-cloud file.

    Text files use one field separator throughout: ``;``, tab, ``,`` or spaces.  The
    decimal mark is ``.`` or, in files separated by ``;``, tabs or spaces, ``,`` (the
    usual layout of European CMM and spreadsheet exports: ``12,5;3,25;7,75``).  With
    ``decimal=None`` the mark is detected from the file; a file that mixes marks or
    separators, or a line whose fields cannot be read one way only (``12,5,3`` where
    ``,`` is the decimal mark), is refused rather than guessed.

    Parameters
    ----------
    path : str or Path
        ``.csv``, ``.txt``, ``.xyz``, ``.ds`` (NIST), ``.ply`` or ``.pcd``.
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
    >>> _ = open(path, "w").write("x;y;z\\n12,5;3,25;7,75\\n")
    >>> read_points(path).tolist()
    [[12.5, 3.25, 7.75]]
    """
    if decimal not in (None, ".", ","):
        raise InvalidInputError("decimal", "None, '.' or ','", repr(decimal))
    file = Path(path)
    suffix = file.suffix.lower()
    if suffix in POINT_CLOUD_SUFFIXES:
        return _read_cloud(file)
    if suffix not in TEXT_SUFFIXES:
        raise FileFormatError(str(file), f"expected one of {', '.join(TEXT_SUFFIXES[:-1] + POINT_CLOUD_SUFFIXES)}")
    return _read_text(file, decimal)


def _read_text(file: Path, decimal: str | None) -> FloatArray:
    from pcmm_geo.io._text import read_text_lines

    lines = [(n, t.strip()) for n, t in read_text_lines(file)]
    lines = [(n, t) for n, t in lines if t and not t.startswith("#")]
    if not lines:
        raise FileFormatError(str(file), "no points in the file")
    expected_count: int | None = None
    if re.fullmatch(r"[0-9]{1,12}", lines[0][1]):  # NIST .ds: point count first
        expected_count = int(lines[0][1])
        lines = lines[1:]
    header: tuple[int, str] | None = None
    if lines and not _looks_numeric(lines[0][1]):
        header, lines = lines[0], lines[1:]
    if not lines:
        if header is not None and not {"x", "y", "z"} <= _header_tokens(header[1]):
            raise FileFormatError(str(file), f"header without x, y, z columns: {excerpt(header[1])}", line=header[0])
        raise FileFormatError(str(file), "no points in the file (a header only)")
    layout = _Layout.detect(file, lines[0], decimal)
    columns = None if header is None else layout.xyz_columns(*header)
    if columns is None and layout.width < 3:
        raise FileFormatError(str(file), f"expected at least 3 columns, got {layout.width}", line=lines[0][0])
    data = np.array([layout.parse(number, text) for number, text in lines], dtype=float)
    points = data[:, list(columns)] if columns is not None else data[:, :3]
    if expected_count is not None and expected_count != len(points):
        raise FileFormatError(str(file), f"header announces {expected_count} points, found {len(points)}", line=1)
    if not np.all(np.isfinite(points)):
        row = int(np.argwhere(~np.isfinite(points))[0, 0])
        raise FileFormatError(str(file), f"non-finite coordinate {excerpt(lines[row][1])}", line=lines[row][0])
    return points


_POINT_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?|[+-]?(nan|inf|infinity)", re.IGNORECASE | re.ASCII)
_COMMA_NUMBER = re.compile(r"[+-]?(\d+,?\d*|,\d+)([eE][+-]?\d+)?|[+-]?(nan|inf|infinity)", re.IGNORECASE | re.ASCII)
_SEPARATOR_NAMES = {";": "';'", "\t": "tab", ",": "','", " ": "spaces"}


def _header_tokens(text: str) -> set[str]:
    """Lower-case column names of a header line, whatever its separator."""
    return {t.strip('"').lower() for t in re.split(r"[,;\s]+", text) if t}


def _looks_numeric(text: str) -> bool:
    """Whether every token of the line is a number in one of the two decimal conventions (else: a header)."""
    tokens = [t for t in re.split(r"[;\s]+", text) if t]
    return all(_POINT_NUMBER.fullmatch(t) or _COMMA_NUMBER.fullmatch(t) or
               all(_POINT_NUMBER.fullmatch(p) for p in t.split(",")) for t in tokens)


class _Layout:
    """One field separator and one decimal mark for the whole file, checked on every line."""

    def __init__(self, file: Path, separator: str, decimal: str, width: int) -> None:
        self.file, self.separator, self.decimal, self.width = file, separator, decimal, width

    @classmethod
    def detect(cls, file: Path, first: tuple[int, str], decimal: str | None) -> _Layout:
        number, text = first
        if ";" in text:
            separator = ";"
        elif "\t" in text:
            separator = "\t"
        elif decimal == ",":
            separator = " "
        elif "," in text and all(_POINT_NUMBER.fullmatch(f.strip()) for f in text.split(",")):
            separator = ","
        elif "," in text and all(_COMMA_NUMBER.fullmatch(f) for f in text.split()):
            separator = " "  # 12,5 3,25 7,75: spaces between fields, decimal commas
        elif "," in text:
            separator = ","
        else:
            separator = " "
        fields = cls._split(text, separator)
        if decimal is None:
            decimal = "," if separator != "," and any("," in f for f in fields) else "."
        if separator == "," and decimal == ",":
            raise FileFormatError(
                str(file), f"ambiguous line {excerpt(text)}: ',' cannot be both separator and decimal mark", line=number
            )
        layout = cls(file, separator, decimal, len(fields))
        layout.parse(number, text)
        return layout

    @staticmethod
    def _split(text: str, separator: str) -> list[str]:
        if separator == " ":
            return text.split()
        return [f.strip() for f in text.split(separator)]

    def xyz_columns(self, line: int, text: str) -> tuple[int, int, int]:
        """Indices of the x, y, z columns named by the header ``text`` (split like the data)."""
        names = [f.strip('"').lower() for f in self._split(text, self.separator)]
        if len(names) != self.width and {"x", "y", "z"} <= _header_tokens(text):
            raise FileFormatError(
                str(self.file), f"header has {len(names)} columns separated by {_SEPARATOR_NAMES[self.separator]}, "
                f"the first data line {self.width}: {excerpt(text)}", line=line,
            )
        if not {"x", "y", "z"} <= set(names):
            raise FileFormatError(str(self.file), f"header without x, y, z columns: {excerpt(text)}", line=line)
        return names.index("x"), names.index("y"), names.index("z")

    def parse(self, number: int, text: str) -> list[float]:
        fields = self._split(text, self.separator)
        sep = _SEPARATOR_NAMES[self.separator]
        if len(fields) != self.width:
            raise FileFormatError(
                str(self.file),
                f"expected {self.width} values separated by {sep}, got {len(fields)} in {excerpt(text)}", line=number,
            )
        pattern = _COMMA_NUMBER if self.decimal == "," else _POINT_NUMBER
        values = []
        for field in fields:
            if not pattern.fullmatch(field):
                if self.decimal == "," and _POINT_NUMBER.fullmatch(field) and "." in field:
                    reason = f"decimal point in {excerpt(field)}, but this file uses decimal commas"
                elif self.decimal == "." and _COMMA_NUMBER.fullmatch(field) and "," in field:
                    reason = f"decimal comma in {excerpt(field)}, but this file uses decimal points"
                elif "," in field and self.decimal == ",":
                    reason = f"ambiguous number {excerpt(field)}: ',' as decimal mark and separator"
                else:
                    reason = f"expected numbers separated by {sep}, got {excerpt(field)}"
                raise FileFormatError(str(self.file), reason, line=number)
            values.append(float(field.replace(",", ".")))
        return values


def _read_cloud(file: Path) -> FloatArray:
    o3d = require("open3d")

    if not file.exists():
        raise FileNotFoundError(str(file))
    cloud = o3d.io.read_point_cloud(str(file))
    points = np.asarray(cloud.points, dtype=float)
    if points.size == 0:
        raise FileFormatError(str(file), "no points could be read (empty or malformed point cloud)")
    return points


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
    text = "x,y,z\n" + "".join(f"{float(x)!r},{float(y)!r},{float(z)!r}\n" for x, y, z in pts)
    return write_atomic(file, text, overwrite=overwrite)
