"""Measurement tasks of the virtual micro-CMM: where the probe touches and how the result is evaluated.

A task is a set of ``P`` nominal contact points on an artefact with their outward surface
normals (the probe approaches against the normal, so the tip center at contact is
``contact + r normal``) and a vectorised evaluation ``(T, P, 3) -> (T,)`` of the measured
points -- the same computation the library uses for one measurement, batched:

* :func:`gauge_block_task` -- central length by the ISO 3650 method
  (:func:`~pcmm_geo.artefacts.gauge_block.measure_gauge_block`: least-squares plane per
  measuring face, center points, mean of the two one-way lengths) with batched plane fits;
* :func:`sphere_task` -- diameter of a Gaussian sphere fit (batched);
* :func:`distance_task` -- distance between two single probings on opposite faces.

All lengths in mm.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError

__all__ = [
    "GAUGE_FACE_OFFSETS",
    "MeasurementTask",
    "distance_task",
    "gauge_block_task",
    "gauge_block_central_lengths",
    "sphere_task",
]

FloatArray = NDArray[np.float64]
#: (z, y) offsets (mm) of the probings on a 9 mm x 35 mm measuring face: a cross around its center
GAUGE_FACE_OFFSETS = np.array(
    [[0.0, 0.0], [0.0, 12.0], [0.0, -12.0], [3.0, 0.0], [-3.0, 0.0], [2.0, 8.0], [-2.0, -8.0]]
)


@record
class MeasurementTask:
    """One measurement of the virtual CMM.

    Attributes
    ----------
    name : str
        ``"gauge_block"``, ``"sphere"`` or ``"distance"``.
    quantity : str
        The measurand (``"central_length"``, ``"diameter"``, ``"distance"``).
    nominal : float
        Its nominal value (mm).
    contacts : ndarray, shape (P, 3)
        Nominal contact points in the machine frame (mm).
    normals : ndarray, shape (P, 3)
        Outward unit surface normals at the contacts.
    evaluate : callable
        ``evaluate(points (T, P, 3)) -> (T,)`` measured value per trial (mm).
    """

    name: str
    quantity: str
    nominal: float
    contacts: FloatArray
    normals: FloatArray
    evaluate: Callable[[FloatArray], FloatArray]


def _center(center: ArrayLike) -> FloatArray:
    c = np.asarray(center, dtype=float)
    if c.shape != (3,) or not np.all(np.isfinite(c)):
        raise InvalidInputError("center", "a finite point of shape (3,) in mm", repr(c.tolist()))
    return c


def gauge_block_central_lengths(face_1: FloatArray, face_2: FloatArray) -> FloatArray:
    """Central length (ISO 3650 method) of ``T`` measurements at once.

    Parameters
    ----------
    face_1, face_2 : ndarray, shape (T, N, 3)
        Measured points on the two measuring faces (N >= 3 each, mm).

    Returns
    -------
    ndarray, shape (T,)
        Mean of the distances from each face's center point to the other face's plane.

    Examples
    --------
    >>> f1 = np.array([[[0.0, 0, 0], [0, 10, 0], [0, 0, 3], [0, -10, -3]]])
    >>> f2 = f1 + [100.0, 0.0, 0.0]
    >>> np.round(gauge_block_central_lengths(f1, f2), 9).tolist()
    [100.0]
    """
    from pcmm_geo.fit.batch import fit_planes

    plane_1, plane_2 = fit_planes(face_1), fit_planes(face_2)
    c1, c2 = np.asarray(plane_1.points), np.asarray(plane_2.points)  # centroids = center points
    towards = c2 - c1
    n1 = np.asarray(plane_1.normals) * np.sign(np.sum(np.asarray(plane_1.normals) * towards, axis=1))[:, None]
    n2 = np.asarray(plane_2.normals) * np.sign(np.sum(np.asarray(plane_2.normals) * towards, axis=1))[:, None]
    return 0.5 * (np.sum(towards * n2, axis=1) + np.sum(towards * n1, axis=1))


def gauge_block_task(length: float, center: ArrayLike, *, points_per_face: int = 5) -> MeasurementTask:
    """Central length of a gauge block lying along x, probed on both measuring faces.

    Parameters
    ----------
    length : float
        Nominal length (mm).
    center : array_like, shape (3,)
        Block center in the machine frame (mm).
    points_per_face : int
        3 to 7 probings per face on a cross about the face center (:data:`GAUGE_FACE_OFFSETS`).

    Examples
    --------
    >>> task = gauge_block_task(100.0, [0.0, 0.0, -380.0])
    >>> task.contacts.shape, round(float(task.evaluate(task.contacts[None])[0]), 9)
    ((10, 3), 100.0)
    """
    if not 3 <= points_per_face <= len(GAUGE_FACE_OFFSETS):
        raise InvalidInputError("points_per_face", f"3 to {len(GAUGE_FACE_OFFSETS)}", str(points_per_face))
    if not (np.isfinite(length) and length > 0):
        raise InvalidInputError("length", "a positive length in mm", str(length))
    c = _center(center)
    offsets = GAUGE_FACE_OFFSETS[:points_per_face]
    contacts, normals = [], []
    for sign in (-1.0, 1.0):
        face = c + np.column_stack([np.full(len(offsets), sign * length / 2.0), offsets[:, 1], offsets[:, 0]])
        contacts.append(face)
        normals.append(np.tile([sign, 0.0, 0.0], (len(offsets), 1)))
    n = points_per_face

    def evaluate(points: FloatArray) -> FloatArray:
        return gauge_block_central_lengths(points[:, :n], points[:, n:])

    return MeasurementTask("gauge_block", "central_length", float(length), np.vstack(contacts), np.vstack(normals),
                           evaluate)


def sphere_task(diameter: float, center: ArrayLike, *, points: int = 25) -> MeasurementTask:
    """Diameter of a reference sphere probed on its upper hemisphere (Gaussian fit).

    Points lie on a spiral over the hemisphere above the equator (a stylus reaches them
    from above), as an ISO 10360-5 style distribution.

    Examples
    --------
    >>> task = sphere_task(25.0, [0.0, 0.0, -380.0])
    >>> round(float(task.evaluate(task.contacts[None])[0]), 9)
    25.0
    """
    if not (np.isfinite(diameter) and diameter > 0):
        raise InvalidInputError("diameter", "a positive diameter in mm", str(diameter))
    if points < 5:
        raise InvalidInputError("points", "at least 5 probings", str(points))
    c = _center(center)
    golden = np.pi * (3.0 - np.sqrt(5.0))
    index = np.arange(points)
    height = 1.0 - (index + 0.5) / points  # upper hemisphere
    ring = np.sqrt(1.0 - height**2)
    normals = np.column_stack([ring * np.cos(golden * index), ring * np.sin(golden * index), height])
    contacts = c + 0.5 * diameter * normals

    def evaluate(measured: FloatArray) -> FloatArray:
        from pcmm_geo.fit.batch import fit_spheres

        return 2.0 * np.asarray(fit_spheres(measured).radii)

    return MeasurementTask("sphere", "diameter", float(diameter), contacts, normals, evaluate)


def distance_task(length: float, center: ArrayLike, *, direction: ArrayLike = (1.0, 0.0, 0.0)) -> MeasurementTask:
    """Distance between two single probings on opposite parallel faces ``length`` apart.

    Examples
    --------
    >>> task = distance_task(50.0, [0.0, 0.0, -380.0])
    >>> round(float(task.evaluate(task.contacts[None])[0]), 9)
    50.0
    """
    if not (np.isfinite(length) and length > 0):
        raise InvalidInputError("length", "a positive length in mm", str(length))
    d = np.asarray(direction, dtype=float)
    if d.shape != (3,) or not np.linalg.norm(d) > 0:
        raise InvalidInputError("direction", "a non-zero vector of shape (3,)", repr(d.tolist()))
    d = d / np.linalg.norm(d)
    c = _center(center)
    contacts = np.vstack([c - 0.5 * length * d, c + 0.5 * length * d])
    normals = np.vstack([-d, d])

    def evaluate(measured: FloatArray) -> FloatArray:
        return np.linalg.norm(measured[:, 1] - measured[:, 0], axis=1)

    return MeasurementTask("distance", "distance", float(length), contacts, normals, evaluate)
