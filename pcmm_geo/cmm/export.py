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

A refit of a feature of a QIF file keeps what the file states about that feature
(:func:`file_feature`): its name, its nominal (placement and nominal size, written as QIF
``FeatureDefinition`` / ``FeatureNominal`` / ``FeatureItem``), its ``InternalExternal`` and its size
characteristic's name, nominal and tolerance (written with the refitted value and status
``NOT_ANALYZED``: the verdict is not this module's).  Several fitted features go into one file
through :func:`~pcmm_geo.io.cmm.results_document`.

QIF ``combinedUncertainty`` is written as the standard uncertainty (k = 1) of the fit; the probe
radius is taken as exact unless the compensation says otherwise.

Examples
--------
Two fitted features, each named, in one file:

>>> import pathlib, tempfile
>>> from pcmm_geo.fit import fit_plane, fit_sphere
>>> from pcmm_geo.io.cmm import read_qif, results_document, write_qif
>>> d = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1.0]])
>>> ball = feature_report(fit_sphere(5 * d), "sphere", name="BALL")
>>> face = feature_report(fit_plane(d[:4] + [0, 0, 2.0]), "plane", name="TOP")
>>> path = write_qif(results_document([ball, face]), pathlib.Path(tempfile.mkdtemp()) / "two.qif")
>>> [(f.name, f.type) for f in read_qif(path).measured_features]
[('BALL', 'sphere'), ('TOP', 'plane')]
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import SummaryRow
from pcmm_geo.elements import FEATURE_TYPES, SIZED_FEATURES, SPECS, Element, FeatureType, element_of
from pcmm_geo.errors import InvalidInputError

if TYPE_CHECKING:
    from pcmm_geo.cmm.refit import Refit
    from pcmm_geo.cmm.verify import Verification
    from pcmm_geo.fit import FitResult
    from pcmm_geo.fit.probe import ProbeCompensation
    from pcmm_geo.fit.zone.form import FormEvaluation
    from pcmm_geo.io.cmm import Characteristic, CmmDocument, FeatureGeometry, FeatureReport, MeasuredFeature

__all__ = ["ALGORITHMS", "FORM_CHARACTERISTICS", "FileFeature", "feature_report", "file_feature",
           "fit_results_document", "refit_report", "verification_document"]

FloatArray = NDArray[np.float64]

#: fit criterion -> QIF SubstituteFeatureAlgorithmEnum
ALGORITHMS = {"gaussian": "LEASTSQUARES", "chebyshev": "MINMAX", "mcc": "MINCIRCUMSCRIBED", "mic": "MAXINSCRIBED"}
#: element -> QIF form characteristic (written with a tolerance; without one the form is the feature's ``Form``)
#: (QIF names the ISO roundness circularity)
FORM_CHARACTERISTICS = {kind: "circularity" if SPECS[kind].form == "roundness" else str(SPECS[kind].form)
                        for kind in FEATURE_TYPES if SPECS[kind].form is not None}
_SIZE_CHARACTERISTICS = {"circle": "diameter", "cylinder": "diameter", "sphere": "spherical_diameter"}
#: the fitted elements the QIF writer has a feature record for (pcmm_geo.elements)
ELEMENTS: tuple[FeatureType, ...] = tuple(kind for kind in FEATURE_TYPES if SPECS[kind].fitted)
#: what a nominal of each element must give to be written (QIF 3.0 feature nominal and definition)
_NOMINAL_NEEDS = {kind: SPECS[kind].nominal_fields for kind in FEATURE_TYPES}


@dataclass(frozen=True, eq=False)
class FileFeature:
    """What a file states about one of its features that a refit of its points keeps.

    Attributes
    ----------
    type : str
        The file's feature type (``"circle"``, ...); kept only by a refit of the same element.
    name : str or None
        The feature's name in the file.
    nominal : FeatureGeometry or None
        Nominal placement and size (QIF ``FeatureNominal`` with the definition's diameter,
        length, half angle; mm, rad), None when the file gives none or not all QIF requires.
    internal_external : str or None
        QIF ``InternalExternal`` (``"INTERNAL"``, ``"EXTERNAL"``, ``"NOT_APPLICABLE"``).
    size : Characteristic or None
        The file's size characteristic of the feature (its name, ``nominal`` and ``tolerance``;
        the file's value and verdict are not kept), None when there is none or more than one.
    notes : tuple of str
        What was not kept, and why.
    """

    type: str
    name: str | None = None
    nominal: FeatureGeometry | None = None
    internal_external: str | None = None
    size: Characteristic | None = None
    notes: tuple[str, ...] = field(default=())


