"""Building blocks of the rigid-body model: slider lines, tetrahedron, column lines, input checks.

Re-exported by :mod:`pcmm_geo.machine.kinematics.model`; import them from there.

Examples
--------
>>> from pcmm_geo.machine.kinematics.model_parts import SliderLine
>>> SliderLine([0, 0, 0], [0, 0, 1], laser_offset=60.0).joint(10.0).tolist()
[0.0, 0.0, 70.0]
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._deprecation import renamed_fields
from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError

__all__ = [
    "ARMS",
    "ColumnLine",
    "ForwardSolution",
    "InverseSolution",
    "SliderLine",
    "Tetrahedron",
    "as_readings",
    "as_vector3",
    "check_arm_keys",
]

FloatArray = NDArray[np.float64]

#: arm / column / laser labels, clockwise seen from above (thesis 2.6.4)
ARMS: tuple[str, str, str] = ("a", "b", "c")


def as_vector3(value: ArrayLike, name: str, *, unit_length: bool = False) -> FloatArray:
    """Validate one finite 3-vector (optionally normalised to unit length).

    Raises
    ------
    InvalidInputError
        Not 3 finite numbers, or zero length when ``unit_length``.
    """
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInputError(name, "3 numbers", repr(value)) from None
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise InvalidInputError(name, "3 finite numbers (shape (3,))", f"{arr.tolist()} (shape {arr.shape})")
    if unit_length:
        norm = float(np.linalg.norm(arr))
        if norm == 0.0:
            raise InvalidInputError(name, "a non-zero direction", "the zero vector")
        arr = arr / norm
    return arr


def as_readings(value: ArrayLike, name: str) -> FloatArray:
    """Validate readings of shape ``(..., 3)`` (arm order a, b, c) and return float64.

    Raises
    ------
    InvalidInputError
        Wrong last dimension, non-numeric, NaN or inf.
    """
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInputError(name, "an array of numbers of shape (..., 3)", type(value).__name__) from None
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise InvalidInputError(name, "shape (..., 3) in arm order a, b, c", f"shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(name, "finite values", "NaN or inf")
    return arr


def check_arm_keys(mapping: Mapping[str, Any], name: str) -> None:
    if set(mapping) != set(ARMS):
        raise InvalidInputError(name, "keys 'a', 'b', 'c'", f"keys {sorted(mapping)}")


@record
class SliderLine:
    """Line of one arm's slider in the tetrahedron frame.

    Attributes
    ----------
    point : ndarray, shape (3,)
        Joint centre when ``s = 0`` (mm).
    direction : ndarray, shape (3,)
        Unit vector from the tip side towards the joint.
    laser_scale, laser_offset : float
        ``s = laser_scale * laser_reading + laser_offset`` (mm).  For the seed
        ``laser_offset`` = start of range (60 mm) + dead distance ``d_i``.
    """

    point: FloatArray
    direction: FloatArray
    laser_scale: float = 1.0
    laser_offset: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "point", as_vector3(self.point, "slider_line.point"))
        object.__setattr__(self, "direction", as_vector3(self.direction, "slider_line.direction", unit_length=True))
        if not (np.isfinite(self.laser_scale) and self.laser_scale != 0 and np.isfinite(self.laser_offset)):
            raise InvalidInputError(
                "slider_line", "finite non-zero laser_scale and finite laser_offset", f"{self.laser_scale}, "
                f"{self.laser_offset}"
            )

    def joint(self, laser: ArrayLike) -> FloatArray:
        """Joint centre ``(..., 3)`` (tetrahedron frame, mm) for laser readings ``(...,)``.

        Examples
        --------
        >>> SliderLine([0, 0, 0], [0, 0, 2], laser_offset=10.0).joint(5.0).tolist()
        [0.0, 0.0, 15.0]
        """
        slide = self.laser_scale * np.asarray(laser, dtype=float) + self.laser_offset
        return self.point + slide[..., None] * self.direction


@renamed_fields(tip_centre="tip_center")
@record
class Tetrahedron:
    """The rigid tetrahedron: three slider lines and the probe-tip centre (tetrahedron frame)."""

    sliders: Mapping[str, SliderLine]
    tip_center: FloatArray

    def __post_init__(self) -> None:
        check_arm_keys(self.sliders, "tetrahedron.sliders")
        object.__setattr__(self, "sliders", {arm: self.sliders[arm] for arm in ARMS})
        object.__setattr__(self, "tip_center", as_vector3(self.tip_center, "tetrahedron.tip_center"))

    def dead_distance(self, lasers: ArrayLike) -> FloatArray:
        """Tip-to-joint distances ``(..., 3)`` (mm) for laser readings ``(..., 3)``.

        Constant minus the laser reading only when the slider lines meet at the tip
        (the seed's assumption, erratum 9).
        """
        readings = as_readings(lasers, "lasers")
        joints = np.stack([self.sliders[arm].joint(readings[..., k]) for k, arm in enumerate(ARMS)], axis=-2)
        return np.linalg.norm(joints - self.tip_center, axis=-1)


@record
class ColumnLine:
    """Line of one pivot (spherical joint) in the machine frame (seed eqs 2.19-2.20).

    Attributes
    ----------
    point : ndarray, shape (3,)
        Pivot centre at ``z = 0`` (mm).
    direction : ndarray, shape (3,)
        Unit vector, upwards.
    encoder_scale : float
        Distance along the column per unit of height reading, ``z = encoder_scale * height``.
    """

    point: FloatArray
    direction: FloatArray
    encoder_scale: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "point", as_vector3(self.point, "column_line.point"))
        object.__setattr__(self, "direction", as_vector3(self.direction, "column_line.direction", unit_length=True))
        if not (np.isfinite(self.encoder_scale) and self.encoder_scale != 0):
            raise InvalidInputError("column_line.encoder_scale", "a finite non-zero number", str(self.encoder_scale))

    def pivot(self, height: ArrayLike) -> FloatArray:
        """Pivot centre ``(..., 3)`` (machine frame, mm) for height readings ``(...,)``.

        Examples
        --------
        >>> ColumnLine([1, 2, 0], [0, 0, 1]).pivot(400.0).tolist()
        [1.0, 2.0, 400.0]
        """
        along = self.encoder_scale * np.asarray(height, dtype=float)
        return self.point + along[..., None] * self.direction


@record
class ForwardSolution:
    """Result of :meth:`RigidBodyMachine.forward` (leading shape ``...`` of the input).

    Attributes
    ----------
    tip : ndarray, shape (..., 3)
        Probe-tip centre in the machine frame (mm).
    rotation : ndarray, shape (..., 3, 3)
        Pose rotation, tetrahedron frame -> machine frame.
    translation : ndarray, shape (..., 3)
        Pose translation (mm).
    lasers, heights : ndarray, shape (..., 3)
        Readings as solved (equal to the measured ones when the data are consistent).
    residuals : ndarray, shape (..., 9)
        Loop closure ``T(q_i + s_i w_i) - (c_i + z_i v_i)`` for arms a, b, c (x, y, z each, mm)
        evaluated with the *measured* readings where given and the solved ones otherwise.
        Zero when only one kind of reading is given; shows inconsistency when both are.
    converged : ndarray of bool, shape (...)
    iterations : int
        Gauss-Newton iterations used for the batch.
    """

    tip: FloatArray
    rotation: FloatArray
    translation: FloatArray
    lasers: FloatArray
    heights: FloatArray
    residuals: FloatArray
    converged: NDArray[np.bool_]
    iterations: int


@record
class InverseSolution:
    """Result of :meth:`RigidBodyMachine.inverse`: readings that put the tip at the target.

    Attributes
    ----------
    heights, lasers : ndarray, shape (..., 3)
    rotation : ndarray, shape (..., 3, 3)
    translation : ndarray, shape (..., 3)
    converged : ndarray of bool, shape (...)
    iterations : int
    """

    heights: FloatArray
    lasers: FloatArray
    rotation: FloatArray
    translation: FloatArray
    converged: NDArray[np.bool_]
    iterations: int
