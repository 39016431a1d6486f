"""Sensitivity of the probe-tip position to laser and encoder readings over the working cube.

The machine has three degrees of freedom, the three pivot heights ``h`` (motors).
The tip ``X(h)`` and the lasers ``L(h)`` are both functions of them; their Jacobians
``dX/dh`` and ``dL/dh`` (central differences of :meth:`RigidBodyMachine.forward`
with heights only) give:

* ``tip_per_height = dX/dh`` -- encoder-based kinematics;
* ``tip_per_laser = dX/dh (dL/dh)^+`` -- tip change per laser change when the pose is
  inferred from the lasers (the seed's way, thesis 5.2 / Appendix D); directions the
  lasers cannot see are dropped by the pseudo-inverse;
* ``laser_gain``: the largest singular value of ``tip_per_laser`` (mm of tip error per mm
  of laser error), the laser-accuracy-to-tip-error amplification;
* ``motor_ratio[i] = |dX/dh_i| / |dL/dh_i|``: probe movement per laser movement when
  only motor ``i`` moves -- the quantity behind the thesis' "20:1" (6.x: 100 mm of probe
  travel showed 5 mm on the laser, turning 0.05 mm laser accuracy into 1 mm);
* ``path_ratio``: 100 mm (``size``) straight probe paths through the cube center along
  x, y and z divided by the largest laser change along them.

Two structural facts show up (seed geometry, vertical columns): a vertical translation
of the tetrahedron changes no laser (``path_ratio[z]`` infinite), and when the three
pivots are level the pivot distances change only to second order, so ``dL/dh = 0``:
the level pose is a singularity of laser-based kinematics (``laser_gain`` infinite).

Examples
--------
>>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
>>> sens = sensitivity_over_cube(RigidBodyMachine.from_dpkm(), points_per_axis=2)
>>> sens.points.shape, sens.tip_per_laser.shape
((8, 3), (8, 3, 3))
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._deprecation import renamed_fields, renamed_parameters
from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.machine.kinematics.model import RigidBodyMachine, as_readings, as_vector3

__all__ = ["Sensitivity", "sensitivity_over_cube", "tip_jacobian"]

FloatArray = NDArray[np.float64]

#: laser accuracy of the seed's microEpsilon lasers (thesis 3.1), mm
SEED_LASER_ACCURACY = 0.05
#: ``|dL/dh|`` below this (mm/mm) counts as "lasers blind" (finite-difference noise is ~1e-9)
BLIND = 1e-6


@renamed_fields(centre="center")
@record
class Sensitivity:
    """Sensitivities on a grid of ``N`` tip positions.

    Attributes
    ----------
    points : ndarray, shape (N, 3)
        Tip positions (machine frame, mm).
    heights, lasers : ndarray, shape (N, 3)
        Readings at those positions.
    tip_per_height : ndarray, shape (N, 3, 3)
        ``dX/dh`` (rows x, y, z; columns motors a, b, c), mm/mm.
    laser_per_height : ndarray, shape (N, 3, 3)
        ``dL/dh`` (rows lasers a, b, c; columns motors), mm/mm.
    tip_per_laser : ndarray, shape (N, 3, 3)
        ``dX/dh (dL/dh)^+``, mm/mm; NaN where the lasers are blind.
    laser_gain, height_gain : ndarray, shape (N,)
        Largest singular values of ``tip_per_laser`` (inf where blind) and ``tip_per_height``.
    motor_ratio : ndarray, shape (N, 3)
        ``|dX/dh_i| / |dL/dh_i|`` per motor (inf where blind).
    path_ratio : ndarray, shape (3,)
        ``size`` / largest laser change for straight probe paths along x, y, z through the center.
    center : ndarray, shape (3,)
    size : float
        Edge of the cube (mm).
    laser_accuracy : float
        Laser accuracy used for ``tip_error`` (mm).
    """

    points: FloatArray
    heights: FloatArray
    lasers: FloatArray
    tip_per_height: FloatArray
    laser_per_height: FloatArray
    tip_per_laser: FloatArray
    laser_gain: FloatArray
    height_gain: FloatArray
    motor_ratio: FloatArray
    path_ratio: FloatArray
    center: FloatArray
    size: float
    laser_accuracy: float

    @property
    def tip_error(self) -> FloatArray:
        """Worst-case first-order tip error from the laser accuracy, ``laser_accuracy * laser_gain`` (N,), mm."""
        return self.laser_accuracy * self.laser_gain

    def summary(self) -> dict[str, Any]:
        """JSON-ready summary (max / median over the finite values, count of blind points)."""

        def stats(values: FloatArray) -> dict[str, Any]:
            finite = values[np.isfinite(values)]
            return {
                "median": float(np.median(finite)) if finite.size else None,
                "max_finite": float(finite.max()) if finite.size else None,
                "infinite": int(np.sum(~np.isfinite(values))),
            }

        return {
            "center": self.center.tolist(),
            "size_mm": self.size,
            "points": int(self.points.shape[0]),
            "laser_accuracy_mm": self.laser_accuracy,
            "laser_gain": stats(self.laser_gain),
            "tip_error_mm": stats(self.tip_error),
            "height_gain": stats(self.height_gain),
            "motor_ratio": {arm: stats(self.motor_ratio[:, k]) for k, arm in enumerate("abc")},
            "path_ratio": {axis: float(self.path_ratio[k]) for k, axis in enumerate("xyz")},
        }


def tip_jacobian(
    machine: RigidBodyMachine, heights: ArrayLike, *, step: float = 1e-3
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Central-difference Jacobians at height readings ``(N, 3)``.

    Returns
    -------
    tip_per_height, laser_per_height : ndarray, shape (N, 3, 3)
    tips, lasers : ndarray, shape (N, 3)

    Raises
    ------
    InvalidInputError
        Bad heights or a non-positive step.

    Examples
    --------
    >>> m = RigidBodyMachine.from_dpkm()
    >>> jx, jl, _, _ = tip_jacobian(m, m.reference_heights[None] + [[0.0, 40.0, -30.0]])
    >>> (np.round(jx[0] @ np.ones(3), 6) + 0.0).tolist()  # all motors up 1 mm: tip up 1 mm
    [0.0, 0.0, 1.0]
    """
    if not (np.isfinite(step) and step > 0):
        raise InvalidInputError("step", "a positive finite number (mm)", str(step))
    base = as_readings(heights, "heights").reshape(-1, 3)
    offsets = np.zeros((6, 3))
    for arm in range(3):
        offsets[2 * arm, arm] = step
        offsets[2 * arm + 1, arm] = -step
    center = machine.forward(heights=base)  # checks the heights against the machine's limits
    # the +-step differences may step just past a travel end: they probe the model, not the machine
    perturbed = machine.forward(heights=base[:, None, :] + offsets, check_limits=False)
    tip_per_height = np.swapaxes(perturbed.tip[:, 0::2] - perturbed.tip[:, 1::2], 1, 2) / (2 * step)
    laser_per_height = np.swapaxes(perturbed.lasers[:, 0::2] - perturbed.lasers[:, 1::2], 1, 2) / (2 * step)
    return tip_per_height, laser_per_height, center.tip, center.lasers


