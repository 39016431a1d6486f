"""Point clouds from scanners: PLY and PCD (ASCII streamed, binary through open3d) and E57 (pye57).

ASCII PLY and PCD bodies are rows of numbers separated by spaces; their headers state the
columns and the number of points.  :func:`cloud_text_body` reads such a header and returns
the :class:`~pcmm_geo.io._delimited.Layout` of the body, so that the body is parsed like a
text point file (block by block into a preallocated array, every refusal naming its line).
Binary PLY / PCD are read by open3d (extra ``cad``), E57 (ASTM E2807, coordinates in metres)
by pye57 (extra ``e57``); their points come back in millimetres, like every reader's.

PCD's ``VIEWPOINT`` (the sensor pose) is not applied, as in PCL and open3d: the points are
returned in the file's frame.  E57 scans are returned in the file's common frame (each scan's
pose applied), invalid points (``cartesianInvalidState`` / ``sphericalInvalidState`` not 0)
left out, all scans one after the other.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._optional import require
from pcmm_geo.errors import FileFormatError
from pcmm_geo.io._delimited import Layout, read_rows
from pcmm_geo.io._lines import excerpt

__all__ = ["CloudBody", "cloud_text_body", "read_cloud", "read_e57"]

FloatArray = NDArray[np.float64]
#: header lines a PLY / PCD header may have at most
MAX_HEADER_LINES = 1000
_PCD_KEYS = ("VERSION", "FIELDS", "SIZE", "TYPE", "COUNT", "WIDTH", "HEIGHT", "VIEWPOINT", "POINTS", "DATA")


@dataclass(frozen=True)
class CloudBody:
    """Where the rows of an ASCII PLY / PCD body are and how to read them.

    Attributes
    ----------
    layout : Layout
        Spaces between fields, decimal points, the x, y, z columns.
    offset, line : int
        Byte offset and line number of the first point row.
    count : int
        Points the header announces (the rows read).
    """

    layout: Layout
    offset: int
    line: int
    count: int


def _header_lines(file: Path, magic: bytes | None) -> tuple[list[tuple[int, str]], int]:
    """The header lines (up to ``end_header`` / ``DATA``) and the byte offset just after them."""
    lines: list[tuple[int, str]] = []
    offset = 0
    with open(file, "rb") as handle:
        for number in range(1, MAX_HEADER_LINES + 1):
            raw = handle.readline(4096)
            if not raw:
                raise FileFormatError(str(file), "the header does not end (no end_header / DATA line)", line=number)
            offset += len(raw)
            try:
                text = raw.decode("ascii").strip()
            except UnicodeDecodeError:
                raise FileFormatError(str(file), "expected an ASCII header line", line=number) from None
            if number == 1 and magic is not None and raw.rstrip(b"\r\n") != magic:
                raise FileFormatError(str(file), f"expected a file starting with {magic.decode()!r}, got "
                                      f"{excerpt(text)}", line=1)
            lines.append((number, text))
            if text == "end_header" or text.upper().startswith("DATA"):
                return lines, offset
    raise FileFormatError(str(file), f"header longer than {MAX_HEADER_LINES} lines")


def _ply_body(file: Path) -> CloudBody | None:
    lines, offset = _header_lines(file, b"ply")
    name = str(file)
    fmt = next((t.split() for _, t in lines if t.startswith("format ")), None)
    if fmt is None or len(fmt) != 3 or fmt[1] not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise FileFormatError(name, "expected a 'format ascii|binary_little_endian|binary_big_endian 1.0' line")
    if fmt[1] != "ascii":
        return None
    elements: list[tuple[str, int, list[str], int]] = []  # name, count, property names, line
    for number, text in lines:
        words = text.split()
        if words[:1] == ["element"]:
            if len(words) != 3 or not words[2].isdigit():
                raise FileFormatError(name, f"expected 'element NAME COUNT', got {excerpt(text)}", line=number)
            elements.append((words[1], int(words[2]), [], number))
        elif words[:1] == ["property"] and elements:
            if words[1:2] == ["list"] and elements[-1][0] == "vertex":
                raise FileFormatError(name, "a list property in the vertex element is not supported", line=number)
            elements[-1][2].append(words[-1])
    vertex = next((e for e in elements if e[0] == "vertex"), None)
    if vertex is None:
        raise FileFormatError(name, "no vertex element in the header")
    if not {"x", "y", "z"} <= set(vertex[2]):
        raise FileFormatError(name, f"vertex element without x, y, z properties: {' '.join(vertex[2])}",
                              line=vertex[3])
    line = len(lines) + 1
    with open(file, "rb") as handle:  # skip the rows of elements before the vertices
        handle.seek(offset)
        for _ in range(sum(e[1] for e in elements[: elements.index(vertex)])):
            offset += len(handle.readline())
            line += 1
    columns = (vertex[2].index("x"), vertex[2].index("y"), vertex[2].index("z"))
    return CloudBody(Layout(name, " ", ".", len(vertex[2]), columns), offset, line, vertex[1])


def _pcd_body(file: Path) -> CloudBody | None:
    lines, offset = _header_lines(file, None)
    name = str(file)
    fields: dict[str, tuple[int, list[str]]] = {}
    for number, text in lines:
        words = text.split()
        if words and words[0].upper() in _PCD_KEYS:
            fields[words[0].upper()] = (number, words[1:])
        elif words and not text.startswith("#"):
            raise FileFormatError(name, f"expected a PCD header line ({', '.join(_PCD_KEYS)}), got {excerpt(text)}",
                                  line=number)
    missing = [k for k in ("FIELDS", "POINTS", "DATA") if k not in fields]
    if missing:
        raise FileFormatError(name, f"expected a PCD header with {', '.join(missing)}")
    data = fields["DATA"][1]
    if data not in (["ascii"], ["binary"], ["binary_compressed"]):
        raise FileFormatError(name, f"expected 'DATA ascii|binary|binary_compressed', got {excerpt(' '.join(data))}",
                              line=fields["DATA"][0])
    if data != ["ascii"]:
        return None
    names = fields["FIELDS"][1]
    counts = [int(c) for c in fields["COUNT"][1]] if "COUNT" in fields else [1] * len(names)
    if len(counts) != len(names) or not {"x", "y", "z"} <= set(names):
        raise FileFormatError(name, f"expected FIELDS with x, y, z and one COUNT each, got {' '.join(names)}",
                              line=fields["FIELDS"][0])
    starts = np.concatenate(([0], np.cumsum(counts)[:-1])).astype(int).tolist()
    columns = (starts[names.index("x")], starts[names.index("y")], starts[names.index("z")])
    points = fields["POINTS"][1]
    if len(points) != 1 or not points[0].isdigit():
        raise FileFormatError(name, f"expected 'POINTS COUNT', got {excerpt(' '.join(points))}",
                              line=fields["POINTS"][0])
    return CloudBody(Layout(name, " ", ".", int(sum(counts)), columns), offset, len(lines) + 1, int(points[0]))


def cloud_text_body(file: str | Path) -> CloudBody | None:
    """The body of an ASCII PLY or PCD file (None for a binary one).

    Raises
    ------
    FileFormatError
        A header that does not end, lacks the vertex element / FIELDS / POINTS, or has no x,
        y, z; the message names the line.
    """
    path = Path(file)
    if path.is_dir():
        raise FileFormatError(str(path), "is a directory, expected a point cloud")
    return _ply_body(path) if path.suffix.lower() == ".ply" else _pcd_body(path)


def read_cloud(file: str | Path) -> FloatArray:
    """Points ``(N, 3)`` of a PLY or PCD file (ASCII streamed, binary through open3d).

    Raises
    ------
    FileFormatError
        A bad header or row (named), fewer rows than announced, non-finite coordinates.
    MissingDependencyError
        A binary file without open3d (extra ``cad``).
    """
    path = Path(file)
    body = cloud_text_body(path)
    if body is not None:
        points = read_rows(path, body.offset, body.line, body.layout, max_lines=body.count)
        if len(points) != body.count:
            raise FileFormatError(str(path), f"header announces {body.count} points, found {len(points)}")
        return points
    o3d = require("open3d")
    cloud = o3d.io.read_point_cloud(str(path), remove_nan_points=False, remove_infinite_points=False)
    points = np.asarray(cloud.points, dtype=np.float64)
    if points.size == 0:
        raise FileFormatError(str(path), "no points could be read (empty or malformed point cloud)")
    _check_finite(str(path), points)
    return points


def _check_finite(name: str, points: FloatArray) -> None:
    bad = ~np.isfinite(points).all(axis=1)
    if bad.any():
        raise FileFormatError(name, f"non-finite coordinates in {int(bad.sum())} point(s), the first is point "
                              f"{int(np.argmax(bad))} (from 0)")


def read_e57(file: str | Path) -> FloatArray:
    """Points ``(N, 3)`` in mm of every scan of an E57 file, in the file's frame (see the module).

    The file is untrusted: its header, the checksums of its header and XML pages and its XML
    section (no DTD, no entity, bounded depth and size) are checked by
    :func:`pcmm_geo.io._e57.check_e57` before libE57Format sees the file.

    Raises
    ------
    UnsafeXmlError
        The XML section has a DTD, an entity or an external reference, or is too deep or large.
    FileFormatError
        A damaged header or checksum, a file that cannot be read as E57, no valid point, or a
        non-finite coordinate.
    MissingDependencyError
        pye57, defusedxml or google-crc32c is not installed (extra ``e57``).
    """
    from pcmm_geo.io._e57 import check_e57

    pye57 = require("pye57")
    path = Path(file)
    if not path.exists():
        raise FileNotFoundError(str(path))
    check_e57(path)
    try:
        e57 = pye57.E57(str(path))
        scans = [e57.read_scan(k, transform=True, ignore_missing_fields=True) for k in range(e57.scan_count)]
    except Exception as exc:  # libE57Format's own exception types; one typed error naming the file
        first = next((line for line in str(exc).splitlines() if line.strip()), "")  # not libE57's debug trace
        raise FileFormatError(str(path), f"not a readable E57 file: {type(exc).__name__}: {first}") from None
    total = sum(len(scan["cartesianX"]) for scan in scans)
    if total == 0:
        raise FileFormatError(str(path), "no valid points in the E57 file")
    points = np.empty((total, 3), dtype=np.float64)
    row = 0
    for scan in scans:
        n = len(scan["cartesianX"])
        for column, axis in enumerate("XYZ"):
            points[row:row + n, column] = scan.pop(f"cartesian{axis}")
        row += n
    points *= 1000.0  # E57 stores metres (ASTM E2807)
    _check_finite(str(path), points)
    return points
