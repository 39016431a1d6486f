"""Datum reference frames from a CMM's feature actuals: the alignment of a second opinion on QIF characteristics.

A QIF results file reports, for each datum feature, the substitute feature the CMM associated
(a plane's point and normal, a cylinder's axis, a circle's centre and normal).  This module
builds the datum reference frame (ISO 5459, ASME Y14.5 §7) from those *actual* substitute
features and the same frame from the *nominal* datum features, and returns the rigid map
``T(x) = o_n + R_n R_a^T (x - o_a)`` that takes measured coordinates into the nominal (part)
coordinates with the datums in their nominal places.  A datum's actual feature is taken as
the CMM reported it: this is a different computation from :mod:`pcmm_geo.gdt` associating
datums from points.

Construction, in precedence order (the same for the nominal and the actual frame, so its
choice of axes cancels in ``T``):

- ``z``: the primary's direction (a plane's normal, an axis's direction);
- ``x``: the first later datum whose direction is not parallel to ``z`` (a plane's normal or an
  axis, made perpendicular to ``z``), else the direction from the origin toward the first later
  datum's centre (an axis parallel to ``z``, a point), made perpendicular to ``z``;
- origin: the point satisfying each datum's location constraints in precedence order (a plane:
  one equation ``n.p = n.q``; an axis: two; a point: three), each kept only where it constrains a
  direction the earlier ones left free.

Directions left free float: a translation the datums do not fix is removed from deviations
(:attr:`DatumFrame.free_translations`); a rotation about ``z`` that no datum fixes is flagged
(:attr:`DatumFrame.rotation_free`) and positions are then compared by their distance from the
``z`` axis (a zone that may rotate about the primary axis).

Every length in mm; arrays ``(3,)`` and ``(3, 3)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError

__all__ = ["AXIS_TYPES", "PLANE_TYPES", "POINT_TYPES", "DatumFeatureGeometry", "DatumFrame", "FrameMap",
           "datum_frame", "frame_map"]

FloatArray = NDArray[np.float64]

#: QIF feature types whose substitute is a plane (point and normal)
PLANE_TYPES = frozenset({"plane", "opposite_parallel_planes", "extruded_cross_section"})
#: QIF feature types whose substitute is an axis (point and direction, a circle's normal)
AXIS_TYPES = frozenset({"cylinder", "circle", "cone", "line", "elongated_cylinder", "circular_arc",
                        "opposite_parallel_lines", "elongated_circle", "toroidal_segment", "torus"})
#: QIF feature types whose substitute is a point (a centre)
POINT_TYPES = frozenset({"point", "sphere", "spherical_segment", "edge_point", "surface_point"})
#: a direction whose component perpendicular to z is shorter than this is parallel to z
_PARALLEL = 1e-3
#: a constraint row shorter than this after removing the earlier ones adds nothing
_RANK = 1e-6


@record
class DatumFeatureGeometry:
    """A datum feature's substitute: ``kind`` ``"plane"``, ``"axis"`` or ``"point"``, a point on it, its direction."""

    kind: str
    location: FloatArray
    direction: FloatArray | None = None
    label: str = ""


@record
class DatumFrame:
    """A datum reference frame: columns of ``rotation`` are its x, y, z in the file's coordinates.

    Attributes
    ----------
    rotation : (3, 3) ndarray
    origin : (3,) ndarray, mm
    free_translations : (k, 3) ndarray
        Unit directions (file coordinates) the datums leave free to translate (k = 0..3).
    rotation_free : bool
        No datum fixes the rotation about ``z`` (or no datum gives ``z``; then ``z_defined`` is False).
    z_defined : bool
    """

    rotation: FloatArray
    origin: FloatArray
    free_translations: FloatArray
    rotation_free: bool
    z_defined: bool = True


@dataclass(frozen=True)
class FrameMap:
    """The map of measured coordinates into the part's coordinates with the datums in their nominal places.

    ``apply(x) = o_n + R_n R_a^T (x - o_a)``; ``rotate(v) = R_n R_a^T v``.  ``free_translations``
    (part coordinates, unit rows) and ``rotation_free`` (about ``axis`` through ``center``) are the
    degrees of freedom the datums leave: a deviation's components along them do not count.
    """

    nominal: DatumFrame
    actual: DatumFrame

    @property
    def free_translations(self) -> FloatArray:
        return self.nominal.free_translations

    @property
    def rotation_free(self) -> bool:
        return self.nominal.rotation_free

    @property
    def axis(self) -> FloatArray:
        return self.nominal.rotation[:, 2]

    @property
    def center(self) -> FloatArray:
        return self.nominal.origin

    def rotate(self, vector: FloatArray) -> FloatArray:
        return self.nominal.rotation @ (self.actual.rotation.T @ np.asarray(vector, dtype=float))

    def apply(self, point: FloatArray) -> FloatArray:
        return self.nominal.origin + self.rotate(np.asarray(point, dtype=float) - self.actual.origin)

    def deviation(self, actual_point: FloatArray, nominal_point: FloatArray) -> FloatArray:
        """``apply(actual) - nominal`` with the floating degrees of freedom taken out (mm, part coordinates).

        Free translations are removed; a free rotation about the primary axis leaves the difference
        of the distances from that axis (radial) and the axial difference.
        """
        mapped = self.apply(actual_point)
        nominal_point = np.asarray(nominal_point, dtype=float)
        delta = mapped - nominal_point
        for direction in self.free_translations:
            delta = delta - float(direction @ delta) * direction
        if self.rotation_free and self.nominal.z_defined and not len(self.free_translations):
            axis = self.axis
            radial_actual = (mapped - self.center) - float(axis @ (mapped - self.center)) * axis
            radial_nominal = (nominal_point - self.center) - float(axis @ (nominal_point - self.center)) * axis
            size = float(np.linalg.norm(radial_nominal))
            along = float(axis @ delta) * axis
            if size == 0.0:
                delta = along + radial_actual
            else:
                delta = along + (float(np.linalg.norm(radial_actual)) - size) * radial_nominal / size
        return delta


