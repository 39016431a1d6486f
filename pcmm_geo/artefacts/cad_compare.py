"""Comparison of a measured scan with its nominal CAD mesh: registration, then surface deviations.

:func:`compare_to_mesh` registers the scan (:func:`~pcmm_geo.artefacts.cad_register.register_to_mesh`:
open3d point-to-plane ICP, then an exact least-squares best fit to the triangles) and
computes the signed distance of every registered point from the mesh
(:func:`~pcmm_geo.artefacts.cad_distance.surface_distances`): positive outside the material
(along the outward face normals), negative inside.  :func:`mesh_deviations` does the second
step alone for points already in the mesh frame.  The nominal mesh must be closed
(watertight, outward normals), or "outside the material" means nothing.

Examples
--------
>>> import numpy as np
>>> from pcmm_geo.io.meshes import box_mesh
>>> block = box_mesh(100.0, 35.0, 9.0)
>>> scan = np.array([[0, 0, 4.5], [10, 5, 4.5], [-20, -5, 4.5], [50, 0, 0], [50, 10, 2], [-50, 3, -1],
...                  [0, 17.5, 0], [20, 17.5, 3], [0, -17.5, 1], [-30, -17.5, -2]]) + [0.3, -0.2, 0.1]
>>> comparison = compare_to_mesh(scan, block, tolerance=0.001)
>>> np.round(comparison.registration.translation, 9).tolist(), comparison.deviations.summary.count_beyond
([-0.3, 0.2, -0.1], 0)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._optional import require
from pcmm_geo._records import record
from pcmm_geo.artefacts.cad_distance import surface_distances
from pcmm_geo.artefacts.cad_register import DEFAULT_SAMPLE_COUNT, Registration, as_mesh, register_to_mesh
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.fit import as_points

if TYPE_CHECKING:
    trimesh = require("trimesh")

__all__ = [
    "CadComparison",
    "DeviationSummary",
    "MeshDeviations",
    "compare_to_mesh",
    "deviation_summary",
    "mesh_deviations",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@dataclass(frozen=True)
class DeviationSummary:
    """Statistics of signed deviations (mm).

    Attributes
    ----------
    count : int
        Number of points.
    minimum, maximum, mean, rms : float
        Of the signed deviations (mm).
    tolerance : float or None
        Symmetric tolerance (mm) the deviations were checked against.
    count_beyond : int
        Points with ``|deviation| > tolerance`` (0 without a tolerance).
    """

    count: int
    minimum: float
    maximum: float
    mean: float
    rms: float
    tolerance: float | None
    count_beyond: int

    def to_dict(self) -> dict[str, float | int | None]:
        """JSON-ready dictionary."""
        return {
            "count": self.count, "minimum": self.minimum, "maximum": self.maximum, "mean": self.mean,
            "rms": self.rms, "tolerance": self.tolerance, "count_beyond": self.count_beyond,
        }


@record
class MeshDeviations:
    """Signed deviations of points from a nominal mesh.

    Attributes
    ----------
    points : ndarray, shape (N, 3)
        The points in the mesh frame (mm).
    closest : ndarray, shape (N, 3)
        Their nearest points on the nominal surface (mm).
    signed_distance : ndarray, shape (N,)
        Deviation (mm), positive outside the material.
    face_index : ndarray, shape (N,)
        Triangle holding each nearest point.
    summary : DeviationSummary
    """

    points: FloatArray
    closest: FloatArray
    signed_distance: FloatArray
    face_index: IntArray
    summary: DeviationSummary


@dataclass(frozen=True)
class CadComparison:
    """Result of :func:`compare_to_mesh`: the registration and the deviations of the registered points."""

    registration: Registration
    deviations: MeshDeviations


def deviation_summary(signed_distance: ArrayLike, tolerance: float | None = None) -> DeviationSummary:
    """Minimum, maximum, mean, rms and the count beyond a symmetric tolerance of signed deviations (mm).

    Raises
    ------
    InvalidInputError
        No deviations, non-finite ones, or a negative tolerance.

    Examples
    --------
    >>> summary = deviation_summary([0.001, -0.003, 0.002], tolerance=0.0025)
    >>> summary.maximum, summary.minimum, summary.count_beyond
    (0.002, -0.003, 1)
    """
    values = np.asarray(signed_distance, dtype=float).ravel()
    if values.size == 0 or not np.all(np.isfinite(values)):
        raise InvalidInputError("deviations", "at least one finite value", f"{values.size} values")
    _check_tolerance(tolerance)
    return DeviationSummary(
        count=int(values.size),
        minimum=float(values.min()),
        maximum=float(values.max()),
        mean=float(values.mean()),
        rms=float(np.sqrt(np.mean(values**2))),
        tolerance=None if tolerance is None else float(tolerance),
        count_beyond=0 if tolerance is None else int(np.count_nonzero(np.abs(values) > tolerance)),
    )


def mesh_deviations(points: ArrayLike, mesh: trimesh.Trimesh, *, tolerance: float | None = None) -> MeshDeviations:
    """Signed deviations of points (already in the mesh frame) from the nominal surface.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Points in the mesh frame (mm).
    mesh : trimesh.Trimesh or path
        Nominal surface, closed with outward face normals.
    tolerance : float, optional
        Symmetric tolerance (mm) for ``summary.count_beyond``.

    Returns
    -------
    MeshDeviations

    Raises
    ------
    InvalidInputError
        Bad points, a negative tolerance, a mesh without triangles or not closed
        (:func:`~pcmm_geo.artefacts.cad_distance.check_closed_mesh`).
    TooFewPointsError
        No points.

    Examples
    --------
    >>> from pcmm_geo.io.meshes import box_mesh
    >>> result = mesh_deviations([[0, 0, 4.51], [50.0, 0, 0], [0, 17.49, 0]], box_mesh(100, 35, 9))
    >>> (np.round(result.signed_distance, 12) + 0.0).tolist()
    [0.01, 0.0, -0.01]
    """
    data = as_points(points, element="deviations", min_points=1)
    _check_tolerance(tolerance)
    near = surface_distances(data, as_mesh(mesh))
    return MeshDeviations(
        points=data,
        closest=near.closest,
        signed_distance=near.signed_distance,
        face_index=near.face_index,
        summary=deviation_summary(near.signed_distance, tolerance),
    )


def compare_to_mesh(
    points: ArrayLike,
    mesh: trimesh.Trimesh,
    *,
    initial_transform: ArrayLike | None = None,
    tolerance: float | None = None,
    max_distance: float | None = None,
    sample_count: int = DEFAULT_SAMPLE_COUNT,
    seed: int = 0,
) -> CadComparison:
    """Register a scan to its nominal mesh and compute the deviations of every registered point.

    Parameters are those of :func:`~pcmm_geo.artefacts.cad_register.register_to_mesh` and
    :func:`mesh_deviations`; the deviations cover all points, including those the
    registration left out as too far.

    Returns
    -------
    CadComparison

    Raises
    ------
    InvalidInputError
        Bad points, transform, distance, sample count or tolerance; a mesh that is not closed.
    TooFewPointsError
        Fewer than 6 points.
    ConvergenceError
        As :func:`~pcmm_geo.artefacts.cad_register.register_to_mesh`.

    Examples
    --------
    See the module docstring.
    """
    _check_tolerance(tolerance)
    mesh = as_mesh(mesh)  # a file path is read once, for both steps
    registration = register_to_mesh(points, mesh, initial_transform=initial_transform, max_distance=max_distance,
                                     sample_count=sample_count, seed=seed)
    deviations = mesh_deviations(registration.apply(as_points(points, element="registration")), mesh,
                                 tolerance=tolerance)
    return CadComparison(registration=registration, deviations=deviations)


def _check_tolerance(tolerance: float | None) -> None:
    if tolerance is not None and not (np.isfinite(tolerance) and tolerance >= 0):
        raise InvalidInputError("tolerance", "a non-negative distance in mm", repr(tolerance))
