"""Registration of measured points to a nominal CAD mesh: the rigid transform measured -> nominal.

Two stages:

1. open3d's point-to-plane ICP against the nominal surface sampled as a point cloud with
   face normals (seeded sampling) brings the scan close, from ``initial_transform``;
2. a Gauss-Newton best fit against the *exact* triangles then minimises the sum of squared
   signed point-to-surface distances (:mod:`~pcmm_geo.artefacts.cad_distance`) over the six
   rigid-body parameters.  The sampled cloud stands for the surface only to within its
   sample spacing, so the ICP result serves as a starting value, never as the result.

The nominal mesh must be closed (watertight, outward normals): the best fit works on
signed distances.

Examples
--------
>>> import numpy as np
>>> quarter_turn = np.eye(4)
>>> quarter_turn[:2, :2] = [[0.0, -1.0], [1.0, 0.0]]
>>> (as_rigid_transform(quarter_turn)[:3, :3].round(12) + 0.0).tolist()
[[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]

See :func:`register_to_mesh` for a registration.
"""

from __future__ import annotations

import os
import warnings
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._optional import require
from pcmm_geo._records import record
from pcmm_geo.artefacts.cad_distance import SurfaceIndex
from pcmm_geo.errors import ConvergenceError, IllConditionedWarning, InvalidInputError
from pcmm_geo.fit import as_points

if TYPE_CHECKING:
    trimesh = require("trimesh")

__all__ = [
    "DEFAULT_SAMPLE_COUNT",
    "MIN_REGISTRATION_POINTS",
    "Registration",
    "as_rigid_transform",
    "centroid_alignment",
    "register_to_mesh",
]

FloatArray = NDArray[np.float64]

#: default number of points sampled on the nominal surface for the ICP stage
DEFAULT_SAMPLE_COUNT = 50_000
#: default correspondence distance as a fraction of the mesh's bounding-box diagonal
DEFAULT_DISTANCE_FRACTION = 0.05
#: fewest points that can fix the six rigid-body parameters
MIN_REGISTRATION_POINTS = 6
#: Gauss-Newton stops when a step moves no point by more than this fraction of the scan size
_STEP_TOLERANCE = 1e-12
_MAX_REFINEMENT_ITERATIONS = 100
#: iterations during which the inlier set is re-selected (then kept, so the iteration settles)
_RESELECT_ITERATIONS = 5
#: condition number of the (scaled) refinement Jacobian beyond which a warning is emitted
_ILL_CONDITIONED = 1e8


@record
class Registration:
    """Rigid transform taking measured points into the frame of the nominal mesh.

    Attributes
    ----------
    transform : ndarray, shape (4, 4)
        Homogeneous transform: ``nominal = R @ measured + t``.
    fitness : float
        Fraction of the points within ``max_distance`` of the nominal surface after registration.
    inlier_rms : float
        Root mean square signed distance of those points (mm).
    inlier_count : int
        Number of those points (the ones the best fit used).
    max_distance : float
        Correspondence distance (mm): points farther from the surface are left out.
    icp_fitness, icp_inlier_rms : float
        What open3d's ICP stage reported against the sampled surface (rms of point-to-sample
        distances, so it includes the sample spacing; mm).
    iterations : int
        Gauss-Newton iterations of the exact refinement (it raises when it does not settle).
    condition_number : float
        Condition number of the refinement Jacobian (rotations scaled by the scan size); large
        for surfaces that leave a motion free (plane, cylinder, sphere).
    """

    transform: FloatArray
    fitness: float
    inlier_rms: float
    inlier_count: int
    max_distance: float
    icp_fitness: float
    icp_inlier_rms: float
    iterations: int
    condition_number: float

    @property
    def rotation(self) -> FloatArray:
        """Rotation matrix ``R`` (3, 3)."""
        return self.transform[:3, :3]

    @property
    def translation(self) -> FloatArray:
        """Translation ``t`` (3,), mm."""
        return self.transform[:3, 3]

    @property
    def rotation_angle(self) -> float:
        """Angle of the rotation (rad), from its trace."""
        cosine = 0.5 * (float(np.trace(self.rotation)) - 1.0)
        sine = 0.5 * float(np.linalg.norm(_axial_vector(self.rotation)))
        return float(np.arctan2(sine, cosine))

    def apply(self, points: ArrayLike) -> FloatArray:
        """Points ``(..., 3)`` in the nominal frame."""
        return _apply(self.transform, np.asarray(points, dtype=float))



