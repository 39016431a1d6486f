"""The seed's Direct Position Kinematic Model (DPKM, thesis 2.6.4, eqs 2.3-2.21), corrected.

The seed computes the probe as the intersection of three spheres centred on the
pivots (spherical joints) with radii ``L_i = laser_i + 60 + d_i`` (laser reading,
start of the laser's range, dead distance), the pivot heights from laser lengths via
the angle ``beta`` between arms and the pivot spacing ``b`` (eqs 2.3-2.8), and the
pivot x/y from inclined column lines (eqs 2.19-2.20).

This module implements the **corrected** geometry (DESIGN.md errata 1-4):

1. eq 2.17's middle coefficient is ``v = 2DF + 2x_aB - 2AB - 2y_a`` (printed ``+2y``);
2. eq 2.21 is ``c_i = l_i^2 - x_i^2 - y_i^2 - z_i^2`` (printed with ``+``);
3. the root is ``y = (-v +- sqrt(v^2 - 4uw)) / 2u`` (Appendix E uses ``-1`` for ``-v``);
4. eqs 2.12-2.18 assume ``z_a = 0``: heights are taken relative to pivot a and the
   result is shifted back (Appendix E feeds absolute heights).

A negative discriminant raises :class:`~pcmm_geo.errors.NoRealSolutionError`; a real
part of a complex root is never returned.  The printed forms are available, clearly
named, in :func:`pcmm_geo.machine.kinematics.seed_forms.seed_probe_roots_as_printed` for tests and documentation only.

Sign conventions of eq 2.11: with ``D`` as in eq 2.14, ``z = F - D y``; the code of
Appendix D/E uses the opposite sign of ``D`` and ``z = F + D y`` (same result).

Examples
--------
>>> import numpy as np
>>> pivots = np.array([[-268.0, 0.8, 400.0], [123.3, 231.8, 390.0], [129.6, -231.5, 395.0]])
>>> tip = np.array([10.0, -20.0, 40.0])
>>> lengths = np.linalg.norm(pivots - tip, axis=1)
>>> np.round(dpkm_probe(pivots, lengths).point, 9).tolist()
[10.0, -20.0, 40.0]
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError, NoRealSolutionError
from pcmm_geo.machine.kinematics.limits import LASER_MEASURING_RANGE, check_readings
from pcmm_geo.machine.kinematics.model_parts import ARMS, ColumnLine, SliderLine, Tetrahedron, as_readings

__all__ = [
    "APPENDIX_D_COLUMN_POINTS",
    "APPENDIX_E",
    "PAIRS",
    "START_OF_RANGE",
    "TABLE_3_1_BASE_DISTANCE",
    "TABLE_3_1_BETA_DEG",
    "TABLE_3_1_DEAD_DISTANCE",
    "DpkmProbe",
    "arm_lengths",
    "column_pivots",
    "dpkm_probe",
    "height_difference",
    "pivot_distance",
    "relative_pivot_heights",
    "seed_parts",
    "sphere_constants",
    "tetrahedron_directions",
]

FloatArray = NDArray[np.float64]

#: start of the measuring range of the lasers (mm), thesis 5.3 and Appendix D line 37
START_OF_RANGE = 60.0
#: arm pairs (i, i_n) with i_n the next arm clockwise (thesis 2.6.4)
PAIRS: tuple[str, str, str] = ("ab", "bc", "ca")
#: Table 3.1 (Rugbani 2014): dead distance d_i (mm, without the 60 mm start of range)
TABLE_3_1_DEAD_DISTANCE: Mapping[str, float] = {"a": 294.02, "b": 289.90, "c": 289.40}
#: Table 3.1: beta_in, angle between arms i and i_n (degrees)
TABLE_3_1_BETA_DEG: Mapping[str, float] = {"ab": 68.51, "bc": 68.73, "ca": 68.36}
#: Table 3.1: b_in, xy-distance between the pivots of arms i and i_n (mm)
TABLE_3_1_BASE_DISTANCE: Mapping[str, float] = {"ab": 460.10, "bc": 458.89, "ca": 458.09}
#: Appendix D (function ``pp``): pivot x, y used by the seed's post-processing (mm)
APPENDIX_D_COLUMN_POINTS: Mapping[str, tuple[float, float]] = {
    "a": (-268.1534609325, 0.77453872875),
    "b": (123.31416589825, 231.7902010146450),
    "c": (129.56280872246, -231.4925849551),
}


def _appendix_e_inputs() -> dict[str, FloatArray]:
    """Inputs of Appendix E (thermal error model code, lines 11-39) as arrays a, b, c."""
    heights = np.array([400.9875133, 387.2532227, 381.4428078])
    err_x = np.array([-0.1601968, -0.12512656, 0.271252905109806])
    err_y = np.array([0.095144219864, -0.059912, 0.031501548041])
    x = np.array([0.0075, 0.0082, 0.0069]) * heights + np.array([148.59, -253.75, 140.74]) - err_x
    y = np.array([0.0201, 0.0192, 0.0153]) * heights + np.array([3.3691, -220.11, -454.53]) - err_y
    return {
        "lengths": np.array([411.344316, 406.3561545, 407.8386567]),
        "heights": heights,
        "pivots": np.column_stack([x, y, heights]),
    }


#: Appendix E inputs: ``lengths`` r_i (mm), absolute ``heights`` z_i (mm), ``pivots`` (3, 3) from eqs 2.19-2.20
APPENDIX_E: Mapping[str, FloatArray] = _appendix_e_inputs()


@record
class DpkmProbe:
    """Probe point from eqs 2.9-2.18 (corrected), leading shape ``...``.

    Attributes
    ----------
    point : ndarray, shape (..., 3)
        Selected root (mm, machine frame).
    lower, upper : ndarray, shape (..., 3)
        The roots with the smaller / larger ``z``.
    discriminant : ndarray, shape (...)
        ``v^2 - 4uw`` of eq 2.10 (mm^2 scale), non-negative.
    """

    point: FloatArray
    lower: FloatArray
    upper: FloatArray
    discriminant: FloatArray


def arm_lengths(
    lasers: ArrayLike,
    dead_distance: Mapping[str, float],
    *,
    start_of_range: float = START_OF_RANGE,
    measuring_range: float | None = LASER_MEASURING_RANGE,
) -> FloatArray:
    """Pivot-to-tip lengths ``L_i = laser_i + start_of_range + d_i`` (mm), shape ``(..., 3)``.

    Parameters
    ----------
    lasers : array_like, shape (..., 3)
        Laser readings (mm from the start of measuring range).
    dead_distance : mapping arm -> mm
        ``d_i`` without the start of range.
    start_of_range : float
        60 mm (thesis 5.3).
    measuring_range : float or None
        Readings must lie in ``[0, measuring_range]`` (200 mm, thesis 3.1); ``None`` skips
        the check (for analyses beyond the sensors).

    Raises
    ------
    OutOfRangeError
        A reading outside the measuring range; ``quantity`` names its index, e.g.
        ``"lasers[7, 2] (laser c measuring range)"``.

    Examples
    --------
    >>> arm_lengths([50.0, 60.0, 70.0], {"a": 300.0, "b": 290.0, "c": 280.0}).tolist()
    [410.0, 410.0, 410.0]
    """
    readings = as_readings(lasers, "lasers")
    if measuring_range is not None:
        check_readings(readings, [0.0, measuring_range], "lasers", "laser")
    return readings + start_of_range + np.array([dead_distance[arm] for arm in ARMS])


def pivot_distance(length_i: ArrayLike, length_next: ArrayLike, beta: float | ArrayLike) -> FloatArray:
    """Distance between two pivots, eqs 2.7-2.8 (law of cosines), mm.

    ``d_in^2 = l_i^2 + l_in^2 - 2 l_i l_in cos(beta_in)`` with ``beta`` in radians.

    Examples
    --------
    >>> round(float(pivot_distance(3.0, 4.0, np.pi / 2)), 12)
    5.0
    """
    li = np.asarray(length_i, dtype=float)
    ln = np.asarray(length_next, dtype=float)
    return np.sqrt(li**2 + ln**2 - 2.0 * li * ln * np.cos(beta))


def height_difference(
    length_i: ArrayLike, length_next: ArrayLike, beta: float | ArrayLike, base_distance: float | ArrayLike
) -> FloatArray:
    """Magnitude of the pivot height difference ``|dz_in|``, eqs 2.5-2.8 (mm).

    ``dz_in^2 = d_in^2 - b_in^2``; the sign is not determined by the lasers (the seed
    takes it from the motor direction, see :mod:`pcmm_geo.machine.analysis.logproc`).

    Raises
    ------
    NoRealSolutionError
        ``d_in < b_in`` (the pivots are closer than their xy spacing); carries
        ``d_in^2 - b_in^2`` as the discriminant (the seed's "complex values", thesis 5.3).

    Examples
    --------
    >>> round(float(height_difference(3.0, 4.0, np.pi / 2, 4.0)), 12)
    3.0
    """
    squared = pivot_distance(length_i, length_next, beta) ** 2 - np.asarray(base_distance, dtype=float) ** 2
    if np.any(squared < 0):
        raise NoRealSolutionError(
            "pivot height difference (eq 2.5)",
            discriminant=squared if squared.ndim else float(squared),
            detail="pivot distance d_in is shorter than the xy spacing b_in",
        )
    return np.sqrt(squared)


def relative_pivot_heights(
    lengths: ArrayLike,
    beta_deg: Mapping[str, float],
    base_distance: Mapping[str, float],
    signs: ArrayLike,
) -> tuple[FloatArray, FloatArray]:
    r"""Pivot heights relative to pivot a from arm lengths (eqs 2.3-2.8).

    ``z_a = 0``, ``z_b = z_a + sign_ab |dz_ab|`` (eq 2.3), ``z_c = z_a - sign_ca |dz_ca|``
    (eq 2.4 seen from c).  The pair b-c is redundant and returned as a closure error.

    Parameters
    ----------
    lengths : array_like, shape (..., 3)
        ``L_i`` (mm), see :func:`arm_lengths`.
    beta_deg : mapping "ab", "bc", "ca" -> degrees
    base_distance : mapping "ab", "bc", "ca" -> mm
    signs : array_like, shape (..., 2)
        Signs of ``z_b - z_a`` and ``z_a - z_c`` (+1 or -1).

    Returns
    -------
    heights : ndarray, shape (..., 3)
    closure : ndarray, shape (...)
        ``|z_c - z_b| - |dz_bc|`` (mm), zero for consistent geometry.

    Raises
    ------
    NoRealSolutionError
        See :func:`height_difference`.

    See Also
    --------
    height_difference : one pair's height difference (eqs 2.5-2.8)
    dpkm_probe : the probe point from the pivots (eqs 2.9-2.21)

    Notes
    -----
    Thesis section 2.6.4 [1]_: the distance between two pivots follows from the arm lengths and
    the angle between the arms by the cosine rule (eqs 2.7-2.8), and its vertical part from the
    horizontal base distance :math:`b_{in}` (eqs 2.5-2.6),

    .. math::

        d_{in}^2 = l_i^2 + l_{in}^2 - 2 l_i l_{in} \cos\beta_{in} , \qquad
        dz_{in}^2 = d_{in}^2 - b_{in}^2 , \qquad
        z_{in} = z_i + dz_{in}

    (eq 2.3; eq 2.4 for the previous pivot).  Heights are relative to pivot a (erratum 4 of
    [2]_).

    References
    ----------
    .. [1] *A critical investigation into the accuracy of a parallel mechanism coordinate measuring machine*,
           MEng (Mechatronic) thesis, Faculty of Engineering, Stellenbosch University ("the thesis"; the copy
           the project works from names neither author nor year). Section 2.6.4, eqs 2.3-2.8.
    .. [2] The project's errata of the thesis, :doc:`/errata` (numbered as there).

    Examples
    --------
    >>> h, err = relative_pivot_heights([410.0, 410.0, 410.0], {"ab": 60, "bc": 60, "ca": 60},
    ...                                 {"ab": 400.0, "bc": 400.0, "ca": 400.0}, [1, 1])
    >>> (np.round(h, 6) + 0.0).tolist()
    [0.0, 90.0, -90.0]
    """
    length = as_readings(lengths, "lengths")
    sign = np.asarray(signs, dtype=float)
    if sign.shape != (*length.shape[:-1], 2) or not np.all(np.isin(sign, (-1.0, 1.0))):
        raise InvalidInputError("signs", f"+1/-1 values of shape {(*length.shape[:-1], 2)}", f"{sign.tolist()}")
    dz = {}
    for pair, (i, j) in zip(PAIRS, ((0, 1), (1, 2), (2, 0)), strict=True):
        dz[pair] = height_difference(length[..., i], length[..., j], np.radians(beta_deg[pair]), base_distance[pair])
    z_b = sign[..., 0] * dz["ab"]
    z_c = -sign[..., 1] * dz["ca"]
    heights = np.stack([np.zeros_like(z_b), z_b, z_c], axis=-1)
    return heights, np.abs(z_c - z_b) - dz["bc"]


def column_pivots(heights: ArrayLike, intercepts: ArrayLike, slopes: ArrayLike) -> FloatArray:
    """Pivot centres on inclined columns, eqs 2.19-2.20: ``x = g + h z``, ``y = m + n z``.

    Parameters
    ----------
    heights : array_like, shape (..., 3)
        Pivot heights ``z_i`` (mm).
    intercepts : array_like, shape (3, 2)
        ``(g_i, m_i)`` per arm (mm).
    slopes : array_like, shape (3, 2)
        ``(h_i, n_i)`` per arm (mm/mm).

    Returns
    -------
    ndarray, shape (..., 3, 3)

    Examples
    --------
    >>> column_pivots([10.0, 0.0, 0.0], [[1, 2], [3, 4], [5, 6]], [[0.1, 0], [0, 0], [0, 0]])[0].tolist()
    [2.0, 2.0, 10.0]
    """
    z = as_readings(heights, "heights")
    g_m = np.asarray(intercepts, dtype=float)
    h_n = np.asarray(slopes, dtype=float)
    if g_m.shape != (3, 2) or h_n.shape != (3, 2):
        raise InvalidInputError("intercepts/slopes", "shape (3, 2)", f"{g_m.shape}, {h_n.shape}")
    xy = g_m + h_n * z[..., None]
    return np.concatenate([xy, z[..., None]], axis=-1)


def sphere_constants(pivots: ArrayLike, lengths: ArrayLike) -> FloatArray:
    """``c_i = l_i^2 - x_i^2 - y_i^2 - z_i^2`` (eq 2.21 corrected, erratum 2), shape ``(..., 3)``.

    Examples
    --------
    >>> sphere_constants([[[1.0, 2.0, 2.0]] * 3], [[5.0, 5.0, 5.0]]).tolist()
    [[16.0, 16.0, 16.0]]
    """
    p = np.asarray(pivots, dtype=float)
    return np.asarray(lengths, dtype=float) ** 2 - np.sum(p**2, axis=-1)


def _eliminate(pivots: FloatArray, lengths: FloatArray, c_sign: float) -> tuple[FloatArray, ...]:
    """Coefficients A, B, D, F of eqs 2.12-2.15 (Appendix E sign of D), z taken as given."""
    x, y, z = pivots[..., 0], pivots[..., 1], pivots[..., 2]
    c = lengths**2 + c_sign * (x**2 + y**2 + z**2)
    c21, c31 = c[..., 1] - c[..., 0], c[..., 2] - c[..., 0]
    x12, y12 = x[..., 0] - x[..., 1], y[..., 0] - y[..., 1]
    x13, y13 = x[..., 0] - x[..., 2], y[..., 0] - y[..., 2]
    z2, z3 = z[..., 1], z[..., 2]
    denominator = x12 / z2 - x13 / z3
    a_coef = (c21 / (2 * z2) - c31 / (2 * z3)) / denominator
    b_coef = (y12 / z2 - y13 / z3) / denominator
    d_coef = y12 / z2 - b_coef * x12 / z2
    f_coef = a_coef * x12 / z2 - c21 / (2 * z2)
    return a_coef, b_coef, d_coef, f_coef, c


def dpkm_probe(
    pivots: ArrayLike, lengths: ArrayLike, *, root: Literal["lower", "upper"] = "lower"
) -> DpkmProbe:
    r"""Probe point from pivots and arm lengths, eqs 2.9-2.18 with errata 1-4 corrected.

    Heights are made relative to pivot a (erratum 4) before the elimination and the
    result is shifted back; ``v`` uses ``-2 y_a`` (erratum 1), ``c_i`` the sphere
    equation (erratum 2) and the root ``-v`` (erratum 3).

    Parameters
    ----------
    pivots : array_like, shape (..., 3, 3)
        Pivot centres a, b, c (mm).
    lengths : array_like, shape (..., 3)
        Pivot-to-tip lengths ``L_i`` (mm).
    root : {"lower", "upper"}
        The probe hangs below the pivots: ``"lower"`` (default).

    Returns
    -------
    DpkmProbe

    Raises
    ------
    InvalidInputError
        Wrong shapes or non-finite values.
    DegenerateGeometryError
        Pivot b or c level with pivot a, or the eliminations' denominator vanishes
        (the seed's formulation divides by the height differences; use
        :func:`pcmm_geo.machine.kinematics.trilateration.trilaterate` there).
    NoRealSolutionError
        ``v^2 - 4uw < 0``; the error carries the discriminant.

    See Also
    --------
    pcmm_geo.machine.kinematics.trilateration.trilaterate : the same point without the seed's special cases
    relative_pivot_heights : pivot heights from a motor move (eqs 2.3-2.8)
    pcmm_geo.machine.kinematics.model.RigidBodyMachine.forward : the calibrated rigid-body model

    Notes
    -----
    The probe point :math:`\mathbf{x}` is the point at distance :math:`L_i` from the three
    pivots :math:`\mathbf{p}_i` (thesis section 2.6.4 [1]_):

    .. math::

        \lVert \mathbf{x} - \mathbf{p}_i \rVert^2 = L_i^2 , \qquad i = a, b, c .

    Subtracting pivot a's equation from those of b and c leaves two linear equations that give
    :math:`x` and :math:`z` as linear functions of :math:`y` (eqs 2.9 and 2.11, coefficients
    eqs 2.12-2.15); pivot a's sphere then gives the quadratic :math:`u y^2 + v y + w = 0`
    (eqs 2.16-2.18) with the roots of eq 2.10,

    .. math::

        y = \frac{-v \pm \sqrt{v^2 - 4 u w}}{2 u} ,

    and :math:`c_i = L_i^2 - x_i^2 - y_i^2 - z_i^2` (eq 2.21 as the sphere equation gives it,
    erratum 2 of [2]_).  A negative discriminant means the spheres do not meet and is an error,
    never a real part (erratum 4).

    References
    ----------
    .. [1] *A critical investigation into the accuracy of a parallel mechanism coordinate measuring machine*,
           MEng (Mechatronic) thesis, Faculty of Engineering, Stellenbosch University ("the thesis"; the copy
           the project works from names neither author nor year). Section 2.6.4, eqs 2.3-2.21; Appendix E.
    .. [2] The project's errata of the thesis, :doc:`/errata` (numbered as there).

    Examples
    --------
    >>> from pcmm_geo.machine.kinematics.dpkm import APPENDIX_E
    >>> np.round(dpkm_probe(APPENDIX_E["pivots"], APPENDIX_E["lengths"]).point, 3).tolist()
    [15.035, -206.091, 79.681]
    """
    p = np.asarray(pivots, dtype=float)
    length = np.asarray(lengths, dtype=float)
    if p.ndim < 2 or p.shape[-2:] != (3, 3) or length.shape != p.shape[:-1]:
        raise InvalidInputError("pivots/lengths", "shapes (..., 3, 3) and (..., 3)", f"{p.shape} and {length.shape}")
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(length))):
        raise InvalidInputError("pivots/lengths", "finite values", "NaN or inf")
    datum = p[..., 0, 2]
    relative = p.copy()
    relative[..., 2] -= datum[..., None]
    level = np.abs(relative[..., 1:, 2]) <= 1e-9 * np.maximum(np.abs(p).max(axis=(-1, -2)), 1.0)[..., None]
    if np.any(level):
        raise DegenerateGeometryError("DPKM (eqs 2.12-2.15)", "pivot b or c is level with pivot a")
    with np.errstate(divide="ignore", invalid="ignore"):
        a_coef, b_coef, d_coef, f_coef, c = _eliminate(relative, length, -1.0)
    if not (np.all(np.isfinite(a_coef)) and np.all(np.isfinite(b_coef))):
        raise DegenerateGeometryError("DPKM (eqs 2.12-2.15)", "the elimination's denominator vanishes")
    x_a, y_a = relative[..., 0, 0], relative[..., 0, 1]
    u = 1 + b_coef**2 + d_coef**2
    v = 2 * d_coef * f_coef + 2 * x_a * b_coef - 2 * a_coef * b_coef - 2 * y_a
    w = a_coef**2 + f_coef**2 - 2 * x_a * a_coef - c[..., 0]
    discriminant = v**2 - 4 * u * w
    if np.any(discriminant < 0):
        raise NoRealSolutionError(
            "DPKM probe point (eq 2.10)",
            discriminant=discriminant if discriminant.ndim else float(discriminant),
            detail="the three spheres do not meet",
        )
    roots = []
    for sign in (1.0, -1.0):
        y_root = (-v + sign * np.sqrt(discriminant)) / (2 * u)
        roots.append(np.stack([a_coef - b_coef * y_root, y_root, f_coef + d_coef * y_root + datum], axis=-1))
    first_lower = (roots[0][..., 2] <= roots[1][..., 2])[..., None]
    lower = np.where(first_lower, roots[0], roots[1])
    upper = np.where(first_lower, roots[1], roots[0])
    return DpkmProbe(lower if root == "lower" else upper, lower, upper, discriminant)


def tetrahedron_directions(beta_deg: Mapping[str, float]) -> FloatArray:
    """Unit arm directions ``(3, 3)`` (tip -> joint) with the given angles between arms.

    Frame: tip at the origin, the arms' mean direction is ``+z``, arm a lies in the
    ``x-z`` plane at negative ``x``, and a, b, c run clockwise seen from above.

    Raises
    ------
    DegenerateGeometryError
        The three angles cannot form a trihedral corner.

    Examples
    --------
    >>> w = tetrahedron_directions({"ab": 70.0, "bc": 70.0, "ca": 70.0})
    >>> round(float(np.degrees(np.arccos(w[0] @ w[1]))), 9)
    70.0
    """
    cos_ab, cos_bc, cos_ca = (np.cos(np.radians(beta_deg[pair])) for pair in PAIRS)
    w_a = np.array([1.0, 0.0, 0.0])
    w_b = np.array([cos_ab, np.sqrt(1.0 - cos_ab**2), 0.0])
    c_x = cos_ca
    c_y = (cos_bc - cos_ab * c_x) / w_b[1]
    c_z2 = 1.0 - c_x**2 - c_y**2
    if c_z2 <= 0:
        raise DegenerateGeometryError("tetrahedron", f"angles {dict(beta_deg)} do not form a trihedral corner")
    w_c = np.array([c_x, c_y, -np.sqrt(c_z2)])  # negative triple product: clockwise from above
    directions = np.array([w_a, w_b, w_c])
    axis = directions.sum(axis=0)
    axis /= np.linalg.norm(axis)
    e_x = -(directions[0] - (directions[0] @ axis) * axis)
    e_x /= np.linalg.norm(e_x)
    e_y = np.cross(axis, e_x)
    return directions @ np.array([e_x, e_y, axis]).T


def seed_parts(
    *,
    dead_distance: Mapping[str, float] | None = None,
    beta_deg: Mapping[str, float] | None = None,
    column_points: Mapping[str, ArrayLike] | None = None,
    column_slopes: Mapping[str, ArrayLike] | None = None,
    start_of_range: float = START_OF_RANGE,
) -> tuple[Tetrahedron, dict[str, ColumnLine], FloatArray]:
    """Tetrahedron, column lines and approximate level-pose lasers of the seed geometry.

    The building blocks of :func:`pcmm_geo.machine.kinematics.model.seed_machine` (see there
    for the parameters): slider lines from the tip along :func:`tetrahedron_directions` with
    offset ``start_of_range + d_i``; column lines through ``(g_i, m_i)`` with slopes
    ``(h_i, n_i)`` (eqs 2.19-2.20) and the encoder scale that makes the height reading the
    pivot's ``z``.  The third item is a first guess of the laser readings with level pivots.

    Examples
    --------
    >>> tetra, columns, guess = seed_parts()
    >>> round(float(tetra.sliders["a"].laser_offset), 2), columns["b"].direction.tolist()
    (354.02, [0.0, 0.0, 1.0])
    """
    dead = dict(TABLE_3_1_DEAD_DISTANCE if dead_distance is None else dead_distance)
    beta = dict(TABLE_3_1_BETA_DEG if beta_deg is None else beta_deg)
    points = dict(APPENDIX_D_COLUMN_POINTS if column_points is None else column_points)
    slopes = {arm: (0.0, 0.0) for arm in ARMS} if column_slopes is None else dict(column_slopes)
    directions = tetrahedron_directions(beta)
    tip = np.zeros(3)
    sliders = {
        arm: SliderLine(tip, directions[k], 1.0, start_of_range + float(dead[arm])) for k, arm in enumerate(ARMS)
    }
    columns = {}
    for arm in ARMS:
        xyz = np.zeros(3)
        given = np.asarray(points[arm], dtype=float)
        xyz[: given.size] = given
        slope = np.asarray(slopes[arm], dtype=float)
        along = np.array([slope[0], slope[1], 1.0])
        columns[arm] = ColumnLine(xyz, along, float(np.linalg.norm(along)))
    base = [np.linalg.norm(columns[i].point[:2] - columns[j].point[:2]) for i, j in ("ab", "bc", "ca")]
    chord = [2.0 * np.sin(np.radians(beta[pair]) / 2.0) for pair in PAIRS]
    level_length = float(np.mean(base) / np.mean(chord))
    guess = np.array([level_length - sliders[arm].laser_offset for arm in ARMS])
    return Tetrahedron(sliders, tip), columns, guess

