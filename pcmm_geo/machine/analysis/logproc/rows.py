"""Rows of the seed's measurement log (thesis 3.6, Table 3.2): the array type, CSV reader and writer.

Log format (CSV; header as below, or none as the seed's LabVIEW wrote it)::

    start_stop,probe,motor,direction,laser_a,laser_b,laser_c

``start_stop`` is 1 for lasers saved at the start of a motor movement and 0 at its
end; ``probe`` is 1 while the probe touches; ``motor`` (1, 2, 3 = arms a, b, c) is the
motor moved; ``direction`` the last joystick direction (+1 up, -1 down, 0 unknown);
the lasers are raw readings (mm, from the start of the 60 mm range).  ``# key: value``
metadata lines and columns after the seventh (written by :mod:`pcmm_geo.acquisition.acqlog`)
are accepted and ignored.

What the rows mean for the kinematics is in :mod:`pcmm_geo.machine.analysis.logproc`, which also
re-exports every public name of this module.

Examples
--------
>>> log = MeasurementLog([1, 0], [0, 1], [2, 2], [1, 1], [[50.0, 51.0, 52.0], [50.5, 52.0, 52.1]])
>>> len(log), log.probe.tolist()
(2, [0, 1])
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import FileFormatError, InvalidInputError
from pcmm_geo.machine.kinematics.model_parts import as_readings

__all__ = ["LOG_COLUMNS", "MeasurementLog", "read_log", "write_log"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: header of the log CSV (seed Table 3.2)
LOG_COLUMNS: tuple[str, ...] = ("start_stop", "probe", "motor", "direction", "laser_a", "laser_b", "laser_c")


@record
class MeasurementLog:
    """Rows of a Table 3.2 log as arrays (``N`` rows).

    Attributes
    ----------
    start_stop, probe, motor, direction : ndarray of int, shape (N,)
        1 start / 0 stop; 1 contact / 0 free; 1, 2, 3 (arm a, b, c); -1, 0, +1.
    lasers : ndarray, shape (N, 3)
        Raw laser readings a, b, c (mm).
    """

    start_stop: IntArray
    probe: IntArray
    motor: IntArray
    direction: IntArray
    lasers: FloatArray

    def __post_init__(self) -> None:
        lasers = as_readings(self.lasers, "lasers")
        if lasers.ndim != 2:
            raise InvalidInputError("lasers", "shape (N, 3)", f"shape {lasers.shape}")
        count = lasers.shape[0]
        allowed = {"start_stop": (0, 1), "probe": (0, 1), "motor": (1, 2, 3), "direction": (-1, 0, 1)}
        for name, values in allowed.items():
            arr = np.asarray(getattr(self, name))
            if arr.shape != (count,):
                raise InvalidInputError(name, f"shape ({count},)", f"shape {arr.shape}")
            if not np.all(np.isin(arr, values)):
                raise InvalidInputError(name, f"values in {values}", f"{sorted(set(arr.tolist()) - set(values))}")
            object.__setattr__(self, name, arr.astype(np.int64))
        object.__setattr__(self, "lasers", lasers)

    def __len__(self) -> int:
        return int(self.lasers.shape[0])


def read_log(path: str | Path, *, allow_unterminated: bool = False) -> MeasurementLog:
    """Read a Table 3.2 log CSV: with the header :data:`LOG_COLUMNS`, or headerless as the seed wrote it.

    A file whose first row is seven numbers is read as the seed's LabVIEW wrote it (thesis 3.6,
    Table 3.2: no header, the seven columns in the order of :data:`LOG_COLUMNS`); every row
    must then have exactly seven numeric cells with valid flags, otherwise the file is refused
    rather than guessed at.  A UTF-8 byte-order mark is ignored.

    Parameters
    ----------
    path : str or Path
    allow_unterminated : bool
        Accept a last row without a line end.  By default it is refused: a log cut off while
        being written ends without one, and its last value may be torn mid-number (``52.1``
        of ``52.1375``), which no check on the value can detect.  Pass True only for a file
        known to be complete (e.g. written by an editor that drops the final line end).

    Raises
    ------
    FileFormatError
        Missing/different header (and not seven numbers either), wrong number of fields, a
        value that is not a number of the allowed set, an unterminated last row (unless
        ``allow_unterminated``), or no data row; ``line`` is the 1-based line number.
    OSError
        The file cannot be read.

    Examples
    --------
    >>> import tempfile, os
    >>> folder = tempfile.mkdtemp()
    >>> path = os.path.join(folder, "log.csv")
    >>> _ = open(path, "w").write("start_stop,probe,motor,direction,laser_a,laser_b,laser_c\\n1,0,1,1,50,51,52\\n")
    >>> read_log(path).lasers.tolist()
    [[50.0, 51.0, 52.0]]
    >>> _ = open(path, "w").write("1,0,1,1,50,51,52\\n0,0,1,1,50.5,51,52\\n")  # headerless, as the seed wrote
    >>> read_log(path).lasers[:, 0].tolist()
    [50.0, 50.5]
    >>> _ = open(path, "w").write("1,0,1,1,50,51,52\\n0,0,1,1,50.5,51,5")  # cut off while writing
    >>> try:
    ...     read_log(path)
    ... except FileFormatError as exc:
    ...     print(exc.line, exc.reason[:44])
    2 last row has no line end: its last value may
    """
    from pcmm_geo.io.text import excerpt, read_csv_rows

    name = str(path)

    def is_header(cells: tuple[str, ...]) -> bool:
        return [h.strip().lower() for h in cells[: len(LOG_COLUMNS)]] == list(LOG_COLUMNS)

    def check_header(line: int, cells: tuple[str, ...]) -> None:  # before the rest of the file is read
        if is_header(cells):
            return
        if not _all_numbers(cells):
            raise FileFormatError(
                name, f"expected header {','.join(LOG_COLUMNS)} (or {len(LOG_COLUMNS)} numeric columns without "
                f"header), got {excerpt(','.join(cells))}", line=line,
            )
        if len(cells) != len(LOG_COLUMNS):
            raise FileFormatError(
                name, f"expected header {','.join(LOG_COLUMNS)}, or {len(LOG_COLUMNS)} numeric columns without "
                f"header (seed Table 3.2), got {len(cells)} numeric columns", line=line,
            )

    table = read_csv_rows(path, check_header=check_header)
    # ``# key: value`` metadata lines (written by pcmm_geo.acquisition.acqlog) are skipped by
    # read_csv_rows; columns after the seven Table 3.2 columns (sequence number, time, raw counts)
    # are ignored.
    if not table.rows:
        raise FileFormatError(name, f"expected header {','.join(LOG_COLUMNS)} and data rows, got no rows")
    header = table.rows[0][1]
    if is_header(header):
        data_rows, n_columns, headerless = table.rows[1:], len(header), False
    else:  # seven numbers (check_header refused anything else)
        data_rows, n_columns, headerless = table.rows, len(LOG_COLUMNS), True
    torn = table.unterminated_row
    if torn is not None and not allow_unterminated:
        raise FileFormatError(
            name, "last row has no line end: its last value may be torn mid-number (a log cut off while being "
            "written); end the file with a line end if it is complete (or pass allow_unterminated=True, "
            "pcmm process-log --allow-unterminated)", line=torn,
        )
    note = " (read as a headerless Table 3.2 log)" if headerless else ""
    if not data_rows:
        raise FileFormatError(name, "expected at least one data row, got none")
    values = [_row_numbers(name, line, cells, n_columns, note) for line, cells in data_rows]
    data = np.array(values, dtype=float)
    lines = np.array([line for line, _ in data_rows])
    not_finite = ~np.isfinite(data).all(axis=1)
    if not_finite.any():
        row = int(np.argmax(not_finite))
        column = int(np.argmax(~np.isfinite(data[row])))
        raise FileFormatError(name, f"{LOG_COLUMNS[column]}: expected a finite number, got "
                              f"{excerpt(data_rows[row][1][column].strip())}", line=int(lines[row]))
    for column, options in enumerate(_FLAG_VALUES):
        wrong = ~np.isin(data[:, column], options)
        if wrong.any():
            row = int(np.argmax(wrong))
            raise FileFormatError(name, f"{LOG_COLUMNS[column]}: expected one of {options}, got "
                                  f"{data[row, column]:g}{note}", line=int(lines[row]))
    flags_int = data[:, :4].astype(np.int64)
    return MeasurementLog(flags_int[:, 0], flags_int[:, 1], flags_int[:, 2], flags_int[:, 3], data[:, 4:])


_FLAG_VALUES = ((0, 1), (0, 1), (1, 2, 3), (-1, 0, 1))


def _all_numbers(cells: tuple[str, ...]) -> bool:
    from pcmm_geo.io.text import parse_decimal

    try:
        return all(np.isfinite(parse_decimal(cell)) for cell in cells)
    except ValueError:
        return False


def _row_numbers(name: str, line: int, cells: tuple[str, ...], n_columns: int, note: str) -> list[float]:
    """The seven numbers of one log row (ASCII decimals only; finiteness and flags are checked by the caller)."""
    if len(cells) != n_columns:
        raise FileFormatError(name, f"expected {n_columns} fields, got {len(cells)}{note}", line=line)
    row = cells[: len(LOG_COLUMNS)]
    joined = "".join(row)
    if joined.isascii() and "_" not in joined:  # then float() takes exactly the ASCII decimals
        try:
            return [float(cell) for cell in row]
        except ValueError:
            pass
    from pcmm_geo.io.text import excerpt, parse_decimal

    values = []
    for column, cell in zip(LOG_COLUMNS, row, strict=True):
        try:
            values.append(parse_decimal(cell))
        except ValueError:
            raise FileFormatError(name, f"{column}: expected a number, got {excerpt(cell.strip())}{note}",
                                  line=line) from None
    return values


def write_log(path: str | Path, log: MeasurementLog, *, overwrite: bool = False) -> Path:
    """Write ``log`` as a Table 3.2 CSV with header; lasers with 6 decimals (um/1000).

    Raises
    ------
    OutputExistsError
        The file exists and ``overwrite`` is False (nothing recorded is lost).

    Examples
    --------
    >>> import tempfile, os
    >>> log = MeasurementLog([1], [0], [2], [-1], [[50.0, 51.0, 52.0]])
    >>> path = write_log(os.path.join(tempfile.mkdtemp(), "log.csv"), log)
    >>> read_log(path).motor.tolist()
    [2]
    """
    from pcmm_geo._atomic import atomic_output

    target = Path(path)
    with atomic_output(target, overwrite=overwrite) as temporary, \
            open(temporary, "w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(LOG_COLUMNS)
        for k in range(len(log)):
            writer.writerow(
                [int(log.start_stop[k]), int(log.probe[k]), int(log.motor[k]), int(log.direction[k])]
                + [f"{value:.9f}" for value in log.lasers[k]]
            )
    return target
