"""Probe-radius compensation: from the centres of a tactile probe's ball to the surface it touched.

A CMM's tactile probe reports the centre of its ball; the surface lies one (effective, qualified)
probe radius ``r`` away from it along the surface normal, on the material side.  Two ways to get
there, each used where it is exact:

* **Element offset** (:func:`compensate_probe`, the usual CMM way).  Fit the element to the
  centres, then offset the element.  The centres of a ball rolling on an ideal sphere, circle
  (in its plane), cylinder, cone or plane lie on the parallel surface of the same type: same
  centre, axis and normal; radius ``R_c + r`` for an internal feature (hole: the surface is
  farther from the axis than the centres) or ``R_c - r`` for an external one (boss, shaft);
  a plane shifted by ``r`` into the material; a cone with the same half-angle ``alpha`` whose
  apex moves along the axis by ``r / sin(alpha)`` (its radius at a fixed section by
  ``r / cos(alpha)``).  No normal is estimated, the residuals and the form are those of the
  centres (the offset keeps every orthogonal distance), and a minimum-zone, MCC or MIC fit is
  offset the same way (``r_in``, ``r_out`` too).
* **Points along normals** (:func:`compensate_points`): each centre minus ``r`` times its
  outward surface normal.  Needed where an element has no offset surface of its own (a point,
  a line on a surface) and where each point carries its own normal (scanning, XYZIJK
  exports).  An error ``theta`` of a normal moves the point by ``r sin(theta)`` sideways.

Material side: stated (``side=``), read from outward normals at the points (pointing out of the
material, toward the probe: a hole's normals point to its axis), or inferred from the nominal
size when that is unambiguous (flagged ``inferred``); otherwise the compensation is refused.
A stated side that the normals given beside it contradict is refused, never applied.

Examples
--------
Centres of a 5 mm probe ball touching a Ø 20 mm hole lie on a Ø 15 mm circle:

>>> import numpy as np
>>> from pcmm_geo.fit import fit_circle
>>> t = np.linspace(0, 2 * np.pi, 12, endpoint=False)
>>> centres = np.c_[7.5 * np.cos(t), 7.5 * np.sin(t)]
>>> comp = compensate_probe(fit_circle(centres), 2.5, side="internal")
>>> round(comp.surface.diameter, 12), comp.side, comp.side_source
(20.0, 'internal', 'stated')
"""

from __future__ import annotations

import dataclasses
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record, short_value
from pcmm_geo.elements import SPECS, Element, element_of
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.fit._kernels._core import FitResult, as_points
from pcmm_geo.fit._kernels._inputs import positive_length, real_array

__all__ = [
    "ProbeCompensation",
    "compensate_points",
    "compensate_probe",
    "material_side_from_normals",
    "material_side_from_nominal",
]

FloatArray = NDArray[np.float64]
Side = Literal["internal", "external"]
SIDES = ("internal", "external")
#: an inferred side must put the compensated size nearer the nominal than this fraction of the gap
#: between the two candidates (internal and external differ by 4 r in diameter)
INFERENCE_MARGIN = 0.25


