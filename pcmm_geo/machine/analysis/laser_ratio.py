"""Height per laser displacement of measured data (thesis 6.3, eqs 6.1-6.3, Table 6.8).

The seed raised each pivot from about 0 to 100 mm, five times per arm, read the height gauge
on the lead-screw bracket and the arm's laser at the start (``s``) and finish (``f``) of each
run, and formed

* eq 6.1: ``delta_l = l_s - l_f`` (laser of the moved arm, mm);
* eq 6.2: ``delta_h = h_s - h_f`` (height gauge, mm);
* eq 6.3: ``ratio = delta_h / delta_l``.

Table 6.8 prints these ratios (about 5-6) under the inverted header ``l/h``; eq 6.3 and the
values (a 100 mm rise moves the laser by about 18 mm) say ``delta_h / delta_l``.  This module
computes eq 6.3 and calls the quantity ``height_per_laser`` (mm of pivot height per mm of laser).

What the geometry predicts.  The thesis expects equal ratios; the rigid-body model does not
(:mod:`~pcmm_geo.machine.analysis.laser_ratio_model`: about 20 for a 25 mm rise from level pivots,
5.2-5.6 for 100 mm, different per arm).  :func:`laser_height_ratio` therefore predicts every run's
ratio from the model for that arm moved alone between the same start and finish heights, and
reports how fast the prediction changes with the travel and with an offset of the start laser
reading (the settling scatter of Table 6.7).

Splitting a record into runs (the height-gauge CSV of :mod:`pcmm_geo.machine.calibration.numerical.numcal_data`
has no test column): consecutive rows of the same moved arm form one run while the height keeps
moving in one direction; a row that reverses the direction (the return to the start) or names
another arm starts a new run.  A run needs at least two rows; its first and last rows are ``s``
and ``f``.

Reading uncertainties (:class:`ReadingLimits`): the height gauge reads to 0.01 mm with 0.01 mm
accuracy (thesis 6.2.1); the lasers have 0.05 mm accuracy (thesis 3.1) and output steps of
``200 mm x 1.02 / 16368`` (ILD1302, lasers a, b) and ``/ 65520`` (ILD1420, laser c), the
drivers' scaling.  A reading of resolution ``q`` has standard uncertainty ``q / sqrt(12)``
(rectangular, width ``q``); a reading within ``+-A`` has ``A / sqrt(3)``; the two readings of a
difference are taken as independent.  First-order propagation through eq 6.3 gives
``u(ratio)`` from the resolutions alone and from the stated accuracies.

Examples
--------
>>> from pcmm_geo.machine.analysis.laser_ratio_model import synthesise_ratio_record
>>> record = synthesise_ratio_record(travel=100.0, runs_per_arm=2)
>>> result = laser_height_ratio(record)
>>> [round(arm.mean, 2) for arm in result.arms]
[5.24, 5.29, 5.55]
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.acquisition.drivers.lasers import ILD1302_FULL_SCALE, ILD1420_FULL_SCALE, MEASURING_RANGE_MM
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.machine.analysis.laser_ratio_model import (
    DEFAULT_MODEL_NAME,
    ArmPrediction,
    predict_arm,
    predicted_height_per_laser,
)
from pcmm_geo.machine.analysis.repeatability import ARMS, ArmStatistics, arm_statistics
from pcmm_geo.machine.analysis.sensitivity import SEED_LASER_ACCURACY
from pcmm_geo.machine.kinematics.model import RigidBodyMachine

__all__ = [
    "HeightGaugeRecord",
    "LaserHeightRatio",
    "RatioRun",
    "ReadingLimits",
    "laser_height_ratio",
    "split_runs",
]

FloatArray = NDArray[np.float64]
#: the height gauge of thesis 6.2.1: "accuracy and resolution of 0.01 mm"
HEIGHT_GAUGE_RESOLUTION = 0.01
HEIGHT_GAUGE_ACCURACY = 0.01
#: output step of the lasers (mm per count), the drivers' scaling ``MR * 1.02 / full scale``
LASER_RESOLUTION = (
    MEASURING_RANGE_MM * 1.02 / ILD1302_FULL_SCALE,
    MEASURING_RANGE_MM * 1.02 / ILD1302_FULL_SCALE,
    MEASURING_RANGE_MM * 1.02 / ILD1420_FULL_SCALE,
)
_STEP_GUARD = 1e-9  # mm: a height step smaller than this does not set or reverse a direction


class HeightGaugeRecord(Protocol):
    """What the analysis needs of a height-gauge record.

    :class:`pcmm_geo.machine.calibration.numerical.numcal_data.NumcalData` (read by
    :func:`~pcmm_geo.machine.calibration.numerical.numcal_data.read_numcal_csv`) is one.
    """

    moved: tuple[str, ...]
    lasers: FloatArray
    heights: FloatArray


@dataclass(frozen=True)
class ReadingLimits:
    """Resolution and accuracy of the readings, mm (defaults: the seed's instruments).

    Attributes
    ----------
    height_resolution, height_accuracy : float
        Height gauge (thesis 6.2.1: 0.01 mm each).
    laser_resolution : tuple of float
        Output step of lasers a, b, c (ILD1302, ILD1302, ILD1420 scaling of the drivers).
    laser_accuracy : float
        +- mm of one laser reading (thesis 3.1: 0.05 mm).
    """

    height_resolution: float = HEIGHT_GAUGE_RESOLUTION
    height_accuracy: float = HEIGHT_GAUGE_ACCURACY
    laser_resolution: tuple[float, float, float] = LASER_RESOLUTION
    laser_accuracy: float = SEED_LASER_ACCURACY

    def __post_init__(self) -> None:
        values = (self.height_resolution, self.height_accuracy, *self.laser_resolution, self.laser_accuracy)
        if len(self.laser_resolution) != 3 or not all(np.isfinite(v) and v >= 0 for v in values):
            raise InvalidInputError("reading limits", "non-negative lengths in mm (three laser resolutions)",
                                    repr(self))

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (mm)."""
        return {**self.__dict__, "laser_resolution": list(self.laser_resolution), "unit": "mm"}


def _ratio_uncertainty(delta_h: float, delta_l: float, u_h: float, u_l: float) -> float:
    """First-order standard uncertainty of ``delta_h / delta_l`` for independent differences."""
    return float(np.hypot(u_h / delta_l, delta_h * u_l / delta_l**2))


@dataclass(frozen=True)
class RatioRun:
    """One run of one arm: eqs 6.1-6.3 and the model's prediction for the same heights.

    Attributes
    ----------
    arm : str
        Moved arm (its laser is used).
    test : int
        Run number of that arm, from 1.
    rows : tuple of int
        First and last data row of the run (from 0).
    laser_start, laser_finish, height_start, height_finish : float
        ``l_s, l_f, h_s, h_f``, mm.
    laser_change, height_change : float
        ``delta_l = l_s - l_f`` (eq 6.1), ``delta_h = h_s - h_f`` (eq 6.2), mm.
    height_per_laser : float
        ``delta_h / delta_l`` (eq 6.3), mm/mm.
    u_resolution, u_accuracy : float
        Standard uncertainty of the ratio from the reading resolutions / from the stated
        accuracies (see the module documentation).
    predicted : float
        The model's ``delta_h / delta_l`` for this arm moved alone from ``h_s`` to ``h_f``.
    """

    arm: str
    test: int
    rows: tuple[int, int]
    laser_start: float
    laser_finish: float
    height_start: float
    height_finish: float
    laser_change: float
    height_change: float
    height_per_laser: float
    u_resolution: float
    u_accuracy: float
    predicted: float

    @property
    def deviation(self) -> float:
        """Measured minus predicted ratio."""
        return self.height_per_laser - self.predicted

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {**self.__dict__, "rows": list(self.rows), "deviation": self.deviation}


@dataclass(frozen=True)
class LaserHeightRatio:
    """Height per laser displacement of a record (thesis Table 6.8, eq 6.3).

    Attributes
    ----------
    runs : tuple of RatioRun
        In record order.
    arms : tuple of ArmStatistics
        Statistics of ``height_per_laser`` for each arm with at least two runs (unit ``"1"``,
        i.e. mm/mm), both ``sigma_sample`` (ddof 1) and ``sigma_population`` (ddof 0).
    predictions : tuple of ArmPrediction
        The model's ratio for each arm with runs.
    predicted_spread : float
        Largest minus smallest predicted ratio over those arms: how different the arms should
        be from the geometry alone.
    limits : ReadingLimits
    model : str
        Which machine model made the predictions.
    """

    runs: tuple[RatioRun, ...]
    arms: tuple[ArmStatistics, ...]
    predictions: tuple[ArmPrediction, ...]
    predicted_spread: float
    limits: ReadingLimits
    model: str = field(default="")

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {
            "quantity": "height_per_laser = delta_h / delta_l (thesis eq 6.3; Table 6.8's header l/h is inverted)",
            "unit": "mm/mm",
            "runs": [run.as_dict() for run in self.runs],
            "arms": {stats.arm: stats.as_dict() for stats in self.arms},
            "predictions": {p.arm: dict(p.__dict__) for p in self.predictions},
            "predicted_spread": self.predicted_spread,
            "reading_limits": self.limits.as_dict(),
            "model": self.model,
        }


def split_runs(moved: Sequence[str], heights: ArrayLike) -> list[tuple[str, int, int]]:
    """Split a record into runs ``(arm, first_row, last_row)`` (rule in the module documentation).

    Raises
    ------
    InvalidInputError
        A run of a single row (no finish), or a run whose height does not change.

    Examples
    --------
    >>> split_runs(["a", "a", "a", "a", "a", "b", "b"], [0, 50, 100, 0.02, 99.98, 0, 99.5])
    [('a', 0, 2), ('a', 3, 4), ('b', 5, 6)]
    """
    h = np.asarray(heights, dtype=float)
    runs: list[tuple[str, int, int]] = []
    row = 0
    while row < len(moved):
        arm, first, direction = moved[row], row, 0.0
        row += 1
        while row < len(moved) and moved[row] == arm:
            step = h[row] - h[row - 1]
            sign = 0.0 if abs(step) <= _STEP_GUARD else float(np.sign(step))
            if direction and sign and sign != direction:
                break
            direction = direction or sign
            row += 1
        last = row - 1
        if last == first:
            raise InvalidInputError("height-gauge record", "runs of at least two rows (start and finish)",
                                    f"a single row of arm {arm} at data row {first + 1}")
        if not direction:
            raise InvalidInputError("height-gauge record", "a height change in every run",
                                    f"arm {arm}, data rows {first + 1}-{last + 1} at one height")
        runs.append((arm, first, last))
    return runs


def laser_height_ratio(record: HeightGaugeRecord, *, machine: RigidBodyMachine | None = None,
                       limits: ReadingLimits | None = None, model_name: str = "") -> LaserHeightRatio:
    """Eqs 6.1-6.3 per run and arm, statistics per arm, and the model's expectation (Table 6.8).

    Parameters
    ----------
    record : HeightGaugeRecord
        ``moved`` (M,), ``lasers`` (M, 3) mm, ``heights`` (M,) mm relative to the level start, e.g.
        the :class:`~pcmm_geo.machine.calibration.numerical.numcal_data.NumcalData` of ``read_numcal_csv``.
    machine : RigidBodyMachine, optional
        Geometry of the prediction (default: the thesis geometry, :meth:`RigidBodyMachine.from_dpkm`).
    limits : ReadingLimits, optional
        Reading resolutions and accuracies (default: the seed's instruments).
    model_name : str
        Description of ``machine`` for the result.

    Returns
    -------
    LaserHeightRatio

    Raises
    ------
    InvalidInputError
        Bad shapes, a run of one row or without height change (see :func:`split_runs`), a run
        whose laser change is not larger than the laser's resolution (eq 6.3 undefined: the dead
        spot of thesis 6.3).
    NoRealSolutionError
        Heights the model cannot reach.
    """
    limits = limits or ReadingLimits()
    if machine is None:
        machine = RigidBodyMachine.from_dpkm()
        model_name = model_name or DEFAULT_MODEL_NAME
    moved = tuple(record.moved)
    lasers = np.asarray(record.lasers, dtype=float)
    heights = np.asarray(record.heights, dtype=float)
    if lasers.shape != (len(moved), 3) or heights.shape != (len(moved),):
        raise InvalidInputError("height-gauge record", f"lasers ({len(moved)}, 3) and heights ({len(moved)},)",
                                f"{lasers.shape} and {heights.shape}")
    if not moved:
        raise InvalidInputError("height-gauge record", "at least one run of two rows", "no rows")
    runs: list[RatioRun] = []
    counts = dict.fromkeys(ARMS, 0)
    u_h_res = np.sqrt(2.0) * limits.height_resolution / np.sqrt(12.0)
    u_h_acc = np.sqrt(2.0) * limits.height_accuracy / np.sqrt(3.0)
    u_l_acc = np.sqrt(2.0) * limits.laser_accuracy / np.sqrt(3.0)
    for arm, first, last in split_runs(moved, heights):
        k = ARMS.index(arm)
        l_s, l_f, h_s, h_f = lasers[first, k], lasers[last, k], heights[first], heights[last]
        delta_l, delta_h = l_s - l_f, h_s - h_f
        if abs(delta_l) <= max(limits.laser_resolution[k], _STEP_GUARD):
            raise InvalidInputError(
                f"laser {arm} change over data rows {first + 1}-{last + 1}",
                f"more than the laser resolution {limits.laser_resolution[k]:.4g} mm (eq 6.3 is undefined otherwise: "
                "the dead spot of thesis 6.3?)", f"{delta_l:.6g} mm")
        counts[arm] += 1
        u_l_res = np.sqrt(2.0) * limits.laser_resolution[k] / np.sqrt(12.0)
        runs.append(RatioRun(
            arm=arm, test=counts[arm], rows=(first, last), laser_start=float(l_s), laser_finish=float(l_f),
            height_start=float(h_s), height_finish=float(h_f), laser_change=float(delta_l),
            height_change=float(delta_h), height_per_laser=float(delta_h / delta_l),
            u_resolution=_ratio_uncertainty(delta_h, delta_l, u_h_res, u_l_res),
            u_accuracy=_ratio_uncertainty(delta_h, delta_l, u_h_acc, u_l_acc),
            predicted=float(predicted_height_per_laser(machine, arm, h_s, h_f)),
        ))
    arms = tuple(
        arm_statistics([r.height_per_laser for r in runs if r.arm == arm], arm, unit="1")
        for arm in ARMS if counts[arm] >= 2
    )
    predictions = tuple(
        predict_arm(machine, arm, float(np.mean([r.height_start for r in runs if r.arm == arm])),
                    float(np.mean([r.height_finish for r in runs if r.arm == arm])),
                    float(np.mean([r.laser_change for r in runs if r.arm == arm])))
        for arm in ARMS if counts[arm]
    )
    values = [p.height_per_laser for p in predictions]
    return LaserHeightRatio(tuple(runs), arms, predictions, float(max(values) - min(values)), limits, model_name)


