"""Reading and writing the external-CMM calibration data (thesis 7.1, DESIGN.md "File formats").

Three CSV formats:

* **raw probings** -- header ``feature,position,x,y,z``; ``feature`` is one of
  ``joint_a``, ``joint_b``, ``joint_c``, ``tip``; ``position`` is the integer slider
  position index (empty for ``tip``); ``x, y, z`` in mm.  One row per probed point;
  every (feature, position) group is fitted with a Gaussian sphere.
* **element-level export** (what the seed's CMM₁ returned, Appendix C ``CMM.csv``) --
  five numbers per row ``x,y,z,d,r`` (center, diameter, roundness, mm), with or
  without that header line.  Rows are assigned as in Appendix C: rows ``3k+1, 3k+2,
  3k+3`` are the joints ``a, b, c`` at slider position ``k+1`` and the **last** row is
  the probe tip, so a file holds ``3K + 1`` rows for K positions.  ``d`` and ``r`` may be
  ``nan`` or empty when unknown.
* **laser readings** -- header ``position,laser_a,laser_b,laser_c`` (mm), one row per
  slider position.

A QIF 3.0 results file of the probed balls is read by :meth:`ProbedFeatures.from_qif`
(:mod:`pcmm_geo.machine.calibration.qif_probings`).

Blank lines and lines starting with ``#`` are ignored.  Any other deviation raises
:class:`~pcmm_geo.errors.FileFormatError` naming the file and the 1-based line.

Examples
--------
>>> import tempfile, pathlib
>>> folder = pathlib.Path(tempfile.mkdtemp())
>>> _ = (folder / "lasers.csv").write_text("position,laser_a,laser_b,laser_c\\n1,50.8,136.5,139.0\\n")
>>> table = read_lasers(folder / "lasers.csv")
>>> table.positions, table.readings.tolist()
((1,), [[50.8, 136.5, 139.0]])
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._atomic import write_atomic
from pcmm_geo._deprecation import renamed_fields, renamed_parameters
from pcmm_geo._records import record
from pcmm_geo.errors import FileFormatError, PcmmGeoError
from pcmm_geo.io.text import excerpt, parse_decimal
from pcmm_geo.machine.calibration.geometry import FittedSphere, fit_probed_sphere
from pcmm_geo.machine.calibration.inputs import check_readings, points_by_role, read_qif_balls

__all__ = [
    "ARMS",
    "LaserTable",
    "ProbedFeatures",
    "probed_features_from_points",
    "read_lasers",
    "read_probings",
    "write_element_export",
    "write_lasers_csv",
    "write_probings_csv",
]

FloatArray = NDArray[np.float64]
ARMS: tuple[str, str, str] = ("a", "b", "c")
RAW_HEADER = ("feature", "position", "x", "y", "z")
EXPORT_HEADER = ("x", "y", "z", "d", "r")
LASER_HEADER = ("position", "laser_a", "laser_b", "laser_c")
FEATURES = ("joint_a", "joint_b", "joint_c", "tip")


@renamed_fields(centres="centers")
@record
class ProbedFeatures:
    """Spheres measured by the external CMM: joints per arm and slider position, and the tip.

    Attributes
    ----------
    joints : dict
        ``joints[arm][position]`` -> :class:`FittedSphere` for arms ``'a', 'b', 'c'``.
        Every arm has the same set of positions.
    tip : FittedSphere
        The probe tip.
    points : dict
        Raw probed points ``{(feature, position): (N, 3)}`` (position ``None`` for the tip);
        empty for element-level data.
    source : str
        File name or ``"<arrays>"``.
    """

    joints: Mapping[str, Mapping[int, FittedSphere]]
    tip: FittedSphere
    points: Mapping[tuple[str, int | None], FloatArray]
    source: str

    @property
    def positions(self) -> tuple[int, ...]:
        """Sorted slider position indices."""
        return tuple(sorted(self.joints["a"]))

    def centers(self) -> FloatArray:
        """Joint centers, shape (K, 3, 3): position, arm (a, b, c), xyz (mm)."""
        return np.array([[self.joints[arm][pos].center for arm in ARMS] for pos in self.positions])

    @classmethod
    def from_csv(cls, path: str | Path) -> ProbedFeatures:
        """Read a probings CSV: raw ``feature,position,x,y,z`` or the ``x,y,z,d,r`` export (:func:`read_probings`)."""
        return read_probings(path)

    @classmethod
    def from_qif(cls, path: str | Path, *, feature_map: Mapping[str, tuple[str, int | None]] | str | Path | None = None,
                 max_bytes: int | None = None) -> ProbedFeatures:
        """Read the balls from a QIF 3.0 results file: sphere features ``joint_a_1`` ... ``joint_c_K``, ``tip``
        (or named by ``feature_map``), refitted where the file has their points
        (:func:`~pcmm_geo.machine.calibration.inputs.read_qif_balls`; what was refitted, reported
        and ignored: :func:`~pcmm_geo.machine.calibration.qif_probings.read_qif_probings`)."""
        balls = read_qif_balls(path, feature_map=feature_map, max_bytes=max_bytes)
        return _assemble(balls.spheres, balls.points, balls.source)

    @classmethod
    def from_points(cls, points: Mapping[Any, Any]) -> ProbedFeatures:
        """Fit the balls to arrays (mm): ``{"joint_a": [(N, 3) per position] or {position: (N, 3)}, ...,
        "tip": (N, 3)}``, or ``{(feature, position): (N, 3)}`` (:func:`probed_features_from_points`)."""
        return probed_features_from_points(points_by_role(points))


@record
class LaserTable:
    """Laser readings per slider position: ``positions`` (K,) and ``readings`` (K, 3) mm, arms a, b, c."""

    positions: tuple[int, ...]
    readings: FloatArray
    source: str = "<arrays>"

    @classmethod
    def from_csv(cls, path: str | Path) -> LaserTable:
        """Read ``position,laser_a,laser_b,laser_c`` (:func:`read_lasers`)."""
        return read_lasers(path)

    @classmethod
    def from_readings(cls, readings: Any, positions: tuple[int, ...] | None = None) -> LaserTable:
        """Readings (K, 3) in the order of ``positions`` (default 1 ... K), or ``{position: (3,)}``."""
        if isinstance(readings, Mapping):
            keys = tuple(int(k) for k in readings)
            values = np.array([np.asarray(readings[k], dtype=float) for k in readings])
            return cls(keys, check_readings(values, len(keys), "lasers"))
        values = check_readings(readings, None if positions is None else len(positions), "lasers")
        return cls(tuple(range(1, len(values) + 1)) if positions is None else tuple(positions), values)

    def at(self, positions: tuple[int, ...]) -> FloatArray:
        """Readings (K, 3) in the order of ``positions``.

        Raises
        ------
        CalibrationError
            A position has no laser reading.
        """
        from pcmm_geo.errors import CalibrationError

        index = {pos: k for k, pos in enumerate(self.positions)}
        missing = [pos for pos in positions if pos not in index]
        if missing:
            raise CalibrationError(
                f"{self.source}: expected laser readings for slider positions {list(positions)}, "
                f"got none for {missing}",
                missing=missing,
            )
        return self.readings[[index[pos] for pos in positions]]


def _data_lines(path: Path, check_header: Callable[[int, list[str]], None]) -> list[tuple[int, list[str]]]:
    """Rows (fields stripped) without blank and ``#`` lines; ``check_header`` sees the first row before the rest."""
    from pcmm_geo.io.text import read_csv_rows

    table = read_csv_rows(path, check_header=lambda line, cells: check_header(line, [c.strip() for c in cells]))
    if not table.rows:
        raise FileFormatError(str(path), "expected a header and data rows, got an empty file")
    return [(number, [field.strip() for field in cells]) for number, cells in table.rows]