@record
class ProbeCompensation:
    """Result of :func:`compensate_probe`.

    Attributes
    ----------
    surface : FitResult
        The element of the touched surface, of the same type as ``probe_center`` (its
        ``residuals``, ``rms`` and ``form`` are those of the centres, which the offset keeps;
        its covariance is the centres' plus ``probe_radius_u**2`` on the size or position).
    probe_center : FitResult
        The element fitted to the probe-ball centres.
    probe_radius : float
        Effective probe-ball radius (mm).
    side : {"internal", "external"}
        Material side of a feature of size: internal (hole, the surface lies outside the
        centres) or external (boss, shaft).  Planes and lines are touched from outside the
        material: ``"external"``, with the direction in ``outward``.
    side_source : {"stated", "normals", "nominal size"}
        Where the side came from.
    inferred : bool
        True when the side was inferred from the nominal size (the file did not state it).
    outward : ndarray, shape (D,) or None
        Plane and line: unit normal pointing out of the material (toward the probe) along
        which the element moved by ``-probe_radius``; None for features of size.
    probe_radius_u : float
        Standard uncertainty of the probe radius added to the surface element (mm).
    """

    surface: FitResult
    probe_center: FitResult
    probe_radius: float
    side: str
    side_source: str
    inferred: bool
    outward: FloatArray | None = None
    probe_radius_u: float = 0.0

    @property
    def method(self) -> str:
        """How the surface was obtained: always ``"element offset"`` (see the module notes)."""
        return "element offset"

    def surface_points(self, points: ArrayLike) -> FloatArray:
        """The probe centres ``points`` (``(N, D)``) moved onto the surface along the element's normals.

        The point-wise picture of the element offset: each centre moves by the probe radius
        toward the material, along the normal of the probe-centre element through it (radial for
        spheres, circles and cylinders, the cone's surface normal, ``-outward`` for planes and
        lines).  Their fit is :attr:`surface`.

        Examples
        --------
        >>> from pcmm_geo.fit import fit_sphere
        >>> d = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1.0]])
        >>> comp = compensate_probe(fit_sphere(12 * d), 2.0, side="external")
        >>> (comp.surface_points(12 * d)[:2] + 0.0).tolist()
        [[10.0, 0.0, 0.0], [-10.0, 0.0, 0.0]]
        """
        element = _element(self.probe_center)
        dims = 2 if element == "circle" and self.probe_center.normal is None else 3
        pts = as_points(points, element=element, dims=(dims,))
        if self.outward is not None:
            return compensate_points(pts, self.outward, self.probe_radius)
        away = _radial_directions(self.probe_center, element, pts)
        if SPECS[element].offset == "conical":
            alpha = float(self.probe_center.half_angle)
            away = np.cos(alpha) * away - np.sin(alpha) * self.probe_center.axis
        outward = -away if self.side == "internal" else away
        return compensate_points(pts, outward, self.probe_radius)

    def __repr__(self) -> str:
        parts = [f"surface={self.surface!r}", f"probe_radius={self.probe_radius:.12g}", f"side={self.side!r}",
                 f"side_source={self.side_source!r}", f"inferred={self.inferred}"]
        if self.outward is not None:
            parts.append(f"outward={short_value(self.outward)}")
        if self.probe_radius_u:
            parts.append(f"probe_radius_u={self.probe_radius_u:.6g}")
        return f"ProbeCompensation({', '.join(parts)})"


def _element(fit: FitResult) -> Element:
    element = element_of(fit)  # the elements with an offset surface of their own (pcmm_geo.elements)
    if element is None or SPECS[element].offset not in ("radial", "conical", "normal"):
        raise InvalidInputError("element", "a sphere, circle, cylinder, cone, plane or line fit", type(fit).__name__)
    return element


def _unit_rows(vectors: ArrayLike, name: str, dims: int) -> FloatArray:
    arr = real_array(vectors, name)
    arr = arr.reshape(1, -1) if arr.ndim == 1 else arr
    if arr.ndim != 2 or arr.shape[1] != dims:
        raise InvalidInputError(name, f"shape ({dims},) or (N, {dims})", f"shape {np.shape(vectors)}")
    norms = np.linalg.norm(arr, axis=1)
    if not np.all(np.isfinite(norms)) or np.any(norms == 0):
        row = int(np.argmax(~np.isfinite(norms) | (norms == 0)))
        raise InvalidInputError(name, "finite non-zero vectors", f"{arr[row].tolist()} in row {row}")
    return arr / norms[:, None]


def _radial_directions(fit: FitResult, element: Element, points: FloatArray) -> FloatArray:
    """Unit vectors from the centre / axis of ``fit`` to ``points``, perpendicular to the axis (or normal)."""
    row = SPECS[element]  # sphere: no axis; a 2-D circle: its normal is None
    rel = points - getattr(fit, str(row.location_field))
    axis = None if row.axis_field is None else getattr(fit, row.axis_field)
    if axis is not None:
        rel = rel - np.outer(rel @ axis, axis)
    norms = np.linalg.norm(rel, axis=1)
    if np.any(norms == 0):
        raise InvalidInputError("points", f"points off the {element}'s centre / axis",
                                f"point {int(np.argmax(norms == 0))} on it")
    return rel / norms[:, None]


def material_side_from_normals(fit: FitResult, points: ArrayLike, outward: ArrayLike) -> Side:
    """Material side of a feature of size from outward surface normals at its points.

    Parameters
    ----------
    fit : SphereFit, CircleFit, CylinderFit or ConeFit
        The element fitted to ``points``.
    points : array_like, shape (N, D)
        The points (probe centres), D as the fit's.
    outward : array_like, shape (N, D)
        Surface normals pointing out of the material (toward the probe) at those points.

    Returns
    -------
    {"internal", "external"}
        ``"internal"`` when every normal points toward the centre / axis (a hole), ``"external"``
        when every one points away from it.

    Raises
    ------
    InvalidInputError
        Shapes disagree, a zero normal, or normals that do not agree on one side (the count of
        each is named).

    Examples
    --------
    >>> from pcmm_geo.fit import fit_sphere
    >>> d = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]], dtype=float)
    >>> material_side_from_normals(fit_sphere(10 * d), 10 * d, -d)
    'internal'
    """
    side, counts = _side_shown(fit, points, outward)
    if side is None:
        raise InvalidInputError(
            "outward normals", "normals that all point toward the axis (internal) or all away from it (external)",
            counts,
        )
    return side


