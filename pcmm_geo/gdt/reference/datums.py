"""Datum features associated from measured points (ISO 5459-2, ASME Y14.5-2018 / Y14.5.1-2019).

Associations (``criterion``):

``"minimax"`` (ISO 5459 default for planes)
    The tangent, outside-material, orientation-constrained minimax plane: of the planes with every
    point on the material side, the one minimising the largest distance.  With the normal free this is
    the material-side-outer plane of the minimum-zone slab (the narrowest slab of the convex hull, exact
    by :func:`pcmm_geo.fit.fit_plane` ``criterion="chebyshev"``); with the normal constrained
    perpendicular to the primary's direction it is the narrowest strip of the points projected along
    it (exact 2-D minimum zone); with the normal fixed it is the supporting plane.
``"constrained-lsq"`` (ASME Y14.5.1-2019 default; Shakarji & Srinivasan)
    Least squares of the distances with every point on the material side (a local optimum by SLSQP
    with its KKT multipliers, scope ``"local"``).
``"mic"`` / ``"mcc"`` (cylinders, spheres)
    The maximum inscribed (a hole: internal) or minimum circumscribed (a shaft: external) element,
    :mod:`pcmm_geo.fit.zone`; a secondary or tertiary axis parallel to the primary direction is the
    circle of the points projected along it (exact, global).
``"point"``
    A datum point: the mean of its points (usually one).

Every association carries a :class:`DatumCertificate`: the contact points, their KKT multipliers
(``sum(lower * p) - sum(upper * p)`` along the normal for a plane), the proven scope and bound.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError, TooFewPointsError

__all__ = [
    "DATUM_CRITERIA",
    "DatumAssociation",
    "DatumCertificate",
    "associate_datum",
    "default_criterion",
]

FloatArray = NDArray[np.float64]

#: the associations each element admits; the first is the ISO default
DATUM_CRITERIA = {
    "plane": ("minimax", "constrained-lsq"),
    "cylinder": ("mic", "mcc"),
    "sphere": ("mic", "mcc"),
    "point": ("point",),
}


@record
class DatumCertificate:
    """Evidence of a datum association.

    Attributes
    ----------
    contacts : ndarray of int, shape (M,)
        Indices of the contact points into the datum feature's points.
    levels : ndarray of int, shape (M,)
        Plane: 0 = on the datum plane (material-side minimum), 1 = at the largest distance.
        Round elements: 0 (every contact is on the associated surface).
    multipliers : ndarray, shape (M,)
        KKT multipliers (non-negative, each level summing to 1 for minimax planes).
    scope : str
        ``"global"`` (optimal over :attr:`domain`) or ``"local"``.
    bound_mm : float
        Proven bound: lower bound of the largest distance (planes), upper bound of a MIC radius, lower
        bound of a MCC radius; NaN when none.
    kkt_residual : float
        Stationarity residual relative to the data's scale (dimensionless).
    domain : str
        Plain-language domain of the scope.
    method : str
    """

    contacts: NDArray[np.int64]
    levels: NDArray[np.int64]
    multipliers: FloatArray
    scope: str
    bound_mm: float
    kkt_residual: float
    domain: str
    method: str


@record
class DatumAssociation:
    """One associated datum (situation feature) in measurement coordinates.

    Attributes
    ----------
    label : str
        Datum letter.
    element : str
        ``"plane"``, ``"cylinder"``, ``"sphere"`` or ``"point"``.
    criterion : str
        Association used (see :data:`DATUM_CRITERIA`).
    point : ndarray, shape (3,)
        A point of the plane (the first level-0 contact's foot), of the axis, or the centre, mm.
    direction : ndarray, shape (3,)
        Plane: unit normal into the material; cylinder: unit axis; sphere / point: NaN.
    radius : float
        Cylinder / sphere radius, mm (NaN otherwise).
    deviation_mm : float
        Largest distance of a point from the associated element (plane: on its material side), mm.
    constrained_by : tuple of str
        Directions the association was constrained by (``"perpendicular to A"`` ...).
    certificate : DatumCertificate
    """

    label: str
    element: str
    criterion: str
    point: FloatArray
    direction: FloatArray
    radius: float
    deviation_mm: float
    constrained_by: tuple[str, ...]
    certificate: DatumCertificate

    def to_dict(self) -> dict[str, object]:
        """JSON-ready summary (lengths in mm)."""
        cert = self.certificate
        return {
            "label": self.label, "element": self.element, "criterion": self.criterion,
            "point_mm": self.point.tolist(),
            "direction": None if not np.all(np.isfinite(self.direction)) else self.direction.tolist(),
            "radius_mm": None if not np.isfinite(self.radius) else self.radius,
            "deviation_mm": self.deviation_mm, "constrained_by": list(self.constrained_by),
            "certificate": {"contacts": cert.contacts.tolist(), "multipliers": cert.multipliers.tolist(),
                            "scope": cert.scope,
                            "bound_mm": None if not np.isfinite(cert.bound_mm) else cert.bound_mm,
                            "kkt_residual": cert.kkt_residual, "domain": cert.domain, "method": cert.method},
        }


def default_criterion(element: str, standard: str, side: str) -> str:
    """The default association of ``element`` under ``standard`` (``"ISO"`` / ``"ASME"``) and ``side``."""
    if element == "plane":
        return "minimax" if standard == "ISO" else "constrained-lsq"
    if element in ("cylinder", "sphere"):
        return "mic" if side == "internal" else "mcc"
    return "point"


def _unit(vector: ArrayLike, name: str) -> FloatArray:
    v = np.asarray(vector, dtype=float).reshape(-1)
    if v.shape != (3,) or not np.all(np.isfinite(v)) or np.linalg.norm(v) == 0:
        raise InvalidInputError(name, "a non-zero 3-vector", repr(vector))
    return v / np.linalg.norm(v)


def _basis_perpendicular(fixed: list[FloatArray]) -> FloatArray:
    """Orthonormal rows spanning the complement of the ``fixed`` directions."""
    if not fixed:
        return np.eye(3)
    f = np.array(fixed, dtype=float)
    _, s, vt = np.linalg.svd(f)
    rank = int(np.sum(s > 1e-9))
    return vt[rank:]


def _plane_multipliers(points: FloatArray, normal: FloatArray, lower: NDArray[np.int64], upper: NDArray[np.int64],
                       free_rows: FloatArray) -> tuple[FloatArray, FloatArray, float]:
    """Non-negative multipliers of ``sum(mu p_upper) - sum(lam p_lower) = w n`` in the free rotation rows."""
    from scipy.optimize import nnls

    # stationarity of the width in the directions the normal may turn to (free_rows, perpendicular to n)
    turn = free_rows - np.outer(free_rows @ normal, normal)
    keep = np.linalg.norm(turn, axis=1) > 1e-9
    turn = turn[keep]
    scale = max(float(np.ptp(points, axis=0).max()), 1.0)
    rel = points - points.mean(axis=0)
    cols = np.hstack([-(rel[lower] @ turn.T).T, (rel[upper] @ turn.T).T]) / scale
    rows = np.vstack([cols, np.r_[np.ones(len(lower)), np.zeros(len(upper))],
                      np.r_[np.zeros(len(lower)), np.ones(len(upper))]])
    rhs = np.r_[np.zeros(len(turn)), 1.0, 1.0]
    mult, residual = nnls(rows, rhs)
    return mult[:len(lower)], mult[len(lower):], float(residual)


def _tangent_minimax(points: FloatArray, inward: FloatArray, fixed: list[FloatArray]) -> tuple[FloatArray, str, float]:
    """Inward normal of the tangent minimax plane, the scope and the proven bound of the largest distance."""
    from pcmm_geo.fit import fit_line, fit_plane

    free = _basis_perpendicular(fixed)
    if len(free) == 3:
        fit = fit_plane(points, criterion="chebyshev")
        normal = fit.normal
        scope, bound = fit.certificate.scope, fit.certificate.bound_mm
    elif len(free) == 2:
        flat = points @ free.T
        fit = fit_line(flat, criterion="chebyshev")
        across = np.array([-fit.direction[1], fit.direction[0]])
        normal = across @ free
        scope, bound = fit.certificate.scope, fit.certificate.bound_mm
    elif len(free) == 1:
        normal = free[0]
        scope, bound = "global", float("nan")
    else:
        raise DegenerateGeometryError("plane datum", "its normal is fixed by three other directions")
    normal = normal / np.linalg.norm(normal)
    if normal @ inward < 0:
        normal = -normal
    heights = points @ normal
    if not np.isfinite(bound):
        bound = float(np.ptp(heights))
    return normal, scope, float(bound)


def _constrained_lsq(points: FloatArray, inward: FloatArray, fixed: list[FloatArray]) -> FloatArray:
    """Inward normal of the constrained least-squares plane (every point on the material side)."""
    from scipy.optimize import minimize

    from pcmm_geo.fit import fit_plane

    free = _basis_perpendicular(fixed)
    start = fit_plane(points).normal if len(free) == 3 else free.T @ (free @ inward)
    start = start / np.linalg.norm(start)
    if start @ inward < 0:
        start = -start
    if len(free) <= 1:
        return start
    turn = free - np.outer(free @ start, start)
    turn = turn[np.linalg.norm(turn, axis=1) > 1e-9]
    u, _, _ = np.linalg.svd(turn.T, full_matrices=False)
    tangents = u[:, : len(free) - 1].T
    centre = points.mean(axis=0)
    rel = points - centre
    scale = max(float(np.ptp(rel, axis=0).max()), 1.0)

    def normal_of(x: FloatArray) -> FloatArray:
        n = start + x[:-1] @ tangents
        return n / np.linalg.norm(n)

    def cost(x: FloatArray) -> float:
        d = (rel @ normal_of(x) - x[-1] * scale) / scale
        return float(d @ d)

    def constraint(x: FloatArray) -> FloatArray:
        return (rel @ normal_of(x)) / scale - x[-1]

    x0 = np.r_[np.zeros(len(tangents)), float((rel @ start).min()) / scale]
    res = minimize(cost, x0, method="SLSQP", constraints=[{"type": "ineq", "fun": constraint}],
                   options={"ftol": 1e-16, "maxiter": 200})
    return normal_of(res.x)


def associate_datum(
    points: ArrayLike,
    element: str,
    *,
    label: str = "A",
    criterion: str | None = None,
    side: str = "external",
    nominal_direction: ArrayLike | None = None,
    perpendicular_to: tuple[ArrayLike, ...] = (),
    parallel_to: ArrayLike | None = None,
    constraint_names: tuple[str, ...] = (),
    angle_to: tuple[ArrayLike, float] | None = None,
) -> DatumAssociation:
    """Associate a datum feature to measured points.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        The datum feature's points in measurement coordinates, mm.
    element : {"plane", "cylinder", "sphere", "point"}
    label : str
        The datum letter (named in errors and results).
    criterion : str, optional
        See :data:`DATUM_CRITERIA`; default ``"minimax"`` for planes, ``"mic"`` (internal) / ``"mcc"``.
    side : {"internal", "external"}
        Cylinder / sphere: a hole (internal) or a shaft (external).
    nominal_direction : array_like, shape (3,)
        Plane: the nominal normal pointing into the material; cylinder: the nominal axis (its sign is kept).
        Required for planes and cylinders (the part is pre-aligned, so it tells the sides apart).
    perpendicular_to : tuple of array_like
        Plane only: directions (of higher-precedence datums) the normal must be perpendicular to.
    parallel_to : array_like, shape (3,), optional
        Cylinder only: the axis is constrained parallel to this direction (a secondary hole
        perpendicular to a primary plane).
    constraint_names : tuple of str
        Text recorded in :attr:`DatumAssociation.constrained_by`.
    angle_to : (array_like, float), optional
        Plane only: ``(a, cos_alpha)`` -- the inward normal keeps the nominal angle ``alpha`` to the
        direction ``a`` of a higher datum (a secondary at an angle other than 0 or 90 deg;
        :mod:`~pcmm_geo.gdt.reference.constrained`).

    Returns
    -------
    DatumAssociation

    Raises
    ------
    InvalidInputError, TooFewPointsError, DegenerateGeometryError
    """
    from pcmm_geo.fit import fit_circle, fit_cylinder, fit_sphere

    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3 or not np.all(np.isfinite(pts)):
        raise InvalidInputError(f"datum {label} points", "a finite (N, 3) array", repr(pts.shape))
    if element not in DATUM_CRITERIA:
        raise InvalidInputError(f"datum {label} element", f"one of {tuple(DATUM_CRITERIA)}", repr(element))
    if criterion is None:
        criterion = default_criterion(element, "ISO", side)
    if criterion not in DATUM_CRITERIA[element]:
        raise InvalidInputError(f"datum {label} criterion", f"one of {DATUM_CRITERIA[element]}", repr(criterion))
    nan3 = np.full(3, np.nan)
    if element == "point":
        centre = pts.mean(axis=0)
        cert = DatumCertificate(np.arange(len(pts)), np.zeros(len(pts), dtype=np.int64),
                                np.full(len(pts), 1.0 / len(pts)), "global", float("nan"), 0.0, "the mean", "mean")
        dev = float(np.linalg.norm(pts - centre, axis=1).max())
        return DatumAssociation(label, element, criterion, centre, nan3, float("nan"), dev, constraint_names, cert)
    if element == "plane":
        if len(pts) < 3:
            raise TooFewPointsError(f"plane datum {label}", 3, len(pts))
        if nominal_direction is None:
            raise InvalidInputError(f"datum {label} nominal_direction", "the nominal inward normal", "None")
        inward = _unit(nominal_direction, f"datum {label} nominal_direction")
        fixed = [_unit(v, f"datum {label} perpendicular_to") for v in perpendicular_to]
        free_rows = _basis_perpendicular(fixed)
        if angle_to is not None:
            from pcmm_geo.gdt.reference.constrained import cone_plane

            axis = _unit(angle_to[0], f"datum {label} angle_to")
            normal, turn, scope, bound = cone_plane(pts, inward, axis, float(angle_to[1]), criterion=criterion,
                                                    label=label)
            free_rows = (turn / np.linalg.norm(turn))[None, :]
            method = ("tangent outside-material minimax at the nominal angle (branch and bound, exact contacts)"
                      if criterion == "minimax" else "constrained least squares at the nominal angle (local)")
        elif criterion == "minimax":
            normal, scope, bound = _tangent_minimax(pts, inward, fixed)
            method = "tangent outside-material minimax (minimum zone, exact)"
        else:
            normal = _constrained_lsq(pts, inward, fixed)
            scope, bound, method = "local", float("nan"), "constrained least squares (SLSQP + KKT)"
        heights = pts @ normal
        low, high = float(heights.min()), float(heights.max())
        width = high - low
        tol = 1e-9 * max(1.0, float(np.abs(pts).max()))
        lower = np.flatnonzero(heights - low <= tol)
        if criterion == "minimax":
            upper = np.flatnonzero(high - heights <= tol)
            lam, mu, residual = _plane_multipliers(pts, normal, lower, upper, free_rows)
            contacts, mult = np.r_[lower, upper], np.r_[lam, mu]
            levels = np.r_[np.zeros(len(lower)), np.ones(len(upper))]
            named = ", ".join(constraint_names) or "the given directions"
            domain = "all planes" if not fixed else f"planes whose normal is perpendicular to {named}"
            if angle_to is not None:
                domain = (f"planes whose normal keeps the nominal angle to {named} (azimuth within 15 deg of "
                          "the nominal)")
        else:
            # KKT of sum d^2 with d >= 0: the gradient sum(d_i p_i) balanced by the active contacts
            from scipy.optimize import nnls

            d = heights - low
            rel = pts - pts.mean(axis=0)
            turn = free_rows - np.outer(free_rows @ normal, normal)
            turn = turn[np.linalg.norm(turn, axis=1) > 1e-9]
            scale = max(float(np.ptp(pts, axis=0).max()), 1.0)
            grad_turn = (turn @ (rel.T @ d)) / scale
            grad_off = float(d.sum())
            a = np.vstack([(rel[lower] @ turn.T).T / scale, np.ones(len(lower))])
            mult, residual = nnls(a, np.r_[grad_turn, grad_off])
            residual /= max(1.0, float(np.linalg.norm(np.r_[grad_turn, grad_off])))
            contacts, levels = lower, np.zeros(len(lower))
            domain = "planes near the least-squares plane (local)"
        foot = pts[lower[0]]
        cert = DatumCertificate(contacts.astype(np.int64), levels.astype(np.int64), mult, scope,
                                bound if criterion == "minimax" else float("nan"), float(residual), domain, method)
        return DatumAssociation(label, element, criterion, foot, normal, float("nan"), width, constraint_names, cert)
    # cylinder / sphere
    if element == "sphere":
        fit = fit_sphere(pts, criterion=criterion)
        centre, direction = np.asarray(fit.center, dtype=float), nan3
        dist = np.linalg.norm(pts - centre, axis=1)
        domain = fit.certificate.domain
    elif parallel_to is not None:
        axis = _unit(parallel_to, f"datum {label} parallel_to")
        if nominal_direction is not None and axis @ _unit(nominal_direction, f"datum {label} nominal_direction") < 0:
            axis = -axis
        rows = _basis_perpendicular([axis])
        fit = fit_circle(pts @ rows.T, criterion=criterion)
        centre = np.asarray(fit.center) @ rows + axis * float((pts @ axis).mean())
        direction = axis
        dist = np.linalg.norm((pts - centre) @ rows.T, axis=1)
        domain = f"axes parallel to {', '.join(constraint_names) or 'the given direction'} ({fit.certificate.domain})"
    else:
        hint = None if nominal_direction is None else _unit(nominal_direction, f"datum {label} nominal_direction")
        fit = fit_cylinder(pts, criterion=criterion)
        direction = np.asarray(fit.axis, dtype=float)
        if hint is not None and direction @ hint < 0:
            direction = -direction
        centre = np.asarray(fit.point, dtype=float)
        rel = pts - centre
        dist = np.linalg.norm(rel - np.outer(rel @ direction, direction), axis=1)
        domain = fit.certificate.domain
    radius = float(fit.radius)
    c = fit.certificate
    dev = float(np.abs(dist - radius).max())
    cert = DatumCertificate(np.asarray(fit.contacts, dtype=np.int64), np.zeros(len(fit.contacts), dtype=np.int64),
                            np.asarray(c.multipliers, dtype=float), c.scope, float(c.bound_mm), float(c.kkt_residual),
                            domain, c.method)
    return DatumAssociation(label, element, criterion, centre, direction, radius, dev, constraint_names, cert)
