"""Labelled point files: one point per row with a name (``name,x,y,z``), the labels kept.

A labelled file is a text table (comma, semicolon, tab or spaces) whose header names the
``x``, ``y`` and ``z`` columns and exactly one label column, named ``name``, ``label``,
``face``, ``feature``, ``point`` or ``id`` (any other single non-coordinate column also
counts).  Without a header, a row of one non-numeric field followed by three numbers is read
as ``name,x,y,z``.  ``#`` lines are comments.  Anything else is refused, never guessed.

:func:`read_labelled_points` returns a :class:`LabelledPoints` (points, labels and the file
line of each point); plain ``x,y,z`` files are read by :func:`pcmm_geo.io.read_points`.

Examples
--------
>>> import tempfile, pathlib
>>> path = pathlib.Path(tempfile.mkdtemp()) / "probed.csv"
>>> _ = path.write_text("name,x,y,z\\nP1,0,0,0\\nP2,1,0,0\\nP1,0,1,0\\n")
>>> found = read_labelled_points(path)
>>> found.labels, found.points.shape
(('P1', 'P2', 'P1'), (3, 3))
>>> found.groups()["P1"].tolist()
[[0.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import FileFormatError
from pcmm_geo.io._text import excerpt, iter_text_lines, parse_decimal

__all__ = ["LABEL_COLUMNS", "LabelledPoints", "read_labelled_points"]

FloatArray = NDArray[np.float64]

#: header names recognised as the label column
LABEL_COLUMNS = ("name", "label", "face", "feature", "point", "id")
_DELIMITED = re.compile(r"[,;\t]")


@record
class LabelledPoints:
    """Points with one label each, in file order.

    Attributes
    ----------
    points : ndarray, shape (N, 3)
        Coordinates (mm).
    labels : tuple of str
        Label of each point (stripped of spaces and quotes).
    lines : tuple of int
        Line of the file each point came from (1-based), for messages.
    source : str
        The file.
    """

    points: FloatArray
    labels: tuple[str, ...]
    lines: tuple[int, ...]
    source: str

    def __len__(self) -> int:
        return len(self.labels)

    def groups(self) -> dict[str, FloatArray]:
        """Points by label ``{label: (M, 3)}``, labels in order of first appearance."""
        order = list(dict.fromkeys(self.labels))
        labels = np.asarray(self.labels, dtype=object)
        return {label: self.points[labels == label] for label in order}

    def __repr__(self) -> str:
        kinds = list(dict.fromkeys(self.labels))
        shown = ", ".join(kinds[:5]) + (", ..." if len(kinds) > 5 else "")
        return f"LabelledPoints(n={len(self)}, labels={len(kinds)} distinct [{shown}], source={self.source!r})"


def _fields(text: str) -> list[str]:
    """Fields split at commas, semicolons or tabs when the line has any (labels may hold spaces), else spaces."""
    parts = _DELIMITED.split(text) if _DELIMITED.search(text) else text.split()
    return [f.strip().strip('"').strip("'") for f in parts]


def _is_number(text: str) -> bool:
    try:
        parse_decimal(text)
    except ValueError:
        return False
    return True


def _header_columns(file: Path, names: list[str], line: int) -> tuple[int, tuple[int, int, int]]:
    lowered = [n.lower() for n in names]
    missing = [axis for axis in ("x", "y", "z") if axis not in lowered]
    if missing:
        raise FileFormatError(
            str(file), f"expected a header with x, y, z and a label column, got "
            f"{excerpt(','.join(names))} (missing {', '.join(missing)})",
            line,
        )
    others = [k for k, n in enumerate(lowered) if n not in ("x", "y", "z")]
    named = [k for k in others if lowered[k] in LABEL_COLUMNS]
    if len(named) == 1:
        label = named[0]
    elif len(named) == 0 and len(others) == 1:
        label = others[0]
    else:
        raise FileFormatError(
            str(file), f"expected exactly one label column ({', '.join(LABEL_COLUMNS)}), got columns "
            f"{excerpt(','.join(names))}", line
        )
    return label, (lowered.index("x"), lowered.index("y"), lowered.index("z"))


def read_labelled_points(path: str | Path) -> LabelledPoints:
    """Read a labelled point file (``name,x,y,z``; see the module docstring), labels kept.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    LabelledPoints

    Raises
    ------
    FileFormatError
        No label column or several candidates, rows of the wrong width, non-numeric or
        non-finite coordinates, an empty label, or no points; the message names the line.
    OSError
        The file cannot be read.
    """
    file = Path(path)
    label_column: int | None = None
    xyz: tuple[int, int, int] = (1, 2, 3)
    width: int | None = None
    points: list[list[float]] = []
    labels: list[str] = []
    lines: list[int] = []
    for number, raw in iter_text_lines(file):  # a wrong header stops the reading there
        text = raw.strip()
        if not text or text.startswith("#"):
            continue
        if text.count('"') % 2:
            raise FileFormatError(str(file), f"unbalanced double quote in {excerpt(text)}", number)
        fields = _fields(text)
        if label_column is None:
            if sum(_is_number(f) for f in fields) < 3:  # the header
                label_column, xyz = _header_columns(file, fields, number)
                width = len(fields)
                continue
            if len(fields) != 4 or _is_number(fields[0]):
                raise FileFormatError(
                    str(file), f"expected a header, or rows 'name,x,y,z' with a non-numeric name, got {excerpt(text)}",
                    number,
                )
            label_column, width = 0, 4
        if len(fields) != width:
            raise FileFormatError(str(file), f"expected {width} fields, got {len(fields)}: {excerpt(text)}", number)
        try:
            point = [parse_decimal(fields[k]) for k in xyz]
        except ValueError:
            raise FileFormatError(str(file), f"expected numbers for x, y, z, got {excerpt(text)}", number) from None
        if not all(np.isfinite(point)):
            raise FileFormatError(str(file), f"expected finite coordinates, got {excerpt(text)}", number)
        if not fields[label_column]:
            raise FileFormatError(str(file), "expected a label, got an empty field", number)
        points.append(point)
        labels.append(fields[label_column])
        lines.append(number)
    if not points:
        raise FileFormatError(str(file), "no points in the file")
    return LabelledPoints(np.asarray(points, dtype=float), tuple(labels), tuple(lines), str(file))