@renamed_parameters(centre="center")
def sensitivity_over_cube(
    machine: RigidBodyMachine | None = None,
    *,
    center: ArrayLike | None = None,
    size: float = 100.0,
    points_per_axis: int = 5,
    step: float = 1e-3,
    laser_accuracy: float = SEED_LASER_ACCURACY,
) -> Sensitivity:
    """Sensitivities on a regular grid over the working cube.

    Parameters
    ----------
    machine : RigidBodyMachine, optional
        Default: :meth:`RigidBodyMachine.from_dpkm` (thesis Table 3.1 geometry).
    center : array_like, shape (3,), optional
        Cube center (default: the tip at the machine's reference heights).
    size : float
        Cube edge, 100 mm (thesis 2.6.3).
    points_per_axis : int
        Grid points per axis (>= 2).
    step : float
        Central-difference step on the heights (mm).
    laser_accuracy : float
        Laser accuracy for :attr:`Sensitivity.tip_error` (0.05 mm, thesis 3.1).

    Returns
    -------
    Sensitivity

    Raises
    ------
    InvalidInputError
        Non-positive size or accuracy, fewer than 2 points per axis.
    OutOfRangeError, NoRealSolutionError
        The cube leaves the machine's workspace (column travel, laser range; see
        :mod:`pcmm_geo.machine.kinematics.limits`).

    Examples
    --------
    >>> sens = sensitivity_over_cube(points_per_axis=2)
    >>> bool(sens.path_ratio[1] > 5.0)  # the probe moves far more than any laser
    True
    """
    machine = RigidBodyMachine.from_dpkm() if machine is None else machine
    if not (np.isfinite(size) and size > 0):
        raise InvalidInputError("size", "a positive cube edge (mm)", str(size))
    if not (np.isfinite(laser_accuracy) and laser_accuracy > 0):
        raise InvalidInputError("laser_accuracy", "a positive accuracy (mm)", str(laser_accuracy))
    if int(points_per_axis) < 2:
        raise InvalidInputError("points_per_axis", "at least 2", str(points_per_axis))
    middle = (
        machine.forward(heights=machine.reference_heights).tip if center is None else as_vector3(center, "center")
    )
    axis = np.linspace(-size / 2, size / 2, int(points_per_axis))
    grid = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3) + middle
    heights = machine.inverse(grid).heights
    tip_per_height, laser_per_height, tips, lasers = tip_jacobian(machine, heights, step=step)
    laser_sv = np.linalg.svd(laser_per_height, compute_uv=False)
    blind = laser_sv[:, 0] < BLIND
    pinv = np.linalg.pinv(laser_per_height, rcond=1e-6)
    tip_per_laser = tip_per_height @ pinv
    tip_per_laser[blind] = np.nan
    laser_gain = np.where(blind, np.inf, np.linalg.svd(np.nan_to_num(tip_per_laser), compute_uv=False)[:, 0])
    height_gain = np.linalg.svd(tip_per_height, compute_uv=False)[:, 0]
    laser_norm = np.linalg.norm(laser_per_height, axis=1)
    with np.errstate(divide="ignore"):
        motor_ratio = np.where(laser_norm < BLIND, np.inf, np.linalg.norm(tip_per_height, axis=1) / laser_norm)
    path_ratio = np.empty(3)
    for k in range(3):
        path = np.zeros((2, 3))
        path[:, k] = (-size / 2, size / 2)
        ends = machine.inverse(middle + path).lasers
        change = float(np.abs(ends[1] - ends[0]).max())
        path_ratio[k] = np.inf if change < BLIND * size else size / change
    return Sensitivity(
        points=tips,
        heights=heights,
        lasers=lasers,
        tip_per_height=tip_per_height,
        laser_per_height=laser_per_height,
        tip_per_laser=tip_per_laser,
        laser_gain=laser_gain,
        height_gain=height_gain,
        motor_ratio=motor_ratio,
        path_ratio=path_ratio,
        center=middle,
        size=float(size),
        laser_accuracy=float(laser_accuracy),
    )
