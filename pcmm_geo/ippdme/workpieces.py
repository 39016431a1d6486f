"""Simulated workpieces on the micro-CMM's table: signed distances of the probe-tip centre.

Each workpiece gives the signed distance (mm, positive outside the material) of points from
its surface; the probe ball of radius ``r`` touches when the distance of its centre is ``r``.
:func:`first_contact` walks a straight tip-centre path and returns the first touching point.

* :class:`SphereWorkpiece` -- exact ``|p - c| - R``;
* :class:`PlaneWorkpiece` -- a half-space below the plane (``(p - p0) . n``);
* :class:`BoxWorkpiece` -- a gauge block (rectangular box, exact box distance);
* :class:`CylinderWorkpiece` -- a finite solid cylinder (exact, flat ends);
* :class:`MeshWorkpiece` -- a closed triangle mesh (exact signed distances of
  :func:`pcmm_geo.artefacts.cad_distance.surface_distances`; needs the ``cad`` extra).
"""

from __future__ import annotations

from dataclasses import field
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError

__all__ = [
    "BoxWorkpiece",
    "CylinderWorkpiece",
    "MeshWorkpiece",
    "PlaneWorkpiece",
    "SphereWorkpiece",
    "Workpiece",
    "first_contact",
]

FloatArray = NDArray[np.float64]


class Workpiece(Protocol):
    """Anything with ``distance(points (N, 3)) -> (N,)`` signed distances (mm, > 0 outside) and ``describe()``."""

    def distance(self, points: FloatArray) -> FloatArray: ...  # pragma: no cover

    def describe(self) -> dict[str, Any]: ...  # pragma: no cover


def _vector(value: ArrayLike, name: str, *, unit: bool = False) -> FloatArray:
    v = np.asarray(value, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise InvalidInputError(name, "three finite numbers", repr(value))
    if unit:
        norm = float(np.linalg.norm(v))
        if norm == 0:
            raise InvalidInputError(name, "a non-zero direction", repr(value))
        v = v / norm
    return v


def _positive(value: float, name: str) -> float:
    if not (np.isfinite(value) and value > 0):
        raise InvalidInputError(name, "a positive length in mm", repr(value))
    return float(value)


@record
class SphereWorkpiece:
    """Reference sphere: ``center`` (3,) mm, ``diameter`` mm."""

    center: FloatArray
    diameter: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _vector(self.center, "center"))
        object.__setattr__(self, "diameter", _positive(self.diameter, "diameter"))

    def distance(self, points: FloatArray) -> FloatArray:
        return np.linalg.norm(np.atleast_2d(points) - self.center, axis=-1) - self.diameter / 2.0

    def describe(self) -> dict[str, Any]:
        return {"type": "sphere", "center_mm": self.center.tolist(), "diameter_mm": self.diameter}


@record
class PlaneWorkpiece:
    """Material below a plane through ``point`` with outward ``normal``."""

    point: FloatArray
    normal: FloatArray

    def __post_init__(self) -> None:
        object.__setattr__(self, "point", _vector(self.point, "point"))
        object.__setattr__(self, "normal", _vector(self.normal, "normal", unit=True))

    def distance(self, points: FloatArray) -> FloatArray:
        return (np.atleast_2d(points) - self.point) @ self.normal

    def describe(self) -> dict[str, Any]:
        return {"type": "plane", "point_mm": self.point.tolist(), "normal": self.normal.tolist()}


@record
class BoxWorkpiece:
    """Gauge block: ``center`` (3,), ``size`` (3,) mm along the rows of ``axes`` (3, 3) (default machine axes)."""

    center: FloatArray
    size: FloatArray
    axes: FloatArray = field(default_factory=lambda: np.eye(3))

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _vector(self.center, "center"))
        size = _vector(self.size, "size")
        if not np.all(size > 0):
            raise InvalidInputError("size", "three positive lengths in mm", repr(self.size))
        object.__setattr__(self, "size", size)
        axes = np.asarray(self.axes, dtype=float)
        if axes.shape != (3, 3) or not np.allclose(axes @ axes.T, np.eye(3), atol=1e-9):
            raise InvalidInputError("axes", "an orthonormal (3, 3) matrix of rows", repr(self.axes))
        object.__setattr__(self, "axes", axes)

    def distance(self, points: FloatArray) -> FloatArray:
        local = np.abs((np.atleast_2d(points) - self.center) @ self.axes.T) - self.size / 2.0
        outside = np.linalg.norm(np.clip(local, 0.0, None), axis=-1)
        inside = np.minimum(local.max(axis=-1), 0.0)
        return outside + inside

    def describe(self) -> dict[str, Any]:
        return {"type": "gauge-block", "center_mm": self.center.tolist(), "size_mm": self.size.tolist(),
                "axes": self.axes.tolist()}


