"""Build a :class:`CmmDocument` for the QIF writer from one record per measured feature (ids assigned).

:class:`FeatureReport` holds what a user knows about one measured feature: its fitted actuals,
optionally its nominal and material side, the points it was fitted to and its characteristics
(size, form) with value, tolerance, verdict and uncertainty.  :func:`results_document` numbers
every QIF element (definition, nominal, item, measurement, point set, characteristic definition,
nominal, item and measurement) and links them, so that :func:`~pcmm_geo.io.cmm.write_qif` can
write a schema-valid QIF 3.0 results document.

Examples
--------
>>> import numpy as np
>>> from pcmm_geo.io.cmm import Characteristic, FeatureGeometry, Tolerance
>>> hole = FeatureReport(
...     type="circle", name="HOLE1",
...     actual=FeatureGeometry(location=np.zeros(3), normal=np.array([0.0, 0.0, 1.0]), diameter=12.004),
...     nominal=FeatureGeometry(location=np.zeros(3), normal=np.array([0.0, 0.0, 1.0]), diameter=12.0),
...     internal_external="INTERNAL",
...     characteristics=(Characteristic(id=0, type="diameter", value=12.004, nominal=12.0,
...                                     tolerance=Tolerance(max_value=0.01, min_value=-0.01), status="PASS"),))
>>> document = results_document([hole])
>>> feature = document.measured_features[0]
>>> feature.name, feature.internal_external, document.definition_of(feature).diameter
('HOLE1', 'INTERNAL', 12.0)
>>> [c.type for c in document.characteristics_of(feature)]
['diameter']
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

from pcmm_geo.elements import SIZED_FEATURES, SPECS
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.io.cmm.document import CmmDocument
from pcmm_geo.io.cmm.model import (
    FEATURE_TYPES,
    Characteristic,
    FeatureDefinition,
    FeatureGeometry,
    FeatureItem,
    FeatureNominal,
    MeasuredFeature,
    MeasuredPointSet,
    MeasurementResults,
    PointSetReference,
    Units,
)
from pcmm_geo.io.cmm.qif.write._xml_out import check_xml_text

__all__ = ["INTERNAL_EXTERNAL", "NOMINAL_NEEDS", "FeatureReport", "check_feature_name", "results_document"]

#: the values of QIF ``InternalExternal``
INTERNAL_EXTERNAL = ("INTERNAL", "EXTERNAL", "NOT_APPLICABLE")
#: what a nominal of each type must give (QIF 3.0 feature nominal and definition)
NOMINAL_NEEDS: dict[str, tuple[str, ...]] = {kind: SPECS[kind].nominal_fields for kind in FEATURE_TYPES}
_SIZED = SIZED_FEATURES


@dataclass(frozen=True, eq=False)
class FeatureReport:
    """One measured feature to write as QIF.

    Attributes
    ----------
    type : str
        One of ``"circle"``, ``"cylinder"``, ``"sphere"``, ``"plane"``, ``"line"``, ``"point"``, ``"cone"``.
    name : str
        Feature name (QIF ``FeatureName``).
    actual : FeatureGeometry
        The fitted actuals (mm, rad); ``form`` and ``uncertainty`` are written where given.
    nominal : FeatureGeometry or None
        Nominal placement and size (see :data:`NOMINAL_NEEDS`); without it only the measurement is
        written (QIF keeps the material side in the definition, which needs a nominal).
    internal_external : str or None
        ``"INTERNAL"``, ``"EXTERNAL"`` or ``"NOT_APPLICABLE"`` (default for sized types with a nominal:
        ``"NOT_APPLICABLE"``).
    points : MeasuredPointSet or None
        The points fitted (its id is replaced).
    characteristics : tuple of Characteristic
        Size and form characteristics of this feature (ids and links are replaced).
    substitute_algorithm : str or None
        QIF ``SubstituteFeatureAlgorithmEnum`` of the fit (``"LEASTSQUARES"``, ``"MINMAX"``,
        ``"MAXINSCRIBED"``, ``"MINCIRCUMSCRIBED"``, ...) or None.
    """

    type: str
    name: str
    actual: FeatureGeometry
    nominal: FeatureGeometry | None = None
    internal_external: str | None = None
    points: MeasuredPointSet | None = None
    characteristics: tuple[Characteristic, ...] = ()
    substitute_algorithm: str | None = "LEASTSQUARES"


def check_feature_name(name: object, what: str = "name") -> str:
    """``name`` when QIF can hold it and :func:`~pcmm_geo.io.cmm.read_qif` reads it back the same.

    A feature name is not empty, holds only characters XML 1.0 can hold, and has no tab, line
    end, leading, trailing or repeated space (the reader joins a name's words with one space).

    Raises
    ------
    InvalidInputError
        Naming ``what``.

    Examples
    --------
    >>> check_feature_name("HOLE <A> 1")
    'HOLE <A> 1'
    """
    if not isinstance(name, str) or not name.strip():
        raise InvalidInputError(what, "a non-empty feature name", repr(name))
    check_xml_text(name, what)
    if name != " ".join(name.split()):
        raise InvalidInputError(what, "a name that reads back the same: words separated by single spaces, no tab, "
                                "line end or space at either end", repr(name))
    return name


def _check(report: FeatureReport, index: int) -> None:
    what = f"features[{index}] ({report.name!r})"
    if report.type not in FEATURE_TYPES:
        raise InvalidInputError(f"{what}.type", f"one of {', '.join(FEATURE_TYPES)}", repr(report.type))
    if report.internal_external is not None and report.internal_external not in INTERNAL_EXTERNAL:
        raise InvalidInputError(f"{what}.internal_external", f"one of {', '.join(INTERNAL_EXTERNAL)}",
                                repr(report.internal_external))
    if report.nominal is None:
        if report.internal_external in ("INTERNAL", "EXTERNAL"):
            raise InvalidInputError(f"{what}.nominal", "a nominal (QIF keeps the material side in the feature "
                                    "definition, which needs the nominal size)", "None")
        return
    missing = [name for name in NOMINAL_NEEDS[report.type] if getattr(report.nominal, name) is None]
    if missing:
        needs = ", ".join(NOMINAL_NEEDS[report.type])
        raise InvalidInputError(f"{what}.nominal", f"a {report.type} nominal with {needs}",
                                f"none for {', '.join(missing)}")


def results_document(features: Sequence[FeatureReport], *, application: str = "pcmm_geo",
                     inspection_status: str | None = None, source: str = "") -> CmmDocument:
    """A :class:`CmmDocument` holding ``features`` with every QIF id assigned and linked.

    Parameters
    ----------
    features : sequence of FeatureReport
    application : str
        Written as the QIF ``Header/Application/Name``.
    inspection_status : str or None
        QIF ``InspectionStatusEnum`` of the whole results (``"PASS"``, ``"FAIL"``, ``"UNKNOWN"``, ...);
        default: ``"FAIL"`` when any characteristic failed, ``"PASS"`` when all passed, ``"UNKNOWN"``
        when some are indeterminate or not analysed, ``"UNDEFINED"`` without characteristics.
    source : str
        Recorded as the document's ``source``.

    Returns
    -------
    CmmDocument
        ``format="qif"``, units mm / rad.

    Raises
    ------
    InvalidInputError
        An unknown type or material side, a nominal lacking what QIF requires.
    """
    names: dict[str, int] = {}
    for index, report in enumerate(features):
        _check(report, index)
        check_feature_name(report.name, f"features[{index}].name")
        if report.name in names:
            raise InvalidInputError(f"features[{index}].name", "a name no other feature has (features["
                                    f"{names[report.name]}] has it; a file's features are chosen by name)",
                                    repr(report.name))
        names[report.name] = index
    counter = iter(range(1, 1 << 31))
    definitions, nominals, items = {}, {}, {}
    measured, point_sets, characteristics = [], {}, []
    results_id = next(counter)
    for report in features:
        item_id = None
        side = report.internal_external
        if report.nominal is not None:
            definition_id, nominal_id, item_id = next(counter), next(counter), next(counter)
            side = side or ("NOT_APPLICABLE" if report.type in _SIZED else None)
            definitions[definition_id] = FeatureDefinition(
                id=definition_id, type=report.type, internal_external=side if report.type in _SIZED else None,
                diameter=report.nominal.diameter if report.type in _SIZED else None,
                length=report.nominal.length, half_angle=report.nominal.half_angle)
            nominals[nominal_id] = FeatureNominal(id=nominal_id, type=report.type, definition_id=definition_id,
                                                  geometry=report.nominal)
            items[item_id] = FeatureItem(id=item_id, type=report.type, name=report.name, nominal_id=nominal_id)
        feature_id = next(counter)
        references: tuple[PointSetReference, ...] = ()
        if report.points is not None:
            set_id = next(counter)
            point_sets[set_id] = replace(report.points, id=set_id, results_id=results_id)
            references = (PointSetReference(set_id),)
        measured.append(MeasuredFeature(
            id=feature_id, type=report.type, name=report.name, actual=report.actual, item_id=item_id,
            internal_external=side, point_set_refs=references, substitute_algorithm=report.substitute_algorithm,
            results_id=results_id))
        for characteristic in report.characteristics:
            definition_id, nominal_id, char_item_id, measurement_id = (next(counter) for _ in range(4))
            characteristics.append(replace(
                characteristic, id=measurement_id, name=characteristic.name or f"{report.name}_{characteristic.type}",
                feature_measurement_ids=(feature_id,), feature_item_ids=() if item_id is None else (item_id,),
                item_id=char_item_id, nominal_id=nominal_id, definition_id=definition_id, results_id=results_id))
    if inspection_status is None:
        statuses = {c.status for c in characteristics}
        inspection_status = ("UNDEFINED" if not statuses else "FAIL" if "FAIL" in statuses
                             else "PASS" if statuses == {"PASS"} else "UNKNOWN")
    results = MeasurementResults(id=results_id, features=tuple(measured), point_sets=point_sets,
                                 characteristics=tuple(characteristics), inspection_status=inspection_status)
    return CmmDocument(source=source, format="qif", units=Units(), version="3.0.0", feature_definitions=definitions,
                       feature_nominals=nominals, feature_items=items, results=(results,), application=application)