def _side_shown(fit: FitResult, points: ArrayLike, outward: ArrayLike) -> tuple[Side | None, str]:
    """The side every outward normal shows (None when they point both ways) and their counts, in words."""
    element = _element(fit)
    if SPECS[element].offset == "normal":
        raise InvalidInputError("element", "a feature of size (sphere, circle, cylinder, cone)", element)
    dims = 3 if element != "circle" or fit.normal is not None else 2
    pts = as_points(points, element=element, dims=(dims,))
    normals = _unit_rows(outward, "outward normals", dims)
    if normals.shape[0] != pts.shape[0]:
        raise InvalidInputError("outward normals", f"one per point ({pts.shape[0]})", f"{normals.shape[0]}")
    along = np.einsum("ij,ij->i", normals, _radial_directions(fit, element, pts))
    away, toward = int(np.sum(along > 0)), int(np.sum(along < 0))
    side: Side | None = "external" if away and not toward else "internal" if toward and not away else None
    return side, f"{away} pointing away, {toward} toward, {pts.shape[0] - away - toward} tangential"


def material_side_from_nominal(
    center_diameter: float, nominal_diameter: float, probe_radius: float, *, cone_half_angle: float = 0.0
) -> Side:
    """Material side inferred from the nominal size, when unambiguous.

    The internal reading gives the diameter ``D_c + 2 r k``, the external one ``D_c - 2 r k``
    (``k = 1 / cos(alpha)`` for a cone at a fixed section, 1 otherwise): they differ by
    ``4 r k``.  The side is inferred when one reading lies within a quarter of that gap of the
    nominal (so the other lies at least three times farther).

    Parameters
    ----------
    center_diameter : float
        Diameter of the element fitted to the probe centres (mm).
    nominal_diameter : float
        Nominal diameter of the feature at the same place (mm).
    probe_radius : float
        Probe radius (mm).
    cone_half_angle : float
        Half-angle of a cone (rad); 0 for spheres, circles, cylinders.

    Raises
    ------
    InvalidInputError
        Neither reading is near enough the nominal: the side must be stated.

    Examples
    --------
    >>> material_side_from_nominal(7.09, 12.0, 2.5)
    'internal'
    >>> material_side_from_nominal(17.0, 12.0, 2.5)
    'external'
    """
    k = 1.0 / np.cos(cone_half_angle)
    internal = center_diameter + 2.0 * probe_radius * k
    external = center_diameter - 2.0 * probe_radius * k
    margin = INFERENCE_MARGIN * 4.0 * probe_radius * k
    if abs(internal - nominal_diameter) < margin:
        return "internal"
    if abs(external - nominal_diameter) < margin:
        return "external"
    raise InvalidInputError(
        "material side",
        "a stated side (internal or external) -- the nominal size does not decide it",
        f"nominal diameter {nominal_diameter:.6g} mm, compensated {internal:.6g} mm if internal, "
        f"{external:.6g} mm if external",
    )


def _outward_direction(outward: ArrayLike | None, fit: FitResult, element: Element) -> FloatArray:
    """The one unit outward normal of a plane or line (mean of per-point normals, checked)."""
    dims = fit.point.size
    if outward is None:
        raise InvalidInputError(
            "outward normal", f"the {element}'s surface normal pointing out of the material (from the file or "
            "the nominal)", "none")
    normals = _unit_rows(outward, "outward normal", dims)
    mean = normals.mean(axis=0)
    if np.any(normals @ mean <= 0) or np.linalg.norm(mean) == 0:
        raise InvalidInputError("outward normal", "normals on one side of the element", "opposing normals")
    direction = getattr(fit, str(SPECS[element].axis_field))
    if SPECS[element].axis_field == "normal":  # a plane; a line's direction lies in the surface
        along = float(mean @ direction)
        if abs(along) < 1e-3 * np.linalg.norm(mean):
            raise InvalidInputError("outward normal", "a normal not parallel to the plane", mean.tolist())
        return np.sign(along) * direction
    # line: the part of the normal perpendicular to the line
    across = mean - (mean @ direction) * direction
    size = float(np.linalg.norm(across))
    if size < 1e-3 * np.linalg.norm(mean):
        raise InvalidInputError("outward normal", "a surface normal perpendicular to the line (IJK)",
                                f"{np.round(mean / np.linalg.norm(mean), 9).tolist()}, parallel to the line")
    return across / size


