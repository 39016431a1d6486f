"""Physical thermal model of the micro-CMM: expand the members, re-solve the kinematics.

The tip is where three arms of known length meet, each hanging from a pivot that slides
on a vertical column standing on the frame.  For the *same* sensor readings the machine
assumes nominal member lengths; thermally the frame triangle deforms (eqs 4.2-4.9, columns
attached at fixed barycentric coordinates), each column lengthens from its base
(``z' = z_base + (z − z_base)(1 + α ΔT)``) and each arm lengthens
(``L' = L (1 + α ΔT)``).  Re-solving the three-sphere intersection (the branch nearest
the nominal tip) gives the true tip; its difference from the nominal tip is the thermal
probe error.  No averaging, no small-angle assumption.  The sphere intersection is solved
here in closed form (the seed DPKM with exact pivots: arms swing freely about the tip); the
same expansion applied to the rigid-body machine model is in
:mod:`pcmm_geo.thermal.machine_expansion`.
"""

from __future__ import annotations

import math
from dataclasses import field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._deprecation import renamed_fields
from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.thermal.expansion import ALPHA_ALUMINIUM, REFERENCE_TEMPERATURE
from pcmm_geo.thermal.probe_error import fixed_shape_array, trilaterate
from pcmm_geo.thermal.triangle import NOMINAL_SIDE, expand_frame, frame_corners

__all__ = [
    "MEMBERS",
    "ThermalMachineGeometry",
    "ThermalSensitivityTable",
    "physical_tip",
    "physical_tip_displacement",
    "thermal_sensitivity_table",
]

FloatArray = NDArray[np.float64]

#: Member names, in the order used by :func:`thermal_sensitivity_table`.
MEMBERS = ("frame_ab", "frame_ac", "frame_bc", "column_a", "column_b", "column_c", "arm_a", "arm_b", "arm_c")


@renamed_fields(working_volume_centre="working_volume_center")
@record
class ThermalMachineGeometry:
    """Nominal (20 °C) geometry of the micro-CMM for the physical thermal model.

    Attributes
    ----------
    frame_sides : ndarray, shape (3,)
        Frame sides AB, AC, BC (mm), 650 mm in the thesis (Table 4.1).
    column_xy : ndarray, shape (3, 2)
        Plan positions of the columns of arms a, b, c (mm); default a 265 mm circle
        (pivot spacing about 459 mm as in the seed's calibration) towards corners A, B, C.
    column_base_z : float
        Height of the column bases, from where columns expand (mm).
    alpha_frame, alpha_column, alpha_arm : float
        Expansion coefficients (1/K); default aluminium (seed).
    pivot_drop : float
        Height of the pivots above the tip used by :func:`thermal_sensitivity_table` (mm);
        314 mm gives arms of about 411 mm (the seed's laser lengths).
    working_volume_center : ndarray, shape (3,)
        Centre of the 100 mm working cube (mm).

    Notes
    -----
    The frame is placed as in Table 4.1 for its side AB: A pinned at ``(−l_AB/√3, 0)``, B
    sliding along x at ``y = l_AB/2`` (the equilateral layout centred on the origin).
    """

    frame_sides: FloatArray = field(default_factory=lambda: np.full(3, NOMINAL_SIDE))
    column_xy: FloatArray = field(
        default_factory=lambda: 265.0 * np.array([[-1.0, 0.0], [0.5, math.sqrt(0.75)], [0.5, -math.sqrt(0.75)]])
    )
    column_base_z: float = 0.0
    alpha_frame: float = ALPHA_ALUMINIUM
    alpha_column: float = ALPHA_ALUMINIUM
    alpha_arm: float = ALPHA_ALUMINIUM
    pivot_drop: float = 314.0
    working_volume_center: FloatArray = field(default_factory=lambda: np.array([0.0, 0.0, 86.0]))

    def frame_anchor(self) -> tuple[FloatArray, float]:
        """Fixed coordinates of the frame: A ``(2,)`` and ``b_y`` (mm), Table 4.1 layout for side AB."""
        side_ab = float(self.frame_sides[0])
        return np.array([-side_ab / math.sqrt(3.0), 0.0]), side_ab / 2.0

    def barycentric(self) -> FloatArray:
        """Barycentric coordinates ``(3, 3)`` of the columns in the nominal frame triangle."""
        anchor_a, anchor_by = self.frame_anchor()
        tri = frame_corners(*map(float, self.frame_sides), a=anchor_a, b_y=anchor_by)
        corners = tri.corners
        system = np.vstack([corners.T, np.ones(3)])
        rhs = np.vstack([np.asarray(self.column_xy, dtype=float).T, np.ones(3)])
        return np.linalg.solve(system, rhs).T


