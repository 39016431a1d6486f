"""Kinematics of log rows in distances: what a row's three lasers say about its three pivot heights.

Why distances
-------------
A rigid motion carries the three joints of the tetrahedron onto the three pivots exactly when
the two triangles are congruent.  The loop closure of a row (nine equations, six pose
unknowns, :mod:`~pcmm_geo.machine.kinematics._pose_solver`) is therefore equivalent to three
scalar conditions, one per pair of arms ``p = (i, j)`` in :data:`PAIRS`:

``d_p(l) = D_p(H)``,  ``d_p = |J_i - J_j|``,  ``J_i = q_i + (k_i l_i + o_i) w_i``   (tetrahedron frame)

``D_p = |P_i - P_j|``,  ``P_i = c_i + e_i H_i v_i``   (machine frame)

with the joints ``J`` from the lasers ``l`` and the pivots ``P`` from the heights ``H``.  Both
sides are explicit; the pose follows afterwards from the matched triangles (Kabsch).  With
parallel columns ``D_p^2 = b_p^2 + (H_i - H_j)^2``: the lasers see the *squares* of the height
differences (blind at the level pose, mirror poses about it) and never the common height.

Derivatives
-----------
At a consistent state (``d(l) = D(H)``) the pose, lasers and tip are functions of the heights
(and of the geometry ``theta``).  :func:`row_kinematics` linearises the nine closure equations
``R J_i + t - P_i = 0`` in the pose increment (rotation vector on the left, translation) and the
lasers, ``M (dphi, dt, dl) = -(K_H dH + K_theta dtheta)``, and returns
``F = dl/dH``, ``T = dtip/dH`` and, on request, ``dl/dtheta`` and ``dtip/dtheta`` for the
:data:`GEOMETRY_PARAMETERS` (the calibration file's tetrahedron parameters).  They are checked
against central differences in ``tests/machine/test_logproc_geometry.py``.

Examples
--------
>>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
>>> machine = RigidBodyMachine.from_dpkm()
>>> heights = np.array([[400.0, 460.0, 350.0]])
>>> lasers, ok = lasers_for_heights(machine.geometry, heights, machine.reference_lasers[None])
>>> bool(ok[0]), bool(np.allclose(lasers, machine.forward(heights=heights[0]).lasers, atol=1e-9))
(True, True)
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.machine.kinematics import pose_solver as solver

__all__ = [
    "GEOMETRY_PARAMETERS",
    "PAIRS",
    "RowKinematics",
    "joint_distances",
    "lasers_for_heights",
    "pivot_distances",
    "row_kinematics",
]

FloatArray = NDArray[np.float64]

#: the three pairs of arms (a-b, b-c, c-a) whose distances the lasers and the heights must agree on
PAIRS: tuple[tuple[int, int], ...] = ((0, 1), (1, 2), (2, 0))
_FIRST = np.array([i for i, _ in PAIRS])
_SECOND = np.array([j for _, j in PAIRS])
_SLIDER_NAMES = ("point_x", "point_y", "point_z", "direction_x", "direction_y", "direction_z", "laser_scale",
                 "laser_offset")
#: tetrahedron parameters whose covariance a calibration file stores, in its order (``covariance.names``;
#: :data:`pcmm_geo.uncertainty.calibration.MODEL_PARAMETERS`); the tip radius does not move the tip centre
GEOMETRY_PARAMETERS: tuple[str, ...] = (
    *(f"slider_{arm}.{name}" for arm in "abc" for name in _SLIDER_NAMES),
    "tip_center_x", "tip_center_y", "tip_center_z", "tip_radius",
)
#: Newton on the distance equations: stop when every laser step is below this (mm)
_STEP_TOLERANCE = 1e-11
_MAX_ITERATIONS = 50


def _pair_gradients(points: FloatArray, along: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Distances ``(N, 3)`` of the point pairs and their derivatives ``(N, 3, 3)`` by each point's coordinate.

    ``points`` ``(N, 3, 3)`` are the three points of each row; point ``i`` moves along ``along[i]``
    (``(3, 3)``) per unit of its coordinate.
    """
    difference = points[:, _FIRST] - points[:, _SECOND]
    distance = np.linalg.norm(difference, axis=-1)
    unit = difference / distance[..., None]
    gradient = np.zeros((len(points), 3, 3))
    for pair, (i, j) in enumerate(PAIRS):
        gradient[:, pair, i] += unit[:, pair] @ along[i]
        gradient[:, pair, j] -= unit[:, pair] @ along[j]
    return distance, gradient