def file_feature(document: CmmDocument, feature: MeasuredFeature) -> FileFeature:
    """What ``document`` states about ``feature`` that a refit keeps (see :class:`FileFeature`).

    Parameters
    ----------
    document : CmmDocument
        The file read (usually by :func:`~pcmm_geo.io.cmm.read_qif`).
    feature : MeasuredFeature
        One of its feature measurements.

    Returns
    -------
    FileFeature
    """
    from pcmm_geo.io.cmm import FeatureGeometry

    notes = []
    nominal = None
    record = document.nominal_of(feature)
    definition = document.definition_of(feature)
    if record is not None and feature.type in _NOMINAL_NEEDS:
        geometry = record.geometry
        nominal = FeatureGeometry(
            location=geometry.location, normal=geometry.normal, direction=geometry.direction,
            diameter=definition.diameter if definition is not None and definition.diameter is not None
            else geometry.diameter,
            length=definition.length if definition is not None and definition.length is not None else geometry.length,
            half_angle=definition.half_angle if definition is not None and definition.half_angle is not None
            else geometry.half_angle)
        missing = [name for name in _NOMINAL_NEEDS[feature.type] if getattr(nominal, name) is None]
        if missing:
            notes.append(f"nominal not kept: the file's nominal {record.id} gives no {', '.join(missing)}")
            nominal = None
    size = None
    size_type = _SIZE_CHARACTERISTICS.get(feature.type)
    if size_type is not None:
        found = [c for c in document.characteristics_of(feature) if c.type == size_type]
        if len(found) == 1:
            size = found[0]
        elif len(found) > 1:
            notes.append(f"size tolerance not kept: the file has {len(found)} {size_type} characteristics of the "
                         f"feature ({', '.join(str(c.name or c.id) for c in found)})")
    return FileFeature(type=feature.type, name=feature.name, nominal=nominal,
                       internal_external=feature.internal_external, size=size, notes=tuple(notes))


def _three(vector: Any, fill: float = 0.0) -> FloatArray:
    arr = np.asarray(vector, dtype=float).ravel()
    return arr if arr.size == 3 else np.append(arr, [fill] * (3 - arr.size))


def _std(values: list[float]) -> float | None:
    """The largest standard uncertainty of summary rows; None when none has one (NaN: not fitted) or all are 0."""
    values = [u for u in values if not np.isnan(u)]
    if not values or not all(np.isfinite(values)) or max(values) == 0:
        return None
    return float(max(values))


def _rows(fit: FitResult, element: str) -> tuple[dict[str, list[SummaryRow]], dict[str, float]]:
    """The summary rows of ``fit`` by quantity, and the QIF uncertainties of its location and diameter."""
    rows: dict[str, list[SummaryRow]] = {}
    for row in fit.summary(complete=True):  # with the rows the table leaves out (a cone's radius_at_point)
        rows.setdefault(row.quantity, []).append(row)
    spec = SPECS[element]
    uncertainty: dict[str, float] = {}
    diameter_u = _std([row.u for row in rows.get("diameter", [])]) if spec.size is not None else None
    if diameter_u is not None:
        uncertainty["diameter"] = diameter_u
    location_u = _std([row.u for row in rows.get(str(spec.location_field), [])])
    if location_u is not None:
        uncertainty["location"] = location_u
    return rows, uncertainty