def _integer(text: str) -> int:
    """An ASCII integer (``int`` would also take ``1_0`` or non-ASCII digits); ValueError otherwise."""
    if not re.fullmatch(r"[+-]?[0-9]{1,18}", text.strip()):
        raise ValueError(text)
    return int(text)


def _number(text: str, path: Path, line: int, column: str, *, allow_missing: bool = False) -> float:
    if allow_missing and text.lower() in ("", "nan"):
        return math.nan
    try:
        value = parse_decimal(text)
    except ValueError:
        raise FileFormatError(str(path), f"column {column}: expected a number, got {excerpt(text)}", line) from None
    if not math.isfinite(value):
        raise FileFormatError(str(path), f"column {column}: expected a finite number, got {excerpt(text)}", line)
    return value


def read_probings(path: str | Path) -> ProbedFeatures:
    """Read external-CMM probings: raw points (``feature,position,x,y,z``) or the element export (``x,y,z,d,r``).

    Parameters
    ----------
    path : str or Path
        CSV file in one of the two formats described in the module docstring.

    Returns
    -------
    ProbedFeatures
        Raw points are fitted with Gaussian spheres (radius and form reported).

    Raises
    ------
    FileFormatError
        Unknown header, wrong field count, non-numeric value, unknown feature, bad position,
        missing tip, arms probed at different positions, or a group that cannot be fitted
        (fewer than 4 points, coplanar points), each with path and line.
    OSError
        File cannot be read.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> file = pathlib.Path(tempfile.mkdtemp()) / "cmm.csv"
    >>> rows = ["0,0,10,6,0.001", "10,0,10,6,0", "0,10,10,6,0", "0,0,0,6,0", "9,1,0,6,0", "1,9,0,6,0", "3,3,-400,2,0"]
    >>> _ = file.write_text("x,y,z,d,r\\n" + "\\n".join(rows) + "\\n")
    >>> features = read_probings(file)
    >>> features.positions, features.tip.center.tolist(), features.joints["a"][1].radius
    ((1, 2), [3.0, 3.0, -400.0], 3.0)
    """
    file = Path(path)

    def check_header(line: int, first: list[str]) -> None:  # before the rest of the file is read
        _probings_layout(file, line, first)

    rows = _data_lines(file, check_header)
    kind = _probings_layout(file, *rows[0])
    if kind == "raw":
        return _read_raw(file, rows[1:])
    return _read_export(file, rows if kind == "headerless" else rows[1:])


