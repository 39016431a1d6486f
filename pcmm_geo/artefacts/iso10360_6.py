"""ISO 10360-6 test harness: compare any software's Gaussian fits with reference results.

The standard tests fitting software by giving it reference data sets with known
least-squares solutions and comparing the software's answers with the reference on four
kinds of deviation, each against a stated maximum permissible error:

* position -- distance from an anchor point on the reference element to the test element
  (plane), to the test axis (line, cylinder, cone) or between centres (circle, sphere,
  torus).  The anchor is the data centroid projected onto the reference element (the
  reference location when no points are known), so representations that choose different
  points on an axis compare fairly;
* orientation -- angle between directions (normal or axis), ignoring sign except for the
  cone, whose axis must point towards the opening;
* size -- radius difference (circle, sphere, cylinder; the larger of the two radii of a
  torus; the cone's radius at the anchor's station);
* angle -- cone half-angle difference.

Element parameters use one schema for references and results (:class:`ElementParameters`):
``location`` (point on the element/axis, or centre; a cone may use its apex with size 0),
``direction`` (unit normal or axis), ``size`` (radius in mm; a cone's radius at
``location``), ``size2`` (torus minor radius) and ``half_angle`` (cone, rad).

Files (reference parameters, software results, NIST reference pairs) are read by
:mod:`pcmm_geo.artefacts.iso10360_6_io`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo._records import record
from pcmm_geo.elements import Element
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.fit import ELEMENTS as _FIT_ELEMENTS

__all__ = [
    "ELEMENTS",
    "CaseDeviation",
    "ElementParameters",
    "HarnessMpe",
    "HarnessReport",
    "ReferenceCase",
    "cases_from_reference_data",
    "compare_results",
    "fit_with_pcmm_geo",
]

FloatArray = NDArray[np.float64]

ELEMENTS = _FIT_ELEMENTS  # the fits' element names
_AXIAL = {"line", "cylinder", "cone"}
_CENTRED = {"circle", "sphere", "torus"}
# ReferenceCase.circle_method -> pcmm_geo.fit.fit_circle(method=...)
_CIRCLE_METHODS = {"projected": "projected", "geometric": "gaussian"}


@record
class ElementParameters:
    """Geometry of a fitted element in the harness's common schema (mm, rad)."""

    element: Element
    location: FloatArray
    direction: FloatArray | None = None
    size: float = math.nan
    size2: float = math.nan
    half_angle: float = math.nan

    def __post_init__(self) -> None:
        if self.element not in ELEMENTS:
            raise InvalidInputError("element", f"one of {ELEMENTS}", repr(self.element))
        loc = np.asarray(self.location, dtype=float)
        if loc.shape != (3,) or not np.all(np.isfinite(loc)):
            raise InvalidInputError("location", "a finite 3-vector", f"{loc.tolist()}")
        object.__setattr__(self, "location", loc)
        if self.element != "sphere":
            if self.direction is None:
                raise InvalidInputError("direction", f"a direction for a {self.element}", "none")
            d = np.asarray(self.direction, dtype=float)
            norm = float(np.linalg.norm(d)) if d.shape == (3,) else 0.0
            if d.shape != (3,) or not math.isfinite(norm) or norm == 0:
                raise InvalidInputError("direction", "a non-zero finite 3-vector", f"{d.tolist()}")
            object.__setattr__(self, "direction", d / norm)
        needs = {"circle": ("size",), "sphere": ("size",), "cylinder": ("size",), "cone": ("size", "half_angle"),
                 "torus": ("size", "size2")}.get(self.element, ())
        for name in needs:
            if not math.isfinite(getattr(self, name)):
                raise InvalidInputError(name, f"a number for a {self.element}", "empty")


@record
class ReferenceCase:
    """A reference data set: name, reference solution and (optionally) the points.

    Attributes
    ----------
    name : str
    reference : ElementParameters
    points : ndarray, shape (N, 3) or (N, 2), optional
        The data (2 columns for planar line / circle data sets).
    circle_method : str
        ``"projected"`` (plane, then 2-D circle of the projected points: the NIST
        convention) or ``"geometric"`` (3-D distance to the circle); circles only.
    planar_axis : int or None
        For 2-D elements given in three coordinates (NIST ``Line2d``/``Circle2d``): the index
        of the constant coordinate; the fit then runs in the other two.
    """

    name: str
    reference: ElementParameters
    points: FloatArray | None = None
    circle_method: str = "projected"
    planar_axis: int | None = None


