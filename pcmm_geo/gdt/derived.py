"""Symmetry of a derived median surface (ISO 1101:2017 18.14) and profile of a line in sections (ISO 1101 18.4 / 18.5).

**Symmetry** (ISO only: ASME Y14.5-2018 removed it).  The toleranced feature is a slot or a tab: two
opposite planar faces.  Its derived median surface is built as ISO 17450-3 builds a derived feature from
an associated one: each face is associated by its least-squares plane (normal ``u1``, ``u2``); every
extracted point ``p`` of one face is paired with the opposite face's associated plane along that plane's
normal, and the median point is the middle of the pair, ``m = p - (d / 2) u`` with ``d = (p - c) . u`` its
signed distance from the opposite plane (``c`` a point of it).  The median points of both faces are the
extracted median surface.  The zone is two parallel planes ``t`` apart, symmetric about the datum's median
plane -- the nominal median plane of the two faces (the middle of their nominal points, normal the first
face's nominal normal) in the DRF of the frame's datums --; the value is ``2 max |(m - c0) . n0|``.
The DRF must locate that plane (fix the translation along its normal and its tilts), else the frame is
refused by name.

**Profile of a line** (ISO 1101 18.4 without datums, 18.5 with; ASME Y14.5-2018 11.4).  The points are
cut into sections by the intersection plane the plan names (its normal ``s`` in the DRF, ISO 1101's
intersection plane indicator): points whose heights ``p . s`` agree to 1 µm form one section line; the
nominal points (with outward normals) at the same height are its nominal curve.  Each point's deviation is
its distance along the in-plane nominal normal from the tangent line of the nearest nominal point of its
section.  A section with no nominal points at its height is measured against the nominal surface
intersected: the trace, in the section plane, of the tangent plane of the nearest nominal point (3-D),
``(p - q) . n / |n - (n . s) s|`` -- exact where that tangent plane is tangent along a line through
the section (a developable surface's generator through ``q``: extrusions, cones), first order
otherwise.  The zone is equally disposed about the nominal curve (``2 max |d|`` per section; the value
is the largest section's).  With datums the zone is fixed, except in the motions within the section plane
the DRF leaves free (in-plane translations: one linear program, exact for the correspondences; a free
rotation about ``s``: local); without datums each section floats in its own plane in the three in-plane
degrees of freedom -- a local L-infinity fit (linear programs on the linearised rotation, the points
turned exactly), so NOT PROVEN applies as for profile of a surface: PASS when the zone found is within
the tolerance, NOT PROVEN otherwise, never FAIL.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.gdt.characteristics import CharacteristicResult, FeatureData, decide
from pcmm_geo.gdt.reference.frame import DatumReferenceFrame

__all__ = ["evaluate_line_profile", "evaluate_planned", "evaluate_symmetry", "median_points"]

FloatArray = NDArray[np.float64]
_UNIT = {"x": np.array([1.0, 0, 0]), "y": np.array([0, 1.0, 0]), "z": np.array([0, 0, 1.0])}


def _ls_plane(points: FloatArray, hint: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Least-squares plane (centroid, unit normal oriented along ``hint``)."""
    centre = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - centre, full_matrices=False)
    normal = vt[-1]
    return centre, normal if normal @ hint >= 0 else -normal


def median_points(face1: FloatArray, face2: FloatArray, direction: FloatArray) -> FloatArray:
    """Derived median points of two opposite faces (see the module docstring).

    Parameters
    ----------
    face1, face2 : ndarray, shape (N1, 3), (N2, 3)
        The faces' points (any one frame), mm.
    direction : ndarray, shape (3,)
        Roughly the faces' common normal (orients the least-squares normals).

    Returns
    -------
    ndarray, shape (N1 + N2, 3)
        Face 1's points paired with face 2's associated plane, then face 2's with face 1's.
    """
    c1, u1 = _ls_plane(face1, direction)
    c2, u2 = _ls_plane(face2, direction)
    m1 = face1 - 0.5 * np.outer((face1 - c2) @ u2, u2)
    m2 = face2 - 0.5 * np.outer((face2 - c1) @ u1, u1)
    return np.vstack([m1, m2])


