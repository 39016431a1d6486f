"""Profile of a surface against nominal points with normals or a mesh (ISO 1101:2017 18.5 / 18.6; ASME Y14.5 11).

Each measured point's deviation (in the DRF) is, against nominal points with normals, its distance
along the nominal normal from the tangent plane of the nearest nominal point, ``d_i = (p_i - q_j) . n_j``;
against a nominal mesh (STL / OBJ / PLY, :func:`read_nominal_mesh`), the exact signed distance from
the mesh surface (:class:`pcmm_geo.artefacts.cad_distance.SurfaceIndex`: the nearest triangle proven in
double precision), positive outside the material -- the sign is the side the outward face normals
point to, so the mesh must be closed and consistently oriented with outward normals (refused by
name otherwise).  The zone is equally disposed about the nominal surface (``2 max |d_i|``).

Degrees of freedom the DRF leaves free let the zone float (ISO 1101 18.6: profile with an
incomplete datum system; without datums all six float):

- free translations only: ``d_i - n_j . s`` is linear in the shift ``s`` for the fixed correspondences,
  so one linear program (HiGHS) gives the exact minimum of ``max |d_i - n_j . s|``: scope ``"global"``
  (for those correspondences, recomputed once at the optimum);
- free rotations: the rotation is linearised about the current pose and the linear programs are
  repeated, moving the points exactly, until the step is below 1e-12: a local optimum only (the six
  degree-of-freedom L-infinity fit has local minima), scope ``"local"`` -- the verdict is then PASS
  when the zone found is within the tolerance and NOT PROVEN otherwise, never FAIL.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import FileFormatError, InvalidInputError, PcmmGeoError
from pcmm_geo.gdt.characteristics import CharacteristicResult, decide
from pcmm_geo.gdt.reference.frame import DatumReferenceFrame

if TYPE_CHECKING:
    from pcmm_geo.artefacts.cad_distance import SurfaceIndex

__all__ = ["MAX_MESH_BYTES", "evaluate_profile", "read_nominal_mesh", "surface_nominal"]

#: largest nominal mesh file read (bytes): 512 MiB, about 10^7 triangles of binary STL
MAX_MESH_BYTES = 512 << 20

FloatArray = NDArray[np.float64]
_UNIT = {"x": np.array([1.0, 0, 0]), "y": np.array([0, 1.0, 0]), "z": np.array([0, 0, 1.0])}


def _rotation(omega: FloatArray) -> FloatArray:
    angle = float(np.linalg.norm(omega))
    if angle == 0.0:
        return np.eye(3)
    k = omega / angle
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * kx + (1 - np.cos(angle)) * kx @ kx


def _tangent_plane_deviations(nominal_points: ArrayLike, nominal_normals: ArrayLike) -> Any:
    """``cloud -> (d, n)``: distances from the nearest nominal point's tangent plane along its normal; the normals."""
    from scipy.spatial import cKDTree

    q = np.asarray(nominal_points, dtype=float)
    nrm = np.asarray(nominal_normals, dtype=float)
    for what, arr in (("nominal_points", q), ("nominal_normals", nrm)):
        if arr.ndim != 2 or arr.shape[1] != 3 or not np.all(np.isfinite(arr)) or len(arr) == 0:
            raise InvalidInputError(what, "a finite (N, 3) array", repr(arr.shape))
    if q.shape != nrm.shape:
        raise InvalidInputError("nominal_normals", f"the shape of nominal_points {q.shape}", repr(nrm.shape))
    lengths = np.linalg.norm(nrm, axis=1)
    if np.any(lengths == 0):
        raise InvalidInputError("nominal_normals", "non-zero normals", f"row {int(np.argmin(lengths))} is zero")
    nrm = nrm / lengths[:, None]
    tree = cKDTree(q)

    def deviations(cloud: FloatArray) -> tuple[FloatArray, FloatArray]:
        _, j = tree.query(cloud)
        return np.einsum("ij,ij->i", cloud - q[j], nrm[j]), nrm[j]

    return deviations


def _mesh_deviations(index: SurfaceIndex) -> Any:
    """``cloud -> (d, n)``: exact signed distances from the mesh and their gradients (a move ``dp`` changes ``d`` by
    ``n . dp``)."""
    def deviations(cloud: FloatArray) -> tuple[FloatArray, FloatArray]:
        found = index.distances(cloud)
        return np.asarray(found.signed_distance, dtype=float), np.asarray(found.direction, dtype=float)

    return deviations


