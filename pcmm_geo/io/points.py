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

__all__ = ["read_points", "write_points", "POINT_CLOUD_SUFFIXES", "TEXT_SUFFIXES"]

FloatArray = NDArray[np.float64]
TEXT_SUFFIXES = (".csv", ".txt", ".xyz", ".ds", ".dat", ".asc", "")
POINT_CLOUD_SUFFIXES = (".ply", ".pcd")
_SPLIT = re.compile(r"[,;\s]+")


def read_points(path: str | Path) -> FloatArray:
    """Read points ``(N, 3)`` (mm) from a text or point-cloud file.

    Parameters
    ----------
    path : str or Path
        ``.csv``, ``.txt``, ``.xyz``, ``.ds`` (NIST), ``.ply`` or ``.pcd``.

    Returns
    -------
    ndarray, shape (N, 3)

    Raises
    ------
    FileFormatError
        Unknown suffix, non-numeric values, rows of different lengths, fewer than three
        columns, a NIST count that does not match, or an empty file; the message names the
        line.
    OSError
        The file cannot be read.

    Examples
    --------
    >>> import tempfile, os
    >>> path = os.path.join(tempfile.mkdtemp(), "pts.csv")
    >>> _ = open(path, "w").write("x,y,z\\n1,2,3\\n4,5,6\\n")
    >>> read_points(path).tolist()
    [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]
    """
    file = Path(path)
    suffix = file.suffix.lower()
    if suffix in POINT_CLOUD_SUFFIXES:
        return _read_cloud(file)
    if suffix not in TEXT_SUFFIXES:
        raise FileFormatError(str(file), f"expected one of {', '.join(TEXT_SUFFIXES[:-1] + POINT_CLOUD_SUFFIXES)}")
    return _read_text(file)


def _read_text(file: Path) -> FloatArray:
    rows: list[list[float]] = []
    columns: tuple[int, int, int] | None = None
    expected_count: int | None = None
    width: int | None = None
    with open(file, encoding="utf-8-sig") as handle:
        for number, raw in enumerate(handle, start=1):
            text = raw.strip()
            if not text or text.startswith("#"):
                continue
            fields = [f for f in _SPLIT.split(text) if f]
            if not rows and columns is None and expected_count is None:
                if len(fields) == 1 and fields[0].isdigit():
                    expected_count = int(fields[0])  # NIST .ds: point count first
                    continue
                try:
                    [float(f) for f in fields]
                except ValueError:
                    names = [f.strip().strip('"').lower() for f in fields]
                    if not {"x", "y", "z"} <= set(names):
                        raise FileFormatError(
                            str(file), f"header without x, y, z columns: {text!r}", line=number
                        ) from None
                    columns = (names.index("x"), names.index("y"), names.index("z"))
                    continue
            try:
                values = [float(f) for f in fields]
            except ValueError:
                raise FileFormatError(str(file), f"expected numbers, got {text!r}", line=number) from None
            if width is None:
                width = len(values)
                if width < 3 and columns is None:
                    raise FileFormatError(str(file), f"expected at least 3 columns, got {width}", line=number)
            elif len(values) != width:
                raise FileFormatError(str(file), f"expected {width} values, got {len(values)}", line=number)
            rows.append(values)
    if not rows:
        raise FileFormatError(str(file), "no points in the file")
    data = np.asarray(rows, dtype=float)
    points = data[:, list(columns)] if columns is not None else data[:, :3]
    if expected_count is not None and expected_count != len(points):
        raise FileFormatError(str(file), f"header announces {expected_count} points, found {len(points)}", line=1)
    if not np.all(np.isfinite(points)):
        row = int(np.argwhere(~np.isfinite(points))[0, 0])
        raise FileFormatError(str(file), f"non-finite coordinate in point {row + 1}")
    return points


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
    if file.exists() and not overwrite:
        raise OutputExistsError(str(file))
    suffix = file.suffix.lower()
    if suffix in POINT_CLOUD_SUFFIXES:
        o3d = require("open3d")

        cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts))
        # binary keeps full double precision (open3d's ASCII writer rounds to 6 digits)
        if not o3d.io.write_point_cloud(str(file), cloud, write_ascii=False):
            raise OSError(f"{file}: open3d could not write the point cloud")
        return file
    with open(file, "w", encoding="utf-8") as handle:
        handle.write("x,y,z\n")
        for x, y, z in pts:
            handle.write(f"{float(x)!r},{float(y)!r},{float(z)!r}\n")
    return file
