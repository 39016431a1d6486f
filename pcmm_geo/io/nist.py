"""NIST least-squares reference pairs: a point data set plus NIST's reference fit.

NIST's dimensional-metrology "algorithm testing" reference pairs consist of a data file
(``NAME.ds``; the same format also appears as ``NAME.txt``) and a fit file (``NAME.fit``)
in a folder named after the element type (``Line2d``, ``Line3d``, ``Plane``, ``Circle2d``,
``Circle3d``, ``Sphere``, ``Cylinder``, ``Cone``).

Data file
    First line: the number of points N.  Then N lines ``x y z`` (any white space).
Fit file
    One number per line; lengths in the data units (mm), angles in degrees:

    ===========  =====  ================================================================
    element      count  meaning
    ===========  =====  ================================================================
    line         6      point on the line, direction cosines
    plane        6      point on the plane, direction cosines of the normal
    circle       7      centre, direction cosines of the plane normal, diameter
    sphere       4      centre, diameter
    cylinder     7      point on the axis, axis direction cosines, diameter
    cone         8      point on the axis, axis direction (towards growing radius),
                        perpendicular distance ``s`` from that point to the surface,
                        full apex angle in degrees
    ===========  =====  ================================================================

For the cone, with half angle ``alpha = apex_angle / 2`` the radius at the reported point
is ``r = s / cos(alpha)`` and the apex lies at ``point - r / tan(alpha) * axis``.
NIST fits 3-D circles as "plane first, then a 2-D circle of the projected points".

This module only reads files (io layer: it imports nothing from :mod:`pcmm_geo.fit`).

Examples
--------
>>> from pathlib import Path
>>> import tempfile
>>> folder = Path(tempfile.mkdtemp()) / "Sphere"
>>> folder.mkdir()
>>> _ = (folder / "s1.ds").write_text("4\\n1 0 0\\n-1 0 0\\n0 1 0\\n0 0 1\\n")
>>> _ = (folder / "s1.fit").write_text("0\\n0\\n0\\n2\\n")
>>> pair = read_nist_pair(folder / "s1.ds")
>>> pair.element, pair.points.shape, pair.parameters["radius"]
('sphere', (4, 3), 1.0)
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import FileFormatError, InvalidInputError
from pcmm_geo.io._text import excerpt, parse_decimal

__all__ = ["NIST_ELEMENTS", "NistPair", "iter_nist_pairs", "read_nist_fit", "read_nist_pair", "read_nist_points"]

FloatArray = NDArray[np.float64]

#: folder name -> (pcmm_geo element name, number of values in the ``.fit`` file)
NIST_ELEMENTS: dict[str, tuple[str, int]] = {
    "Line2d": ("line2d", 6),
    "Line3d": ("line3d", 6),
    "Line": ("line3d", 6),
    "Plane": ("plane", 6),
    "Circle2d": ("circle2d", 7),
    "Circle3d": ("circle3d", 7),
    "Sphere": ("sphere", 4),
    "Cylinder": ("cylinder", 7),
    "Cone": ("cone", 8),
}

_DATA_SUFFIXES = (".ds", ".txt")


@record
class NistPair:
    """One NIST reference pair.

    Attributes
    ----------
    name : str
        File stem, e.g. ``"cyl21"``.
    element : str
        ``"line2d"``, ``"line3d"``, ``"plane"``, ``"circle2d"``, ``"circle3d"``,
        ``"sphere"``, ``"cylinder"`` or ``"cone"`` (from the folder name).
    points : ndarray, shape (N, 3)
        The data points, mm.  2-D elements keep all three coordinates (one is constant).
    parameters : dict
        NIST's reference element under pcmm_geo's contract names (vectors as ``(3,)``
        arrays, lengths in mm, angles in radians):

        - line2d/line3d: ``point``, ``direction``
        - plane: ``point``, ``normal``
        - circle2d/circle3d: ``center``, ``normal``, ``radius``, ``diameter``
        - sphere: ``center``, ``radius``, ``diameter``
        - cylinder: ``point``, ``axis``, ``radius``, ``diameter``
        - cone: ``point``, ``axis`` (towards growing radius), ``s`` (perpendicular distance
          of ``point`` from the surface), ``apex_angle_deg`` (full angle, degrees),
          ``half_angle`` (radians), ``radius_at_point`` (``s / cos(half_angle)``), ``apex``.
    raw_fit : ndarray, shape (K,)
        The numbers of the ``.fit`` file as read.
    data_path, fit_path : pathlib.Path
        The two files.
    """

    name: str
    element: str
    points: FloatArray
    parameters: dict[str, Any]
    raw_fit: FloatArray
    data_path: Path
    fit_path: Path

    @property
    def constant_axis(self) -> int | None:
        """Index (0, 1, 2) of the coordinate that is the same for every point, or None.

        NIST writes 2-D data in three coordinates, one of them constant; drop that column
        to fit in 2-D.
        """
        spread = np.ptp(self.points, axis=0)
        constant = np.flatnonzero(spread == 0.0)
        return int(constant[0]) if constant.size else None


def _number(text: str, path: Path, line: int) -> float:
    try:
        value = parse_decimal(text)
    except ValueError:
        raise FileFormatError(str(path), f"expected a number, got {excerpt(text)}", line) from None
    if not math.isfinite(value):
        raise FileFormatError(str(path), f"expected a finite number, got {excerpt(text)}", line)
    return value


def read_nist_points(path: str | Path) -> FloatArray:
    """Read a NIST data file (``.ds`` / ``.txt``): the count N, then N lines ``x y z``.

    Parameters
    ----------
    path : str or Path
        The data file.

    Returns
    -------
    ndarray, shape (N, 3)
        Points, mm.

    Raises
    ------
    FileFormatError
        Missing or wrong count, a line without exactly three numbers, extra lines.
    OSError
        The file cannot be read.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.ds"
    >>> _ = p.write_text("2\\n1\\t2\\t3\\n4 5 6\\n")
    >>> read_nist_points(p).tolist()
    [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]
    """
    from pcmm_geo.io._text import read_text_lines

    path = Path(path)
    lines = [text for _, text in read_text_lines(path)]
    if not lines or not lines[0].strip():
        raise FileFormatError(str(path), "expected the number of points on the first line, got an empty line", 1)
    head = lines[0].split()
    if len(head) != 1 or not re.fullmatch(r"[0-9]{1,12}", head[0]):
        raise FileFormatError(str(path), f"expected the number of points on the first line, got {excerpt(lines[0])}", 1)
    count = int(head[0])
    body = [(number, text) for number, text in enumerate(lines[1:], start=2) if text.strip()]
    if len(body) != count:
        raise FileFormatError(str(path), f"expected {count} point lines (from line 1), got {len(body)}")
    points = np.empty((count, 3))
    for row, (number, text) in enumerate(body):
        fields = text.split()
        if len(fields) != 3:
            raise FileFormatError(str(path), f"expected 3 coordinates, got {len(fields)}: {excerpt(text)}", number)
        points[row] = [_number(value, path, number) for value in fields]
    return points


def read_nist_fit(path: str | Path, expected_count: int | None = None) -> FloatArray:
    """Read a NIST ``.fit`` file: one number per line.

    Parameters
    ----------
    path : str or Path
        The fit file.
    expected_count : int, optional
        Number of values the element needs (see the module table); checked if given.

    Returns
    -------
    ndarray, shape (K,)

    Raises
    ------
    FileFormatError
        A line that is not exactly one number, or the wrong count.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.fit"
    >>> _ = p.write_text("1.5\\n0\\n")
    >>> read_nist_fit(p).tolist()
    [1.5, 0.0]
    """
    path = Path(path)
    values: list[float] = []
    from pcmm_geo.io._text import read_text_lines

    for number, text in read_text_lines(path):
        if not text.strip():
            continue
        fields = text.split()
        if len(fields) != 1:
            raise FileFormatError(str(path), f"expected one number per line, got {excerpt(text)}", number)
        values.append(_number(fields[0], path, number))
    if expected_count is not None and len(values) != expected_count:
        raise FileFormatError(str(path), f"expected {expected_count} values, got {len(values)}")
    return np.array(values)


def _unit_direction(values: FloatArray, path: Path, what: str) -> FloatArray:
    norm = float(np.linalg.norm(values))
    if abs(norm - 1.0) > 1e-6:
        raise FileFormatError(str(path), f"expected unit direction cosines for the {what}, got length {norm:.9g}")
    return values / norm


def _parameters(element: str, raw: FloatArray, path: Path) -> dict[str, Any]:
    point = raw[0:3].copy()
    if element in ("line2d", "line3d"):
        return {"point": point, "direction": _unit_direction(raw[3:6], path, "line")}
    if element == "plane":
        return {"point": point, "normal": _unit_direction(raw[3:6], path, "plane normal")}
    if element == "sphere":
        return {"center": point, "radius": float(raw[3]) / 2.0, "diameter": float(raw[3])}
    if element in ("circle2d", "circle3d"):
        normal = _unit_direction(raw[3:6], path, "circle normal")
        return {"center": point, "normal": normal, "radius": float(raw[6]) / 2.0, "diameter": float(raw[6])}
    if element == "cylinder":
        axis = _unit_direction(raw[3:6], path, "cylinder axis")
        return {"point": point, "axis": axis, "radius": float(raw[6]) / 2.0, "diameter": float(raw[6])}
    # cone
    axis = _unit_direction(raw[3:6], path, "cone axis")
    s_distance, apex_angle_deg = float(raw[6]), float(raw[7])
    if not 0.0 < apex_angle_deg < 180.0:
        raise FileFormatError(str(path), f"expected a full apex angle in (0, 180) degrees, got {apex_angle_deg}")
    half_angle = math.radians(apex_angle_deg) / 2.0
    radius_at_point = s_distance / math.cos(half_angle)
    return {
        "point": point,
        "axis": axis,
        "s": s_distance,
        "apex_angle_deg": apex_angle_deg,
        "half_angle": half_angle,
        "radius_at_point": radius_at_point,
        "apex": point - radius_at_point / math.tan(half_angle) * axis,
    }


def read_nist_pair(data_path: str | Path) -> NistPair:
    """Read one NIST reference pair from its data file (the ``.fit`` sits next to it).

    Parameters
    ----------
    data_path : str or Path
        ``<Type>/<name>.ds`` (or ``.txt``); ``<Type>`` is one of the keys of
        :data:`NIST_ELEMENTS` and gives the element.

    Returns
    -------
    NistPair

    Raises
    ------
    InvalidInputError
        The folder name is not a NIST element type.
    FileFormatError
        Either file does not follow the format (message names path and line).
    FileNotFoundError
        The data file or its ``.fit`` is missing.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp()) / "Plane"
    >>> folder.mkdir()
    >>> _ = (folder / "p.ds").write_text("3\\n0 0 0\\n1 0 0\\n0 1 0\\n")
    >>> _ = (folder / "p.fit").write_text("0.3\\n0.3\\n0\\n0\\n0\\n1\\n")
    >>> read_nist_pair(folder / "p.ds").parameters["normal"].tolist()
    [0.0, 0.0, 1.0]
    """
    data_path = Path(data_path)
    folder = data_path.parent.name
    if folder not in NIST_ELEMENTS:
        raise InvalidInputError(
            "data_path", f"a file in a folder named one of {sorted(NIST_ELEMENTS)}", f"folder {folder!r}"
        )
    element, count = NIST_ELEMENTS[folder]
    fit_path = data_path.with_suffix(".fit")
    if not fit_path.is_file():
        raise FileNotFoundError(f"{fit_path}: reference fit of {data_path.name} not found")
    points = read_nist_points(data_path)
    raw = read_nist_fit(fit_path, count)
    return NistPair(
        name=data_path.stem,
        element=element,
        points=points,
        parameters=_parameters(element, raw, fit_path),
        raw_fit=raw,
        data_path=data_path,
        fit_path=fit_path,
    )


def iter_nist_pairs(folder: str | Path) -> Iterator[NistPair]:
    """Yield every complete pair below ``folder`` (recursively), sorted by path.

    A data file (``.ds``/``.txt``) counts when a ``.fit`` of the same stem sits next to it
    and its folder is a NIST element type; other files are ignored.

    Parameters
    ----------
    folder : str or Path
        E.g. ``tests/data/nist`` (finds ``Sphere/sph11.ds`` and
        ``extra-from-points-txt/Sphere/sph3.txt`` alike).

    Raises
    ------
    FileNotFoundError
        ``folder`` is not a directory.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> (root / "Sphere").mkdir()
    >>> _ = (root / "Sphere" / "s.ds").write_text("4\\n1 0 0\\n-1 0 0\\n0 1 0\\n0 0 1\\n")
    >>> _ = (root / "Sphere" / "s.fit").write_text("0\\n0\\n0\\n2\\n")
    >>> [pair.name for pair in iter_nist_pairs(root)]
    ['s']
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise FileNotFoundError(f"{folder}: not a directory")
    for path in sorted(folder.rglob("*")):
        if path.suffix in _DATA_SUFFIXES and path.parent.name in NIST_ELEMENTS and path.with_suffix(".fit").is_file():
            yield read_nist_pair(path)
