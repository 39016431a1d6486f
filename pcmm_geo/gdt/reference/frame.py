"""The datum reference frame (DRF) type: axes, origin and the degrees of freedom the datums leave free.

ISO 5459-1:2011 clause 3 / ASME Y14.5-2018 clause 7: the datums of a frame, primary, secondary and
tertiary in that order, constrain the six degrees of freedom of the part; the coordinate system is

- z along the primary datum (a plane's normal pointing into the material, a cylinder's axis);
- x along the secondary datum (a plane's inward normal made perpendicular to z; for a secondary axis
  parallel to z, from that axis toward the tertiary's centre);
- y = z x x; the origin where the datums meet.

Degrees of freedom the datums do not constrain are listed in :attr:`DatumReferenceFrame.free`
(translations ``"tx" "ty" "tz"`` along, rotations ``"rx" "ry" "rz"`` about the DRF's axes); a
tolerance zone floats in them.
"""

from __future__ import annotations

from dataclasses import field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError

__all__ = ["DEGREES_OF_FREEDOM", "DatumReferenceFrame"]

FloatArray = NDArray[np.float64]

#: names of the six degrees of freedom, in the DRF's axes (translations along, rotations about)
DEGREES_OF_FREEDOM = ("tx", "ty", "tz", "rx", "ry", "rz")


@record
class DatumReferenceFrame:
    """A datum reference frame in measurement coordinates.

    Attributes
    ----------
    rotation : ndarray, shape (3, 3)
        Rows are the DRF's x, y and z axes (unit vectors) in measurement coordinates; a proper
        rotation (determinant +1).  ``(p - origin) @ rotation.T`` maps measurement points to the DRF.
    origin : ndarray, shape (3,)
        The DRF's origin in measurement coordinates, mm.
    free : tuple of str
        Degrees of freedom the datums leave free, names from :data:`DEGREES_OF_FREEDOM`.
    datums : tuple of str
        Datum labels, primary first (empty for the measurement frame itself).
    standard : str
        ``"ISO"`` (ISO 5459) or ``"ASME"`` (Y14.5-2018): the rules the datums were associated by.
    pivot : ndarray, shape (3,)
        DRF coordinates of a point on every free rotation axis (a datum axis or centre; the origin
        when the free rotations are about a datum plane's normal, whose position then also floats).
    """

    rotation: FloatArray
    origin: FloatArray
    free: tuple[str, ...] = DEGREES_OF_FREEDOM
    datums: tuple[str, ...] = ()
    standard: str = "ISO"
    associations: tuple[object, ...] = field(default=(), compare=False, repr=False)
    pivot: FloatArray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        rotation = np.asarray(self.rotation, dtype=float)
        origin = np.asarray(self.origin, dtype=float)
        if rotation.shape != (3, 3) or not np.all(np.isfinite(rotation)):
            raise InvalidInputError("rotation", "a finite (3, 3) matrix", repr(rotation.shape))
        if not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-9) or np.linalg.det(rotation) < 0:
            raise InvalidInputError("rotation", "a proper rotation (orthonormal rows, det +1)", "another matrix")
        if origin.shape != (3,) or not np.all(np.isfinite(origin)):
            raise InvalidInputError("origin", "3 finite coordinates", repr(origin.shape))
        unknown = [name for name in self.free if name not in DEGREES_OF_FREEDOM]
        if unknown:
            raise InvalidInputError("free", f"names from {DEGREES_OF_FREEDOM}", repr(unknown))
        pivot = np.asarray(self.pivot, dtype=float)
        if pivot.shape != (3,) or not np.all(np.isfinite(pivot)):
            raise InvalidInputError("pivot", "3 finite coordinates", repr(pivot.shape))
        rotation.flags.writeable = False
        origin.flags.writeable = False
        pivot.flags.writeable = False
        object.__setattr__(self, "pivot", pivot)
        object.__setattr__(self, "rotation", rotation)
        object.__setattr__(self, "origin", origin)
        object.__setattr__(self, "free", tuple(name for name in DEGREES_OF_FREEDOM if name in self.free))

    @classmethod
    def measurement(cls) -> DatumReferenceFrame:
        """The measurement coordinate system itself, every degree of freedom free (no datums)."""
        return cls(np.eye(3), np.zeros(3))

    @property
    def x(self) -> FloatArray:
        """The DRF's x axis in measurement coordinates, shape (3,)."""
        return self.rotation[0]

    @property
    def y(self) -> FloatArray:
        """The DRF's y axis in measurement coordinates, shape (3,)."""
        return self.rotation[1]

    @property
    def z(self) -> FloatArray:
        """The DRF's z axis in measurement coordinates, shape (3,)."""
        return self.rotation[2]

    @property
    def constrained(self) -> tuple[str, ...]:
        """Degrees of freedom the datums constrain (the complement of :attr:`free`)."""
        return tuple(name for name in DEGREES_OF_FREEDOM if name not in self.free)

    def to_dict(self) -> dict[str, object]:
        """JSON-ready: ``datums``, ``standard``, ``origin_mm``, ``axes`` (rows x, y, z), ``free``, ``pivot_mm``."""
        return {"datums": list(self.datums), "standard": self.standard, "origin_mm": self.origin.tolist(),
                "axes": self.rotation.tolist(), "free": list(self.free), "pivot_mm": self.pivot.tolist()}

    def to_frame(self, points: ArrayLike) -> FloatArray:
        """Measurement coordinates (N, 3) or (3,) -> DRF coordinates, same shape, mm."""
        return (np.asarray(points, dtype=float) - self.origin) @ self.rotation.T

    def to_measurement(self, points: ArrayLike) -> FloatArray:
        """DRF coordinates (N, 3) or (3,) -> measurement coordinates, same shape, mm."""
        return np.asarray(points, dtype=float) @ self.rotation + self.origin

    def direction_to_frame(self, vectors: ArrayLike) -> FloatArray:
        """Directions (N, 3) or (3,) from measurement to DRF coordinates (rotation only)."""
        return np.asarray(vectors, dtype=float) @ self.rotation.T

    def direction_to_measurement(self, vectors: ArrayLike) -> FloatArray:
        """Directions (N, 3) or (3,) from DRF to measurement coordinates (rotation only)."""
        return np.asarray(vectors, dtype=float) @ self.rotation