@dataclass(frozen=True)
class HarnessMpe:
    """Maximum permissible deviations: position and size in mm, orientation and angle in rad."""

    position: float = 1e-9
    orientation: float = 1e-9
    size: float = 1e-9
    angle: float = 1e-9


@dataclass(frozen=True)
class CaseDeviation:
    """Deviations of one case (NaN where not applicable) and its verdict."""

    name: str
    element: Element
    position: float
    orientation: float
    size: float
    angle: float
    passed: bool
    note: str = ""


@dataclass(frozen=True)
class HarnessReport:
    """ISO 10360-6 harness report."""

    cases: tuple[CaseDeviation, ...]
    mpe: HarnessMpe
    passed: bool
    n_failed: int

    def max_deviation(self, kind: str) -> float:
        """Largest finite deviation of a kind (``position``, ``orientation``, ``size``, ``angle``)."""
        values = [getattr(c, kind) for c in self.cases if math.isfinite(getattr(c, kind))]
        return max(values) if values else math.nan

    def to_markdown(self) -> str:
        """Markdown text: MPEs, verdict and one row per case."""
        lines = [
            "# ISO 10360-6 software test",
            "",
            f"MPE: position {self.mpe.position:g} mm, orientation {self.mpe.orientation:g} rad, "
            f"size {self.mpe.size:g} mm, cone angle {self.mpe.angle:g} rad",
            "",
            f"Verdict: **{'PASS' if self.passed else 'FAIL'}** ({len(self.cases) - self.n_failed}/"
            f"{len(self.cases)} cases within MPE)",
            "",
            "| case | element | position (mm) | orientation (rad) | size (mm) | angle (rad) | result |",
            "|---|---|---|---|---|---|---|",
        ]

        def cell(value: float) -> str:
            return "-" if not math.isfinite(value) else f"{value:.3e}"

        for c in self.cases:
            verdict = "pass" if c.passed else f"FAIL{': ' + c.note if c.note else ''}"
            lines.append(
                f"| {c.name} | {c.element} | {cell(c.position)} | {cell(c.orientation)} | {cell(c.size)} | "
                f"{cell(c.angle)} | {verdict} |"
            )
        return "\n".join(lines) + "\n"


def _anchor(case: ReferenceCase) -> FloatArray:
    ref = case.reference
    if case.points is None or len(case.points) == 0:
        return ref.location
    centroid = _three(np.asarray(case.points, dtype=float).mean(axis=0))
    if ref.element == "plane":
        return centroid - float((centroid - ref.location) @ ref.direction) * ref.direction
    if ref.element in _AXIAL:
        return ref.location + float((centroid - ref.location) @ ref.direction) * ref.direction
    return ref.location


def _distance_to_line(point: FloatArray, origin: FloatArray, direction: FloatArray) -> float:
    rel = point - origin
    return float(np.linalg.norm(rel - (rel @ direction) * direction))


def _cone_radius(params: ElementParameters, point: FloatArray) -> float:
    station = float((point - params.location) @ params.direction)
    return params.size + station * math.tan(params.half_angle)


def _deviation(case: ReferenceCase, test: ElementParameters, mpe: HarnessMpe) -> CaseDeviation:
    ref = case.reference
    if test.element != ref.element:
        return CaseDeviation(case.name, ref.element, math.nan, math.nan, math.nan, math.nan, False,
                             f"result is a {test.element}")
    anchor = _anchor(case)
    nan = math.nan
    if ref.element == "plane":
        position = abs(float((anchor - test.location) @ test.direction))
    elif ref.element in _AXIAL:
        position = _distance_to_line(anchor, test.location, test.direction)
    else:
        position = float(np.linalg.norm(test.location - ref.location))
    orientation = nan
    if ref.direction is not None and test.direction is not None:
        cosine = float(ref.direction @ test.direction)
        if ref.element != "cone":
            cosine = abs(cosine)
        sine = float(np.linalg.norm(np.cross(ref.direction, test.direction)))
        orientation = math.atan2(sine, cosine)
    size = nan
    angle = nan
    if ref.element in ("circle", "sphere", "cylinder"):
        size = abs(test.size - ref.size)
    elif ref.element == "torus":
        size = max(abs(test.size - ref.size), abs(test.size2 - ref.size2))
    elif ref.element == "cone":
        station_point = test.location + float((anchor - test.location) @ test.direction) * test.direction
        size = abs(_cone_radius(test, station_point) - _cone_radius(ref, anchor))
        angle = abs(test.half_angle - ref.half_angle)
    checks = [(position, mpe.position), (orientation, mpe.orientation), (size, mpe.size), (angle, mpe.angle)]
    failed = [not (value <= limit) for value, limit in checks if not math.isnan(value)]
    return CaseDeviation(case.name, ref.element, position, orientation, size, angle, not any(failed))