def _probings_layout(file: Path, line: int, first: list[str]) -> str:
    """``"raw"``, ``"export"`` or ``"headerless"`` (an export without header) from the first row; else refused."""
    header = tuple(field.lower() for field in first)
    if header == RAW_HEADER:
        return "raw"
    if header == EXPORT_HEADER:
        return "export"
    if len(first) == 5:
        try:
            [parse_decimal(field) for field in first[:3]]
        except ValueError:
            pass
        else:
            return "headerless"
    raise FileFormatError(
        str(file),
        f"expected header {','.join(RAW_HEADER)!r} or {','.join(EXPORT_HEADER)!r} (or 5 numbers per row), "
        f"got {excerpt(','.join(first))}",
        line,
    )


def _read_raw(file: Path, rows: list[tuple[int, list[str]]]) -> ProbedFeatures:
    groups: dict[tuple[str, int | None], list[list[float]]] = {}
    first_line: dict[tuple[str, int | None], int] = {}
    for line, fields in rows:
        if len(fields) != 5:
            raise FileFormatError(str(file), f"expected 5 fields (feature,position,x,y,z), got {len(fields)}", line)
        feature = fields[0].lower()
        if feature not in FEATURES:
            expected = ", ".join(FEATURES)
            raise FileFormatError(str(file), f"feature: expected one of {expected}, got {excerpt(fields[0])}", line)
        position: int | None
        if feature == "tip":
            if fields[1] != "":
                raise FileFormatError(str(file), f"position: expected empty for the tip, got {excerpt(fields[1])}",
                                      line)
            position = None
        else:
            try:
                position = _integer(fields[1])
            except ValueError:
                raise FileFormatError(
                    str(file), f"position: expected an integer slider position, got {excerpt(fields[1])}", line
                ) from None
        xyz = [_number(fields[k], file, line, name) for k, name in zip((2, 3, 4), "xyz", strict=True)]
        key = (feature, position)
        groups.setdefault(key, []).append(xyz)
        first_line.setdefault(key, line)
    points = {key: np.array(values) for key, values in groups.items()}
    return probed_features_from_points(points, source=str(file), lines=first_line)