def _axial_vector(rotation: FloatArray) -> FloatArray:
    return np.array([rotation[2, 1] - rotation[1, 2], rotation[0, 2] - rotation[2, 0], rotation[1, 0] - rotation[0, 1]])


def _apply(transform: FloatArray, points: FloatArray) -> FloatArray:
    return points @ transform[:3, :3].T + transform[:3, 3]


def _rotation_from_vector(rotation_vector: FloatArray) -> FloatArray:
    """Rodrigues' formula: rotation by ``|v|`` rad about ``v``."""
    angle = float(np.linalg.norm(rotation_vector))
    if angle == 0.0:
        return np.eye(3)
    axis = rotation_vector / angle
    cross = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + np.sin(angle) * cross + (1.0 - np.cos(angle)) * (cross @ cross)


def as_rigid_transform(matrix: ArrayLike, *, name: str = "initial_transform") -> FloatArray:
    """Validate a homogeneous rigid transform (4, 4): orthonormal rotation with det +1, last row 0 0 0 1.

    Raises
    ------
    InvalidInputError
        Wrong shape, non-finite entries, a rotation part that is not a proper rotation
        (to 1e-9) or a last row other than ``0 0 0 1``.

    Examples
    --------
    >>> as_rigid_transform(np.eye(4)).shape
    (4, 4)
    """
    transform = np.asarray(matrix, dtype=float)
    if transform.shape != (4, 4) or not np.all(np.isfinite(transform)):
        raise InvalidInputError(name, "a finite 4x4 matrix", f"shape {transform.shape}")
    rotation = transform[:3, :3]
    orthogonality = float(np.abs(rotation.T @ rotation - np.eye(3)).max())
    if orthogonality > 1e-9 or np.linalg.det(rotation) < 0.0:
        raise InvalidInputError(name, "a proper rotation (R^T R = I to 1e-9, det R = +1)",
                                f"|R^T R - I| = {orthogonality:.3g}, det R = {np.linalg.det(rotation):.6g}")
    if not np.allclose(transform[3], [0.0, 0.0, 0.0, 1.0], rtol=0.0, atol=1e-12):
        raise InvalidInputError(name, "last row 0 0 0 1", str(transform[3].tolist()))
    return transform


def centroid_alignment(points: ArrayLike, mesh: trimesh.Trimesh) -> FloatArray:
    """Translation (4, 4) moving the centroid of ``points`` onto the area centroid of the mesh surface.

    A starting value for :func:`register_to_mesh` when the scan is far from the nominal
    frame but not much rotated; the centroid of a partial scan is not that of the surface,
    so only as a start.

    Examples
    --------
    >>> from pcmm_geo.io.meshes import box_mesh
    >>> centroid_alignment([[10.0, 0, 4.5], [12.0, 0, 4.5]], box_mesh(100, 35, 9))[:3, 3].tolist()
    [-11.0, 0.0, -4.5]
    """
    data = as_points(points, element="registration", min_points=1)
    transform = np.eye(4)
    transform[:3, 3] = np.asarray(mesh.centroid, dtype=float) - data.mean(axis=0)
    return transform