def compare_results(
    cases: Sequence[ReferenceCase],
    results: dict[str, ElementParameters] | Iterable[tuple[str, ElementParameters]],
    mpe: HarnessMpe | None = None,
) -> HarnessReport:
    """Compare a software's results with the reference cases.

    Parameters
    ----------
    cases : sequence of ReferenceCase
    results : mapping or iterable of (name, ElementParameters)
        The software's answers by case name; a missing case fails.
    mpe : HarnessMpe, optional
        Default 1e-9 mm / 1e-9 rad.

    Returns
    -------
    HarnessReport

    Raises
    ------
    InvalidInputError
        No cases.

    See Also
    --------
    cases_from_reference_data : reference cases from the generator of :mod:`pcmm_geo.fit.reference`
    fit_with_pcmm_geo : pcmm_geo's own answers to the cases

    Notes
    -----
    ISO 10360-6 [1]_: the software's Gaussian elements are compared with reference results
    parameter by parameter -- the distance of the reported location from the reference element,
    the angle between the directions, the size difference -- each against its maximum
    permissible error.  Reference cases with known Gaussian solutions can be made by
    :mod:`pcmm_geo.fit.reference` (foot points on the element moved along its normals by
    residuals that leave the solution unchanged), in the manner of the NIST algorithm testing
    system [2]_.

    References
    ----------
    .. [1] ISO 10360-6:2001, *Geometrical Product Specifications (GPS) -- Acceptance and reverification tests
           for coordinate measuring machines (CMM) -- Part 6: Estimation of errors in computing Gaussian
           associated features*.
    .. [2] C. M. Shakarji, "Least-squares fitting algorithms of the NIST algorithm testing system", *J. Res.
           Natl. Inst. Stand. Technol.* 103(6), 633-641 (1998).

    Examples
    --------
    >>> ref = ElementParameters("sphere", np.zeros(3), size=5.0)
    >>> test = ElementParameters("sphere", np.array([0.0, 0.0, 2e-10]), size=5.0 + 3e-10)
    >>> report = compare_results([ReferenceCase("s1", ref)], {"s1": test})
    >>> report.passed, report.cases[0].position
    (True, 2e-10)
    """
    if not cases:
        raise InvalidInputError("cases", "at least one reference case", "none")
    table = dict(results.items() if isinstance(results, dict) else results)
    limits = HarnessMpe() if mpe is None else mpe
    rows = []
    for case in cases:
        test = table.get(case.name)
        if test is None:
            rows.append(CaseDeviation(case.name, case.reference.element, math.nan, math.nan, math.nan, math.nan,
                                      False, "missing in results"))
        else:
            rows.append(_deviation(case, test, limits))
    n_failed = sum(not r.passed for r in rows)
    return HarnessReport(cases=tuple(rows), mpe=limits, passed=n_failed == 0, n_failed=n_failed)


def _params_from_fit(element: Element, fit: Any) -> ElementParameters:
    def vec(name: str) -> FloatArray:
        return _three(getattr(fit, name))

    if element == "line":
        return ElementParameters("line", vec("point"), vec("direction"))
    if element == "plane":
        return ElementParameters("plane", vec("point"), vec("normal"))
    if element == "circle":
        normal = vec("normal") if getattr(fit, "normal", None) is not None else np.array([0.0, 0.0, 1.0])
        return ElementParameters("circle", vec("center"), normal, size=float(fit.radius))
    if element == "sphere":
        return ElementParameters("sphere", vec("center"), size=float(fit.radius))
    if element == "cylinder":
        return ElementParameters("cylinder", vec("point"), vec("axis"), size=float(fit.radius))
    if element == "cone":
        return ElementParameters("cone", vec("apex"), vec("axis"), size=0.0, half_angle=float(fit.half_angle))
    return ElementParameters("torus", vec("center"), vec("axis"), size=float(fit.major_radius),
                             size2=float(fit.minor_radius))