def _geometry(fit: FitResult, element: Element, form: float | None, outward: FloatArray | None) -> FeatureGeometry:
    """The QIF actuals of ``fit``: its summary rows of the spec's location, orientation, size and angles.

    The values and their standard uncertainties are those :meth:`~pcmm_geo.fit.FitResult.summary`
    shows (``complete=True``), picked by the element spec (:data:`pcmm_geo.elements.SPECS`): the
    rows of its ``location_field`` and ``axis_field``, its ``diameter`` row when it has a size,
    the rows of its angle parameters.
    """
    from pcmm_geo.io.cmm import FeatureGeometry

    spec = SPECS[element]
    rows, uncertainty = _rows(fit, element)

    def values_of(quantity: str | None) -> list[float]:
        return [row.value for row in rows.get(str(quantity), ())]

    values: dict[str, Any] = {"location": _three(values_of(spec.location_field))}
    if spec.size is not None:
        values["diameter"] = values_of("diameter")[0]
    values.update({p.name: values_of(p.name)[0] for p in spec.parameters if p.kind == "angle"})
    if spec.orientation is not None:
        components = values_of(spec.axis_field)  # none: a planar circle, whose axis is z
        axis = np.array([0.0, 0.0, 1.0]) if not components else _three(components)
        if element == "plane" and outward is not None and float(axis @ outward) < 0:
            axis = -axis  # QIF: a plane's normal points out of the material
        values[spec.orientation] = axis
    return FeatureGeometry(**values, form=form, uncertainty=uncertainty)


def _status(evaluation: FormEvaluation) -> str:
    return {True: "PASS", False: "FAIL", None: "INDETERMINATE"}[evaluation.passed]