def as_mesh(mesh: Any) -> trimesh.Trimesh:
    """A mesh object, or the mesh read from a file path (:func:`pcmm_geo.io.read_mesh`).

    Raises
    ------
    InvalidInputError
        ``mesh`` is neither a path nor a mesh with vertices and faces.
    FileFormatError
        The file cannot be read as a mesh.
    """
    if isinstance(mesh, str | os.PathLike):
        from pcmm_geo.io.meshes import read_mesh

        return read_mesh(mesh)
    if not (hasattr(mesh, "vertices") and hasattr(mesh, "faces")):
        raise InvalidInputError("mesh", "a trimesh.Trimesh or the path of a mesh file", type(mesh).__name__)
    return mesh


def register_to_mesh(
    points: ArrayLike,
    mesh: trimesh.Trimesh,
    *,
    initial_transform: ArrayLike | None = None,
    max_distance: float | None = None,
    sample_count: int = DEFAULT_SAMPLE_COUNT,
    seed: int = 0,
) -> Registration:
    """Register measured points to a nominal mesh (ICP point-to-plane, then an exact least-squares fit).

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Measured points (mm), N >= 6.
    mesh : trimesh.Trimesh or path
        Nominal surface (mm), closed with outward face normals, or its file (STL, PLY, OBJ, OFF:
        :func:`pcmm_geo.io.read_mesh`).
    initial_transform : array_like, shape (4, 4), optional
        Starting transform measured -> nominal (default identity); see :func:`centroid_alignment`.
    max_distance : float, optional
        Correspondence distance (mm); points farther from the (moved) surface are ignored.
        Default 5 % of the mesh's bounding-box diagonal.
    sample_count : int
        Points sampled on the nominal surface for the ICP stage.
    seed : int
        Seed of that sampling.

    Returns
    -------
    Registration

    Raises
    ------
    InvalidInputError
        Bad points, transform, distance or sample count; a mesh that is not closed
        (:func:`~pcmm_geo.artefacts.cad_distance.check_closed_mesh`).
    TooFewPointsError
        Fewer than 6 points.
    DegenerateGeometryError
        All points identical.
    ConvergenceError
        Fewer than 6 points end up within ``max_distance`` of the surface (a poor start), or
        the refinement does not settle.

    Warns
    -----
    IllConditionedWarning
        The nominal surface leaves a rigid motion undetermined (plane, cylinder, sphere...).

    Examples
    --------
    >>> from pcmm_geo.io.meshes import box_mesh
    >>> block = box_mesh(100.0, 35.0, 9.0)
    >>> corners = np.array([[-50.0, -17.5, -4.5], [50.0, 17.5, 4.5]])
    >>> grid = np.stack(np.meshgrid(*[np.linspace(lo, hi, 5) for lo, hi in corners.T]), -1).reshape(-1, 3)
    >>> on_surface = grid[np.any(np.isclose(np.abs(grid), corners[1]), axis=1)]
    >>> fit = register_to_mesh(on_surface + [0.2, 0.0, -0.1], block)
    >>> (np.round(fit.translation, 9) + 0.0).tolist(), round(fit.inlier_rms, 12) + 0.0
    ([-0.2, 0.0, 0.1], 0.0)
    """
    o3d = require("open3d")
    trimesh = require("trimesh")

    mesh = as_mesh(mesh)
    data = as_points(points, element="registration", min_points=MIN_REGISTRATION_POINTS)
    start = np.eye(4) if initial_transform is None else as_rigid_transform(initial_transform)
    diagonal = float(np.linalg.norm(np.ptp(np.asarray(mesh.vertices, dtype=float), axis=0)))
    if max_distance is None:
        max_distance = DEFAULT_DISTANCE_FRACTION * diagonal
    if not np.isfinite(max_distance) or max_distance <= 0:
        raise InvalidInputError("max_distance", "a positive distance in mm", repr(max_distance))
    if int(sample_count) < 100:
        raise InvalidInputError("sample_count", "at least 100 surface samples", repr(sample_count))
    surface = SurfaceIndex.build(mesh)  # refuses an open mesh before any work

    samples, sample_faces = trimesh.sample.sample_surface(mesh, int(sample_count), seed=seed)
    target = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.asarray(samples, dtype=float)))
    target.normals = o3d.utility.Vector3dVector(np.asarray(mesh.face_normals, dtype=float)[sample_faces])
    source = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(data))
    icp = o3d.pipelines.registration.registration_icp(
        source, target, float(max_distance), start,
        o3d.pipelines.registration.TransformationEstimationPointToPlane(),
        o3d.pipelines.registration.ICPConvergenceCriteria(relative_fitness=1e-10, relative_rmse=1e-10,
                                                          max_iteration=200),
    )
    transform, iterations, condition = _refine(data, surface, np.array(icp.transformation), max_distance)
    distances = surface.distances(_apply(transform, data)).signed_distance
    inliers = np.abs(distances) <= max_distance
    return Registration(
        transform=transform,
        fitness=float(inliers.mean()),
        inlier_rms=float(np.sqrt(np.mean(distances[inliers] ** 2))) if inliers.any() else float("nan"),
        inlier_count=int(inliers.sum()),
        max_distance=float(max_distance),
        icp_fitness=float(icp.fitness),
        icp_inlier_rms=float(icp.inlier_rmse),
        iterations=iterations,
        condition_number=condition,
    )


