"""Thermal expansion applied to the rigid-body machine model, then forward kinematics re-solved.

:func:`expand_rigid_body_machine` returns a warmed copy of a
:class:`pcmm_geo.machine.kinematics.model.RigidBodyMachine` (passed in; this layer does not import the
machine package, it only uses the object's fields and ``dataclasses.replace``):

* frame -- the plan triangle of the column points deforms with the temperatures of its
  sides a-b, a-c, b-c (:func:`~pcmm_geo.thermal.triangle.deform_triangle`: column a pinned,
  column b sliding along ``slide_direction``), the columns follow;
* columns -- each column lengthens from its base: for a base at height reading ``z0`` the
  pivot ``c + e z v`` becomes ``c + e z0 v + e (1 + α ΔT)(z − z0) v``;
* arms -- each arm lengthens about the probe tip: its slider line point, laser scale and
  laser offset are scaled by ``1 + α ΔT`` about the tip centre (the whole tip-to-joint
  distance grows by ``α ΔT``).

:func:`rigid_body_tip_displacement` finds the readings that put the cold machine's tip at a
point (inverse kinematics), then the warmed machine's true tip for the same readings of one
kind (forward kinematics): ``readings="heights"`` -- the motors hold the pivots, the rigid
tetrahedron settles where its slider lines pass through them (the physical situation; arm
expansion about the tip leaves the lines, hence the tip, where they were and only changes
what the lasers read); ``readings="lasers"`` -- the slide positions are held and the pivots
find their heights.  Using both kinds at once over-determines the warmed machine, so it is
not offered.

The tetrahedron here is rigid, whereas the closed-form model of
:mod:`pcmm_geo.thermal.physical` (the seed's DPKM) lets each arm swing freely about the tip;
the two agree exactly where the rigid body can follow a similarity (uniform temperature) or
a translation (equal column growth), and differ otherwise -- that difference is the
modelling question the seed's eqs 4.10-4.17 never faced.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.thermal.expansion import ALPHA_ALUMINIUM, REFERENCE_TEMPERATURE
from pcmm_geo.thermal.probe_error import fixed_shape_array
from pcmm_geo.thermal.triangle import deform_triangle

__all__ = ["expand_rigid_body_machine", "rigid_body_tip_displacement"]

FloatArray = NDArray[np.float64]
_ARMS = ("a", "b", "c")


def expand_rigid_body_machine(
    machine: Any,
    *,
    frame_temperatures: ArrayLike = (20.0, 20.0, 20.0),
    column_temperatures: ArrayLike = (20.0, 20.0, 20.0),
    arm_temperatures: ArrayLike = (20.0, 20.0, 20.0),
    alpha_frame: float = ALPHA_ALUMINIUM,
    alpha_column: float = ALPHA_ALUMINIUM,
    alpha_arm: float = ALPHA_ALUMINIUM,
    column_base_heights: ArrayLike = (0.0, 0.0, 0.0),
    slide_direction: ArrayLike = (1.0, 0.0),
    reference_temperature: float = REFERENCE_TEMPERATURE,
) -> Any:
    """A copy of a ``RigidBodyMachine`` with its frame, columns and arms thermally expanded.

    Parameters
    ----------
    machine : RigidBodyMachine
        Nominal (20 °C) machine (:mod:`pcmm_geo.machine.kinematics.model`).
    frame_temperatures : array_like, shape (3,)
        Frame sides between columns a-b, a-c, b-c (°C).
    column_temperatures, arm_temperatures : array_like, shape (3,)
        Members of arms a, b, c (°C).
    alpha_frame, alpha_column, alpha_arm : float
        Expansion coefficients (1/K).
    column_base_heights : array_like, shape (3,)
        Height readings at which each column is fixed to the frame (its expansion origin).
    slide_direction : array_like, shape (2,)
        Direction in which column b's foot may slide (plan view).
    reference_temperature : float
        °C.

    Returns
    -------
    RigidBodyMachine
        Same type as ``machine``.

    Raises
    ------
    InvalidInputError, NoRealSolutionError
        Bad shapes or impossible frame lengths.

    Examples
    --------
    >>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
    >>> cold = RigidBodyMachine.from_dpkm()
    >>> hot = expand_rigid_body_machine(cold, column_temperatures=[21.0, 21.0, 21.0])
    >>> round(float(hot.columns["a"].encoder_scale - cold.columns["a"].encoder_scale), 10)
    2.31e-05
    """
    t_frame = fixed_shape_array(frame_temperatures, "frame_temperatures", (3,))
    t_col = fixed_shape_array(column_temperatures, "column_temperatures", (3,))
    t_arm = fixed_shape_array(arm_temperatures, "arm_temperatures", (3,))
    bases = fixed_shape_array(column_base_heights, "column_base_heights", (3,))
    try:
        columns = [machine.columns[arm] for arm in _ARMS]
        tetrahedron = machine.tetrahedron
        sliders = [tetrahedron.sliders[arm] for arm in _ARMS]
        tip = np.asarray(tetrahedron.tip_center, dtype=float)
    except (AttributeError, KeyError, TypeError):
        raise InvalidInputError(
            "machine", "a RigidBodyMachine (columns a, b, c and a tetrahedron)", type(machine).__name__
        ) from None
    feet = np.array([np.asarray(col.point, dtype=float)[:2] for col in columns])
    nominal_sides = np.array(
        [np.linalg.norm(feet[1] - feet[0]), np.linalg.norm(feet[2] - feet[0]), np.linalg.norm(feet[2] - feet[1])]
    )
    # frame temperatures are given in the order a-b, a-c, b-c like the sides
    new_feet = deform_triangle(
        feet, nominal_sides * (1.0 + alpha_frame * (t_frame - reference_temperature)), slide_direction=slide_direction
    )
    new_columns = {}
    for k, (arm, col) in enumerate(zip(_ARMS, columns, strict=True)):
        growth = alpha_column * (t_col[k] - reference_temperature)
        point = np.asarray(col.point, dtype=float).copy()
        point[:2] = new_feet[k]
        direction = np.asarray(col.direction, dtype=float)
        point = point - col.encoder_scale * growth * bases[k] * direction
        new_columns[arm] = dataclasses.replace(col, point=point, encoder_scale=col.encoder_scale * (1.0 + growth))
    new_sliders = {}
    for k, (arm, slider) in enumerate(zip(_ARMS, sliders, strict=True)):
        factor = 1.0 + alpha_arm * (t_arm[k] - reference_temperature)
        new_sliders[arm] = dataclasses.replace(
            slider,
            point=tip + (np.asarray(slider.point, dtype=float) - tip) * factor,
            laser_scale=slider.laser_scale * factor,
            laser_offset=slider.laser_offset * factor,
        )
    new_tetrahedron = dataclasses.replace(tetrahedron, sliders=new_sliders)
    return dataclasses.replace(machine, tetrahedron=new_tetrahedron, columns=new_columns)


def rigid_body_tip_displacement(
    machine: Any, tip: ArrayLike, *, readings: str = "heights", **expansion: Any
) -> FloatArray:
    """Thermal probe error of a ``RigidBodyMachine`` at a tip position (mm), shape (3,).

    Parameters
    ----------
    machine : RigidBodyMachine
        Nominal machine.
    tip : array_like, shape (3,)
        Nominal tip position (mm).
    readings : {"heights", "lasers"}
        Which readings are held while the machine warms (see the module notes).
    **expansion
        Keyword arguments of :func:`expand_rigid_body_machine` (temperatures, alphas, ...).

    Returns
    -------
    ndarray, shape (3,)
        True tip minus indicated tip for the readings that indicate ``tip``.

    Raises
    ------
    InvalidInputError, NoRealSolutionError, ConvergenceError
        From the expansion or the kinematics.

    Examples
    --------
    >>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
    >>> machine = RigidBodyMachine.from_dpkm()
    >>> d = rigid_body_tip_displacement(machine, [0.0, 0.0, 90.0])
    >>> bool(np.abs(d).max() < 1e-9)
    True
    """
    if readings not in ("heights", "lasers"):
        raise InvalidInputError("readings", "'heights' or 'lasers'", repr(readings))
    target = fixed_shape_array(tip, "tip", (3,))
    solution = machine.inverse(target)
    lasers, heights = np.asarray(solution.lasers), np.asarray(solution.heights)
    warmed = expand_rigid_body_machine(machine, **expansion)
    if readings == "heights":
        true_tip = warmed.forward(heights=heights, lasers_hint=lasers).tip
    else:
        true_tip = warmed.forward(lasers=lasers, heights_hint=heights).tip
    return np.asarray(true_tip, dtype=float) - target