def joint_distances(geometry: solver.Geometry, lasers: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``(d, dd/dl)``: joint-to-joint distances ``(N, 3)`` (pairs :data:`PAIRS`, mm) for lasers ``(N, 3)``.

    Examples
    --------
    >>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
    >>> g = RigidBodyMachine.from_dpkm().geometry
    >>> d, grad = joint_distances(g, np.array([[50.0, 55.0, 67.0]]))
    >>> d.shape, grad.shape
    ((1, 3), (1, 3, 3))
    """
    along = geometry.laser_scale[:, None] * geometry.slider_directions
    return _pair_gradients(solver.joints_in_tetrahedron(geometry, lasers), along)


def pivot_distances(geometry: solver.Geometry, heights: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``(D, dD/dH)``: pivot-to-pivot distances ``(N, 3)`` (pairs :data:`PAIRS`, mm) for heights ``(N, 3)``."""
    along = geometry.encoder_scale[:, None] * geometry.column_directions
    return _pair_gradients(solver.pivots_in_machine(geometry, heights), along)


def lasers_for_heights(
    geometry: solver.Geometry, heights: FloatArray, start: FloatArray
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Lasers ``(N, 3)`` that fit heights ``(N, 3)`` exactly, by Newton's method from ``start`` ``(N, 3)``.

    The distance equations have several solutions (a slider may sit on either side of the
    point where its line passes closest to its partner's); the one nearest ``start`` (the
    measured lasers, or a previous solution) is returned.  ``converged`` ``(N,)`` is False where
    the iteration did not close the equations to 1e-9 mm (heights no pose can reach).
    """
    target, _ = pivot_distances(geometry, heights)
    lasers = np.array(start, dtype=float, copy=True)
    active = np.ones(len(lasers), dtype=bool)
    for _ in range(_MAX_ITERATIONS):
        distance, gradient = joint_distances(geometry, lasers[active])
        try:
            step = np.linalg.solve(gradient, (distance - target[active])[..., None])[..., 0]
        except np.linalg.LinAlgError:
            break
        step = np.clip(np.nan_to_num(step, nan=0.0), -20.0, 20.0)
        lasers[active] -= step
        still = np.abs(step).max(axis=1) > _STEP_TOLERANCE
        active[np.flatnonzero(active)[~still]] = False
        if not active.any():
            break
    distance, _ = joint_distances(geometry, lasers)
    converged = np.all(np.abs(distance - target) < 1e-9, axis=1) & np.all(np.isfinite(lasers), axis=1)
    return lasers, converged


@record
class RowKinematics:
    """Consistent lasers, pose and tip of ``N`` rows and their derivatives (:func:`row_kinematics`).

    Attributes
    ----------
    lasers : ndarray, shape (N, 3)
        Lasers that fit the heights exactly (mm).
    tips : ndarray, shape (N, 3)
        Probe-tip centres (machine frame, mm).
    laser_gain : ndarray, shape (N, 3, 3)
        ``dl/dH`` (mm/mm): column ``i`` is how the lasers change when pivot ``i`` rises.
    tip_gain : ndarray, shape (N, 3, 3)
        ``dtip/dH`` (mm/mm).
    laser_geometry_gain, tip_geometry_gain : ndarray, shape (N, 3, 28), or None
        ``dl/dtheta`` and ``dtip/dtheta`` for :data:`GEOMETRY_PARAMETERS` (mm per mm, per unit of a
        direction component or a scale).
    converged : ndarray of bool, shape (N,)
    """

    lasers: FloatArray
    tips: FloatArray
    laser_gain: FloatArray
    tip_gain: FloatArray
    laser_geometry_gain: FloatArray | None
    tip_geometry_gain: FloatArray | None
    converged: NDArray[np.bool_]


def row_kinematics(
    geometry: solver.Geometry, heights: FloatArray, start: FloatArray, *, geometry_gains: bool = False
) -> RowKinematics:
    """Lasers, tips and derivatives of rows at heights ``(N, 3)`` (lasers solved from ``start`` ``(N, 3)``).

    See the module notes for the derivatives.  ``geometry_gains`` adds the derivatives by the
    tetrahedron parameters (for the calibration's covariance).
    """
    lasers, converged = lasers_for_heights(geometry, heights, start)
    count = len(lasers)
    joints = solver.joints_in_tetrahedron(geometry, lasers)
    rotation, translation = solver.kabsch(joints, solver.pivots_in_machine(geometry, heights))
    rotated = np.einsum("kij,kaj->kai", rotation, joints)
    slide = geometry.laser_scale * lasers + geometry.laser_offset
    closure = np.zeros((count, 9, 9))
    by_height = np.zeros((count, 9, 3))
    by_geometry = np.zeros((count, 9, len(GEOMETRY_PARAMETERS))) if geometry_gains else None
    eye = np.eye(3)
    for arm in range(3):
        rows = slice(3 * arm, 3 * arm + 3)
        direction = rotation @ geometry.slider_directions[arm]  # (N, 3)
        closure[:, rows, 0:3] = -solver.skew(rotated[:, arm])
        closure[:, rows, 3:6] = eye
        closure[:, rows, 6 + arm] = geometry.laser_scale[arm] * direction
        by_height[:, rows, arm] = -geometry.encoder_scale[arm] * geometry.column_directions[arm]
        if by_geometry is not None:
            base = 8 * arm
            by_geometry[:, rows, base:base + 3] = rotation
            by_geometry[:, rows, base + 3:base + 6] = rotation * slide[:, arm, None, None]
            by_geometry[:, rows, base + 6] = direction * lasers[:, arm, None]
            by_geometry[:, rows, base + 7] = direction
    try:
        inverse = np.linalg.inv(closure)  # regular at every reachable pose
    except np.linalg.LinAlgError:
        inverse = np.linalg.pinv(closure)
    tip_offset = rotation @ geometry.tip_center
    to_tip = np.concatenate([-solver.skew(tip_offset), np.broadcast_to(eye, (count, 3, 3))], axis=2)
    response = -inverse @ by_height
    laser_geometry = tip_geometry = None
    if by_geometry is not None:
        geometry_response = -inverse @ by_geometry
        laser_geometry = geometry_response[:, 6:9]
        tip_geometry = to_tip @ geometry_response[:, 0:6]
        tip_geometry[:, :, 24:27] += rotation
    return RowKinematics(
        lasers=lasers,
        tips=tip_offset + translation,
        laser_gain=response[:, 6:9],
        tip_gain=to_tip @ response[:, 0:6],
        laser_geometry_gain=laser_geometry,
        tip_geometry_gain=tip_geometry,
        converged=converged,
    )
