"""A fit result (with its form evaluation, verdict and uncertainty) as records of the QIF writer.

:func:`feature_report` turns a :class:`~pcmm_geo.fit.FitResult` into one
:class:`~pcmm_geo.io.cmm.FeatureReport`: the fitted actuals (mm, rad; a 2-D circle or line lies in
the plane z = 0), the fitting algorithm (least squares, minimum zone, MCC, MIC), the measured
points exactly as they were fitted -- probe centres stay probe centres, written with
``Compensated=false``, their ``ProbeRadius`` and the outward surface normals of the compensation,
so the file says everything needed to redo it -- the size characteristic with its standard
uncertainty, and, from a :class:`~pcmm_geo.fit.zone.form.FormEvaluation`, the form characteristic
with its tolerance and verdict.  :func:`fit_results_document` wraps it into a
:class:`~pcmm_geo.io.cmm.CmmDocument` ready for :func:`~pcmm_geo.io.cmm.write_qif`.

QIF ``combinedUncertainty`` is written as the standard uncertainty (k = 1) of the fit; the probe
radius is taken as exact unless the compensation says otherwise.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo.errors import InvalidInputError

if TYPE_CHECKING:
    from pcmm_geo.fit import FitResult
    from pcmm_geo.fit.probe import ProbeCompensation
    from pcmm_geo.fit.zone.form import FormEvaluation
    from pcmm_geo.io.cmm import CmmDocument, FeatureGeometry, FeatureReport

__all__ = ["ALGORITHMS", "FORM_CHARACTERISTICS", "feature_report", "fit_results_document"]

FloatArray = NDArray[np.float64]

#: fit criterion -> QIF SubstituteFeatureAlgorithmEnum
ALGORITHMS = {"gaussian": "LEASTSQUARES", "chebyshev": "MINMAX", "mcc": "MINCIRCUMSCRIBED", "mic": "MAXINSCRIBED"}
#: element -> QIF form characteristic (written with a tolerance; without one the form is the feature's ``Form``)
FORM_CHARACTERISTICS = {"circle": "circularity", "plane": "flatness", "cylinder": "cylindricity",
                        "sphere": "sphericity", "line": "straightness", "cone": "conicity"}
_SIZE_CHARACTERISTICS = {"circle": "diameter", "cylinder": "diameter", "sphere": "spherical_diameter"}
ELEMENTS = ("circle", "cylinder", "sphere", "plane", "line", "cone")


def _three(vector: Any, fill: float = 0.0) -> FloatArray:
    arr = np.asarray(vector, dtype=float).ravel()
    return arr if arr.size == 3 else np.append(arr, [fill] * (3 - arr.size))


def _std(fit: FitResult, names: tuple[str, ...]) -> float | None:
    errors = dict(zip(fit.parameter_names, np.asarray(fit.std_errors).tolist(), strict=True))
    values = [errors[name] for name in names if name in errors]
    if not values or not all(np.isfinite(values)) or max(values) == 0:
        return None
    return float(max(values))


def _geometry(fit: FitResult, element: str, form: float | None, outward: FloatArray | None) -> FeatureGeometry:
    from pcmm_geo.io.cmm import FeatureGeometry

    uncertainty: dict[str, float] = {}
    radius_u = _std(fit, ("radius", "radius_at_point"))
    if radius_u is not None and element in ("circle", "cylinder", "sphere", "cone"):
        uncertainty["diameter"] = 2.0 * radius_u
    location_u = _std(fit, ("center_x", "center_y", "center_z", "point_x", "point_y", "point_z"))
    if location_u is not None:
        uncertainty["location"] = location_u
    if element in ("circle", "sphere"):
        normal = None if element == "sphere" else (
            np.array([0.0, 0.0, 1.0]) if fit.normal is None else np.asarray(fit.normal, dtype=float))
        return FeatureGeometry(location=_three(fit.center), normal=normal, diameter=2.0 * fit.radius, form=form,
                               uncertainty=uncertainty)
    if element == "cylinder":
        return FeatureGeometry(location=_three(fit.point), direction=np.asarray(fit.axis, dtype=float),
                               diameter=2.0 * fit.radius, form=form, uncertainty=uncertainty)
    if element == "cone":
        return FeatureGeometry(location=_three(fit.point), direction=np.asarray(fit.axis, dtype=float),
                               diameter=2.0 * fit.radius_at_point, half_angle=float(fit.half_angle), form=form,
                               uncertainty=uncertainty)
    if element == "plane":
        normal = np.asarray(fit.normal, dtype=float)
        if outward is not None and float(normal @ outward) < 0:
            normal = -normal  # QIF: a plane's normal points out of the material
        return FeatureGeometry(location=_three(fit.point), normal=normal, form=form, uncertainty=uncertainty)
    return FeatureGeometry(location=_three(fit.point), direction=_three(fit.direction), form=form,
                           uncertainty=uncertainty)


def _status(evaluation: FormEvaluation) -> str:
    return {True: "PASS", False: "FAIL", None: "INDETERMINATE"}[evaluation.passed]


def feature_report(
    fit: FitResult,
    element: str,
    *,
    points: ArrayLike | None = None,
    normals: ArrayLike | None = None,
    probe_radius: float = 0.0,
    compensation: ProbeCompensation | None = None,
    evaluation: FormEvaluation | None = None,
    name: str | None = None,
    nominal: FeatureGeometry | None = None,
    internal_external: str | None = None,
) -> FeatureReport:
    """One fitted feature as a :class:`~pcmm_geo.io.cmm.FeatureReport` for the QIF writer.

    Parameters
    ----------
    fit : FitResult
        The surface element (after probe compensation, if any): circle, cylinder, sphere, plane,
        line or cone fit, any criterion.
    element : str
        Its type.
    points : array_like, shape (N, 2) or (N, 3), optional
        The points as fitted (probe centres when ``probe_radius > 0``).
    normals : array_like, shape (N, D), optional
        Their outward surface normals when known (else, with ``compensation``, those of the
        element through each point).
    probe_radius : float
        Radius the points still carried (0: surface points, written ``Compensated=true``).
    compensation : ProbeCompensation, optional
        How the radius was applied (material side, outward normals).
    evaluation : FormEvaluation, optional
        Minimum-zone form evaluation: the feature's form, and with a tolerance the form
        characteristic with its verdict (PASS, FAIL, INDETERMINATE when an uncertified zone
        exceeds the tolerance).
    name : str, optional
        Feature name (default: the element type in capitals).
    nominal : FeatureGeometry, optional
        Nominal of the feature (lets QIF record the material side).
    internal_external : str, optional
        QIF ``InternalExternal`` (default from ``compensation`` when a nominal is given).

    Returns
    -------
    FeatureReport

    Raises
    ------
    InvalidInputError
        An element the QIF writer has no feature for (torus), points of the wrong shape.
    """
    from pcmm_geo.io.cmm import Characteristic, FeatureReport, MeasuredPointSet, Tolerance

    if element not in ELEMENTS:
        raise InvalidInputError("element", f"one of {', '.join(ELEMENTS)} (QIF has no {element} feature record)",
                                repr(element))
    outward = None if compensation is None or compensation.outward is None else _three(compensation.outward)
    form = None if evaluation is None else float(evaluation.deviation)
    actual = _geometry(fit, element, form, outward)
    point_set = None
    if points is not None:
        pts = np.asarray(points, dtype=float)
        if pts.ndim != 2 or pts.shape[1] not in (2, 3):
            raise InvalidInputError("points", "shape (N, 2) or (N, 3)", f"shape {pts.shape}")
        surface_normals = None
        if normals is not None:
            surface_normals = np.asarray(normals, dtype=float)
        elif compensation is not None and probe_radius > 0:
            moved = compensation.surface_points(pts)
            surface_normals = (pts - moved) / probe_radius  # from the surface out to the probe centre
        point_set = MeasuredPointSet(
            id=0, points=np.column_stack([pts, np.zeros(len(pts))]) if pts.shape[1] == 2 else pts,
            normals=None if surface_normals is None else
            (np.column_stack([surface_normals, np.zeros(len(pts))]) if surface_normals.shape[1] == 2
             else surface_normals),
            compensated=probe_radius == 0, probe_radius=float(probe_radius) if probe_radius > 0 else None)
    characteristics = []
    if element in _SIZE_CHARACTERISTICS:
        size_u = actual.uncertainty.get("diameter")
        characteristics.append(Characteristic(id=0, type=_SIZE_CHARACTERISTICS[element], value=actual.diameter,
                                              status="NOT_ANALYZED", uncertainty=size_u))
    if evaluation is not None and evaluation.tolerance is not None:
        # straightness of a 3-D line: the smallest enclosing cylinder; of a 2-D line: two parallel lines
        zone = None if element != "line" else "diametrical" if np.size(fit.point) == 3 else "non_diametrical"
        characteristics.append(Characteristic(id=0, type=FORM_CHARACTERISTICS[element],
                                              value=float(evaluation.deviation),
                                              tolerance=Tolerance(value=float(evaluation.tolerance)),
                                              status=_status(evaluation), zone_shape=zone))
    if internal_external is None and nominal is not None and compensation is not None \
            and element in ("circle", "cylinder", "sphere", "cone"):
        internal_external = compensation.side.upper()
    return FeatureReport(type=element, name=name or element.upper(), actual=actual, nominal=nominal,
                         internal_external=internal_external if nominal is not None else None, points=point_set,
                         characteristics=tuple(characteristics),
                         substitute_algorithm=ALGORITHMS.get(fit.criterion, "LEASTSQUARES"))


def fit_results_document(fit: FitResult, element: str, *, source: str = "", **options: Any) -> CmmDocument:
    """A QIF results document holding one fitted feature (:func:`feature_report` options).

    Examples
    --------
    >>> from pcmm_geo.fit import fit_sphere
    >>> d = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1.0]])
    >>> document = fit_results_document(fit_sphere(5 * d + 100.0), "sphere", points=5 * d + 100.0, name="BALL")
    >>> feature = document.measured_features[0]
    >>> feature.name, round(feature.actual.diameter, 12), feature.substitute_algorithm
    ('BALL', 10.0, 'LEASTSQUARES')
    """
    from pcmm_geo.io.cmm import results_document

    return results_document([feature_report(fit, element, **options)], source=source)