def _linf_step(d: FloatArray, jac: FloatArray) -> tuple[FloatArray, float]:
    """``argmin_s max |d - jac s|`` and its value (linear program, HiGHS)."""
    from scipy.optimize import linprog

    n, p = jac.shape
    c = np.r_[np.zeros(p), 1.0]
    a = np.vstack([np.c_[-jac, -np.ones(n)], np.c_[jac, -np.ones(n)]])
    b = np.r_[-d, d]
    res = linprog(c, A_ub=a, b_ub=b, bounds=[(None, None)] * p + [(0, None)], method="highs")
    if res.status != 0:
        return np.zeros(p), float(np.abs(d).max())
    return res.x[:p], float(res.x[-1])


def read_nominal_mesh(path: str | Path, *, max_bytes: int = MAX_MESH_BYTES) -> SurfaceIndex:
    """Read a nominal mesh for a profile (STL, OBJ or PLY; mm, DRF coordinates) and index it for exact distances.

    Parameters
    ----------
    path : str or Path
    max_bytes : int
        Largest file read (default :data:`MAX_MESH_BYTES`).

    Returns
    -------
    SurfaceIndex
        Built once; :func:`evaluate_profile` queries it (``nominal_mesh``).

    Raises
    ------
    FileFormatError
        Naming the file: missing, larger than ``max_bytes``, unreadable or no triangles
        (:func:`pcmm_geo.io.meshes.read_mesh`), or not closed / not consistently oriented / inward normals
        (:func:`pcmm_geo.artefacts.cad_distance.check_closed_mesh`: the sign of a deviation could not be trusted).
    """
    from pcmm_geo.artefacts.cad_distance import SurfaceIndex, check_closed_mesh
    from pcmm_geo.io.meshes import read_mesh

    file = Path(path)
    if not file.is_file():
        raise FileFormatError(str(file), "nominal mesh not found")
    size = file.stat().st_size
    if size > max_bytes:
        raise FileFormatError(str(file), f"nominal mesh of {size} bytes, larger than the limit of {max_bytes} bytes")
    try:
        mesh = read_mesh(file)
        check_closed_mesh(mesh, what=str(file))
        return SurfaceIndex.build(mesh, require_closed=False)  # checked just above, naming the file
    except FileFormatError:
        raise
    except PcmmGeoError as exc:
        raise FileFormatError(str(file), f"nominal mesh: {exc}") from None


