"""Noise-free measurement logs of the rigid-body model: the constructed truth of log processing.

:func:`synthesise_log` is re-exported by :mod:`pcmm_geo.machine.analysis.logproc`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.machine.analysis.logproc.rows import MeasurementLog
from pcmm_geo.machine.kinematics.model import RigidBodyMachine, as_readings

__all__ = ["synthesise_log"]


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