def probed_features_from_points(
    points: Mapping[tuple[str, int | None], object],
    *,
    source: str = "<arrays>",
    lines: Mapping[tuple[str, int | None], int] | None = None,
) -> ProbedFeatures:
    """Fit a sphere to every ``(feature, position)`` group of probed points.

    Parameters
    ----------
    points : mapping
        ``{("joint_a", 1): (N, 3), ..., ("tip", None): (N, 3)}``, mm.
    source : str
        Name used in error messages.
    lines : mapping, optional
        First line of each group in the source file (for error messages).

    Returns
    -------
    ProbedFeatures

    Raises
    ------
    FileFormatError
        A group cannot be fitted, the tip is missing or the arms were probed at different
        positions, when ``source`` names a file.
    CalibrationError
        The same problems for in-memory data (``source="<arrays>"``).

    Examples
    --------
    >>> import numpy as np
    >>> ball = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1.0]])
    >>> data = {(f"joint_{arm}", pos): ball + 10 * pos * k for k, arm in enumerate("abc", 1) for pos in (1, 2)}
    >>> data[("tip", None)] = ball * 2
    >>> features = probed_features_from_points(data)
    >>> features.positions, float(features.tip.radius), features.joints["b"][2].center.tolist()
    ((1, 2), 2.0, [40.0, 40.0, 40.0])
    """
    fitted: dict[tuple[str, int | None], FittedSphere] = {}
    arrays: dict[tuple[str, int | None], FloatArray] = {}
    for key, value in points.items():
        feature, position = key
        label = feature if position is None else f"{feature} position {position}"
        try:
            arrays[key] = np.asarray(value, dtype=float)
            fitted[key] = fit_probed_sphere(arrays[key], what=label)
        except (PcmmGeoError, ValueError, TypeError) as exc:
            line = None if lines is None else lines.get(key)
            raise _fail(source, f"{label}: cannot fit a sphere: {exc}", line) from None
    return _assemble(fitted, arrays, source)


def _assemble(
    fitted: Mapping[tuple[str, int | None], FittedSphere],
    arrays: Mapping[tuple[str, int | None], FloatArray],
    source: str,
) -> ProbedFeatures:
    tip = fitted.get(("tip", None))
    if tip is None:
        raise _fail(source, "expected probings of feature 'tip', got none")
    joints: dict[str, dict[int, FittedSphere]] = {arm: {} for arm in ARMS}
    for (feature, position), sphere in fitted.items():
        if feature != "tip" and position is not None:
            joints[feature[-1]][position] = sphere
    position_sets = {arm: sorted(joints[arm]) for arm in ARMS}
    if len({tuple(v) for v in position_sets.values()}) != 1:
        raise _fail(source, f"expected every joint probed at the same slider positions, got {position_sets}")
    if len(position_sets["a"]) < 2:
        raise _fail(source, f"expected joints probed at >= 2 slider positions, got {len(position_sets['a'])}")
    return ProbedFeatures(joints=joints, tip=tip, points=dict(arrays), source=source)


