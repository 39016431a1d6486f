"""Logs of known truth for testing log processing: noise-free synthesis, added laser noise, a faulty reading.

:func:`synthesise_log` is re-exported by :mod:`pcmm_geo.machine.analysis.logproc`;
:func:`with_laser_noise` and :func:`with_reading_fault` turn a clean log (synthesised, or written
by the simulated machine, ``pcmm acquire --simulate``) into the logs of a noisy or faulty session.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.machine.analysis.logproc.rows import MeasurementLog
from pcmm_geo.machine.kinematics.model import RigidBodyMachine, as_readings

__all__ = ["synthesise_log", "with_laser_noise", "with_reading_fault"]


def synthesise_log(
    machine: RigidBodyMachine,
    initial_heights: ArrayLike,
    moves: Sequence[tuple[int, float, bool]],
) -> MeasurementLog:
    """Noise-free log of single-motor moves computed with the rigid-body model.

    Each move ``(motor, height_change, probe)`` adds a start row (lasers before the move,
    ``direction = sign(height_change)``) and a stop row (lasers after it) whose probe flag
    is ``probe``.  Lasers come from :meth:`RigidBodyMachine.forward` with heights only.

    Raises
    ------
    InvalidInputError
        Motor not 1, 2 or 3.

    Examples
    --------
    >>> m = RigidBodyMachine.from_dpkm()
    >>> len(synthesise_log(m, m.reference_heights, [(3, 2.0, True)]))
    2
    """
    heights = [as_readings(initial_heights, "initial_heights").astype(float)]
    flags: list[tuple[int, int, int, int]] = []
    for motor, change, touching in moves:
        if motor not in (1, 2, 3):
            raise InvalidInputError("motor", "1, 2 or 3", repr(motor))
        direction = int(np.sign(change))
        flags.append((1, 0, motor, direction))
        heights.append(heights[-1])
        after = heights[-1].copy()
        after[motor - 1] += change
        flags.append((0, int(bool(touching)), motor, direction))
        heights.append(after)
    state_heights = np.array(heights[1:])
    lasers = machine.forward(heights=state_heights).lasers
    table = np.array(flags, dtype=np.int64).reshape(-1, 4)
    return MeasurementLog(table[:, 0], table[:, 1], table[:, 2], table[:, 3], lasers)


def with_reading_fault(log: MeasurementLog, row: int, arm: int, size: float) -> MeasurementLog:
    """``log`` with ``size`` mm added to the reading of laser ``arm`` (0, 1, 2) on row ``row`` (0-based) only.

    A start row that repeated that reading no longer does: like a real faulty reading, the fault
    is in one read of the sensor.

    Examples
    --------
    >>> log = MeasurementLog([1, 0], [0, 1], [2, 2], [1, 1], [[50.0, 51.0, 52.0], [50.5, 52.0, 52.1]])
    >>> with_reading_fault(log, 1, 2, 0.3).lasers[:, 2].tolist()
    [52.0, 52.4]
    """
    if not (0 <= row < len(log) and arm in (0, 1, 2)):
        raise InvalidInputError("row/arm", f"a row in [0, {len(log)}) and an arm 0, 1 or 2", f"{row}, {arm}")
    lasers = log.lasers.copy()
    lasers[row, arm] += size
    return MeasurementLog(log.start_stop, log.probe, log.motor, log.direction, lasers)


def with_laser_noise(
    log: MeasurementLog,
    rng: np.random.Generator,
    sigma: float,
    steps: Sequence[float] | None = None,
    *,
    start_of_scale: float = 2.0,
) -> MeasurementLog:
    """``log`` with Gaussian noise ``sigma`` (mm) on every reading, each row read afresh, then rounded to ``steps``.

    Every row is a new read of the sensors (a start row no longer repeats the row before it).
    ``steps`` (mm, lasers a, b, c) rounds each value as the sensors' digital output does:
    ``raw = round((l + start_of_scale) / q)``, ``l = raw q - start_of_scale`` (2 mm: the optoNCDT
    scale starts at -1 % of the 200 mm range).
    """
    lasers = log.lasers + rng.normal(0.0, sigma, log.lasers.shape)
    if steps is not None:
        step = np.asarray(steps, dtype=float)
        lasers = np.round((lasers + start_of_scale) / step) * step - start_of_scale
    return MeasurementLog(log.start_stop, log.probe, log.motor, log.direction, lasers)
