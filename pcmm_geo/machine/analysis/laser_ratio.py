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

What the geometry predicts.  The thesis expects equal ratios ("theoretically these ratios should
be the same").  The rigid-body model (:class:`~pcmm_geo.machine.kinematics.model.RigidBodyMachine`)
says more: starting from level pivots, the laser of the moved arm changes with the *square* of
the rise at first (the pivot distance grows as ``sqrt(b^2 + h^2)``), so the ratio is far from
constant -- about 20 for a 25 mm rise and 5.2-5.6 for 100 mm with the thesis geometry -- and
depends on each arm's geometry.  :func:`laser_height_ratio` therefore predicts every run's ratio
from the model for that arm moved alone between the same start and finish heights, and reports
how fast the prediction changes with the travel and with an offset of the start laser reading
(the settling scatter of Table 6.7).

Splitting a record into runs (the height-gauge CSV of :mod:`pcmm_geo.machine.calibration.numcal_data`
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
from pcmm_geo.errors import InconsistentMeasurementError, InvalidInputError
from pcmm_geo.machine.analysis.repeatability import ARMS, ArmStatistics, arm_statistics
from pcmm_geo.machine.analysis.sensitivity import SEED_LASER_ACCURACY
from pcmm_geo.machine.kinematics.model import RigidBodyMachine

__all__ = [
    "ArmPrediction",
    "HeightGaugeRecord",
    "LaserHeightRatio",
    "RatioRun",
    "ReadingLimits",
    "laser_height_ratio",
    "predicted_height_per_laser",
    "split_runs",
    "synthesise_ratio_record",
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

    :class:`pcmm_geo.machine.calibration.numcal_data.NumcalData` (read by
    :func:`~pcmm_geo.machine.calibration.numcal_data.read_numcal_csv`) is one.
    """

    moved: tuple[str, ...]
    lasers: FloatArray
    heights: FloatArray


@dataclass(frozen=True)
class SimpleRecord:
    """A height-gauge record in memory: ``moved`` (M,), ``lasers`` (M, 3) mm, ``heights`` (M,) mm."""

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
class ArmPrediction:
    """The model's ratio for one arm at that arm's mean start and finish heights.

    Attributes
    ----------
    arm : str
    height_start, height_finish : float
        Mean ``h_s`` and ``h_f`` of the arm's runs, mm.
    height_per_laser : float
        Predicted ``delta_h / delta_l``.
    per_mm_travel : float
        Change of the predicted ratio per mm more travel (``h_f`` moved away from ``h_s``), 1/mm.
    per_mm_start_laser : float
        Change of the measured ratio per mm of offset in the start laser reading
        (``-ratio / delta_l``), 1/mm: how much a settling offset (Table 6.7) moves the ratio.
    """

    arm: str
    height_start: float
    height_finish: float
    height_per_laser: float
    per_mm_travel: float
    per_mm_start_laser: float


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


def predicted_height_per_laser(machine: RigidBodyMachine, arm: str, height_start: ArrayLike,
                               height_finish: ArrayLike) -> FloatArray:
    """The model's ``delta_h / delta_l`` for ``arm`` moved alone (others at the reference heights).

    Heights are relative to the machine's reference heights (the level start), mm; arrays broadcast.

    Raises
    ------
    InconsistentMeasurementError
        The model finds no pose for a start or finish height (out of reach).

    Examples
    --------
    >>> machine = RigidBodyMachine.from_dpkm()
    >>> [round(float(predicted_height_per_laser(machine, "a", 0.0, t)), 2) for t in (25.0, 50.0, 100.0)]
    [20.24, 10.19, 5.24]
    """
    if arm not in ARMS:
        raise InvalidInputError("arm", "'a', 'b' or 'c'", repr(arm))
    start, finish = np.broadcast_arrays(np.asarray(height_start, float), np.asarray(height_finish, float))
    index = ARMS.index(arm)
    both = np.stack([start.ravel(), finish.ravel()])  # (2, n)
    heights = np.broadcast_to(machine.reference_heights, (*both.shape, 3)).copy()
    heights[..., index] += both
    solution = machine.forward(heights=heights, lasers_hint=machine.reference_lasers)
    if not np.all(solution.converged):
        raise InconsistentMeasurementError(f"model pose of arm {arm} between {start.min()} and {finish.max()} mm",
                                           "no solution", "a converged pose", detail="heights out of the model's reach")
    laser = solution.lasers[..., index]
    return np.asarray((both[0] - both[1]) / (laser[0] - laser[1])).reshape(start.shape)


def laser_height_ratio(record: HeightGaugeRecord, *, machine: RigidBodyMachine | None = None,
                       limits: ReadingLimits | None = None, model_name: str = "") -> LaserHeightRatio:
    """Eqs 6.1-6.3 per run and arm, statistics per arm, and the model's expectation (Table 6.8).

    Parameters
    ----------
    record : HeightGaugeRecord
        ``moved`` (M,), ``lasers`` (M, 3) mm, ``heights`` (M,) mm relative to the level start, e.g.
        the :class:`~pcmm_geo.machine.calibration.numcal_data.NumcalData` of ``read_numcal_csv``.
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
        Bad shapes, a run of one row or without height change (see :func:`split_runs`).
    InconsistentMeasurementError
        A run whose laser change is not larger than the laser's resolution (eq 6.3 undefined:
        the dead spot of thesis 6.3), or heights the model cannot reach.
    """
    limits = limits or ReadingLimits()
    if machine is None:
        machine = RigidBodyMachine.from_dpkm()
        model_name = model_name or "thesis geometry (Table 3.1 / Appendix D, RigidBodyMachine.from_dpkm)"
    moved = tuple(record.moved)
    lasers = np.asarray(record.lasers, dtype=float)
    heights = np.asarray(record.heights, dtype=float)
    if lasers.shape != (len(moved), 3) or heights.shape != (len(moved),):
        raise InvalidInputError("height-gauge record", f"lasers ({len(moved)}, 3) and heights ({len(moved)},)",
                                f"{lasers.shape} and {heights.shape}")
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
            raise InconsistentMeasurementError(
                f"laser {arm} change over data rows {first + 1}-{last + 1}", float(delta_l),
                limits.laser_resolution[k], detail="not larger than the laser's resolution: eq 6.3 is undefined")
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
    predictions = tuple(_arm_prediction(machine, arm, [r for r in runs if r.arm == arm]) for arm in ARMS
                        if counts[arm])
    values = [p.height_per_laser for p in predictions]
    return LaserHeightRatio(tuple(runs), arms, predictions, float(max(values) - min(values)), limits, model_name)


def _arm_prediction(machine: RigidBodyMachine, arm: str, runs: list[RatioRun]) -> ArmPrediction:
    start = float(np.mean([r.height_start for r in runs]))
    finish = float(np.mean([r.height_finish for r in runs]))
    ratio = float(predicted_height_per_laser(machine, arm, start, finish))
    step = 0.5 * float(np.sign(finish - start))  # mm of extra travel, central difference
    more = predicted_height_per_laser(machine, arm, start, finish + step)
    less = predicted_height_per_laser(machine, arm, start, finish - step)
    per_travel = float((more - less) / (2.0 * abs(step)))
    delta_l = float(np.mean([r.laser_change for r in runs]))
    return ArmPrediction(arm, start, finish, ratio, per_travel, -ratio / delta_l)


def synthesise_ratio_record(*, machine: RigidBodyMachine | None = None, travel: float | Sequence[float] = 100.0,
                            runs_per_arm: int = 5, arms: Sequence[str] = ARMS, height_resolution: float = 0.0,
                            laser_resolution: Sequence[float] | None = None,
                            start_offsets: ArrayLike | None = None) -> SimpleRecord:
    """A model-generated height-gauge record of known ratio (Table 6.8's experiment).

    Each run of each arm has two rows: the level start (height 0) and the finish (height
    ``travel``), all three lasers from the rigid-body model, optionally rounded to the given
    resolutions and with the start lasers of run ``j`` shifted by ``start_offsets[j]`` (mm, a
    settling offset that does not follow the motion; same for the finish of that run).

    Parameters
    ----------
    machine : RigidBodyMachine, optional
        Default: the thesis geometry.
    travel : float or sequence of float
        Rise of each run (one value, or one per run), mm.
    runs_per_arm : int
    arms : sequence of str
    height_resolution : float
        Round heights to this step (0: exact).
    laser_resolution : sequence of 3 float, optional
        Round lasers to these steps (None: exact).
    start_offsets : array_like, shape (runs_per_arm, 3), optional
        Settling offsets of the lasers per run, mm.

    Returns
    -------
    SimpleRecord
        ``moved``, ``lasers`` (M, 3), ``heights`` (M,) with ``M = 2 runs_per_arm len(arms)``.
    """
    machine = machine or RigidBodyMachine.from_dpkm()
    travels = np.broadcast_to(np.asarray(travel, dtype=float), (runs_per_arm,))
    offsets = np.zeros((runs_per_arm, 3)) if start_offsets is None else np.asarray(start_offsets, float)
    if offsets.shape != (runs_per_arm, 3):
        raise InvalidInputError("start_offsets", f"shape ({runs_per_arm}, 3)", f"shape {offsets.shape}")
    moved: list[str] = []
    rows: list[FloatArray] = []
    heights: list[float] = []
    for arm in arms:
        index = ARMS.index(arm)
        for run in range(runs_per_arm):
            pivot = np.tile(machine.reference_heights, (2, 1))
            pivot[1, index] += travels[run]
            solution = machine.forward(heights=pivot, lasers_hint=machine.reference_lasers)
            for point in range(2):
                moved.append(arm)
                rows.append(solution.lasers[point] + offsets[run])
                heights.append(float(travels[run]) if point else 0.0)
    laser_array, height_array = np.array(rows), np.array(heights)
    if height_resolution > 0:
        height_array = np.round(height_array / height_resolution) * height_resolution
    if laser_resolution is not None:
        steps = np.asarray(laser_resolution, dtype=float)
        laser_array = np.round(laser_array / steps) * steps
    return SimpleRecord(tuple(moved), laser_array, height_array)
