"""Thermal probe error of the micro-CMM: the seed's simple model (eqs 4.10-4.17) and a physical model.

Seed model (thesis section 4.1.2-4.1.3, implemented by :func:`seed_probe_error`)
--------------------------------------------------------------------------------
Assumptions stated by the thesis: members expand linearly and do not bend; joints are
pins; the base is fixed in z; the vertical error comes only from the columns and the
planar error only from the arms; the probe moves by the *average* of what the three
members suggest, because the 100 mm working volume is small next to the structure.

* eq 4.10 ``δ_k = z_k − z_p`` (height of pivot k above the probe),
* eq 4.11 ``z_k' = z_k + Δl_k`` with ``Δl_k = α z_k ΔT_column,k`` (column from z = 0),
* eq 4.12 as printed, ``z_p' = (z_a' + z_b' + z_c')/3``, is the mean *pivot* height
  (about 390 mm), not a probe height.  We use the reading of the Appendix E code,
  ``z_p' = z_p + mean_k(z_k' − z_k)``.
* eq 4.13 ``α_k = acos(|k_y − y| / sqrt((k_x − x)² + (k_y − y)²))``, the angle between
  the arm's plan view and the y axis,
* eqs 4.14-4.15 as printed, ``|k_x − x'_k| = (δ_k / l'_k) sin α_k``, equate a length (mm)
  with the dimensionless ratio ``δ_k/l'_k`` -- a dimensional error.  The consistent
  reading, which the code computes (``delta_a = sqrt(la_p² − da²)``) but never uses,
  is the plan-view reach ``h'_k = sqrt(l'_k² − δ_k²)`` of the expanded arm:
  ``x'_k = k_x ± h'_k sin α_k``, ``y'_k = k_y ± h'_k cos α_k`` (signs towards the probe).
* eqs 4.16-4.17 ``x_p' = mean x'_k``, ``y_p' = mean y'_k``.

The Appendix E code also adds an ad-hoc frame term ``((c_x − c_x0) + (b_x − b_x0))/2``,
``c_y − c_y0`` and mixes corner coordinates into single arms; it uses the seed
``delta_l`` (erratum 5).  Table 4.2 (0.022, 0.020, 0.011 mm for +1 K) is therefore not
reproducible from the equations; its z rows differ by 0.009 mm, which is eq 4.1 applied
to the mean pivot height 389.9 mm (23.1e-6 · 389.9 = 0.0090 mm), not the seed's
``α·10·ΔT`` (0.00023 mm).

The physical model (expanded members, exact re-solution) is in
:mod:`pcmm_geo.thermal.physical`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._deprecation import renamed_parameters
from pcmm_geo._records import record
from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError, NoRealSolutionError
from pcmm_geo.thermal.expansion import ALPHA_ALUMINIUM, REFERENCE_TEMPERATURE

__all__ = ["SeedProbeError", "seed_probe_error", "trilaterate"]

FloatArray = NDArray[np.float64]

def fixed_shape_array(value: ArrayLike, name: str, shape: tuple[int, ...]) -> FloatArray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInputError(name, f"numbers of shape {shape}", type(value).__name__) from None
    if arr.shape != shape:
        raise InvalidInputError(name, f"shape {shape}", f"shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(name, "finite values", f"{arr.tolist()}")
    return arr


@record
class SeedProbeError:
    """Result of the seed's simple thermal probe model (eqs 4.10-4.17).

    Attributes
    ----------
    probe : ndarray, shape (3,)
        Probe position before the temperature change (mm).
    probe_after : ndarray, shape (3,)
        ``(x_p', y_p', z_p')`` (mm).
    displacement : ndarray, shape (3,)
        ``probe_after − probe`` (mm).
    arm_points : ndarray, shape (3, 2)
        Plan-view probe estimates ``(x'_k, y'_k)`` of arms a, b, c (mm), eqs 4.14-4.15.
    column_growth : ndarray, shape (3,)
        ``z_k' − z_k`` of the three pivots (mm), eq 4.11.
    arm_angles : ndarray, shape (3,)
        ``α_k`` of eq 4.13 (rad).
    """

    probe: FloatArray
    probe_after: FloatArray
    displacement: FloatArray
    arm_points: FloatArray
    column_growth: FloatArray
    arm_angles: FloatArray


def seed_probe_error(
    probe: ArrayLike,
    pivots: ArrayLike,
    *,
    column_temperatures: ArrayLike = (20.0, 20.0, 20.0),
    arm_temperatures: ArrayLike = (20.0, 20.0, 20.0),
    arm_lengths: ArrayLike | None = None,
    alpha_column: float = ALPHA_ALUMINIUM,
    alpha_arm: float = ALPHA_ALUMINIUM,
    reference_temperature: float = REFERENCE_TEMPERATURE,
) -> SeedProbeError:
    """The seed's averaged thermal probe model, eqs 4.10-4.17, in its dimensionally consistent reading.

    Parameters
    ----------
    probe : array_like, shape (3,)
        Probe position ``(x, y, z_p)`` (mm).
    pivots : array_like, shape (3, 3)
        Pivots a, b, c as rows ``(k_x, k_y, z_k)`` (mm); columns stand on z = 0.
    column_temperatures, arm_temperatures : array_like, shape (3,)
        Temperatures of columns and arms a, b, c (°C).
    arm_lengths : array_like, shape (3,), optional
        Pivot-to-probe lengths ``l_k`` at 20 °C (mm); default ``|probe − pivot_k|``.
    alpha_column, alpha_arm : float
        Expansion coefficients (1/K).
    reference_temperature : float
        °C, default 20.

    Returns
    -------
    SeedProbeError

    Raises
    ------
    InvalidInputError
        Wrong shapes or non-finite values.
    NoRealSolutionError
        An expanded arm shorter than its pivot's height above the probe.
    DegenerateGeometryError
        The probe directly below a pivot (eq 4.13 undefined).

    Examples
    --------
    >>> pivots = [[-265.0, 0.0, 400.0], [132.5, 229.5, 400.0], [132.5, -229.5, 400.0]]
    >>> res = seed_probe_error([0.0, 0.0, 86.0], pivots, column_temperatures=[21.0, 21.0, 21.0])
    >>> round(float(res.displacement[2]), 6)   # 23.1e-6 * 400 mm * 1 K
    0.00924
    """
    p = fixed_shape_array(probe, "probe", (3,))
    piv = fixed_shape_array(pivots, "pivots", (3, 3))
    t_col = fixed_shape_array(column_temperatures, "column_temperatures", (3,))
    t_arm = fixed_shape_array(arm_temperatures, "arm_temperatures", (3,))
    if arm_lengths is None:
        lengths = np.linalg.norm(p - piv, axis=1)
    else:
        lengths = fixed_shape_array(arm_lengths, "arm_lengths", (3,))
    growth = alpha_column * piv[:, 2] * (t_col - reference_temperature)  # eq 4.11 with l0 = z_k
    z_after = p[2] + growth.mean()  # eq 4.12, code's reading
    delta = piv[:, 2] - p[2]  # eq 4.10
    plan = p[:2] - piv[:, :2]
    plan_dist = np.linalg.norm(plan, axis=1)
    if np.any(plan_dist == 0):
        raise DegenerateGeometryError("seed thermal model", "probe directly below a pivot: eq 4.13 undefined")
    arm_angles = np.arccos(np.abs(plan[:, 1]) / plan_dist)  # eq 4.13
    lengths_after = lengths * (1.0 + alpha_arm * (t_arm - reference_temperature))
    radicand = lengths_after**2 - delta**2
    if np.any(radicand < 0):
        raise NoRealSolutionError("seed thermal model (eqs 4.14-4.15)", radicand.min(), "arm shorter than its drop")
    reach = np.sqrt(radicand)
    sign = np.where(plan >= 0, 1.0, -1.0)
    arm_points = np.column_stack(
        [
            piv[:, 0] + sign[:, 0] * reach * np.sin(arm_angles),  # eq 4.14
            piv[:, 1] + sign[:, 1] * reach * np.cos(arm_angles),  # eq 4.15
        ]
    )
    after = np.array([arm_points[:, 0].mean(), arm_points[:, 1].mean(), z_after])  # eqs 4.16-4.17
    return SeedProbeError(
        probe=p,
        probe_after=after,
        displacement=after - p,
        arm_points=arm_points,
        column_growth=growth,
        arm_angles=arm_angles,
    )


@renamed_parameters(centres="centers")
def trilaterate(centers: ArrayLike, radii: ArrayLike, near: ArrayLike) -> FloatArray:
    """Intersection of three spheres: the one of the two solutions nearest ``near``.

    Parameters
    ----------
    centers : array_like, shape (3, 3)
        Sphere centers (mm).
    radii : array_like, shape (3,)
        Radii (mm).
    near : array_like, shape (3,)
        Point selecting the branch (mm).

    Returns
    -------
    ndarray, shape (3,)

    Raises
    ------
    DegenerateGeometryError
        Collinear centers.
    NoRealSolutionError
        The spheres do not meet (negative discriminant); never returns a real part.

    Examples
    --------
    >>> c = [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0]]
    >>> trilaterate(c, [np.sqrt(75.0)] * 3, [5.0, 5.0, -1.0]).round(12).tolist()
    [5.0, 5.0, -5.0]
    """
    cen = fixed_shape_array(centers, "centers", (3, 3))
    rad = fixed_shape_array(radii, "radii", (3,))
    ref = fixed_shape_array(near, "near", (3,))
    base = cen[1] - cen[0]
    dist = float(np.linalg.norm(base))
    if dist == 0:
        raise DegenerateGeometryError("trilateration", "two sphere centres coincide")
    ex = base / dist
    other = cen[2] - cen[0]
    i = float(ex @ other)
    perp = other - i * ex
    j = float(np.linalg.norm(perp))
    if j <= 1e-12 * max(dist, 1.0):
        raise DegenerateGeometryError("trilateration", "the three sphere centres are collinear")
    ey = perp / j
    ez = np.cross(ex, ey)
    x = (rad[0] ** 2 - rad[1] ** 2 + dist**2) / (2.0 * dist)
    y = (rad[0] ** 2 - rad[2] ** 2 + i**2 + j**2) / (2.0 * j) - (i / j) * x
    disc = rad[0] ** 2 - x**2 - y**2
    if disc < 0:
        raise NoRealSolutionError("trilateration", disc, "the three spheres do not meet")
    h = math.sqrt(disc)
    foot = cen[0] + x * ex + y * ey
    side = 1.0 if float((ref - foot) @ ez) >= 0 else -1.0
    return foot + side * h * ez