def _unit(vector: FloatArray | None) -> FloatArray | None:
    if vector is None:
        return None
    vector = np.asarray(vector, dtype=float)
    length = float(np.linalg.norm(vector))
    return None if length == 0.0 else vector / length


def _perpendicular(vector: FloatArray, z: FloatArray) -> FloatArray | None:
    rest = vector - float(z @ vector) * z
    length = float(np.linalg.norm(rest))
    return None if length < _PARALLEL else rest / length


def _rows(datum: DatumFeatureGeometry) -> FloatArray:
    if datum.kind == "plane":
        return np.asarray(datum.direction, dtype=float)[None, :]
    if datum.kind == "axis":
        direction = np.asarray(datum.direction, dtype=float)
        u, _, _ = np.linalg.svd(np.eye(3) - np.outer(direction, direction))
        return u[:, :2].T
    return np.eye(3)


def datum_frame(datums: list[DatumFeatureGeometry] | tuple[DatumFeatureGeometry, ...]) -> DatumFrame:
    """The datum reference frame of datum substitutes given in precedence order (see the module docstring).

    Parameters
    ----------
    datums : sequence of DatumFeatureGeometry
        Primary first; 0 to 3 (more are used in order).  An empty sequence is the file's own
        coordinate system (identity, nothing free): QIF writes an empty ``DatumReferenceFrame``
        for "no datums".

    Returns
    -------
    DatumFrame

    Raises
    ------
    InvalidInputError
        A plane or axis without a direction, a kind other than plane / axis / point (``datums``).
    """
    if not datums:
        return DatumFrame(rotation=np.eye(3), origin=np.zeros(3), free_translations=np.zeros((0, 3)),
                          rotation_free=False)
    for datum in datums:
        if datum.kind not in ("plane", "axis", "point"):
            raise InvalidInputError("datums", "datum substitutes of kind plane, axis or point", repr(datum.kind))
        if datum.kind != "point" and _unit(datum.direction) is None:
            raise InvalidInputError("datums", f"a direction for the {datum.kind} datum {datum.label}", "none")
    datums = [DatumFeatureGeometry(d.kind, np.asarray(d.location, dtype=float),
                                   None if d.direction is None else _unit(d.direction), d.label) for d in datums]
    basis: list[FloatArray] = []
    targets: list[float] = []
    for datum in datums:
        for row in _rows(datum):
            rest = row - sum((float(b @ row) * b for b in basis), np.zeros(3))
            length = float(np.linalg.norm(rest))
            if length < _RANK:
                continue
            # the constraint row @ p = row @ q, expressed on the orthonormal basis
            projected = float(row @ datum.location) - sum(
                float(b @ row) * t for b, t in zip(basis, targets, strict=True))
            basis.append(rest / length)
            targets.append(projected / length)
    origin = sum((t * b for b, t in zip(basis, targets, strict=True)), np.zeros(3))
    stack = np.array(basis) if basis else np.zeros((0, 3))
    _, _, vt = np.linalg.svd(np.vstack([stack, np.zeros((3, 3))]))
    free = vt[len(basis):] if len(basis) < 3 else np.zeros((0, 3))
    z = datums[0].direction if datums[0].kind != "point" else None
    if z is None:
        return DatumFrame(rotation=np.eye(3), origin=origin, free_translations=free, rotation_free=True,
                          z_defined=False)
    x = None
    for datum in datums[1:]:
        if datum.direction is not None:
            x = _perpendicular(datum.direction, z)
        if x is None and datum.kind != "plane":  # an axis parallel to z, a point: toward its centre
            x = _perpendicular(datum.location - origin, z)
        if x is not None:
            break
    rotation_free = x is None
    if x is None:  # any perpendicular: the rotation about z floats
        x = _perpendicular(np.eye(3)[int(np.argmin(np.abs(z)))], z)
    y = np.cross(z, x)  # type: ignore[arg-type]
    return DatumFrame(rotation=np.column_stack([x, y, z]), origin=origin, free_translations=free,
                      rotation_free=rotation_free)


def frame_map(nominal: list[DatumFeatureGeometry], actual: list[DatumFeatureGeometry]) -> FrameMap:
    """The map from measured into part coordinates by the datums (nominal and actual substitutes, same order).

    Each actual direction is first oriented like its nominal (a plane's normal or an axis may be
    reported either way round): the actuals are taken to be in the part's coordinates or in those
    of a pre-aligned part (each actual direction within 90 degrees of its nominal), as a CMM
    reports them after its alignment.

    Raises
    ------
    InvalidInputError
        ``nominal`` and ``actual`` differ in length or in kinds.
    """
    if len(nominal) != len(actual) or any(n.kind != a.kind for n, a in zip(nominal, actual, strict=True)):
        raise InvalidInputError("actual", "the same datum kinds as nominal, in the same order",
                                f"{[a.kind for a in actual]} for {[n.kind for n in nominal]}")
    oriented = []
    for n, a in zip(nominal, actual, strict=True):
        direction = a.direction
        if direction is not None and n.direction is not None and float(np.dot(direction, n.direction)) < 0:
            direction = -np.asarray(direction, dtype=float)
        oriented.append(DatumFeatureGeometry(a.kind, a.location, direction, a.label))
    return FrameMap(nominal=datum_frame(nominal), actual=datum_frame(oriented))