def feature_report(
    fit: FitResult,
    element: Element,
    *,
    points: ArrayLike | None = None,
    normals: ArrayLike | None = None,
    probe_radius: float = 0.0,
    compensation: ProbeCompensation | None = None,
    evaluation: FormEvaluation | None = None,
    name: str | None = None,
    nominal: FeatureGeometry | None = None,
    internal_external: str | None = None,
    from_file: FileFeature | None = None,
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
        Feature name (default: the name in ``from_file``, else the element type in capitals).
    nominal : FeatureGeometry, optional
        Nominal of the feature (lets QIF record the material side; default from ``from_file``).
        Without a nominal QIF has no feature item: only the measurement (with its name) is written.
    internal_external : str, optional
        QIF ``InternalExternal`` when a nominal is given (default: the side ``compensation``
        applied, else the one in ``from_file``).
    from_file : FileFeature, optional
        What the file the points came from states about the feature (:func:`file_feature`): its
        name, nominal, ``InternalExternal`` and size characteristic (name, nominal, tolerance)
        are kept when ``element`` is the file's type (else only the name).

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
    kept = from_file if from_file is not None and from_file.type == element else None
    if from_file is not None:
        name = name or from_file.name
    if kept is not None and nominal is None:
        nominal = kept.nominal
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
        size = Characteristic(id=0, type=_SIZE_CHARACTERISTICS[element], value=actual.diameter,
                              status="NOT_ANALYZED", uncertainty=size_u)
        if kept is not None and kept.size is not None:
            size = replace(size, name=kept.size.name, nominal=kept.size.nominal, tolerance=kept.size.tolerance)
        characteristics.append(size)
    if evaluation is not None and evaluation.tolerance is not None:
        # straightness of a 3-D line: the smallest enclosing cylinder; of a 2-D line: two parallel lines
        zone = None if element != "line" else "diametrical" if np.size(fit.point) == 3 else "non_diametrical"
        characteristics.append(Characteristic(id=0, type=FORM_CHARACTERISTICS[element],
                                              value=float(evaluation.deviation),
                                              tolerance=Tolerance(value=float(evaluation.tolerance)),
                                              status=_status(evaluation), zone_shape=zone))
    if internal_external is None and nominal is not None and compensation is not None \
            and element in SIZED_FEATURES:
        internal_external = compensation.side.upper()  # the side applied to the numbers written
    if internal_external is None and nominal is not None and kept is not None:
        internal_external = kept.internal_external
    return FeatureReport(type=element, name=name or element.upper(), actual=actual, nominal=nominal,
                         internal_external=internal_external if nominal is not None else None, points=point_set,
                         characteristics=tuple(characteristics),
                         substitute_algorithm=ALGORITHMS.get(fit.criterion, "LEASTSQUARES"))


def fit_results_document(fit: FitResult, element: Element, *, source: str = "", **options: Any) -> CmmDocument:
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


def refit_report(document: CmmDocument, feature: MeasuredFeature, refit: Refit, *,
                 name: str | None = None) -> FeatureReport:
    """A refit of one feature of ``document`` (:func:`~pcmm_geo.cmm.refit.refit_feature`) as a record for the writer.

    The refitted actuals (mm, rad; a plane's normal out of the material where the compensation
    knows it; no diameter when the material side is unknown), the points exactly as the file
    holds them (flags, radii, normals; common frame), the refit's criterion, and what the file
    states about the feature (:func:`file_feature`): name, nominal, ``InternalExternal`` (the
    side the compensation applied when it knew one) and size tolerance.

    Parameters
    ----------
    document : CmmDocument
    feature : MeasuredFeature
        The feature refitted.
    refit : Refit
        Its refit.
    name : str, optional
        Name written (default: the file's, else the type in capitals and the QIF id).

    Returns
    -------
    FeatureReport
    """
    from pcmm_geo.io.cmm import Characteristic, FeatureGeometry, FeatureReport

    kept = file_feature(document, feature)
    kind = refit.type
    uncertainty: dict[str, float] = {}
    fitted = None if refit.fit is None else element_of(refit.fit)
    if refit.fit is not None and fitted is not None:
        uncertainty = _rows(refit.fit, fitted)[1]
        if refit.diameter is None:
            uncertainty.pop("diameter", None)
    outward = refit.compensation.outward
    direction = None if refit.direction is None else np.asarray(refit.direction, dtype=float)
    if kind == "plane" and direction is not None and outward is not None and float(direction @ outward) < 0:
        direction = -direction  # QIF: a plane's normal points out of the material
    orientation = SPECS[kind].orientation
    normal = direction if orientation == "normal" else (outward if kind == "point" else None)
    actual = FeatureGeometry(location=refit.location, normal=normal,
                             direction=direction if orientation == "direction" else None,
                             diameter=refit.diameter, half_angle=refit.half_angle, uncertainty=uncertainty)
    side = {"internal": "INTERNAL", "external": "EXTERNAL"}.get(refit.compensation.side) \
        if kind in SIZED_FEATURES else None
    nominal = kept.nominal
    characteristics = []
    size_type = _SIZE_CHARACTERISTICS.get(kind)
    if size_type is not None and refit.diameter is not None:
        size = Characteristic(id=0, type=size_type, value=float(refit.diameter), status="NOT_ANALYZED",
                              uncertainty=uncertainty.get("diameter"))
        if kept.size is not None:
            size = replace(size, name=kept.size.name, nominal=kept.size.nominal, tolerance=kept.size.tolerance)
        characteristics.append(size)
    return FeatureReport(
        type=kind, name=name or kept.name or f"{kind.upper()}_{feature.id}", actual=actual, nominal=nominal,
        internal_external=None if nominal is None else (side or kept.internal_external),
        points=document.points_of(feature, frame="common"), characteristics=tuple(characteristics),
        substitute_algorithm=ALGORITHMS.get(refit.method, "LEASTSQUARES"))


def verification_document(document: CmmDocument, verification: Verification) -> CmmDocument:
    """Every feature refitted by :func:`~pcmm_geo.cmm.verify_document` in one QIF results document.

    Each is written by :func:`refit_report`; features of the file not refitted (no points,
    compensation unknown) are left out.  A name that two refitted features share is followed by
    ``_<QIF id>`` to tell them apart.

    Parameters
    ----------
    document : CmmDocument
        The file verified.
    verification : Verification
        Its verification.

    Returns
    -------
    CmmDocument
        Ready for :func:`~pcmm_geo.io.cmm.write_qif`.
    """
    from pcmm_geo.io.cmm import results_document

    features = {f.id: f for f in document.measured_features}
    refitted = [(features[check.id], check.refit_result) for check in verification.features
                if check.refit_result is not None]
    names = [f.name or f"{f.type.upper()}_{f.id}" for f, _ in refitted]
    reports = [refit_report(document, feature, refit,  # type: ignore[arg-type]
                            name=name if names.count(name) == 1 else f"{name}_{feature.id}")
               for (feature, refit), name in zip(refitted, names, strict=True)]
    return results_document(reports, source=document.source)
