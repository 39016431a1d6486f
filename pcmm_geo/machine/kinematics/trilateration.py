"""Intersection of three spheres (trilateration), vectorised and robust.

This is the geometric core of the seed DPKM (thesis eqs 2.9-2.18: the probe is the
point at distance ``L_i`` from the three pivots) written in a form that has no special
cases: a local frame is erected on the three centers, so the result does not depend on
pivot heights being different from each other or measured from pivot a (errata 1-4).

Root selection
--------------
Three spheres meet in two points mirrored in the plane of the centers.  On the
micro-CMM the probe hangs *below* the pivots (the tetrahedron apex points down), so
``root="lower"`` (the default) returns the intersection with the smaller machine ``z``.
``"upper"`` returns the other one; both are always available in
:class:`Trilateration`.

Examples
--------
>>> import numpy as np
>>> centers = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0]])
>>> tip = np.array([2.0, 3.0, -4.0])
>>> radii = np.linalg.norm(centers - tip, axis=1)
>>> np.round(trilaterate(centers, radii).point, 12).tolist()
[2.0, 3.0, -4.0]
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._deprecation import renamed_parameters
from pcmm_geo._records import record
from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError, NoRealSolutionError

__all__ = ["Trilateration", "trilaterate"]

FloatArray = NDArray[np.float64]


@record
class Trilateration:
    """Both intersections of three spheres (leading shape ``...`` of the input).

    Attributes
    ----------
    point : ndarray, shape (..., 3)
        The selected root (mm).
    lower, upper : ndarray, shape (..., 3)
        Root with the smaller / larger machine ``z``.
    height_squared : ndarray, shape (...)
        Squared distance of the roots from the plane of the centers (mm^2); the
        discriminant of the problem (negative means no real intersection).
    """

    point: FloatArray
    lower: FloatArray
    upper: FloatArray
    height_squared: FloatArray


@renamed_parameters(centres="centers")
def trilaterate(
    centers: ArrayLike,
    radii: ArrayLike,
    *,
    root: Literal["lower", "upper"] = "lower",
    tolerance: float = 1e-9,
) -> Trilateration:
    r"""Intersect three spheres.

    Parameters
    ----------
    centers : array_like, shape (..., 3, 3)
        Sphere centers (mm), rows a, b, c.
    radii : array_like, shape (..., 3)
        Sphere radii (mm).
    root : {"lower", "upper"}
        Which intersection goes into ``.point`` (see module notes: the probe hangs below).
    tolerance : float
        A negative ``height_squared`` down to ``-tolerance * max(radius)^2`` counts as a
        tangent contact (height zero) instead of an error.

    Returns
    -------
    Trilateration

    Raises
    ------
    InvalidInputError
        Wrong shapes, non-finite or negative radii, unknown ``root``.
    DegenerateGeometryError
        Two centers coincide or the three centers are collinear.
    NoRealSolutionError
        The spheres do not meet; ``discriminant`` holds ``height_squared`` (mm^2).

    See Also
    --------
    pcmm_geo.machine.kinematics.dpkm.dpkm_probe : the thesis' elimination (eqs 2.9-2.18)

    Notes
    -----
    In the frame erected on the centres -- :math:`\mathbf{e}_x` from centre a to b at distance
    :math:`d`, :math:`\mathbf{e}_y` towards c in their plane (c at :math:`(i, j, 0)`),
    :math:`\mathbf{e}_z = \mathbf{e}_x \times \mathbf{e}_y` -- the intersections are

    .. math::

        x = \frac{r_a^2 - r_b^2 + d^2}{2 d} , \qquad
        y = \frac{r_a^2 - r_c^2 + i^2 + j^2 - 2 i x}{2 j} , \qquad
        z = \pm \sqrt{r_a^2 - x^2 - y^2} ,

    the point of the thesis' DPKM (section 2.6.4, eqs 2.9-2.18 [1]_) without its division by
    pivot height differences (errata 1-4 of [2]_).  ``height_squared`` is
    :math:`r_a^2 - x^2 - y^2`.

    References
    ----------
    .. [1] *A critical investigation into the accuracy of a parallel mechanism coordinate measuring machine*,
           MEng (Mechatronic) thesis, Faculty of Engineering, Stellenbosch University ("the thesis"; the copy
           the project works from names neither author nor year). Section 2.6.4.
    .. [2] The project's errata of the thesis, :doc:`/errata` (numbered as there).

    Examples
    --------
    >>> import numpy as np
    >>> c = np.array([[0.0, 0, 0], [4, 0, 0], [0, 4, 0]])
    >>> r = trilaterate(c, [3.0, 3.0, 3.0])
    >>> np.round(r.lower, 9).tolist(), np.round(r.upper, 9).tolist()
    ([2.0, 2.0, -1.0], [2.0, 2.0, 1.0])
    """
    if root not in ("lower", "upper"):
        raise InvalidInputError("root", "'lower' or 'upper'", repr(root))
    centre_arr = np.asarray(centers, dtype=float)
    radius_arr = np.asarray(radii, dtype=float)
    if centre_arr.ndim < 2 or centre_arr.shape[-2:] != (3, 3):
        raise InvalidInputError("centers", "shape (..., 3, 3)", f"shape {centre_arr.shape}")
    if radius_arr.shape != centre_arr.shape[:-1]:
        raise InvalidInputError("radii", f"shape {centre_arr.shape[:-1]}", f"shape {radius_arr.shape}")
    if not (np.all(np.isfinite(centre_arr)) and np.all(np.isfinite(radius_arr))):
        raise InvalidInputError("centers/radii", "finite values", "NaN or inf")
    if np.any(radius_arr < 0):
        raise InvalidInputError("radii", "non-negative lengths", f"{radius_arr.min()}")
    first, second, third = centre_arr[..., 0, :], centre_arr[..., 1, :], centre_arr[..., 2, :]
    to_second = second - first
    base = np.linalg.norm(to_second, axis=-1)
    scale = np.maximum(np.abs(centre_arr).max(axis=(-1, -2)), 1.0)
    if np.any(base <= 1e-12 * scale):
        raise DegenerateGeometryError("trilateration", "two sphere centres coincide")
    e_x = to_second / base[..., None]
    to_third = third - first
    along = np.einsum("...i,...i->...", e_x, to_third)
    perpendicular = to_third - along[..., None] * e_x
    offset = np.linalg.norm(perpendicular, axis=-1)
    if np.any(offset <= 1e-12 * scale):
        raise DegenerateGeometryError("trilateration", "the three sphere centres are collinear")
    e_y = perpendicular / offset[..., None]
    e_z = np.cross(e_x, e_y)
    r1, r2, r3 = radius_arr[..., 0], radius_arr[..., 1], radius_arr[..., 2]
    x = (r1**2 - r2**2 + base**2) / (2.0 * base)
    y = (r1**2 - r3**2 + along**2 + offset**2 - 2.0 * along * x) / (2.0 * offset)
    height_squared = r1**2 - x**2 - y**2
    max_r2 = np.max(radius_arr, axis=-1) ** 2
    if np.any(height_squared < -tolerance * max_r2):
        worst = height_squared.min()
        raise NoRealSolutionError(
            "trilateration",
            discriminant=height_squared if height_squared.ndim else float(height_squared),
            detail=f"the three spheres do not meet (height^2 down to {worst:.6g} mm^2)",
        )
    height = np.sqrt(np.clip(height_squared, 0.0, None))
    foot = first + x[..., None] * e_x + y[..., None] * e_y
    plus = foot + height[..., None] * e_z
    minus = foot - height[..., None] * e_z
    plus_is_lower = (plus[..., 2] < minus[..., 2])[..., None]
    lower = np.where(plus_is_lower, plus, minus)
    upper = np.where(plus_is_lower, minus, plus)
    return Trilateration(
        point=lower if root == "lower" else upper, lower=lower, upper=upper, height_squared=height_squared
    )