def _read_export(file: Path, rows: list[tuple[int, list[str]]]) -> ProbedFeatures:
    spheres = []
    for line, fields in rows:
        if len(fields) != 5:
            raise FileFormatError(str(file), f"expected 5 fields (x,y,z,d,r), got {len(fields)}", line)
        x, y, z = (_number(fields[k], file, line, name) for k, name in zip(range(3), "xyz", strict=True))
        diameter = _number(fields[3], file, line, "d", allow_missing=True)
        roundness = _number(fields[4], file, line, "r", allow_missing=True)
        spheres.append(FittedSphere(np.array([x, y, z]), 0.5 * diameter, roundness, 0))
    if len(spheres) < 7 or (len(spheres) - 1) % 3 != 0:
        raise FileFormatError(
            str(file), f"expected 3K + 1 sphere rows (K >= 2 positions of joints a, b, c, then the tip), "
            f"got {len(spheres)} rows"
        )
    fitted: dict[tuple[str, int | None], FittedSphere] = {("tip", None): spheres[-1]}
    for index, sphere in enumerate(spheres[:-1]):
        fitted[(f"joint_{ARMS[index % 3]}", index // 3 + 1)] = sphere
    return _assemble(fitted, {}, str(file))


def read_lasers(path: str | Path) -> LaserTable:
    """Read laser readings per slider position (``position,laser_a,laser_b,laser_c``, mm).

    Raises
    ------
    FileFormatError
        Wrong header, field count, non-numeric or duplicate position, no rows.

    Examples
    --------
    See the module docstring.
    """
    file = Path(path)

    def check_header(line: int, header: list[str]) -> None:  # before the rest of the file is read
        if tuple(field.lower() for field in header) != LASER_HEADER:
            raise FileFormatError(str(file), f"expected header {','.join(LASER_HEADER)!r}, got "
                                  f"{excerpt(','.join(header))}", line)

    rows = _data_lines(file, check_header)
    positions: list[int] = []
    readings: list[list[float]] = []
    for line, fields in rows[1:]:
        if len(fields) != 4:
            raise FileFormatError(str(file), f"expected 4 fields (position,laser_a,laser_b,laser_c), got {len(fields)}",
                                  line)
        try:
            position = _integer(fields[0])
        except ValueError:
            raise FileFormatError(str(file), f"position: expected an integer, got {excerpt(fields[0])}", line) from None
        if position in positions:
            raise FileFormatError(str(file), f"position: expected each position once, got {position} again", line)
        positions.append(position)
        readings.append([_number(fields[k], file, line, LASER_HEADER[k]) for k in (1, 2, 3)])
    if not positions:
        raise FileFormatError(str(file), "expected at least one row of laser readings, got none")
    return LaserTable(tuple(positions), np.array(readings), source=str(file))


def _fmt(value: object) -> str:
    """Shortest text that reads back as the same float (``repr`` of a Python float)."""
    return repr(float(value))  # type: ignore[arg-type]


def _fail(source: str, reason: str, line: int | None = None) -> PcmmGeoError:
    """A file error for file sources, a calibration error for in-memory data."""
    if source == "<arrays>":
        from pcmm_geo.errors import CalibrationError

        return CalibrationError(reason)
    return FileFormatError(source, reason, line)


def _open_new(path: str | Path, overwrite: bool) -> Path:
    from pcmm_geo.errors import InvalidInputError, OutputExistsError

    file = Path(path)
    if file.exists() and not overwrite:
        raise OutputExistsError(str(file))
    if file.exists() and file.is_dir():
        raise InvalidInputError("path", "a file path", f"the directory {file}")
    return file


def write_probings_csv(
    path: str | Path, points: Mapping[tuple[str, int | None], object], *, overwrite: bool = False
) -> Path:
    """Write raw probings ``{(feature, position): (N, 3)}`` as ``feature,position,x,y,z`` (full precision).

    Raises
    ------
    OutputExistsError
        ``path`` exists and ``overwrite`` is false.
    """
    file = _open_new(path, overwrite)
    lines = [",".join(RAW_HEADER)]
    for (feature, position), value in points.items():
        for x, y, z in np.asarray(value, dtype=float):
            lines.append(f"{feature},{'' if position is None else position},{_fmt(x)},{_fmt(y)},{_fmt(z)}")
    write_atomic(file, "\n".join(lines) + "\n", overwrite=overwrite)
    return file


@renamed_parameters(centres="centers")
def write_element_export(
    path: str | Path, centers: object, tip: object, *, diameters: object = None, roundness: object = None,
    overwrite: bool = False, header: bool = True,
) -> Path:
    """Write the seed's element-level export: joint centers (K, 3, 3) position-major, then the tip.

    Raises
    ------
    OutputExistsError
        ``path`` exists and ``overwrite`` is false.
    """
    file = _open_new(path, overwrite)
    rows = np.vstack([np.asarray(centers, dtype=float).reshape(-1, 3), np.asarray(tip, dtype=float).reshape(1, 3)])
    count = rows.shape[0]
    diam = np.full(count, np.nan) if diameters is None else np.broadcast_to(np.asarray(diameters, float), (count,))
    rnd = np.full(count, np.nan) if roundness is None else np.broadcast_to(np.asarray(roundness, float), (count,))
    lines = [",".join(EXPORT_HEADER)] if header else []
    for (x, y, z), d, r in zip(rows, diam, rnd, strict=True):
        lines.append(",".join(_fmt(v) for v in (x, y, z, d, r)))
    write_atomic(file, "\n".join(lines) + "\n", overwrite=overwrite)
    return file


def write_lasers_csv(
    path: str | Path, positions: tuple[int, ...] | list[int], readings: object, *, overwrite: bool = False
) -> Path:
    """Write laser readings (K, 3) per position as ``position,laser_a,laser_b,laser_c``.

    Raises
    ------
    OutputExistsError
        ``path`` exists and ``overwrite`` is false.
    """
    file = _open_new(path, overwrite)
    values = np.asarray(readings, dtype=float).reshape(-1, 3)
    lines = [",".join(LASER_HEADER)]
    lines += [f"{pos},{_fmt(a)},{_fmt(b)},{_fmt(c)}" for pos, (a, b, c) in zip(positions, values, strict=True)]
    write_atomic(file, "\n".join(lines) + "\n", overwrite=overwrite)
    return file
