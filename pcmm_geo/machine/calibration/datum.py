"""Datum frame of the tetrahedron from a probed flat face and cylindrical hole (thesis 7.1).

CMM₁ "adds the tetrahedron to its reference coordinate system by measuring a cylindrical
hole and a flat surface".  A plane and one hole fix five of the six degrees of freedom;
the rotation about the plane normal is fixed here by a reference point (by default the
mean centre of joint a):

* origin -- where the hole axis pierces the plane;
* z -- the plane normal, signed so that the reference point has z >= 0;
* x -- the reference point's direction from the origin, projected into the plane;
* y -- z cross x (right-handed).

Coordinates map as ``p_datum = R (p - origin)`` with the rows of ``R`` = x, y, z.

Examples
--------
>>> import numpy as np
>>> angles = np.linspace(0, 2 * np.pi, 12, endpoint=False)
>>> hole = np.c_[5 + 3 * np.cos(angles), 2 + 3 * np.sin(angles), np.repeat([-1.0, -4.0], 6)]
>>> plane = np.array([[0, 0, 0], [20, 0, 0], [0, 20, 0], [20, 20, 0.0], [10, 30, 0]])
>>> frame = datum_frame(plane, hole, x_towards=[50, 2, 40])
>>> (np.round(frame.origin, 9) + 0.0).tolist(), (np.round(frame.apply([50, 2, 40]), 9) + 0.0).tolist()
([5.0, 2.0, 0.0], [45.0, 0.0, 40.0])
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError
from pcmm_geo.machine.calibration.geometry import FittedSphere
from pcmm_geo.machine.calibration.probings import ProbedFeatures

__all__ = ["DatumFrame", "datum_frame"]

FloatArray = NDArray[np.float64]


@record
class DatumFrame:
    """Rigid transform CMM₁ frame -> datum frame: ``p_datum = rotation @ (p - origin)``.

    Attributes
    ----------
    rotation : ndarray, shape (3, 3)
        Rows are the datum x, y, z axes in CMM₁ coordinates.
    origin : ndarray, shape (3,)
        Datum origin in CMM₁ coordinates (mm).
    plane_form : float
        Flatness of the probed face (max - min residual, mm).
    hole_radius : float
        Radius of the fitted hole (mm).
    """

    rotation: FloatArray
    origin: FloatArray
    plane_form: float = float("nan")
    hole_radius: float = float("nan")

    def apply(self, points: ArrayLike) -> FloatArray:
        """Map points ``(..., 3)`` from CMM₁ into the datum frame."""
        return (np.asarray(points, dtype=float) - self.origin) @ self.rotation.T

    def transform_features(self, features: ProbedFeatures) -> ProbedFeatures:
        """The same probed spheres (centres and raw points) expressed in the datum frame."""

        def moved(sphere: FittedSphere) -> FittedSphere:
            return FittedSphere(self.apply(sphere.center), sphere.radius, sphere.form, sphere.n_points)

        joints = {arm: {pos: moved(s) for pos, s in spheres.items()} for arm, spheres in features.joints.items()}
        points = {key: self.apply(value) for key, value in features.points.items()}
        return ProbedFeatures(joints=joints, tip=moved(features.tip), points=points, source=features.source)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {
            "rotation": self.rotation.tolist(),
            "origin": self.origin.tolist(),
            "plane_form": None if not np.isfinite(self.plane_form) else self.plane_form,
            "hole_radius": None if not np.isfinite(self.hole_radius) else self.hole_radius,
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> DatumFrame:
        """Inverse of :meth:`to_dict`.

        Raises
        ------
        InvalidInputError
            Rotation not a proper 3x3 rotation.
        """
        rotation = np.array(data["rotation"], dtype=float)
        if rotation.shape != (3, 3) or not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-9):
            raise InvalidInputError("datum.rotation", "a 3x3 rotation matrix", str(rotation.tolist()))
        plane_form = data.get("plane_form")
        hole_radius = data.get("hole_radius")
        return cls(
            rotation=rotation,
            origin=np.array(data["origin"], dtype=float).reshape(3),
            plane_form=float("nan") if plane_form is None else float(plane_form),
            hole_radius=float("nan") if hole_radius is None else float(hole_radius),
        )


def datum_frame(plane_points: ArrayLike, hole_points: ArrayLike, *, x_towards: ArrayLike) -> DatumFrame:
    """Build the datum frame from a probed plane and cylindrical hole (thesis 7.1).

    Parameters
    ----------
    plane_points : array_like, shape (N, 3)
        Points on the flat face (N >= 3, not collinear), mm.
    hole_points : array_like, shape (M, 3)
        Points in the cylindrical hole (enough for a cylinder fit), mm.
    x_towards : array_like, shape (3,)
        Reference point fixing the x axis and the sign of z (e.g. joint a's centre).

    Returns
    -------
    DatumFrame

    Raises
    ------
    DegenerateGeometryError
        Collinear plane points, a hole axis parallel to the plane, or a reference point on
        the normal through the origin.
    TooFewPointsError, InvalidInputError
        From the fits.

    Examples
    --------
    See the module docstring.
    """
    from pcmm_geo.fit import as_points, fit_cylinder

    plane = as_points(plane_points, element="datum plane", min_points=3, name="datum_plane")
    centroid = plane.mean(axis=0)
    _, sing, vt = np.linalg.svd(plane - centroid, full_matrices=False)
    if sing[1] <= 1e-9 * max(1.0, float(sing[0])):
        raise DegenerateGeometryError("datum plane", "the probed points are collinear")
    normal = vt[2]
    plane_residuals = (plane - centroid) @ normal
    hole = fit_cylinder(hole_points)
    axis = np.asarray(hole.axis, dtype=float)
    along = float(axis @ normal)
    if abs(along) < 1e-6:
        raise DegenerateGeometryError("datum", "the hole axis is parallel to the probed plane")
    axis_point = np.asarray(hole.point, dtype=float)
    origin = axis_point + ((centroid - axis_point) @ normal / along) * axis
    reference = np.asarray(x_towards, dtype=float).reshape(3) - origin
    if reference @ normal < 0:
        normal = -normal
    in_plane = reference - (reference @ normal) * normal
    length = float(np.linalg.norm(in_plane))
    if length < 1e-9 * max(1.0, float(np.linalg.norm(reference))):
        raise DegenerateGeometryError("datum", "the reference point lies on the normal through the origin")
    x_axis = in_plane / length
    y_axis = np.cross(normal, x_axis)
    return DatumFrame(
        rotation=np.vstack([x_axis, y_axis, normal]),
        origin=origin,
        plane_form=float(np.ptp(plane_residuals)),
        hole_radius=float(hole.radius),
    )