def _temps(value: ArrayLike, name: str) -> FloatArray:
    return fixed_shape_array(value, name, (3,))


def physical_tip(
    geometry: ThermalMachineGeometry,
    tip: ArrayLike,
    pivot_heights: ArrayLike,
    *,
    frame_temperatures: ArrayLike = (20.0, 20.0, 20.0),
    column_temperatures: ArrayLike = (20.0, 20.0, 20.0),
    arm_temperatures: ArrayLike = (20.0, 20.0, 20.0),
    reference_temperature: float = REFERENCE_TEMPERATURE,
) -> FloatArray:
    """True tip position for the sensor readings that indicate ``tip`` at 20 °C.

    Parameters
    ----------
    geometry : ThermalMachineGeometry
    tip : array_like, shape (3,)
        Nominal (indicated) tip position (mm).
    pivot_heights : array_like, shape (3,)
        Nominal pivot heights z_a, z_b, z_c (mm) from the encoders.
    frame_temperatures : array_like, shape (3,)
        Sides AB, AC, BC (°C).
    column_temperatures, arm_temperatures : array_like, shape (3,)
        Members a, b, c (°C).
    reference_temperature : float
        °C.

    Returns
    -------
    ndarray, shape (3,)
        Tip position with the expanded members (mm).

    Raises
    ------
    InvalidInputError, NoRealSolutionError, DegenerateGeometryError
        Bad shapes, impossible geometry.

    Examples
    --------
    >>> geo = ThermalMachineGeometry()
    >>> tip = np.array([0.0, 0.0, 86.0])
    >>> moved = physical_tip(geo, tip, [400.0, 400.0, 400.0], column_temperatures=[21.0, 21.0, 21.0])
    >>> (moved - tip).round(9).tolist() == [0.0, 0.0, 0.00924]   # every pivot rises 23.1e-6 * 400 mm
    True
    """
    p = fixed_shape_array(tip, "tip", (3,))
    heights = fixed_shape_array(pivot_heights, "pivot_heights", (3,))
    t_frame = _temps(frame_temperatures, "frame_temperatures")
    t_col = _temps(column_temperatures, "column_temperatures")
    t_arm = _temps(arm_temperatures, "arm_temperatures")
    column_xy = np.asarray(geometry.column_xy, dtype=float)
    nominal_pivots = np.column_stack([column_xy, heights])
    arm_lengths = np.linalg.norm(p - nominal_pivots, axis=1)
    anchor_a, anchor_by = geometry.frame_anchor()
    frame = expand_frame(
        t_frame,
        nominal_sides=geometry.frame_sides,
        alpha=geometry.alpha_frame,
        reference_temperature=reference_temperature,
        a=anchor_a,
        b_y=anchor_by,
    )
    moved_xy = geometry.barycentric() @ frame.corners
    base = geometry.column_base_z
    moved_z = base + (heights - base) * (1.0 + geometry.alpha_column * (t_col - reference_temperature))
    moved_lengths = arm_lengths * (1.0 + geometry.alpha_arm * (t_arm - reference_temperature))
    return trilaterate(np.column_stack([moved_xy, moved_z]), moved_lengths, p)


def physical_tip_displacement(
    geometry: ThermalMachineGeometry,
    tip: ArrayLike,
    pivot_heights: ArrayLike,
    **temperatures: ArrayLike,
) -> FloatArray:
    """Thermal probe error ``physical_tip(...) − tip`` (mm), shape (3,).

    Same parameters as :func:`physical_tip`.

    Raises
    ------
    InvalidInputError, NoRealSolutionError, DegenerateGeometryError
        As :func:`physical_tip`.

    Examples
    --------
    >>> geo = ThermalMachineGeometry()
    >>> d = physical_tip_displacement(geo, [0.0, 0.0, 86.0], [400.0] * 3)
    >>> bool(np.abs(d).max() < 1e-9)
    True
    """
    return physical_tip(geometry, tip, pivot_heights, **temperatures) - fixed_shape_array(tip, "tip", (3,))