@record
class CylinderWorkpiece:
    """Solid cylinder: axis through ``center`` along ``axis``, ``diameter`` and ``length`` mm (flat ends)."""

    center: FloatArray
    axis: FloatArray
    diameter: float
    length: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _vector(self.center, "center"))
        object.__setattr__(self, "axis", _vector(self.axis, "axis", unit=True))
        object.__setattr__(self, "diameter", _positive(self.diameter, "diameter"))
        object.__setattr__(self, "length", _positive(self.length, "length"))

    def distance(self, points: FloatArray) -> FloatArray:
        d = np.atleast_2d(points) - self.center
        along = d @ self.axis
        radial = np.linalg.norm(d - along[:, None] * self.axis, axis=-1)
        q = np.stack([radial - self.diameter / 2.0, np.abs(along) - self.length / 2.0], axis=-1)
        return np.linalg.norm(np.clip(q, 0.0, None), axis=-1) + np.minimum(q.max(axis=-1), 0.0)

    def describe(self) -> dict[str, Any]:
        return {"type": "cylinder", "center_mm": self.center.tolist(), "axis": self.axis.tolist(),
                "diameter_mm": self.diameter, "length_mm": self.length}


class MeshWorkpiece:
    """A closed triangle mesh (STL/PLY/OBJ via :func:`pcmm_geo.io.meshes.read_mesh`), shifted by ``offset`` mm."""

    def __init__(self, path: str, offset: ArrayLike = (0.0, 0.0, 0.0)) -> None:
        from pcmm_geo.artefacts.cad_distance import check_closed_mesh
        from pcmm_geo.io.meshes import read_mesh

        self.path = str(path)
        self.offset = _vector(offset, "offset")
        self.mesh = read_mesh(path)
        check_closed_mesh(self.mesh, what=self.path)

    def distance(self, points: FloatArray) -> FloatArray:
        from pcmm_geo.artefacts.cad_distance import surface_distances

        result = surface_distances(np.atleast_2d(points) - self.offset, self.mesh, workers=1)
        return np.asarray(result.signed_distance, dtype=float)

    def describe(self) -> dict[str, Any]:
        return {"type": "mesh", "path": self.path, "offset_mm": self.offset.tolist()}


def first_contact(workpieces: list[Any], start: FloatArray, end: FloatArray, radius: float,
                  *, step: float = 0.05) -> float | None:
    """Fraction ``s`` in [0, 1] of the path ``start + s (end - start)`` where the ball of ``radius`` first touches.

    The path is sampled every ``step`` mm (no workpiece feature is thinner than that) and the
    first sign change of ``distance - radius`` refined by bisection to 1e-9 mm.  ``None``: no
    contact on the path; 0.0: already touching at ``start``.
    """
    if not workpieces:
        return None
    start, end = np.asarray(start, float), np.asarray(end, float)
    length = float(np.linalg.norm(end - start))

    def gap(s: FloatArray) -> FloatArray:
        pts = start + np.asarray(s)[:, None] * (end - start)
        return np.min([w.distance(pts) for w in workpieces], axis=0) - radius

    samples = np.linspace(0.0, 1.0, max(2, int(np.ceil(length / step)) + 1))
    values = gap(samples)
    if values[0] <= 0:
        return 0.0
    hits = np.nonzero(values <= 0)[0]
    if not len(hits):
        return None
    low, high = float(samples[hits[0] - 1]), float(samples[hits[0]])
    while (high - low) * length > 1e-9:
        middle = 0.5 * (low + high)
        if gap(np.array([middle]))[0] <= 0:
            high = middle
        else:
            low = middle
    return high
