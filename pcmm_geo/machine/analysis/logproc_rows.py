"""Rows of the seed's measurement log (thesis 3.6, Table 3.2): the array type, CSV reader and writer.

Log format (CSV, header required)::

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
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.errors import FileFormatError, InvalidInputError
from pcmm_geo.machine.kinematics.model_parts import as_readings

__all__ = ["LOG_COLUMNS", "MeasurementLog", "read_log", "write_log"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: header of the log CSV (seed Table 3.2)
LOG_COLUMNS: tuple[str, ...] = ("start_stop", "probe", "motor", "direction", "laser_a", "laser_b", "laser_c")


@dataclass(frozen=True)
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


def read_log(path: str | Path) -> MeasurementLog:
    """Read a Table 3.2 log CSV (header :data:`LOG_COLUMNS` required).

    Raises
    ------
    FileFormatError
        Missing/different header, wrong number of fields, or a value that is not a
        number of the allowed set; ``line`` is the 1-based line number.
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
    """
    name = str(path)
    rows: list[list[float]] = []
    from pcmm_geo.io._text import read_text_lines

    # ``# key: value`` metadata lines (written by pcmm_geo.acquisition.acqlog) are skipped;
    # columns after the seven Table 3.2 columns (sequence number, time, raw counts) are ignored.
    numbered = [(number, text) for number, text in read_text_lines(path) if not text.startswith("#")]
    reader = csv.reader(text for _, text in numbered)
    header = next(reader, None)
    header_line = numbered[0][0] if numbered else 1
    if header is None or [h.strip().lower() for h in header[: len(LOG_COLUMNS)]] != list(LOG_COLUMNS):
        raise FileFormatError(name, f"expected header {','.join(LOG_COLUMNS)}, got {header}", line=header_line)
    n_columns = len(header)
    for index, row in enumerate(reader, start=1):
        line = numbered[index][0] if index < len(numbered) else None
        if not row or all(not cell.strip() for cell in row):
            continue
        if len(row) != n_columns:
            raise FileFormatError(name, f"expected {n_columns} fields, got {len(row)}", line=line)
        row = row[: len(LOG_COLUMNS)]
        try:
            values = [float(cell) for cell in row]
        except ValueError:
            raise FileFormatError(name, f"expected numbers, got {row}", line=line) from None
        if not all(np.isfinite(values)):
            raise FileFormatError(name, f"expected finite numbers, got {row}", line=line)
        flags = values[:4]
        allowed = ((0, 1), (0, 1), (1, 2, 3), (-1, 0, 1))
        for column, value, options in zip(LOG_COLUMNS[:4], flags, allowed, strict=True):
            if value not in options:
                raise FileFormatError(name, f"{column}: expected one of {options}, got {value:g}", line=line)
        rows.append(values)
    if not rows:
        raise FileFormatError(name, "expected at least one data row, got none")
    data = np.array(rows)
    flags_int = data[:, :4].astype(np.int64)
    return MeasurementLog(flags_int[:, 0], flags_int[:, 1], flags_int[:, 2], flags_int[:, 3], data[:, 4:])


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
