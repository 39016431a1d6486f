"""Axis cells and the rigorous bounds of the point distances over a cell.

An axis is ``X + s d`` with ``X = (x0, y0, 0)`` and ``d = (a, b, 1) / q`` in a chart
frame; a *cell* is a box of ``(x0, y0, a, b)`` around a centre axis ``(X_c, d_c)``.  For
a point ``P`` with height ``h = (P - X_c) . d_c``, distance ``rho = |(P - X_c) x d_c|``
and unit radial vector ``beta`` (from the centre axis to the point), every axis of the
cell satisfies (``phi``: largest angle between ``d_c`` and a direction of the cell,
``delta = 2 sin(phi / 2)``, ``hx, hy``: the half widths in ``x0, y0``, ``eps = |(hx, hy)|``)::

    rho(X, d) >= rho + (d - d_c) . alpha - (X - X_c) . beta - eps delta
    rho(X, d) <= rho + (d - d_c) . alpha - (X - X_c) . beta + eps delta + D^2 / (2 rho)

with ``alpha = rho d_c - h beta`` and ``D = |h| sin(phi) + rho delta + eps (1 + delta)``.
Proof: write ``(P - X) x d = m + dm`` with ``m = (P - X_c) x d_c``; then
``|m + dm| >= u . (m + dm)`` for the unit ``u = m / |m|`` (Cauchy-Schwarz) and
``|m + dm| <= |m| + u . dm + |dm|^2 / (2 |m|)``, where
``u . dm = (d - d_c) . alpha - (X - X_c) . beta - u . ((X - X_c) x (d - d_c))`` and ``|dm| <= D``.
The component of ``d - d_c`` normal to ``d_c`` is at most ``sin(phi)`` long, the one along it
lies in ``[cos(phi) - 1, 0]``, and ``|(X - X_c) . beta| <= eps``, so per point::

    rho - |h| sin(phi) - rho (1 - cos(phi)) - eps (1 + delta)  <=  rho(X, d)  <=  rho + D

(:meth:`CellTerms.lower_margin`, :meth:`CellTerms.upper_margin`).  Summed with weights the
linear terms can cancel: :mod:`~pcmm_geo.fit.zone.axial.lagrange`.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record

FloatArray = NDArray[np.float64]

#: relative rounding allowance of a computed distance (times the coordinate scale)
ROUNDING = 64 * np.finfo(float).eps


def directions(tilt: FloatArray) -> FloatArray:
    """Unit directions ``(a, b, 1) / q`` of tilts ``(K, 2)``, shape (K, 3)."""
    q = np.sqrt(1.0 + tilt[:, 0] ** 2 + tilt[:, 1] ** 2)
    return np.column_stack([tilt[:, 0] / q, tilt[:, 1] / q, 1.0 / q])


def _cross(u: FloatArray, v: FloatArray) -> FloatArray:
    """Row-wise cross products of (K, 3) arrays."""
    return np.column_stack([
        u[:, 1] * v[:, 2] - u[:, 2] * v[:, 1],
        u[:, 2] * v[:, 0] - u[:, 0] * v[:, 2],
        u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0],
    ])


def angular_radius(center: FloatArray, half: FloatArray, axis: FloatArray) -> FloatArray:
    """Largest angle (rad) between each cell's centre direction and a direction of the cell, shape (K,).

    In the gnomonic chart ``(a, b)`` the directions within an angle of ``d_c`` form a
    convex set (a conic's interior), so the largest angle over the square is at a corner.
    """
    largest = np.zeros(len(center))
    for sign_a in (-1.0, 1.0):
        for sign_b in (-1.0, 1.0):
            corner_tilt = np.column_stack([center[:, 2] + sign_a * half[:, 2], center[:, 3] + sign_b * half[:, 3]])
            corner = directions(corner_tilt)
            sine = np.linalg.norm(_cross(corner, axis), axis=1)
            cosine = np.einsum("kj,kj->k", corner, axis)
            largest = np.maximum(largest, np.arctan2(sine, cosine))
    return largest


def plane_basis(axis: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Two unit vectors completing each axis (K, 3) to a right-handed orthonormal frame."""
    helper = np.zeros_like(axis)
    helper[np.arange(len(axis)), np.argmin(np.abs(axis), axis=1)] = 1.0
    first = _cross(helper, axis)
    first /= np.linalg.norm(first, axis=1, keepdims=True)
    return first, _cross(axis, first)


@record
class CellTerms:
    """Distances of points from the centre axes of cells and the cells' sizes.

    Attributes
    ----------
    rho, height : ndarray, shape (K, S)
        Distance from / height along each cell's centre axis.
    radial : ndarray, shape (K, S, 3) or None
        Unit radial vectors (only when asked for; without them the position term of the
        margins is its Cauchy-Schwarz bound ``eps``).
    sin_phi, one_minus_cos, chord, eps : ndarray, shape (K,)
        ``sin(phi)``, ``1 - cos(phi)``, ``2 sin(phi / 2)``, ``|(hx, hy)|``.
    half : ndarray, shape (K, 4)
        The cells' half widths.
    axis, foot : ndarray, shape (K, 3)
        Centre directions and crossing points ``X_c``.
    slack : float
        Rounding allowance (mm).
    """

    rho: FloatArray
    height: FloatArray
    radial: FloatArray | None
    sin_phi: FloatArray
    one_minus_cos: FloatArray
    chord: FloatArray
    eps: FloatArray
    half: FloatArray
    axis: FloatArray
    foot: FloatArray
    slack: float

    def select(self, columns: NDArray[np.intp]) -> CellTerms:
        """The terms of a subset of the points (columns)."""
        radial = None if self.radial is None else self.radial[:, columns]
        return dataclasses.replace(self, rho=self.rho[:, columns], height=self.height[:, columns], radial=radial)

    def lower_margin(self) -> FloatArray:
        """Per-point ``rho - min rho(cell)`` bound, shape (K, S)."""
        constant = (self.eps * (1.0 + self.chord))[:, None] + self.slack
        return np.abs(self.height) * self.sin_phi[:, None] + self.rho * self.one_minus_cos[:, None] + constant

    def upper_margin(self) -> FloatArray:
        """Per-point ``max rho(cell) - rho`` bound, shape (K, S): ``D = |h| sin(phi) + rho delta + eps (1 + delta)``.

        (The sharper second-order form serves the multiplier bound, where it matters.)
        """
        constant = (self.eps * (1.0 + self.chord))[:, None] + self.slack
        return np.abs(self.height) * self.sin_phi[:, None] + self.rho * self.chord[:, None] + constant


@record
class CellShape:
    """Centre axes and sizes of cells (K,): what the bounds need besides the points."""

    center: FloatArray
    half: FloatArray
    axis: FloatArray
    first: FloatArray
    second: FloatArray
    foot: FloatArray
    phi: FloatArray

    @classmethod
    def of(cls, center: FloatArray, half: FloatArray) -> CellShape:
        axis = directions(center[:, 2:4])
        first, second = plane_basis(axis)
        foot = np.zeros((len(center), 3))
        foot[:, :2] = center[:, :2]
        phi = np.minimum(angular_radius(center, half, axis), np.pi / 2)
        return cls(center, half, axis, first, second, foot, phi)


def cell_terms(
    points: FloatArray, center: FloatArray | CellShape, half: FloatArray | None = None, *, radial: bool = False
) -> CellTerms:
    """Distances of ``points`` (S, 3) from the centre axes of cells ``centre``/``half`` (K, 4) or a :class:`CellShape`.

    Each point is written in the frame ``(e1, e2, d)`` of the axis with one matrix product,
    minus the foot ``X``'s coordinates: the radial coordinates are then accurate to the
    rounding of the coordinates, even for points on the axis.
    """
    shape = center if isinstance(center, CellShape) else CellShape.of(center, half)  # type: ignore[arg-type]
    k = len(shape.center)
    frames = np.concatenate([shape.axis, shape.first, shape.second])  # (3K, 3)
    coords = frames @ points.T  # (3K, S)
    shift = np.einsum("kj,kj->k", np.tile(shape.foot, (3, 1)), frames)
    coords -= shift[:, None]
    height, u, v = coords[:k], coords[k : 2 * k], coords[2 * k :]
    rho = np.hypot(u, v)
    radial_unit = None
    if radial:  # unit vector (u e1 + v e2) / rho from the axis to each point (any unit vector on the axis)
        safe = np.where(rho > 0, rho, 1.0)
        radial_unit = u[..., None] * shape.first[:, None, :] + v[..., None] * shape.second[:, None, :]
        radial_unit /= safe[..., None]
        on_axis = np.nonzero(rho == 0)
        radial_unit[on_axis] = shape.first[on_axis[0]]
    phi = shape.phi
    scale = float(np.abs(points).max(initial=0.0)) + float(np.abs(shape.center[:, :2]).max(initial=0.0))
    return CellTerms(
        rho=rho,
        height=height,
        radial=radial_unit,
        sin_phi=np.sin(phi),
        one_minus_cos=2.0 * np.sin(phi / 2) ** 2,
        chord=2.0 * np.sin(phi / 2),
        eps=np.hypot(shape.half[:, 0], shape.half[:, 1]),
        half=shape.half,
        axis=shape.axis,
        foot=shape.foot,
        slack=ROUNDING * max(scale, 1.0),
    )


def axis_distances(points: FloatArray, x: FloatArray) -> FloatArray:
    """Distances (M, S) of ``points`` (S, 3) from the axes ``x`` (M, 4), accurate to coordinate rounding."""
    axis = directions(x[:, 2:4])
    first, second = plane_basis(axis)
    foot = np.zeros((len(x), 3))
    foot[:, :2] = x[:, :2]
    u = first @ points.T - np.einsum("kj,kj->k", foot, first)[:, None]
    v = second @ points.T - np.einsum("kj,kj->k", foot, second)[:, None]
    return np.hypot(u, v)


def center_values(rho: FloatArray, mode: str) -> FloatArray:
    """Objective (to minimise) at the centre axes: ``max``, ``max - min`` or ``-min`` of ``rho`` (K,)."""
    if mode == "mcc":
        return rho.max(axis=1)
    if mode == "zone":
        return rho.max(axis=1) - rho.min(axis=1)
    return -rho.min(axis=1)


def point_bounds(terms: CellTerms, mode: str) -> tuple[FloatArray, FloatArray | None, FloatArray | None]:
    """Lower bound of the objective over each cell from the per-point margins, shape (K,).

    Also returns the per-point lower / upper distance bounds used (for the working set).
    """
    low = high = None
    if mode in ("mcc", "zone"):
        low = terms.rho - terms.lower_margin()
    if mode in ("zone", "mic"):
        high = terms.rho + terms.upper_margin()
    if mode == "mcc":
        bound = np.maximum(low.max(axis=1), 0.0)
    elif mode == "zone":
        bound = np.maximum(low.max(axis=1) - high.min(axis=1), 0.0)
    else:
        bound = -high.min(axis=1)
    return bound, low, high