def _check_points(name: str, arr: Any, minimum: int) -> FloatArray:
    pts = np.asarray(arr, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) < minimum or not np.all(np.isfinite(pts)):
        raise InvalidInputError(name, f"a finite (N, 3) array with N >= {minimum}", repr(pts.shape))
    return pts


def evaluate_symmetry(
    face1: FeatureData,
    face2: FeatureData,
    drf: DatumReferenceFrame,
    tolerance_mm: float,
    *,
    name: str = "symmetry",
) -> CharacteristicResult:
    """Symmetry of a slot or tab's median surface about the datum median plane (ISO 1101:2017 18.14).

    Parameters
    ----------
    face1, face2 : FeatureData
        The two opposite planar faces (element ``"plane"``; points in measurement coordinates, nominal
        point and outward normal in the DRF).
    drf : DatumReferenceFrame
        The frame of the datums; it must locate the nominal median plane.
    tolerance_mm : float
        Width of the zone, mm.

    Returns
    -------
    CharacteristicResult
        ``details``: ``median_plane_mm`` (nominal point and normal in the DRF), ``largest_deviation_mm`` /
        ``smallest_deviation_mm`` of the median points from it, ``median_points`` (their number).

    Raises
    ------
    InvalidInputError
        A face that is not a plane, faces that are not opposite (nominal normals not antiparallel), too
        few points, or a DRF that leaves the median plane's normal translation or tilt free.
    """
    for label, face in (("face1", face1), ("face2", face2)):
        if face.element != "plane":
            raise InvalidInputError(f"{name}: {label}", "a plane (a face of the slot or tab)", face.element)
        _check_points(f"{name}: {face.name} points", face.points, 3)
    n1 = np.asarray(face1.direction, dtype=float) / np.linalg.norm(face1.direction)
    n2 = np.asarray(face2.direction, dtype=float) / np.linalg.norm(face2.direction)
    if n1 @ n2 > -1 + 1e-9:
        raise InvalidInputError(f"{name}: faces", "two opposite faces (antiparallel nominal normals)",
                                f"{face1.name} and {face2.name}")
    centre = 0.5 * (np.asarray(face1.point, dtype=float) + np.asarray(face2.point, dtype=float))
    trans = [_UNIT[f[1]] for f in drf.free if f.startswith("t")]
    rots = [_UNIT[f[1]] for f in drf.free if f.startswith("r")]
    if any(abs(t @ n1) > 1e-9 for t in trans) or any(np.linalg.norm(np.cross(r, n1)) > 1e-9 for r in rots):
        raise InvalidInputError(f"{name}: datums", "a DRF that locates the median plane (fixes the translation "
                                "along its normal and its tilts)", "+".join(drf.datums) or "none")
    medians = median_points(drf.to_frame(face1.points), drf.to_frame(face2.points), n1)
    dev = (medians - centre) @ n1
    value = 2.0 * float(np.abs(dev).max())
    details: dict[str, Any] = {"median_plane_mm": {"point": centre.tolist(), "normal": n1.tolist()},
                               "largest_deviation_mm": float(dev.max()), "smallest_deviation_mm": float(dev.min()),
                               "median_points": len(medians)}
    return CharacteristicResult(name, "symmetry", value, value, tolerance_mm, None,
                                decide(value, value, tolerance_mm, tolerance_mm), drf.datums, drf.standard, details)


def _rotation(axis: FloatArray, angle: float) -> FloatArray:
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def _linf(d: FloatArray, jac: FloatArray) -> FloatArray:
    """``argmin_x max |d - jac x|`` (linear program, HiGHS); zeros when it fails."""
    from scipy.optimize import linprog

    n, p = jac.shape
    a = np.vstack([np.c_[-jac, -np.ones(n)], np.c_[jac, -np.ones(n)]])
    res = linprog(np.r_[np.zeros(p), 1.0], A_ub=a, b_ub=np.r_[-d, d], bounds=[(None, None)] * p + [(0, None)],
                  method="highs")
    return res.x[:p] if res.status == 0 else np.zeros(p)