def compensate_probe(
    fit: FitResult,
    probe_radius: float,
    *,
    side: Side | None = None,
    points: ArrayLike | None = None,
    outward: ArrayLike | None = None,
    nominal_diameter: float | None = None,
    probe_radius_u: float = 0.0,
) -> ProbeCompensation:
    """Offset an element fitted to probe-ball centres onto the touched surface.

    Parameters
    ----------
    fit : SphereFit, CircleFit, CylinderFit, ConeFit, PlaneFit or LineFit
        The element fitted to the probe centres (any criterion).
    probe_radius : float
        Effective probe-ball radius (mm, positive).
    side : {"internal", "external"}, optional
        Material side of a feature of size.  Without it the side is read from ``outward``
        normals at ``points``, else inferred from ``nominal_diameter``, else refused.  Given
        with ``outward`` normals, it must agree with them (a side the normals contradict is
        refused; normals on both sides leave the stated side to decide).
    points : array_like, shape (N, D), optional
        The probe centres ``fit`` was fitted to (with ``outward``, to read the side).
    outward : array_like, shape (N, D) or (D,), optional
        Surface normals pointing out of the material.  Required for planes and lines (one
        normal or one per point; for a line its part perpendicular to the line is used).
    nominal_diameter : float, optional
        Nominal diameter of the feature (a cone: at the fit's ``point``), to infer the side.
    probe_radius_u : float
        Standard uncertainty of the probe radius (mm), added to the size / position variance.

    Returns
    -------
    ProbeCompensation
        ``surface`` of the same type as ``fit``.

    Raises
    ------
    InvalidInputError
        Not a supported fit, a bad radius, no way to tell the material side, normals that
        disagree, a stated side the normals contradict, a plane / line normal missing or
        parallel to the element.

    Examples
    --------
    A plane of probe centres 2 mm above the surface z = 0, touched from +z:

    >>> from pcmm_geo.fit import fit_plane
    >>> centres = np.array([[0, 0, 2], [10, 0, 2], [0, 10, 2], [10, 10, 2.0]])
    >>> comp = compensate_probe(fit_plane(centres), 2.0, outward=[0, 0, 1])
    >>> (np.round(comp.surface.point, 12) + 0.0).tolist()
    [5.0, 5.0, 0.0]
    """
    element = _element(fit)
    radius = positive_length(probe_radius, "probe_radius")
    u = float(probe_radius_u)
    if not (np.isfinite(u) and u >= 0):
        raise InvalidInputError("probe_radius_u", "a non-negative finite number (mm)", repr(probe_radius_u))
    if side is not None and side not in SIDES:
        raise InvalidInputError("side", "'internal' or 'external'", repr(side))
    if SPECS[element].offset == "normal":
        if side == "internal":
            raise InvalidInputError("side", f"none for a {element} (its outward normal says the side)", "'internal'")
        normal = _outward_direction(outward, fit, element)
        surface = _offset_flat(fit, element, -radius * normal, u, normal)
        return ProbeCompensation(surface, fit, radius, "external", "normals", False, normal, u)
    source = "stated"
    if outward is not None and points is None:
        raise InvalidInputError("points", "the probe centres beside their outward normals", "none")
    if side is not None and outward is not None:
        shown = _side_shown(fit, points, outward)[0]
        if shown is not None and shown != side:  # normals on both sides show nothing: the stated side decides
            raise InvalidInputError("side", f"{shown!r}, the side the outward normals at the points show (or no "
                                    "side, to take theirs)", repr(side))
    if side is None:
        if outward is not None:
            side, source = material_side_from_normals(fit, points, outward), "normals"
        elif nominal_diameter is not None:
            half = float(fit.half_angle) if SPECS[element].offset == "conical" else 0.0
            size = 2.0 * getattr(fit, str(SPECS[element].size))
            side, source = material_side_from_nominal(size, float(nominal_diameter), radius, cone_half_angle=half), \
                "nominal size"
        else:
            raise InvalidInputError("material side", "internal or external (stated, from normals or from a nominal "
                                    "size)", "nothing to tell it")
    offset = radius if side == "internal" else -radius
    surface = _offset_round(fit, element, offset, u)
    return ProbeCompensation(surface, fit, radius, side, source, source == "nominal size", None, u)


