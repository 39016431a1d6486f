"""Profile of a surface against nominal points with normals (ISO 1101:2017 18.5 / 18.6; ASME Y14.5 11).

Each measured point's deviation is its distance, along the nominal normal, from the tangent plane
of the nearest nominal point (in the DRF): ``d_i = (p_i - q_j) . n_j``.  The zone is equally
disposed about the nominal surface (``2 max |d_i|``).

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

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.gdt.characteristics import CharacteristicResult, decide
from pcmm_geo.gdt.reference.frame import DatumReferenceFrame

__all__ = ["evaluate_profile"]

FloatArray = NDArray[np.float64]
_UNIT = {"x": np.array([1.0, 0, 0]), "y": np.array([0, 1.0, 0]), "z": np.array([0, 0, 1.0])}


def _rotation(omega: FloatArray) -> FloatArray:
    angle = float(np.linalg.norm(omega))
    if angle == 0.0:
        return np.eye(3)
    k = omega / angle
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * kx + (1 - np.cos(angle)) * kx @ kx


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


def evaluate_profile(
    points: ArrayLike,
    drf: DatumReferenceFrame,
    tolerance_mm: float,
    nominal_points: ArrayLike,
    nominal_normals: ArrayLike,
    *,
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
    nominal_points, nominal_normals : array_like, shape (M, 3)
        The nominal surface sampled densely enough that its tangent planes represent it, DRF coordinates;
        normals point out of the material (normalised here).

    Returns
    -------
    CharacteristicResult
        ``details``: ``scope`` (``"global"`` / ``"local"``), ``floating`` (the free degrees of freedom used),
        ``largest_deviation_mm`` and ``smallest_deviation_mm`` at the final pose.

    Raises
    ------
    InvalidInputError
        Shapes, non-finite values, zero normals.
    """
    from scipy.spatial import cKDTree

    pts = np.asarray(points, dtype=float)
    q = np.asarray(nominal_points, dtype=float)
    nrm = np.asarray(nominal_normals, dtype=float)
    for what, arr in (("points", pts), ("nominal_points", q), ("nominal_normals", nrm)):
        if arr.ndim != 2 or arr.shape[1] != 3 or not np.all(np.isfinite(arr)) or len(arr) == 0:
            raise InvalidInputError(what, "a finite (N, 3) array", repr(arr.shape))
    if q.shape != nrm.shape:
        raise InvalidInputError("nominal_normals", f"the shape of nominal_points {q.shape}", repr(nrm.shape))
    lengths = np.linalg.norm(nrm, axis=1)
    if np.any(lengths == 0):
        raise InvalidInputError("nominal_normals", "non-zero normals", f"row {int(np.argmin(lengths))} is zero")
    nrm = nrm / lengths[:, None]
    tree = cKDTree(q)
    local = drf.to_frame(pts)
    trans = [_UNIT[f[1]] for f in drf.free if f.startswith("t")]
    rots = [_UNIT[f[1]] for f in drf.free if f.startswith("r")]
    # rotations turn about the DRF's pivot unless every translation floats too (then any centre will do)
    centre = local.mean(axis=0) if len(trans) == 3 else np.asarray(drf.pivot, dtype=float)

    def deviations(cloud: FloatArray) -> tuple[FloatArray, FloatArray]:
        _, j = tree.query(cloud)
        return np.einsum("ij,ij->i", cloud - q[j], nrm[j]), nrm[j]

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
                               "largest_deviation_mm": float(d.max()), "smallest_deviation_mm": float(d.min())}
    return CharacteristicResult(name, "profile of a surface", value, bound, tolerance_mm, None,
                                decide(value, bound, tolerance_mm, tolerance_mm), drf.datums, drf.standard, details)