def fit_with_pcmm_geo(cases: Sequence[ReferenceCase]) -> dict[str, ElementParameters]:
    """pcmm_geo's own Gaussian fits of every case that carries points.

    3-D circles are fitted as each case asks (``circle_method``): plane then projected
    circle (the NIST reference pairs) or the geometric 3-D circle.

    Raises
    ------
    InvalidInputError
        A case without points.
    PcmmGeoError
        Any error of the fits.

    Examples
    --------
    >>> pts = np.array([[1.0, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])
    >>> case = ReferenceCase("s", ElementParameters("sphere", np.zeros(3), size=1.0), pts)
    >>> round(fit_with_pcmm_geo([case])["s"].size, 12)
    1.0
    """
    from pcmm_geo import fit

    out = {}
    for case in cases:
        if case.points is None:
            raise InvalidInputError(f"case {case.name!r}", "reference points to fit", "none")
        element = case.reference.element
        pts = np.asarray(case.points, dtype=float)
        planar = case.planar_axis if element in ("line", "circle") and pts.shape[1] == 3 else None
        if planar is not None:
            keep = [k for k in range(3) if k != planar]
            result = getattr(fit, f"fit_{element}")(pts[:, keep])
            params = _params_from_fit(element, result)
            out[case.name] = _embed(params, keep, planar, float(pts[0, planar]))
            continue
        if element == "circle" and pts.shape[1] == 3:
            result = fit.fit_circle(pts, method=_CIRCLE_METHODS[case.circle_method])
        else:
            result = getattr(fit, f"fit_{element}")(pts)
        out[case.name] = _params_from_fit(element, result)
    return out


def _embed(params: ElementParameters, keep: list[int], planar: int, level: float) -> ElementParameters:
    """Put a 2-D result (computed in coordinates ``keep``, padded with z = 0) back into 3-D."""
    location = np.zeros(3)
    location[keep] = params.location[:2]
    location[planar] = level
    direction = np.zeros(3)
    if params.element == "line":
        direction[keep] = np.asarray(params.direction)[:2]
    else:
        direction[planar] = 1.0
    return ElementParameters(params.element, location, direction, size=params.size)


def _three(vector: object, fill: float = 0.0) -> FloatArray:
    arr = np.asarray(vector, dtype=float).ravel()
    return arr if arr.size == 3 else np.append(arr, fill)


def cases_from_reference_data(datasets: Iterable[object], *, prefix: str = "case") -> list[ReferenceCase]:
    """Reference cases from :class:`pcmm_geo.fit.reference.ReferenceDataSet` objects (null-space data).

    Planar (2-D) line and circle sets keep their 2-column points; their parameters are
    embedded in the z = 0 plane.  ``circle3d`` is compared with the geometric 3-D circle
    fit, ``circle3d_projected`` with the projected one.

    Parameters
    ----------
    datasets : iterable of ReferenceDataSet
    prefix : str
        Case names are ``f"{prefix}{index}_{element}"``.

    Returns
    -------
    list of ReferenceCase

    Raises
    ------
    InvalidInputError
        An unknown element name.

    Examples
    --------
    >>> from pcmm_geo.fit.reference import make_reference_data
    >>> cases = cases_from_reference_data([make_reference_data("sphere", form=1e-3, rng=2)])
    >>> cases[0].name, cases[0].reference.element
    ('case0_sphere', 'sphere')
    """
    out = []
    for index, data in enumerate(datasets):
        kind = str(data.element)  # type: ignore[attr-defined]
        par = data.parameters  # type: ignore[attr-defined]
        points = np.asarray(data.points, dtype=float)  # type: ignore[attr-defined]
        method = "geometric" if kind == "circle3d" else "projected"
        if kind in ("line2d", "line3d"):
            ref = ElementParameters("line", _three(par["point"]), _three(par["direction"]))
        elif kind == "plane":
            ref = ElementParameters("plane", _three(par["point"]), _three(par["normal"]))
        elif kind == "circle2d":
            ref = ElementParameters("circle", _three(par["center"]), np.array([0.0, 0.0, 1.0]),
                                    size=float(par["radius"]))
        elif kind in ("circle3d", "circle3d_projected"):
            ref = ElementParameters("circle", _three(par["center"]), _three(par["normal"]), size=float(par["radius"]))
        elif kind == "sphere":
            ref = ElementParameters("sphere", _three(par["center"]), size=float(par["radius"]))
        elif kind == "cylinder":
            ref = ElementParameters("cylinder", _three(par["point"]), _three(par["axis"]), size=float(par["radius"]))
        elif kind == "cone":
            ref = ElementParameters("cone", _three(par["apex"]), _three(par["axis"]), size=0.0,
                                    half_angle=float(par["half_angle"]))
        elif kind == "torus":
            ref = ElementParameters("torus", _three(par["center"]), _three(par["axis"]),
                                    size=float(par["major_radius"]), size2=float(par["minor_radius"]))
        else:
            raise InvalidInputError("element", "a reference-data element name", repr(kind))
        out.append(ReferenceCase(f"{prefix}{index}_{kind}", ref, points, circle_method=method))
    return out