def _section(pts: FloatArray, q: FloatArray, nrm: FloatArray, trans: list[FloatArray], rot: FloatArray | None,
             centre: FloatArray, iterations: int = 50) -> FloatArray:
    """Deviations of one section's points after its L-infinity float in ``trans`` (and ``rot``)."""
    from scipy.spatial import cKDTree

    tree = cKDTree(q)

    def deviations(cloud: FloatArray) -> tuple[FloatArray, FloatArray]:
        _, j = tree.query(cloud)
        return np.einsum("ij,ij->i", cloud - q[j], nrm[j]), nrm[j]

    d, normals = deviations(pts)
    if not trans and rot is None:
        return d
    cloud = pts
    scale = max(1.0, float(np.abs(pts - centre).max()))
    for _ in range(iterations):
        cols = [normals @ t for t in trans]
        if rot is not None:
            cols.append(np.einsum("ij,ij->i", np.cross(rot, cloud - centre), normals))
        step = _linf(d, np.column_stack(cols))
        current = float(np.abs(d).max())
        for _halving in range(30):  # the linearised rotation may overshoot: halve until no worse
            shift = sum((step[k] * t for k, t in enumerate(trans)), np.zeros(3))
            turn = _rotation(rot, -step[-1]) if rot is not None else np.eye(3)
            moved = (cloud - centre) @ turn.T + centre - shift
            d_new, n_new = deviations(moved)
            if float(np.abs(d_new).max()) <= current:
                break
            step = step / 2
        else:
            break
        cloud, d, normals = moved, d_new, n_new
        if np.linalg.norm(step) * scale < 1e-12:
            break
    return d


