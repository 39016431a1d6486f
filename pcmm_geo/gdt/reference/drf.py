"""Build a datum reference frame from associated datums and their nominals (ISO 5459-1 clause 6, ASME Y14.5 7.10).

The plan gives every nominal in the DRF, datums included, so the frame is the rigid motion that puts
the datums' nominals onto their associations, in precedence order:

- rotation: the primary's direction (a plane's inward normal, an axis) exactly; then the secondary's
  (or, failing that, the tertiary's) direction in the plane perpendicular to it; when the later datums
  add no direction (a secondary axis parallel to the primary's), the vector from the first located datum
  (axis, centre, point) to the next one, perpendicular to the primary direction;
- origin: each datum in turn fixes the translations it can (a plane one, an axis two, a centre three)
  among those its predecessors left free.

What no datum fixes stays free (:attr:`DatumReferenceFrame.free`).  A datum that fixes nothing its
predecessors left free is refused, by name.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.gdt.reference.datums import DatumAssociation
from pcmm_geo.gdt.reference.frame import DatumReferenceFrame

__all__ = ["DatumNominal", "build_drf"]

FloatArray = NDArray[np.float64]
_AXES = ("x", "y", "z")


@record
class DatumNominal:
    """A datum feature's nominal in the DRF.

    Attributes
    ----------
    point : ndarray, shape (3,)
        A point of the plane / axis, or the centre, DRF coordinates, mm.
    direction : ndarray, shape (3,)
        Plane: unit normal into the material; cylinder: unit axis; NaN for sphere and point.
    """

    point: FloatArray
    direction: FloatArray


def _has_direction(a: DatumAssociation) -> bool:
    return a.element in ("plane", "cylinder")


def _frame_of(first: FloatArray, second: FloatArray) -> FloatArray:
    """Columns: ``first``, ``second`` made perpendicular to it, and their cross product."""
    e1 = first / np.linalg.norm(first)
    e2 = second - (second @ e1) * e1
    e2 /= np.linalg.norm(e2)
    return np.column_stack([e1, e2, np.cross(e1, e2)])


def _minimal_rotation(source: FloatArray, target: FloatArray) -> FloatArray:
    """The smallest rotation taking unit ``source`` to unit ``target`` (Rodrigues)."""
    v = np.cross(source, target)
    c = float(source @ target)
    s = float(np.linalg.norm(v))
    if s < 1e-15:
        return np.eye(3) if c > 0 else -np.eye(3) + 2 * np.outer(_perp(source), _perp(source))
    k = v / s
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + s * kx + (1 - c) * kx @ kx


def _perp(v: FloatArray) -> FloatArray:
    w = np.cross(v, [1.0, 0.0, 0.0] if abs(v[0]) < 0.9 else [0.0, 1.0, 0.0])
    return w / np.linalg.norm(w)


def _axis_name(vector: FloatArray, what: str) -> str:
    k = int(np.argmax(np.abs(vector)))
    if abs(abs(vector[k]) - 1.0) > 1e-9:
        raise InvalidInputError(what, "a direction along a DRF axis (x, y or z)", np.round(vector, 6).tolist())
    return _AXES[k]


def build_drf(
    datums: list[tuple[DatumAssociation, DatumNominal]],
    *,
    standard: str = "ISO",
) -> DatumReferenceFrame:
    """The DRF of associated datums (primary first) and their nominals.

    Parameters
    ----------
    datums : list of (DatumAssociation, DatumNominal)
        One to three datums in precedence order; associations in measurement coordinates, nominals in
        the DRF.
    standard : {"ISO", "ASME"}

    Returns
    -------
    DatumReferenceFrame
        ``rotation`` rows are the DRF axes in measurement coordinates; ``free`` the degrees of freedom
        the datums leave.

    Raises
    ------
    InvalidInputError
        No datum or more than three; a datum that fixes nothing its predecessors left free (named);
        a free rotation or translation not along a DRF axis.
    """
    if not 1 <= len(datums) <= 3:
        raise InvalidInputError("datums", "one to three datums", str(len(datums)))
    labels = tuple(a.label for a, _ in datums)
    # rotation: pairs (nominal direction in the DRF, measured direction)
    pairs: list[tuple[FloatArray, FloatArray, str]] = []
    adds_rotation: dict[str, bool] = {}
    for assoc, nominal in datums:
        adds_rotation[assoc.label] = False
        if not _has_direction(assoc):
            continue
        d_nom = np.asarray(nominal.direction, dtype=float)
        d_nom = d_nom / np.linalg.norm(d_nom)
        m = assoc.direction
        if len(pairs) == 0 or (len(pairs) == 1 and np.linalg.norm(np.cross(pairs[0][0], d_nom)) > 1e-6):
            pairs.append((d_nom, m, assoc.label))
            adds_rotation[assoc.label] = True
    if len(pairs) == 1:
        located = [(a, n) for a, n in datums if a.element in ("sphere", "point")
                   or (a.element == "cylinder" and np.linalg.norm(np.cross(a.direction, pairs[0][1])) < 1e-6)]
        if len(located) >= 2:
            (a1, n1), (a2, n2) = located[0], located[1]
            d0, m0 = pairs[0][0], pairs[0][1]
            v_nom = np.asarray(n2.point) - np.asarray(n1.point)
            v_nom = v_nom - (v_nom @ d0) * d0
            v_meas = a2.point - a1.point
            v_meas = v_meas - (v_meas @ m0) * m0
            if np.linalg.norm(v_nom) > 1e-6 and np.linalg.norm(v_meas) > 1e-6:
                pairs.append((v_nom, v_meas, a2.label))
                adds_rotation[a2.label] = True
    free: list[str] = []
    if len(pairs) >= 2:
        r_m = _frame_of(pairs[0][1], pairs[1][1]) @ _frame_of(pairs[0][0], pairs[1][0]).T
    elif len(pairs) == 1:
        r_m = _minimal_rotation(pairs[0][0], pairs[0][1])
        free.append("r" + _axis_name(pairs[0][0], f"datum {pairs[0][2]} nominal direction"))
    else:
        r_m = np.eye(3)
        free += ["rx", "ry", "rz"]
    # translation, in precedence order
    origin = np.zeros(3)
    rows: list[FloatArray] = []
    for assoc, nominal in datums:
        q = r_m @ np.asarray(nominal.point, dtype=float)
        target = assoc.point - q
        # the rows use the nominal direction as placed (a datum nominally parallel to an earlier one adds nothing)
        placed = None if not _has_direction(assoc) else r_m @ (nominal.direction / np.linalg.norm(nominal.direction))
        if assoc.element == "plane":
            a = placed[None, :]
        elif assoc.element == "cylinder":
            a = _frame_of(placed, _perp(placed))[:, 1:].T
        else:
            a = np.eye(3)
        basis = _null(rows)
        new = a @ basis
        s = np.linalg.svd(new, compute_uv=False) if new.size else np.zeros(0)
        rank = int(np.sum(s > 1e-6))
        if rank == 0 and not adds_rotation[assoc.label]:
            raise InvalidInputError(f"datum {assoc.label}", f"a datum that constrains a degree of freedom "
                                    f"{', '.join(labels[:labels.index(assoc.label)])} left free", "none")
        if rank:
            # move along the still-free directions so this datum's rows hold
            step, *_ = np.linalg.lstsq(new, a @ (target - origin), rcond=1e-6)
            origin = origin + basis @ step
            rows.extend(list(a))
    basis = _null(rows)
    drf_basis = _align(r_m.T @ basis) if basis.shape[1] else basis
    for k in range(drf_basis.shape[1]):
        free.append("t" + _axis_name(drf_basis[:, k], "free translation"))
    # free rotations turn about the last located datum (an axis or a centre), else about the origin
    located = [n for a, n in datums if a.element in ("cylinder", "sphere", "point")]
    pivot = np.asarray(located[-1].point, dtype=float) if located else np.zeros(3)
    return DatumReferenceFrame(r_m.T, origin, tuple(free), labels, standard,
                               associations=tuple(a for a, _ in datums), pivot=pivot)


def _null(rows: list[FloatArray]) -> FloatArray:
    """Orthonormal columns spanning the translations the ``rows`` leave free, shape (3, k)."""
    if not rows:
        return np.eye(3)
    _, s, vt = np.linalg.svd(np.array(rows), full_matrices=True)
    rank = int(np.sum(s > 1e-6))
    return vt[rank:].T


def _align(basis: FloatArray) -> FloatArray:
    """The same span, with columns along coordinate axes where the span contains them."""
    cols = []
    for k in range(3):
        e = np.eye(3)[k]
        if np.linalg.norm(basis @ (basis.T @ e) - e) < 1e-9:
            cols.append(e)
    if len(cols) == basis.shape[1]:
        return np.column_stack(cols)
    return basis


def nominal_of(point: ArrayLike, direction: ArrayLike | None) -> DatumNominal:
    """A :class:`DatumNominal` from lists (direction ``None`` for spheres and points)."""
    d = np.full(3, np.nan) if direction is None else np.asarray(direction, dtype=float)
    return DatumNominal(np.asarray(point, dtype=float), d)
