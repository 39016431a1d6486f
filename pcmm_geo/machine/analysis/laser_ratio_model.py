"""What the rigid-body geometry predicts for the height per laser displacement (thesis 6.3, Table 6.8).

The thesis expects the ratios of eq 6.3 to be equal ("theoretically these ratios should be the
same").  The rigid-body model (:class:`~pcmm_geo.machine.kinematics.model.RigidBodyMachine`) says
more: starting from level pivots, the laser of the moved arm changes with the *square* of the rise
at first (the pivot distance grows as ``sqrt(b^2 + h^2)``), so the ratio is far from constant --
about 20 for a 25 mm rise and 5.2-5.6 for 100 mm with the thesis geometry -- and it differs between
arms with their geometry (column positions, arm angles, dead distances).

- :func:`predicted_height_per_laser` -- the model's ``delta_h / delta_l`` for one arm moved alone;
- :func:`predict_arm` -- that, plus its change per mm of travel and per mm of start-laser offset;
- :func:`ratio_table_summary` -- per-arm statistics of a printed ratio table (Table 6.8) next to
  the prediction for the nominal travel; :func:`read_ratio_table_csv` reads such a table;
- :func:`synthesise_ratio_record` -- a model-generated height-gauge record of known ratio.

Examples
--------
>>> machine = RigidBodyMachine.from_dpkm()
>>> [round(float(predicted_height_per_laser(machine, arm, 0.0, 100.0)), 2) for arm in "abc"]
[5.24, 5.29, 5.55]
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError, NoRealSolutionError
from pcmm_geo.machine.analysis.repeatability import ARMS, ArmStatistics, arm_statistics, read_arm_table_csv
from pcmm_geo.machine.kinematics.model import RigidBodyMachine

__all__ = [
    "RATIO_TABLE_HEADER",
    "ArmPrediction",
    "RatioTableSummary",
    "SimpleRecord",
    "predict_arm",
    "predicted_height_per_laser",
    "ratio_table_summary",
    "read_ratio_table_csv",
    "synthesise_ratio_record",
]

FloatArray = NDArray[np.float64]
RATIO_TABLE_HEADER = ("test", "ratio_a", "ratio_b", "ratio_c")


DEFAULT_MODEL_NAME = "thesis geometry (Table 3.1 / Appendix D, RigidBodyMachine.from_dpkm)"


@record
class SimpleRecord:
    """A height-gauge record in memory: ``moved`` (M,), ``lasers`` (M, 3) mm, ``heights`` (M,) mm."""

    moved: tuple[str, ...]
    lasers: FloatArray
    heights: FloatArray


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
    per_mm_start_height : float
        Change of the predicted ratio when the whole run starts 1 mm higher (same rise), 1/mm: how
        much a start that is not level moves the ratio.
    per_mm_start_laser : float
        Change of the measured ratio per mm of offset in the start laser reading
        (``-ratio / delta_l``), 1/mm: how much a settling offset (Table 6.7) moves the ratio.

    Examples
    --------
    >>> round(predict_arm(RigidBodyMachine.from_dpkm(), "c", 0.0, 100.0).height_per_laser, 2)
    5.55
    """

    arm: str
    height_start: float
    height_finish: float
    height_per_laser: float
    per_mm_travel: float
    per_mm_start_height: float
    per_mm_start_laser: float


