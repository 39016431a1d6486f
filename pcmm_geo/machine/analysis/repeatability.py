"""Start-position repeatability of the laser readings (thesis 6.3, Tables 6.6 and 6.7).

Every test of the seed starts with the three pivots at the same encoder count (the start
position, 247 500 microsteps), yet the lasers read a slightly different start each time:
Table 6.6 shows three tests without, Table 6.7 six tests with the settling pre-sequence (each
motor to its maximum and minimum height and back).  This module measures that scatter per
laser from real inputs -- the first row of each acquisition log or Table 3.2 log (the reading
right after homing / the pre-sequence), or a table of start readings -- and flags readings
that no laser error within the stated accuracy can explain.

Statistics per arm (:class:`ArmStatistics`): mean, median, range ``max - min`` (the thesis'
"Range" row), the *sample* standard deviation (``ddof = 1``, the estimate of the process
standard deviation) and the *population* one (``ddof = 0``, the RMS deviation of these very
values), both given, named so.

Outlier rule: readings of an unchanged position, each within ``+-accuracy`` of the truth, can
differ by up to ``2 accuracy``; the median of such readings is itself within ``+-accuracy``.
A reading further than ``2 accuracy`` from its arm's median therefore cannot be laser error
alone and is flagged.  The rule never flags a reading that laser error can explain; with few
tests it may miss one (with two tests, whose median is their mean, a difference of up to
4 accuracy passes).  With the seed's 0.05 mm (thesis 3.1) the limit is 0.10 mm: Table 6.6's
``l_a = 33.41`` of test 2 (0.29 mm from 33.70) is flagged, the 0.05 and 0.06 mm differences of
``l_b`` and ``l_c`` are not -- as the thesis reads its table.

Examples
--------
>>> table_6_7 = [[34.11, 32.41, 37.65], [34.21, 32.17, 37.82], [34.11, 32.46, 37.67],
...              [34.26, 32.22, 37.78], [33.86, 32.17, 37.53], [33.86, 32.17, 37.50]]
>>> result = start_repeatability(table_6_7)
>>> [round(arm.range, 2) for arm in result.arms]
[0.4, 0.29, 0.32]
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import FileFormatError, InvalidInputError, TooFewPointsError
from pcmm_geo.machine.analysis.sensitivity import SEED_LASER_ACCURACY

__all__ = [
    "ARMS",
    "ArmStatistics",
    "FlaggedReading",
    "StartReadings",
    "StartRepeatability",
    "arm_statistics",
    "read_arm_table_csv",
    "read_start_readings_csv",
    "start_readings_from_logs",
    "start_repeatability",
]

FloatArray = NDArray[np.float64]
ARMS = ("a", "b", "c")
#: first line of a pcmm_geo acquisition log (:mod:`pcmm_geo.acquisition.acqlog`)
_ACQLOG_MARK = "# pcmm_geo acquisition log"
#: a deviation must exceed the limit by more than this (mm): 34.21 - 34.11 = 0.10000000000000142 is not beyond 0.10
_ROUNDING_GUARD = 1e-9
START_READINGS_HEADER = ("test", "laser_a", "laser_b", "laser_c")


@dataclass(frozen=True)
class ArmStatistics:
    """Spread of one arm's values over ``count`` tests.

    Attributes
    ----------
    arm : str
        ``'a'``, ``'b'`` or ``'c'``.
    count : int
        Number of tests.
    mean, median, minimum, maximum : float
        In ``unit``.
    range : float
        ``maximum - minimum`` (the thesis' "Range" row of Table 6.7).
    sigma_sample : float
        Sample standard deviation, ``ddof = 1`` (divides by ``count - 1``).
    sigma_population : float
        Population standard deviation, ``ddof = 0`` (divides by ``count``).
    largest_deviation : float
        Largest ``|value - median|``.
    flagged : tuple of int
        Test indices (from 0) whose value lies further than the outlier limit from the median;
        empty when no limit applies.
    unit : str
        ``"mm"`` for laser readings, ``"1"`` for dimensionless ratios.
    """

    arm: str
    count: int
    mean: float
    median: float
    minimum: float
    maximum: float
    range: float
    sigma_sample: float
    sigma_population: float
    largest_deviation: float
    flagged: tuple[int, ...]
    unit: str

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {**self.__dict__, "flagged": list(self.flagged)}


def arm_statistics(values: ArrayLike, arm: str, *, unit: str = "mm",
                   outlier_limit: float | None = None) -> ArmStatistics:
    """Statistics of one arm's values, shape (K,), K >= 2.

    Parameters
    ----------
    values : array_like, shape (K,)
    arm : str
    unit : str
    outlier_limit : float, optional
        Values further than this from the median are flagged (None: no flagging).

    Raises
    ------
    TooFewPointsError
        Fewer than two values (no spread).
    InvalidInputError
        Not one-dimensional, or NaN / inf.

    Examples
    --------
    >>> s = arm_statistics([5.03, 5.12, 5.39, 5.39, 5.56], "a", unit="1")
    >>> round(s.sigma_population, 4), round(s.sigma_sample, 4)
    (0.1945, 0.2174)
    """
    data = np.asarray(values, dtype=float)
    if data.ndim != 1:
        raise InvalidInputError(f"values of arm {arm}", "shape (K,)", f"shape {data.shape}")
    if data.size < 2:
        raise TooFewPointsError(f"spread of arm {arm}", 2, int(data.size))
    if not np.all(np.isfinite(data)):
        raise InvalidInputError(f"values of arm {arm}", "finite numbers", "NaN or inf")
    median = float(np.median(data))
    deviation = np.abs(data - median)
    flagged: tuple[int, ...] = ()
    if outlier_limit is not None:
        flagged = tuple(int(k) for k in np.nonzero(deviation - outlier_limit > _ROUNDING_GUARD)[0])
    return ArmStatistics(
        arm=arm, count=int(data.size), mean=float(data.mean()), median=median, minimum=float(data.min()),
        maximum=float(data.max()), range=float(data.max() - data.min()), sigma_sample=float(data.std(ddof=1)),
        sigma_population=float(data.std(ddof=0)), largest_deviation=float(deviation.max()), flagged=flagged,
        unit=unit,
    )


@dataclass(frozen=True)
class FlaggedReading:
    """A start reading further than the outlier limit from its arm's median (mm)."""

    test: str
    arm: str
    value: float
    median: float
    deviation: float


@record
class StartRepeatability:
    """Repeatability of the start readings over ``K`` tests.

    Attributes
    ----------
    readings : ndarray, shape (K, 3)
        Start readings of lasers a, b, c (mm from the laser's start of range).
    labels : tuple of str
        One label per test (file name or table row).
    arms : tuple of ArmStatistics
        Arms a, b, c (unit mm).
    laser_accuracy : float
        Stated accuracy of one laser reading, +- mm (seed: 0.05, thesis 3.1).
    outlier_limit : float
        ``2 * laser_accuracy``: largest distance from the median that laser error alone explains, mm.
    flagged : tuple of FlaggedReading
        Readings beyond the limit, in test order.
    """

    readings: FloatArray
    labels: tuple[str, ...]
    arms: tuple[ArmStatistics, ...]
    laser_accuracy: float
    outlier_limit: float
    flagged: tuple[FlaggedReading, ...]

    @property
    def within_accuracy(self) -> bool:
        """True when no reading is flagged."""
        return not self.flagged

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (lengths in mm)."""
        return {
            "unit": "mm",
            "tests": len(self.labels),
            "labels": list(self.labels),
            "readings": self.readings.tolist(),
            "laser_accuracy_mm": self.laser_accuracy,
            "outlier_limit_mm": self.outlier_limit,
            "outlier_rule": "|reading - median of its laser| > 2 x laser accuracy",
            "arms": {arm.arm: arm.as_dict() for arm in self.arms},
            "flagged": [dict(f.__dict__) for f in self.flagged],
            "within_accuracy": self.within_accuracy,
        }


def start_repeatability(readings: ArrayLike, labels: Sequence[str] | None = None, *,
                        laser_accuracy: float = SEED_LASER_ACCURACY) -> StartRepeatability:
    """Per-laser spread of the start readings over repeated tests (thesis Tables 6.6, 6.7).

    Parameters
    ----------
    readings : array_like, shape (K, 3)
        Start readings of lasers a, b, c per test, mm; K >= 2.
    labels : sequence of str, optional
        Test names (default ``test 1`` ... ``test K``).
    laser_accuracy : float
        Accuracy of one laser reading, +- mm (default 0.05 mm, thesis 3.1).

    Returns
    -------
    StartRepeatability

    Raises
    ------
    InvalidInputError
        Not (K, 3), NaN / inf, labels of another length, accuracy not positive.
    TooFewPointsError
        Fewer than two tests.

    Examples
    --------
    Table 6.6 (three tests without the pre-sequence):

    >>> result = start_repeatability([[33.70, 33.51, 37.14], [33.41, 33.56, 37.08], [33.70, 33.51, 37.14]])
    >>> [(f.test, f.arm, f.value, round(f.deviation, 2)) for f in result.flagged]
    [('test 2', 'a', 33.41, 0.29)]
    """
    data = np.asarray(readings, dtype=float)
    if data.ndim != 2 or data.shape[1] != 3:
        raise InvalidInputError("start readings", "shape (K, 3): lasers a, b, c per test", f"shape {data.shape}")
    if not (np.isfinite(laser_accuracy) and laser_accuracy > 0):
        raise InvalidInputError("laser_accuracy", "a positive length in mm", repr(laser_accuracy))
    names = tuple(f"test {k + 1}" for k in range(data.shape[0])) if labels is None else tuple(map(str, labels))
    if len(names) != data.shape[0]:
        raise InvalidInputError("labels", f"{data.shape[0]} labels (one per test)", f"{len(names)}")
    limit = 2.0 * float(laser_accuracy)
    arms = tuple(arm_statistics(data[:, k], arm, outlier_limit=limit) for k, arm in enumerate(ARMS))
    flagged = [
        FlaggedReading(names[t], stats.arm, float(data[t, k]), stats.median, abs(float(data[t, k]) - stats.median))
        for t in range(data.shape[0]) for k, stats in enumerate(arms) if t in stats.flagged
    ]
    return StartRepeatability(data, names, arms, float(laser_accuracy), limit, tuple(flagged))


@record
class StartReadings:
    """Start readings gathered from files.

    Attributes
    ----------
    lasers : ndarray, shape (K, 3)
        Lasers a, b, c at the start of each test, mm.
    labels : tuple of str
        Source of each test (file name, or file name and table label).
    presequence : tuple of bool or None
        Whether the settling pre-sequence ran before the reading (acquisition logs record it;
        None where the file does not say).
    """

    lasers: FloatArray
    labels: tuple[str, ...]
    presequence: tuple[bool | None, ...]


def _first_row_of_acquisition_log(path: Path) -> tuple[FloatArray, bool | None]:
    from pcmm_geo.acquisition.acqlog import read_log as read_acquisition_log

    contents = read_acquisition_log(path)
    if not contents.rows:
        raise FileFormatError(str(path), "expected at least one data row, got none")
    row = contents.rows[0]
    if row.start_stop != 1:
        raise FileFormatError(str(path), "first row is not a start reading (start_stop 1): not a test start")
    key = "start_positions_usteps" if "start_positions_usteps" in contents.metadata else "start_position_usteps"
    start = contents.metadata.get(key)  # each motor's start (pcmm acquire's commanded start), or one for all
    if start is not None:
        try:
            starts = [int(v) for v in start.split()]
        except ValueError:
            starts = []
        wanted = "three integers" if key == "start_positions_usteps" else "an integer"
        if len(starts) != (3 if key == "start_positions_usteps" else 1):
            raise FileFormatError(str(path), f"{key}: expected {wanted}, got {start!r}")
        if any(position != wanted for position, wanted in zip(row.pos_usteps, starts * (3 // len(starts)),
                                                                 strict=True)):
            raise FileFormatError(
                str(path), f"first row is at motor positions {list(row.pos_usteps)}, not at the start position "
                f"{start} microsteps")
    flag = contents.metadata.get("presequence")
    presequence = None if flag is None else flag.strip().lower() in ("true", "1", "yes")
    return np.array([row.laser_a, row.laser_b, row.laser_c]), presequence


def start_readings_from_logs(paths: Sequence[str | Path]) -> StartReadings:
    """The start reading of each test: the first row of each log (one log per test).

    A pcmm_geo acquisition log (``pcmm acquire``) is read with
    :func:`pcmm_geo.acquisition.acqlog.read_log`; its first row is the reading right after homing
    and the pre-sequence, and must be a start row at the recorded start position.  Any other file
    is read as a thesis Table 3.2 log with :func:`pcmm_geo.machine.analysis.logproc.rows.read_log`;
    its first row must be a start row (``start_stop`` 1).

    Parameters
    ----------
    paths : sequence of path-like
        At least two logs.

    Returns
    -------
    StartReadings

    Raises
    ------
    FileFormatError, LogIntegrityError
        A log that cannot be read, or whose first row is not a start reading at the start position.
    InvalidInputError
        Logs with and without the pre-sequence mixed (their scatter is not the same quantity).
    TooFewPointsError
        Fewer than two logs.
    """
    from pcmm_geo.machine.analysis.logproc.rows import read_log as read_table_3_2_log

    if len(paths) < 2:
        raise TooFewPointsError("start repeatability (logs)", 2, len(paths))
    lasers, labels, flags = [], [], []
    for given in paths:
        path = Path(given)
        with open(path, "rb") as handle:
            head = handle.read(len(_ACQLOG_MARK) + 3).decode("utf-8", "replace").lstrip("\ufeff")
        if head.startswith(_ACQLOG_MARK):
            reading, presequence = _first_row_of_acquisition_log(path)
        else:
            log = read_table_3_2_log(path)
            if int(log.start_stop[0]) != 1:
                raise FileFormatError(str(path), "first row is not a start reading (start_stop 1): not a test start")
            reading, presequence = np.asarray(log.lasers[0], dtype=float), None
        lasers.append(reading)
        labels.append(path.name)
        flags.append(presequence)
    known = {flag for flag in flags if flag is not None}
    if len(known) > 1:
        with_pre = [label for label, flag in zip(labels, flags, strict=True) if flag]
        without = [label for label, flag in zip(labels, flags, strict=True) if flag is False]
        raise InvalidInputError("logs", "all with or all without the settling pre-sequence",
                                f"with: {with_pre}, without: {without}")
    return StartReadings(np.array(lasers), tuple(labels), tuple(flags))


def read_arm_table_csv(path: str | Path, header: Sequence[str]) -> tuple[tuple[str, ...], FloatArray]:
    """Read a table of one label and three per-arm numbers per row (``#`` comments allowed).

    Parameters
    ----------
    path : path-like
    header : sequence of 4 str
        The required header, e.g. ``("test", "laser_a", "laser_b", "laser_c")``.

    Returns
    -------
    labels : tuple of str
        First column of each row.
    values : ndarray, shape (K, 3)

    Raises
    ------
    FileFormatError
        Wrong header, field count, non-finite or non-numeric values (with the line number), no rows.
    """
    from pcmm_geo.io.text import excerpt, read_csv_rows

    file = Path(path)
    expected = tuple(header)

    def check_header(line: int | None, cells: tuple[str, ...] | None) -> None:  # before the rest is read
        if cells is None or tuple(f.strip().lower() for f in cells) != expected:
            got = excerpt(",".join(cells)) if cells is not None else "an empty file"
            raise FileFormatError(str(file), f"expected header {','.join(expected)!r}, got {got}", line)

    rows = read_csv_rows(file, check_header=check_header).rows
    if not rows:
        check_header(None, None)
    labels, values = [], []
    for number, cells in rows[1:]:
        fields = [f.strip() for f in cells]
        if len(fields) != 4:
            raise FileFormatError(str(file), f"expected 4 fields, got {len(fields)}", number)
        try:
            row = [float(f) for f in fields[1:]]
        except ValueError:
            raise FileFormatError(str(file), f"expected numbers, got {[f[:20] for f in fields[1:]]}", number) from None
        if not np.all(np.isfinite(row)):
            raise FileFormatError(str(file), "expected finite numbers", number)
        labels.append(fields[0][:80])
        values.append(row)
    if not values:
        raise FileFormatError(str(file), "expected data rows, got none")
    return tuple(labels), np.array(values)


def read_start_readings_csv(path: str | Path) -> StartReadings:
    """Read a table of start readings: header ``test,laser_a,laser_b,laser_c`` (mm), ``#`` comments.

    Raises
    ------
    FileFormatError
        Wrong header, field count, non-finite or non-numeric values (with the line number), no rows.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "start.csv"
    >>> _ = f.write_text("# Table 6.6\\ntest,laser_a,laser_b,laser_c\\n1,33.70,33.51,37.14\\n2,33.41,33.56,37.08\\n")
    >>> read_start_readings_csv(f).lasers[:, 0].tolist()
    [33.7, 33.41]
    """
    labels, values = read_arm_table_csv(path, START_READINGS_HEADER)
    return StartReadings(values, tuple(f"test {label}" for label in labels), (None,) * len(labels))