def _with_parameters(fit: FitResult, changes: dict[str, object], values: dict[str, float],
                     variance: dict[str, float] | None = None,
                     block: tuple[list[int], FloatArray] | None = None) -> FitResult:
    names = list(fit.parameter_names)
    parameters = np.array(fit.parameters, dtype=float)
    covariance = np.array(fit.covariance, dtype=float)
    for name, value in values.items():
        if name in names:
            parameters[names.index(name)] = value
    for name, var in (variance or {}).items():
        if name in names and var:
            i = names.index(name)
            covariance[i, i] += var
    if block is not None:
        rows, extra = block
        covariance[np.ix_(rows, rows)] += extra
    return dataclasses.replace(fit, parameters=parameters, covariance=covariance, **changes)


def _offset_round(fit: FitResult, element: Element, offset: float, u: float) -> FitResult:
    """Sphere, circle, cylinder: radius (and zone radii) + offset; cone: the parallel cone."""
    if SPECS[element].offset == "conical":
        alpha = float(fit.half_angle)
        radius_at_point = fit.radius_at_point + offset / np.cos(alpha)
        with np.errstate(divide="ignore", invalid="ignore"):
            apex = fit.apex - (offset / np.sin(alpha)) * fit.axis if alpha > 0 else np.array(fit.apex, dtype=float)
        return _with_parameters(fit, {"radius_at_point": float(radius_at_point), "apex": apex},
                                {"radius_at_point": radius_at_point}, {"radius_at_point": (u / np.cos(alpha)) ** 2})
    changes: dict[str, object] = {"radius": float(fit.radius + offset)}
    for name in ("r_in", "r_out"):
        value = getattr(fit, name, float("nan"))
        changes[name] = float(value + offset)
    return _with_parameters(fit, changes, {"radius": fit.radius + offset}, {"radius": u**2})


def _offset_flat(fit: FitResult, element: Element, shift: FloatArray, u: float, normal: FloatArray) -> FitResult:
    """Plane or line moved by ``shift`` (its direction / normal unchanged)."""
    point = np.asarray(fit.point, dtype=float) + shift
    names = [f"point_{axis}" for axis in "xyz"[: point.size]]
    values = dict(zip(names, point.tolist(), strict=True))
    rows = [list(fit.parameter_names).index(name) for name in names if name in fit.parameter_names]
    block = (rows, u**2 * np.outer(normal, normal)[: len(rows), : len(rows)]) if u and len(rows) == point.size else None
    return _with_parameters(fit, {"point": point}, values, block=block)


def compensate_points(points: ArrayLike, outward: ArrayLike, probe_radius: float | ArrayLike) -> FloatArray:
    """Surface contact points: each probe centre moved by the probe radius against its outward normal.

    ``surface = centre - r * n / |n|``, with ``n`` pointing out of the material (toward the
    probe).  Used for points and lines on a surface and for points that carry their own
    normals; features of size and planes are compensated exactly by :func:`compensate_probe`.

    Parameters
    ----------
    points : array_like, shape (N, D)
        Probe-ball centres (mm).
    outward : array_like, shape (N, D) or (D,)
        Outward surface normals (any length, not zero), one per point or one for all.
    probe_radius : float or array_like, shape (N,)
        Effective probe radius (mm), one for all or one per point (QIF ``ProbeRadii``);
        zero leaves a point as it is (already compensated).

    Returns
    -------
    ndarray, shape (N, D)

    Raises
    ------
    InvalidInputError
        Shapes that disagree, zero or non-finite normals, negative or non-finite radii.

    Examples
    --------
    >>> compensate_points([[1.0, 2.0, 5.0]], [0, 0, 2], 0.5).tolist()
    [[1.0, 2.0, 4.5]]
    """
    pts = real_array(points, "points")
    if pts.ndim != 2 or pts.shape[1] not in (2, 3) or not np.all(np.isfinite(pts)):
        raise InvalidInputError("points", "finite coordinates of shape (N, 2) or (N, 3)", f"shape {pts.shape}")
    normals = _unit_rows(outward, "outward normals", pts.shape[1])
    if normals.shape[0] not in (1, pts.shape[0]):
        raise InvalidInputError("outward normals", f"one normal or one per point ({pts.shape[0]})",
                                f"{normals.shape[0]}")
    radii = real_array(probe_radius, "probe_radius")
    if radii.ndim > 1 or (radii.ndim == 1 and radii.shape[0] != pts.shape[0]):
        raise InvalidInputError("probe_radius", f"one radius or one per point ({pts.shape[0]})", f"shape {radii.shape}")
    if not np.all(np.isfinite(radii)) or np.any(radii < 0):
        raise InvalidInputError("probe_radius", "non-negative finite radii (mm)", str(radii.min()))
    return pts - np.reshape(radii, (-1, 1)) * normals
