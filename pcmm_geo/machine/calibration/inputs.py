"""Checks of calibration inputs given as arrays, shared by the typed inputs and the calibration.

:func:`points_by_role` puts probed points given per arm into the ``{(feature, position): (N, 3)}``
form of :meth:`~pcmm_geo.machine.calibration.probings.ProbedFeatures.from_points`;
:func:`check_readings` checks laser readings (:meth:`~pcmm_geo.machine.calibration.probings.\
LaserTable.from_readings`, the sweep of :func:`~pcmm_geo.machine.calibration.calibrate_tetrahedron`).

Examples
--------
>>> sorted(points_by_role({"joint_a": [[[0.0, 0, 0]]], "tip": [[1.0, 0, 0]]}))
[('joint_a', 1), ('tip', None)]
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.errors import InvalidInputError

__all__ = ["check_readings", "points_by_role"]


def points_by_role(probings: Mapping[Any, Any]) -> dict[tuple[str, int | None], Any]:
    """Probed points by arm: ``{"joint_a": [(N, 3) per position] or {position: (N, 3)}, ..., "tip": (N, 3)}``
    as ``{(feature, position): (N, 3)}``.

    Raises
    ------
    InvalidInputError
        A key that is none of ``joint_a``, ``joint_b``, ``joint_c``, ``tip`` or a tuple.
    """
    points: dict[tuple[str, int | None], Any] = {}
    for key, value in probings.items():
        if isinstance(key, tuple):
            points[key] = value
        elif key == "tip":
            points[("tip", None)] = value
        elif key in ("joint_a", "joint_b", "joint_c"):
            items = value.items() if isinstance(value, Mapping) else enumerate(value, start=1)
            for position, pts in items:
                points[(key, int(position))] = pts
        else:
            raise InvalidInputError(
                "probings", "keys 'joint_a', 'joint_b', 'joint_c', 'tip' or (feature, position)", repr(key)
            )
    return points


def check_readings(value: Any, count: int | None, name: str) -> NDArray[np.float64]:
    """Laser readings as a finite (K, 3) array (``count`` rows when given).

    Raises
    ------
    InvalidInputError
        Another shape, NaN or inf; ``what`` is ``name``.
    """
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInputError(name, "laser readings of shape (K, 3)", type(value).__name__) from None
    if arr.ndim != 2 or arr.shape[1] != 3 or (count is not None and arr.shape[0] != count):
        want = f"({count}, 3)" if count is not None else "(M, 3)"
        raise InvalidInputError(name, f"laser readings of shape {want} (arms a, b, c)", f"shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(name, "finite laser readings", "NaN or inf")
    return arr
