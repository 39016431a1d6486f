"""Nearest point of a triangle to a point, many pairs at once, in double precision.

The classification of the point into the seven regions of the triangle's plane (three
corners, three edges, the interior) follows the dot-product tests of Ericson, *Real-Time
Collision Detection* (2005), section 5.1.5; here every pair is evaluated at once with
numpy and the answer is returned as barycentric weights, which the sign rule reuses.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def closest_on_triangles(points: FloatArray, corners: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Nearest points of triangles to points, pair by pair.

    Parameters
    ----------
    points : ndarray, shape (M, 3)
        Query points (mm).
    corners : ndarray, shape (M, 3, 3)
        Triangle ``m`` has corners ``corners[m, 0..2]`` (mm).

    Returns
    -------
    closest : ndarray, shape (M, 3)
        Nearest point of triangle ``m`` to point ``m``.
    squared : ndarray, shape (M,)
        Squared distance between them (mm^2).
    barycentric : ndarray, shape (M, 3)
        Weights of the corners giving ``closest`` (non-negative, summing to one; exactly
        zero on the edge or corner regions).

    Examples
    --------
    >>> triangle = np.array([[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]])
    >>> closest, squared, weights = closest_on_triangles(np.array([[2.0, 2.0, 1.0]]), triangle)
    >>> closest.tolist(), squared.tolist(), weights.tolist()
    ([[0.5, 0.5, 0.0]], [5.5], [[0.0, 0.5, 0.5]])
    """
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    ab, ac = b - a, c - a
    ap, bp, cp = points - a, points - b, points - c
    d1, d2 = _dot(ab, ap), _dot(ac, ap)
    d3, d4 = _dot(ab, bp), _dot(ac, bp)
    d5, d6 = _dot(ab, cp), _dot(ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    # interior first, then every region overrides it in the reverse order of Ericson's tests
    with np.errstate(divide="ignore", invalid="ignore"):
        total = va + vb + vc
        v = np.where(total != 0.0, vb / total, 1.0 / 3.0)
        w = np.where(total != 0.0, vc / total, 1.0 / 3.0)
        on_bc = (va <= 0.0) & (d4 - d3 >= 0.0) & (d5 - d6 >= 0.0)
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        v, w = np.where(on_bc, 1.0 - t_bc, v), np.where(on_bc, t_bc, w)
        on_ac = (vb <= 0.0) & (d2 >= 0.0) & (d6 <= 0.0)
        t_ac = d2 / (d2 - d6)
        v, w = np.where(on_ac, 0.0, v), np.where(on_ac, t_ac, w)
        at_c = (d6 >= 0.0) & (d5 <= d6)
        v, w = np.where(at_c, 0.0, v), np.where(at_c, 1.0, w)
        on_ab = (vc <= 0.0) & (d1 >= 0.0) & (d3 <= 0.0)
        t_ab = d1 / (d1 - d3)
        v, w = np.where(on_ab, t_ab, v), np.where(on_ab, 0.0, w)
        at_b = (d3 >= 0.0) & (d4 <= d3)
        v, w = np.where(at_b, 1.0, v), np.where(at_b, 0.0, w)
        at_a = (d1 <= 0.0) & (d2 <= 0.0)
        v, w = np.where(at_a, 0.0, v), np.where(at_a, 0.0, w)
    barycentric = np.stack([1.0 - v - w, v, w], axis=1)
    closest = a + v[:, None] * ab + w[:, None] * ac
    # a corner region is exactly that corner (no rounding of a + 1 * ab)
    corner_b = at_b & ~at_a
    corner_c = at_c & ~at_a & ~at_b & ~on_ab
    closest[corner_b] = b[corner_b]
    closest[corner_c] = c[corner_c]
    offset = points - closest
    return closest, _dot(offset, offset), barycentric


def _dot(left: FloatArray, right: FloatArray) -> FloatArray:
    return np.einsum("ij,ij->i", left, right)