def predicted_height_per_laser(machine: RigidBodyMachine, arm: str, height_start: ArrayLike,
                               height_finish: ArrayLike) -> FloatArray:
    """The model's ``delta_h / delta_l`` for ``arm`` moved alone (others at the reference heights).

    Heights are relative to the machine's reference heights (the level start), mm; arrays broadcast.

    Raises
    ------
    NoRealSolutionError
        The model finds no pose for a start or finish height (out of reach).
    InvalidInputError
        An unknown arm, or heights at which the model's laser is the same (equal, or mirrored
        about level: the laser sees the square of the rise there).

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
        raise NoRealSolutionError(f"model pose of arm {arm} moved from {float(start.min()):g} to "
                                  f"{float(finish.max()):g} mm", detail="heights out of the model's reach")
    laser = solution.lasers[..., index]
    change = laser[0] - laser[1]
    if np.any(np.abs(change) < 1e-9):  # mm; far below any laser step
        raise InvalidInputError(f"heights of arm {arm}", "a start and finish at which the model's laser differs "
                                "(not equal, not mirrored about level)", f"{start.ravel()} and {finish.ravel()} mm")
    return np.asarray((both[0] - both[1]) / change).reshape(start.shape)


def predict_arm(machine: RigidBodyMachine, arm: str, height_start: float, height_finish: float,
                laser_change: float | None = None) -> ArmPrediction:
    """The model's ratio for ``arm`` moved alone from ``height_start`` to ``height_finish`` (mm).

    ``per_mm_travel`` is a central difference over +-0.5 mm of the finish height,
    ``per_mm_start_height`` one over +-0.5 mm of both heights;
    ``per_mm_start_laser`` uses ``laser_change`` (the measured ``delta_l``, mm) or, when None, the
    model's own.

    Examples
    --------
    >>> p = predict_arm(RigidBodyMachine.from_dpkm(), "a", 0.0, 100.0)
    >>> round(p.height_per_laser, 3), round(p.per_mm_travel, 4), round(p.per_mm_start_height, 3)
    (5.239, -0.0487, -0.101)
    """
    ratio = float(predicted_height_per_laser(machine, arm, height_start, height_finish))
    step = 0.5 * float(np.sign(height_finish - height_start))
    more = predicted_height_per_laser(machine, arm, height_start, height_finish + step)
    less = predicted_height_per_laser(machine, arm, height_start, height_finish - step)
    per_travel = float((more - less) / (2.0 * abs(step)))
    higher = predicted_height_per_laser(machine, arm, height_start + 0.5, height_finish + 0.5)
    lower = predicted_height_per_laser(machine, arm, height_start - 0.5, height_finish - 0.5)
    per_start = float(higher - lower)
    delta_l = (height_start - height_finish) / ratio if laser_change is None else float(laser_change)
    return ArmPrediction(arm, float(height_start), float(height_finish), ratio, per_travel, per_start,
                         -ratio / delta_l)


@record
class RatioTableSummary:
    """Per-arm statistics of a printed table of ratios (Table 6.8) and the model's expectation.

    Attributes
    ----------
    labels : tuple of str
        Row labels (tests).
    ratios : ndarray, shape (K, 3)
        ``delta_h / delta_l`` per test (rows) and arm a, b, c (columns).
    arms : tuple of ArmStatistics
        Arms a, b, c (unit ``"1"``): ``sigma_sample`` (ddof 1) and ``sigma_population`` (ddof 0).
    predictions : tuple of ArmPrediction
        The model's ratio for each arm raised from level by ``travel``.
    travel : float
        Nominal rise of the runs, mm (Table 6.8: "approximately 0 mm to 100 mm").
    model : str
    """

    labels: tuple[str, ...]
    ratios: FloatArray
    arms: tuple[ArmStatistics, ...]
    predictions: tuple[ArmPrediction, ...]
    travel: float
    model: str

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {
            "quantity": "height_per_laser = delta_h / delta_l (thesis eq 6.3)", "unit": "mm/mm",
            "labels": list(self.labels), "ratios": self.ratios.tolist(),
            "arms": {stats.arm: stats.as_dict() for stats in self.arms},
            "predictions": {p.arm: dict(p.__dict__) for p in self.predictions},
            "travel_mm": self.travel, "model": self.model,
        }


def read_ratio_table_csv(path: str | Path) -> tuple[tuple[str, ...], FloatArray]:
    """Read ``test,ratio_a,ratio_b,ratio_c`` rows (``#`` comments allowed): labels and (K, 3) ratios.

    Raises
    ------
    FileFormatError
        Wrong header or fields, with the line number.
    """
    return read_arm_table_csv(path, RATIO_TABLE_HEADER)


def ratio_table_summary(ratios: ArrayLike, labels: Sequence[str] | None = None, *, travel: float = 100.0,
                        machine: RigidBodyMachine | None = None, model_name: str = "") -> RatioTableSummary:
    """Statistics of a (K, 3) table of ``delta_h / delta_l`` and the model's ratio for a ``travel`` rise.

    Raises
    ------
    InvalidInputError
        Not (K, 3), labels of another length, travel not positive.
    TooFewPointsError
        Fewer than two rows.

    Examples
    --------
    Thesis Table 6.8 (printed under the inverted header ``l/h``):

    >>> table = [[5.03, 6.20, 5.53], [5.12, 6.31, 5.58], [5.39, 6.34, 5.61], [5.39, 6.30, 5.58], [5.56, 6.41, 5.65]]
    >>> summary = ratio_table_summary(table)
    >>> [round(arm.sigma_population, 3) for arm in summary.arms], [round(arm.sigma_sample, 3) for arm in summary.arms]
    ([0.194, 0.068, 0.039], [0.217, 0.076, 0.044])
    """
    data = np.asarray(ratios, dtype=float)
    if data.ndim != 2 or data.shape[1] != 3:
        raise InvalidInputError("ratio table", "shape (K, 3): arms a, b, c per test", f"shape {data.shape}")
    if not (np.isfinite(travel) and travel > 0):
        raise InvalidInputError("travel", "a positive rise in mm", repr(travel))
    names = tuple(f"test {k + 1}" for k in range(len(data))) if labels is None else tuple(map(str, labels))
    if len(names) != len(data):
        raise InvalidInputError("labels", f"{len(data)} labels", f"{len(names)}")
    if machine is None:
        machine = RigidBodyMachine.from_dpkm()
        model_name = model_name or DEFAULT_MODEL_NAME
    arms = tuple(arm_statistics(data[:, k], arm, unit="1") for k, arm in enumerate(ARMS))
    predictions = tuple(predict_arm(machine, arm, 0.0, float(travel)) for arm in ARMS)
    return RatioTableSummary(names, data, arms, predictions, float(travel), model_name)


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