@record
class ThermalSensitivityTable:
    """Tip displacement per kelvin of each member over a grid in the working volume.

    Attributes
    ----------
    members : tuple of str
        :data:`MEMBERS`.
    positions : ndarray, shape (K, 3)
        Tip positions (mm).
    displacement_um_per_k : ndarray, shape (M, K, 3)
        Tip displacement per kelvin of member m at position k (µm/K).
    delta_t : float
        Temperature step used (K).
    """

    members: tuple[str, ...]
    positions: FloatArray
    displacement_um_per_k: FloatArray
    delta_t: float

    def summary(self) -> list[dict[str, float | str]]:
        """Per member: max and mean ``|d|``, and max ``|dx|``, ``|dy|``, ``|dz|`` over the grid (µm/K)."""
        rows: list[dict[str, float | str]] = []
        for m, name in enumerate(self.members):
            d = self.displacement_um_per_k[m]
            norm = np.linalg.norm(d, axis=1)
            rows.append(
                {
                    "member": name,
                    "max_um_per_k": float(norm.max()),
                    "mean_um_per_k": float(norm.mean()),
                    "max_dx_um_per_k": float(np.abs(d[:, 0]).max()),
                    "max_dy_um_per_k": float(np.abs(d[:, 1]).max()),
                    "max_dz_um_per_k": float(np.abs(d[:, 2]).max()),
                }
            )
        return rows


def thermal_sensitivity_table(
    geometry: ThermalMachineGeometry | None = None,
    *,
    points_per_axis: int = 3,
    size: float = 100.0,
    delta_t: float = 1.0,
) -> ThermalSensitivityTable:
    """µm per kelvin of tip displacement for each member over the working volume.

    Each member of :data:`MEMBERS` in turn is warmed by ``delta_t`` while the others stay at
    20 °C; for every tip position of a ``points_per_axis³`` grid spanning a cube of edge
    ``size`` around ``geometry.working_volume_center`` the pivots sit ``pivot_drop`` above
    the tip, and :func:`physical_tip_displacement` gives the error.

    Parameters
    ----------
    geometry : ThermalMachineGeometry, optional
        Default :class:`ThermalMachineGeometry()`.
    points_per_axis : int
        Grid points per axis (>= 1; 1 means the centre only).
    size : float
        Edge of the working cube (mm).
    delta_t : float
        Temperature step (K), non-zero.

    Returns
    -------
    ThermalSensitivityTable

    Raises
    ------
    InvalidInputError
        ``points_per_axis < 1``, ``size < 0`` or ``delta_t == 0``.

    Examples
    --------
    >>> table = thermal_sensitivity_table(points_per_axis=1)
    >>> round(table.summary()[3]["max_dz_um_per_k"], 2)   # column a: one third of 23.1e-3 * 400
    3.08
    """
    geo = ThermalMachineGeometry() if geometry is None else geometry
    if not isinstance(points_per_axis, int) or points_per_axis < 1:
        raise InvalidInputError("points_per_axis", "an integer >= 1", repr(points_per_axis))
    if not (math.isfinite(size) and size >= 0):
        raise InvalidInputError("size", "a non-negative edge length in mm", repr(size))
    if not (math.isfinite(delta_t) and delta_t != 0):
        raise InvalidInputError("delta_t", "a non-zero temperature step in K", repr(delta_t))
    offsets = np.linspace(-size / 2, size / 2, points_per_axis) if points_per_axis > 1 else np.zeros(1)
    grid = np.array([[x, y, z] for x in offsets for y in offsets for z in offsets]) + geo.working_volume_center
    t_ref = REFERENCE_TEMPERATURE
    out = np.zeros((len(MEMBERS), len(grid), 3))
    for m, member in enumerate(MEMBERS):
        group, _, which = member.partition("_")
        index = {"ab": 0, "ac": 1, "bc": 2, "a": 0, "b": 1, "c": 2}[which]
        temps = np.full(3, t_ref)
        temps[index] += delta_t
        kwargs = {f"{group}_temperatures": temps}
        for k, tip in enumerate(grid):
            heights = np.full(3, tip[2] + geo.pivot_drop)
            out[m, k] = physical_tip_displacement(geo, tip, heights, **kwargs) / delta_t * 1000.0
    return ThermalSensitivityTable(members=MEMBERS, positions=grid, displacement_um_per_k=out, delta_t=delta_t)
