"""Thermal deformation of the machine's triangular frame (thesis section 4.1.1, eqs 4.2-4.9).

Seen from above the frame is a triangle with corners A, B, C.  The thesis fixes
three coordinates so that the frame can expand freely without moving as a whole:
A is pinned (``a_x``, ``a_y`` fixed) and B slides along x (``b_y`` fixed).  Given
the three (expanded) side lengths, the free coordinates follow from

* eq 4.4 ``b_x = sqrt(l'_AB² − (a_y − b_y)²) + a_x``
* eq 4.5 the angle β at B from the cosine rule,
* eq 4.6 ``ψ = asin((b_y − a_y) / l'_AB)``,
* eq 4.7 ``θ = ψ + β − 90°``,
* eqs 4.8-4.9 ``c_y = b_y − l'_BC cos θ``, ``c_x = b_x + l'_BC sin θ``.

Two misprints in the source, both documented here and handled correctly:

* eq 4.5 as printed, ``β = acos((l'_AC² − l'_AB² − l'_BC²) / (2 l'_AB l'_BC))``, has the
  sign of the numerator reversed (it gives β = 120° for the equilateral frame).  The
  cosine rule gives ``cos β = (l'_AB² + l'_BC² − l'_AC²) / (2 l'_AB l'_BC)``, which is what
  the Appendix E code computes (it divides by ``−2 l'_AB l'_BC``).
* Appendix E line 141 uses ``Lab_p`` in place of ``l'_BC`` in eq 4.8.  That is harmless
  only while ``l'_AB = l'_BC``; :func:`seed_frame_corners` reproduces it for comparison.

With 650 mm sides at 20 °C the corners are those of Table 4.1:
A (−375.278, 0), B (187.639, 325), C (187.639, −325) (the table truncates to 2 decimals).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError, NoRealSolutionError
from pcmm_geo.thermal.expansion import ALPHA_ALUMINIUM, REFERENCE_TEMPERATURE

__all__ = [
    "NOMINAL_SIDE",
    "FrameTriangle",
    "deform_triangle",
    "expand_frame",
    "frame_corners",
    "seed_frame_corners",
]

FloatArray = NDArray[np.float64]

#: Side length of the frame triangle in the thesis (Table 4.1), mm.
NOMINAL_SIDE = 650.0


@record
class FrameTriangle:
    """Corners of the frame triangle and the angles of eqs 4.5-4.7.

    Attributes
    ----------
    a, b, c : ndarray, shape (2,)
        Corner coordinates (x, y) in mm.
    side_ab, side_ac, side_bc : float
        Side lengths used (mm), the primed lengths ``l'`` of eq 4.3.
    beta : float
        Interior angle at B (rad), eq 4.5 (corrected).
    psi : float
        Inclination of side AB to the x axis (rad), eq 4.6.
    theta : float
        ``ψ + β − π/2`` (rad), eq 4.7.
    """

    a: FloatArray
    b: FloatArray
    c: FloatArray
    side_ab: float
    side_ac: float
    side_bc: float
    beta: float
    psi: float
    theta: float

    @property
    def corners(self) -> FloatArray:
        """Corners A, B, C as rows of a ``(3, 2)`` array (mm)."""
        return np.vstack([self.a, self.b, self.c])

    def side_lengths(self) -> FloatArray:
        """Lengths ``|AB|``, ``|AC|``, ``|BC|`` recomputed from the corners (mm), shape (3,)."""
        return np.array(
            [np.linalg.norm(self.b - self.a), np.linalg.norm(self.c - self.a), np.linalg.norm(self.c - self.b)]
        )


def _nominal_anchor(side: float) -> tuple[tuple[float, float], float]:
    # Table 4.1: equilateral frame with its centroid at the origin, A on the -x axis
    return (-side / math.sqrt(3.0), 0.0), side / 2.0


def frame_corners(
    side_ab: float,
    side_ac: float,
    side_bc: float,
    *,
    a: ArrayLike | None = None,
    b_y: float | None = None,
) -> FrameTriangle:
    """Corners of the frame for given side lengths, A pinned and B sliding (eqs 4.2-4.9).

    Parameters
    ----------
    side_ab, side_ac, side_bc : float
        Side lengths ``l'_AB``, ``l'_AC``, ``l'_BC`` (mm).
    a : array_like, shape (2,), optional
        Fixed position of A (mm); default Table 4.1's (−650/√3, 0).
    b_y : float, optional
        Fixed y coordinate of B (mm); default 325 mm (Table 4.1).

    Returns
    -------
    FrameTriangle
        Corners and the angles β, ψ, θ.  C lies on the −y side of AB.

    Raises
    ------
    InvalidInputError
        A non-positive or non-finite length.
    NoRealSolutionError
        ``l'_AB < |b_y − a_y|`` (eq 4.4 has no real root) or the sides violate the
        triangle inequality (eq 4.5 has no real angle).

    Examples
    --------
    >>> tri = frame_corners(650.0, 650.0, 650.0)
    >>> [round(float(v), 3) + 0.0 for v in (*tri.a, *tri.b, *tri.c)]
    [-375.278, 0.0, 187.639, 325.0, 187.639, -325.0]
    """
    sides = {"side_ab": side_ab, "side_ac": side_ac, "side_bc": side_bc}
    for name, value in sides.items():
        if not (isinstance(value, (int, float, np.floating)) and math.isfinite(value) and value > 0):
            raise InvalidInputError(name, "a positive finite length in mm", repr(value))
    default_a, default_by = _nominal_anchor(NOMINAL_SIDE)
    a_xy = np.asarray(default_a if a is None else a, dtype=float)
    if a_xy.shape != (2,) or not np.all(np.isfinite(a_xy)):
        raise InvalidInputError("a", "a finite (x, y) pair in mm", f"{a_xy.tolist()}")
    by = float(default_by if b_y is None else b_y)
    rise = by - a_xy[1]
    radicand = side_ab**2 - rise**2
    if radicand < 0:
        raise NoRealSolutionError(
            "frame corner b_x (eq 4.4)", radicand, f"side AB {side_ab} mm is shorter than the fixed rise {rise} mm"
        )
    bx = math.sqrt(radicand) + a_xy[0]  # eq 4.4
    cos_beta = (side_ab**2 + side_bc**2 - side_ac**2) / (2.0 * side_ab * side_bc)  # eq 4.5, corrected sign
    if not -1.0 <= cos_beta <= 1.0:
        raise NoRealSolutionError(
            "frame angle beta (eq 4.5)", cos_beta, "the three side lengths violate the triangle inequality"
        )
    beta = math.acos(cos_beta)
    psi = math.asin(rise / side_ab)  # eq 4.6
    theta = psi + beta - math.pi / 2.0  # eq 4.7
    cy = by - side_bc * math.cos(theta)  # eq 4.8
    cx = bx + side_bc * math.sin(theta)  # eq 4.9
    return FrameTriangle(
        a=a_xy.copy(),
        b=np.array([bx, by]),
        c=np.array([cx, cy]),
        side_ab=float(side_ab),
        side_ac=float(side_ac),
        side_bc=float(side_bc),
        beta=beta,
        psi=psi,
        theta=theta,
    )


def expand_frame(
    temperatures: ArrayLike,
    *,
    nominal_sides: ArrayLike = (NOMINAL_SIDE, NOMINAL_SIDE, NOMINAL_SIDE),
    alpha: float = ALPHA_ALUMINIUM,
    reference_temperature: float = REFERENCE_TEMPERATURE,
    a: ArrayLike | None = None,
    b_y: float | None = None,
) -> FrameTriangle:
    """Frame corners when the sides AB, AC, BC are at the given temperatures.

    Each side becomes ``l' = l0 (1 + α (T − T_ref))`` (eqs 4.1, 4.3), then
    :func:`frame_corners` places the corners (eqs 4.4-4.9).

    Parameters
    ----------
    temperatures : array_like, shape (3,)
        Temperatures of sides AB, AC, BC (°C).
    nominal_sides : array_like, shape (3,)
        Side lengths AB, AC, BC at ``reference_temperature`` (mm); default 650 mm each.
    alpha : float
        Expansion coefficient of the frame (1/K), default aluminium.
    reference_temperature : float
        Temperature of the nominal lengths (°C), default 20 °C.
    a, b_y
        Fixed coordinates, see :func:`frame_corners`.

    Returns
    -------
    FrameTriangle

    Raises
    ------
    InvalidInputError
        Wrong shape or non-finite values.
    NoRealSolutionError
        Impossible side lengths.

    Examples
    --------
    >>> tri = expand_frame([21.0, 21.0, 21.0])
    >>> round(float(tri.side_lengths()[0]) - 650.0, 9)
    0.015015
    """
    temps = np.asarray(temperatures, dtype=float)
    sides = np.asarray(nominal_sides, dtype=float)
    if temps.shape != (3,) or not np.all(np.isfinite(temps)):
        raise InvalidInputError("temperatures", "3 finite temperatures (AB, AC, BC) in °C", f"{temps.tolist()}")
    if sides.shape != (3,):
        raise InvalidInputError("nominal_sides", "3 lengths (AB, AC, BC) in mm", f"shape {sides.shape}")
    expanded = sides * (1.0 + alpha * (temps - reference_temperature))
    return frame_corners(float(expanded[0]), float(expanded[1]), float(expanded[2]), a=a, b_y=b_y)


def seed_frame_corners(side_ab: float, side_ac: float, side_bc: float) -> FrameTriangle:
    """Appendix E's version of eqs 4.4-4.9, including its slip ``c_y = b_y − l'_AB cos θ`` (line 141).

    Identical to :func:`frame_corners` when ``side_ab == side_bc``; otherwise side BC
    no longer has its length.  Kept for comparison only.

    Parameters
    ----------
    side_ab, side_ac, side_bc : float
        Side lengths (mm).

    Returns
    -------
    FrameTriangle

    Raises
    ------
    InvalidInputError, NoRealSolutionError
        As :func:`frame_corners`.

    Examples
    --------
    >>> tri = seed_frame_corners(650.0, 650.0, 651.0)
    >>> [round(float(v), 3) for v in tri.side_lengths()]  # AC and BC are not 650 and 651 mm
    [650.0, 649.499, 650.0]
    """
    correct = frame_corners(side_ab, side_ac, side_bc)
    cy = correct.b[1] - side_ab * math.cos(correct.theta)
    return FrameTriangle(
        a=correct.a,
        b=correct.b,
        c=np.array([correct.c[0], cy]),
        side_ab=correct.side_ab,
        side_ac=correct.side_ac,
        side_bc=correct.side_bc,
        beta=correct.beta,
        psi=correct.psi,
        theta=correct.theta,
    )


def deform_triangle(
    corners: ArrayLike,
    sides: ArrayLike,
    *,
    slide_direction: ArrayLike = (1.0, 0.0),
) -> FloatArray:
    """Corners of any plan triangle after its sides change length, A pinned and B sliding.

    The general form of eqs 4.4-4.9: A stays put, B moves along ``slide_direction`` (the
    root nearest its old place), and C keeps its side of line AB.  For the Table 4.1 layout
    and ``slide_direction = x`` it gives the same corners as :func:`frame_corners`.

    Parameters
    ----------
    corners : array_like, shape (3, 2)
        Nominal corners A, B, C (mm).
    sides : array_like, shape (3,)
        New lengths AB, AC, BC (mm).
    slide_direction : array_like, shape (2,)
        Direction along which B may slide.

    Returns
    -------
    ndarray, shape (3, 2)

    Raises
    ------
    InvalidInputError
        Wrong shapes, non-positive sides, zero slide direction, degenerate nominal triangle.
    NoRealSolutionError
        B cannot reach the new AB length along its slide, or the sides violate the triangle
        inequality.

    Examples
    --------
    >>> tri = frame_corners(650.0, 650.0, 650.0)
    >>> new = deform_triangle(tri.corners, [650.5, 650.0, 649.0])
    >>> bool(np.allclose(new, frame_corners(650.5, 650.0, 649.0).corners, atol=1e-12))
    True
    """
    pts = np.asarray(corners, dtype=float)
    lengths = np.asarray(sides, dtype=float)
    slide = np.asarray(slide_direction, dtype=float)
    if pts.shape != (3, 2) or not np.all(np.isfinite(pts)):
        raise InvalidInputError("corners", "a finite (3, 2) array of A, B, C", f"shape {pts.shape}")
    if lengths.shape != (3,) or not np.all(np.isfinite(lengths)) or np.any(lengths <= 0):
        raise InvalidInputError("sides", "3 positive lengths AB, AC, BC in mm", f"{lengths.tolist()}")
    if slide.shape != (2,) or not np.all(np.isfinite(slide)) or np.linalg.norm(slide) == 0:
        raise InvalidInputError("slide_direction", "a non-zero 2-vector", f"{slide.tolist()}")
    slide = slide / np.linalg.norm(slide)
    a, b, c = pts
    ab = b - a
    orientation = float(ab[0] * (c - a)[1] - ab[1] * (c - a)[0])
    if orientation == 0:
        raise InvalidInputError("corners", "a non-degenerate triangle", "collinear corners")
    side_ab, side_ac, side_bc = map(float, lengths)
    along = float(slide @ ab)
    disc = along**2 - float(ab @ ab) + side_ab**2
    if disc < 0:
        raise NoRealSolutionError("triangle corner B", disc, "B cannot reach the new length AB along its slide")
    roots = (-along + math.sqrt(disc), -along - math.sqrt(disc))
    step = min(roots, key=abs)
    b_new = b + step * slide
    e1 = (b_new - a) / side_ab
    e2 = np.array([-e1[1], e1[0]]) * math.copysign(1.0, orientation)
    x = (side_ac**2 - side_bc**2 + side_ab**2) / (2.0 * side_ab)
    height_sq = side_ac**2 - x**2
    if height_sq < 0:
        raise NoRealSolutionError("triangle corner C", height_sq, "the sides violate the triangle inequality")
    c_new = a + x * e1 + math.sqrt(height_sq) * e2
    return np.vstack([a, b_new, c_new])