def _refine(
    data: FloatArray, surface: SurfaceIndex, transform: FloatArray, max_distance: float
) -> tuple[FloatArray, int, float]:
    """Gauss-Newton on the signed point-to-surface distances over a small rotation and a translation.

    A move ``dp = w x (p - c) + u`` (``c`` the centroid of the used points) changes a
    signed distance by ``g . dp = ((p - c) x g) . w + g . u`` with ``g`` its gradient.
    """
    scale = max(float(np.linalg.norm(np.ptp(data, axis=0))), 1.0)
    inliers: NDArray[np.bool_] | None = None
    condition = float("nan")
    for iteration in range(1, _MAX_REFINEMENT_ITERATIONS + 1):
        moved = _apply(transform, data)
        near = surface.distances(moved)
        if inliers is None or iteration <= _RESELECT_ITERATIONS:
            inliers = np.abs(near.signed_distance) <= max_distance
            if inliers.sum() < MIN_REGISTRATION_POINTS:
                raise ConvergenceError(
                    "registration", iteration,
                    f"only {int(inliers.sum())} of {len(data)} points within {max_distance:g} mm of the nominal "
                    "surface; give a closer initial transform or a larger max_distance",
                )
        used = moved[inliers]
        centre = used.mean(axis=0)
        gradient = near.direction[inliers]
        jacobian = np.hstack([np.cross(used - centre, gradient) / scale, gradient])
        singular = np.linalg.svd(jacobian, compute_uv=False)
        condition = float(singular[0] / singular[-1]) if singular[-1] > 0 else float("inf")
        step, *_ = np.linalg.lstsq(jacobian, -near.signed_distance[inliers], rcond=1e-12)
        rotation_vector, shift = step[:3] / scale, step[3:]
        increment = np.eye(4)
        increment[:3, :3] = _rotation_from_vector(rotation_vector)
        increment[:3, 3] = centre - increment[:3, :3] @ centre + shift
        transform = increment @ transform
        transform[:3, :3] = _orthonormalise(transform[:3, :3])
        if float(np.linalg.norm(step)) <= _STEP_TOLERANCE * scale:
            break
    else:
        raise ConvergenceError("registration", _MAX_REFINEMENT_ITERATIONS, "the best fit to the surface did not settle")
    if condition > _ILL_CONDITIONED:
        warnings.warn(
            f"registration: the nominal surface leaves a rigid motion undetermined (condition number "
            f"{condition:.3g}); the transform is one of many equally good ones",
            IllConditionedWarning,
            stacklevel=3,
        )
    return transform, iteration, condition


def _orthonormalise(rotation: FloatArray) -> FloatArray:
    """Nearest proper rotation (polar decomposition), removing rounding drift."""
    left, _, right = np.linalg.svd(rotation)
    return left @ right