def evaluate_line_profile(
    points: ArrayLike,
    drf: DatumReferenceFrame,
    tolerance_mm: float,
    nominal_points: ArrayLike,
    nominal_normals: ArrayLike,
    *,
    section_normal: ArrayLike,
    name: str = "profile of a line",
) -> CharacteristicResult:
    """Profile of a line: every section line within its zone of width ``tolerance_mm`` (module docstring).

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Measured points on section lines, measurement coordinates, mm.
    drf : DatumReferenceFrame
        The frame of the datums (``DatumReferenceFrame.measurement()`` without datums: each section floats
        in its plane).
    tolerance_mm : float
    nominal_points, nominal_normals : array_like, shape (M, 3)
        The nominal curves of the sections (points and outward normals, DRF), at the sections' heights; a
        section without nominal points at its height uses the nominal surface's tangent planes (intersected).
    section_normal : array_like, shape (3,)
        Normal of the intersection planes, DRF.

    Returns
    -------
    CharacteristicResult
        ``details``: ``sections`` (per section: ``height_mm``, ``points``, ``value_mm``), ``scope``
        (``"global"`` with datums fixing the in-plane rotation, else ``"local"``), ``floating``.

    Raises
    ------
    InvalidInputError
        Shapes, zero normals, normals along the section normal, a section with fewer than 3 points.
    """
    pts = _check_points("points", points, 3)
    q = _check_points("nominal_points", nominal_points, 2)
    nrm = _check_points("nominal_normals", nominal_normals, 2)
    if q.shape != nrm.shape:
        raise InvalidInputError("nominal_normals", f"the shape of nominal_points {q.shape}", repr(nrm.shape))
    s = np.asarray(section_normal, dtype=float)
    if s.shape != (3,) or not np.all(np.isfinite(s)) or np.linalg.norm(s) == 0:
        raise InvalidInputError("section_normal", "a non-zero 3-vector", repr(section_normal))
    s = s / np.linalg.norm(s)
    if np.any(np.linalg.norm(nrm, axis=1) == 0):
        raise InvalidInputError("nominal_normals", "non-zero normals", "a zero row")
    nrm = nrm / np.linalg.norm(nrm, axis=1)[:, None]
    inplane = nrm - np.outer(nrm @ s, s)
    lengths = np.linalg.norm(inplane, axis=1)
    if np.any(lengths < 1e-12):
        raise InvalidInputError("nominal_normals", "normals with a component in the section plane",
                                f"row {int(np.argmin(lengths))}")
    surface_normals = nrm / lengths[:, None]  # (p - q) . n / |n_in-plane|: distance in the plane from the tangent
    inplane /= lengths[:, None]               # plane's trace (the nominal surface intersected, to first order)
    local = drf.to_frame(pts)
    keys, nominal_keys = np.round(local @ s, 3), np.round(q @ s, 3)
    trans = [t for t in (_UNIT[f[1]] for f in drf.free if f.startswith("t")) if abs(t @ s) < 1e-9]
    rot = next((r for r in (_UNIT[f[1]] for f in drf.free if f.startswith("r"))
                if np.linalg.norm(np.cross(r, s)) < 1e-9), None)
    free_inplane = [f for f in drf.free if (f.startswith("t") and abs(_UNIT[f[1]] @ s) < 1e-9) or
                    (f.startswith("r") and np.linalg.norm(np.cross(_UNIT[f[1]], s)) < 1e-9)]
    if drf.datums == () and len(drf.free) == 6:  # no datums: every in-plane motion floats
        basis = np.linalg.svd(np.eye(3) - np.outer(s, s))[0][:, :2]
        trans, rot = [basis[:, 0], basis[:, 1]], s
        free_inplane = ["in-plane translations", "in-plane rotation"]
    sections, value = [], 0.0
    for key in np.unique(keys):
        mine = local[keys == key]
        ref = nominal_keys == key
        if len(mine) < 3:
            raise InvalidInputError(f"{name}: section at {float(key):.3f} mm", "3 points or more", str(len(mine)))
        centre = mine.mean(axis=0) if len(trans) == 2 else np.asarray(drf.pivot, dtype=float)
        if np.any(ref):  # the nominal curve of this section
            d = _section(mine, q[ref], inplane[ref], trans, rot, centre)
        else:  # no nominal points at its height: the nominal surface's tangent planes cut by the section plane
            d = _section(mine, q, surface_normals, trans, rot, centre)
        width = 2.0 * float(np.abs(d).max())
        sections.append({"height_mm": float(key), "points": len(mine), "value_mm": width,
                         "nominal": "curve" if np.any(ref) else "surface intersected"})
        value = max(value, width)
    scope = "local" if rot is not None else "global"
    bound = value if scope == "global" else float("nan")
    details: dict[str, Any] = {"sections": sections, "scope": scope, "floating": free_inplane,
                               "section_normal": s.tolist()}
    return CharacteristicResult(name, "profile of a line", value, bound, tolerance_mm, None,
                                decide(value, bound, tolerance_mm, tolerance_mm), drf.datums, drf.standard, details)


def evaluate_planned(planned: Any, plan: Any, drf: DatumReferenceFrame) -> CharacteristicResult:
    """A plan's symmetry or profile of a line (``planned.extra`` from :func:`pcmm_geo.gdt.plan.frame_extras`).

    Raises
    ------
    FileFormatError
        Symmetry under ASME (removed in Y14.5-2018), a line profile of a feature that is not a ``surface``;
        names the plan's line.
    """
    from pcmm_geo.errors import FileFormatError

    spec = planned.frame
    if spec.characteristic == "symmetry":
        if plan.standard != "ISO":
            raise FileFormatError(plan.path, f"{planned.name}: symmetry was removed in ASME Y14.5-2018", planned.line)
        faces = [plan.features[f] for f in planned.extra["faces"]]
        return evaluate_symmetry(faces[0], faces[1], drf, spec.tolerance_mm, name=planned.name)
    feature = plan.features[planned.feature]
    if feature.element != "surface" or feature.nominal_points is None:
        raise FileFormatError(plan.path, f"{planned.name}: profile of a line needs a feature of element \"surface\" "
                              "with nominal_points and nominal_normals (not a nominal mesh)", planned.line)
    return evaluate_line_profile(feature.points, drf, spec.tolerance_mm, feature.nominal_points,
                                 feature.nominal_normals, section_normal=planned.extra["section_normal"],
                                 name=planned.name)