def evaluate_profile(
    points: ArrayLike,
    drf: DatumReferenceFrame,
    tolerance_mm: float,
    nominal_points: ArrayLike | None = None,
    nominal_normals: ArrayLike | None = None,
    *,
    nominal_mesh: SurfaceIndex | None = None,
    name: str = "profile",
    max_iterations: int = 50,
) -> CharacteristicResult:
    """Profile of a surface: the width of the equally disposed zone about the nominal holding the points.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Measured points, measurement coordinates, mm.
    drf : DatumReferenceFrame
        The frame of the profile's datums (``DatumReferenceFrame.measurement()`` without datums: all six
        degrees of freedom float).
    tolerance_mm : float
        Zone width, mm.
    nominal_points, nominal_normals : array_like, shape (M, 3), optional
        The nominal surface sampled densely enough that its tangent planes represent it, DRF coordinates;
        normals point out of the material (normalised here).
    nominal_mesh : SurfaceIndex or trimesh.Trimesh, optional
        Instead of points and normals: a closed nominal mesh in DRF coordinates (:func:`read_nominal_mesh`;
        a ``Trimesh`` is indexed here and refused unless closed); deviations are the exact signed
        point-to-mesh distances.

    Returns
    -------
    CharacteristicResult
        ``details``: ``scope`` (``"global"`` / ``"local"``), ``floating`` (the free degrees of freedom used),
        ``largest_deviation_mm`` and ``smallest_deviation_mm`` at the final pose.

    Raises
    ------
    InvalidInputError
        Shapes, non-finite values, zero normals; neither or both of (nominal points and normals) and a mesh.
    """
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3 or not np.all(np.isfinite(pts)) or len(pts) == 0:
        raise InvalidInputError("points", "a finite (N, 3) array", repr(pts.shape))
    if (nominal_mesh is None) == (nominal_points is None or nominal_normals is None):
        raise InvalidInputError("nominal_mesh", "either nominal_points with nominal_normals or nominal_mesh",
                                "both" if nominal_mesh is not None else "neither")
    if nominal_mesh is not None and not hasattr(nominal_mesh, "distances"):  # a trimesh: index it (closed)
        from pcmm_geo.artefacts.cad_distance import SurfaceIndex

        nominal_mesh = SurfaceIndex.build(nominal_mesh, require_closed=True)
    deviations = _mesh_deviations(nominal_mesh) if nominal_mesh is not None else \
        _tangent_plane_deviations(nominal_points, nominal_normals)
    local = drf.to_frame(pts)
    trans = [_UNIT[f[1]] for f in drf.free if f.startswith("t")]
    rots = [_UNIT[f[1]] for f in drf.free if f.startswith("r")]
    # rotations turn about the DRF's pivot unless every translation floats too (then any centre will do)
    centre = local.mean(axis=0) if len(trans) == 3 else np.asarray(drf.pivot, dtype=float)

    d, normals = deviations(local)
    scale = max(1.0, float(np.abs(local - centre).max()))
    def jacobian(cloud: FloatArray, normals: FloatArray) -> FloatArray:
        """Change of the deviations per unit of each free motion (translations, rotations about the centre)."""
        cols = [normals @ t for t in trans] + [np.einsum("ij,ij->i", np.cross(r, cloud - centre), normals)
                                               for r in rots]
        return np.column_stack(cols)

    def move(cloud: FloatArray, step: FloatArray) -> FloatArray:
        shift = sum((step[k] * t for k, t in enumerate(trans)), np.zeros(3))
        omega = sum((step[len(trans) + k] * r for k, r in enumerate(rots)), np.zeros(3))
        return (cloud - centre) @ _rotation(omega).T + centre + shift

    if trans or rots:
        # first the least-squares (point-to-plane) placement in the free motions: the DRF's origin along a
        # free translation is arbitrary, and the nearest-point correspondences need a close start
        for _ in range(max_iterations):
            step, *_ = np.linalg.lstsq(jacobian(local, normals), -d, rcond=None)
            local = move(local, step)
            d, normals = deviations(local)
            if np.linalg.norm(step) * scale < 1e-9:
                break
        for _ in range(max_iterations):
            step, _ = _linf_step(d, -jacobian(local, normals))
            current = float(np.abs(d).max())
            for _halving in range(30):  # the linearised rotation may overshoot: halve until no worse
                moved = move(local, step)
                d_new, normals_new = deviations(moved)
                if float(np.abs(d_new).max()) <= current or np.linalg.norm(step) * scale < 1e-12:
                    break
                step = step / 2
            else:
                break
            if float(np.abs(d_new).max()) > current:
                break
            local, d, normals = moved, d_new, normals_new
            if np.linalg.norm(step) * scale < 1e-12:
                break
    scope = "local" if rots else "global"
    value = 2.0 * float(np.abs(d).max())
    bound = value if scope == "global" else float("nan")
    details: dict[str, Any] = {"scope": scope, "floating": list(drf.free),
                               "nominal": "mesh" if nominal_mesh is not None else "points",
                               "largest_deviation_mm": float(d.max()), "smallest_deviation_mm": float(d.min())}
    return CharacteristicResult(name, "profile of a surface", value, bound, tolerance_mm, None,
                                decide(value, bound, tolerance_mm, tolerance_mm), drf.datums, drf.standard, details)


def surface_nominal(table: dict[str, Any], base: Path, fail: Any) -> dict[str, Any]:
    """A plan's ``element = "surface"`` nominal: ``nominal_mesh = "FILE"`` or ``nominal_points`` + ``nominal_normals``.

    Files are relative to ``base`` (the plan's folder); ``fail(key, reason)`` makes the error naming the plan's
    line.  Returns the :class:`~pcmm_geo.gdt.characteristics.FeatureData` fields (``nominal_mesh`` or
    ``nominal_points`` and ``nominal_normals``).
    """
    from pcmm_geo.io.points import read_points

    if "nominal_mesh" in table:
        if not isinstance(table["nominal_mesh"], str) or "nominal_points" in table or "nominal_normals" in table:
            raise fail("nominal_mesh", 'nominal_mesh = "FILE" (STL, OBJ or PLY) instead of nominal_points and '
                       "nominal_normals")
        try:
            return {"nominal_mesh": read_nominal_mesh((base / table["nominal_mesh"]).resolve())}
        except PcmmGeoError as exc:
            raise fail("nominal_mesh", f"nominal_mesh {table['nominal_mesh']!r}: {exc}") from None
    surface: dict[str, Any] = {}
    for key in ("nominal_points", "nominal_normals"):
        if not isinstance(table.get(key), str):
            raise fail(key, f'{key} = "FILE" (or nominal_mesh = "FILE") is required for a surface')
        nominal_file = (base / table[key]).resolve()
        if not nominal_file.is_file():
            raise fail(key, f"{key} file {table[key]!r} not found (looked for {nominal_file})")
        try:
            surface[key] = read_points(nominal_file)
        except PcmmGeoError as exc:
            raise fail(key, f"{key} file {table[key]!r}: {exc}") from None
    if surface["nominal_points"].shape != surface["nominal_normals"].shape:
        raise fail("nominal_normals", "nominal_points and nominal_normals differ in length")
    return surface
