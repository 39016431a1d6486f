"""Refit cases on documents built in memory: compensation flags, per-point radii, criteria, sides, lines, points.

Each document holds probe centres of a surface known in closed form; the CMM's "reported" actuals
are that surface, so a correct refit agrees to 1e-9 mm and every refusal names its reason.
"""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.cmm import refit_feature, verify_document
from pcmm_geo.errors import InvalidInputError, NotRefittedError
from pcmm_geo.io.cmm import (
    CmmDocument,
    FeatureDefinition,
    FeatureGeometry,
    FeatureItem,
    FeatureNominal,
    MeasuredFeature,
    MeasuredPointSet,
    MeasurementResults,
    PointSetReference,
)

R = 0.75  # probe radius, mm
T = np.linspace(0.0, 2 * np.pi, 24, endpoint=False)
RING = np.c_[np.cos(T), np.sin(T), np.zeros_like(T)]  # unit radial directions of a circle in z = 0
CENTRE = np.array([40.0, -12.0, 5.0])
HOLE = 10.0  # radius of the hole's surface, mm


def _document(kind: str, points: np.ndarray, actual: FeatureGeometry, *, normals: np.ndarray | None = None,
              compensated: bool | None = False, flags: np.ndarray | None = None, radii: np.ndarray | None = None,
              side: str | None = "INTERNAL", nominal: FeatureGeometry | None = None,
              nominal_diameter: float | None = None, algorithm: str | None = "LEASTSQUARES") -> CmmDocument:
    point_set = MeasuredPointSet(id=5, points=points, normals=normals, compensated=compensated,
                                 compensated_per_point=flags, probe_radius=None if radii is not None else R,
                                 probe_radii=radii, results_id=1)
    definitions = {1: FeatureDefinition(1, kind, internal_external=side, diameter=nominal_diameter)}
    nominals = {2: FeatureNominal(2, kind, 1, nominal or FeatureGeometry())}
    items = {3: FeatureItem(3, kind, "F", 2)}
    feature = MeasuredFeature(4, kind, "F", actual, item_id=3, internal_external=side,
                              point_set_refs=(PointSetReference(5),), substitute_algorithm=algorithm, results_id=1)
    results = MeasurementResults(1, features=(feature,), point_sets={5: point_set})
    return CmmDocument("memory", "qif", feature_definitions=definitions, feature_nominals=nominals,
                       feature_items=items, results=(results,))


def _hole(**options: object) -> CmmDocument:
    centres = CENTRE + (HOLE - R) * RING  # the ball touches the hole (surface radius HOLE) from inside
    actual = FeatureGeometry(location=CENTRE, normal=np.array([0.0, 0.0, 1.0]), diameter=2 * HOLE)
    return _document("circle", centres, actual, **options)  # type: ignore[arg-type]


def _only(document: CmmDocument) -> object:
    (check,) = verify_document(document, tolerance_mm=1e-9).features
    return check


def test_hole_with_stated_side_agrees() -> None:
    check = _only(_hole())
    assert check.agrees is True and check.compensation.side == "internal"
    assert abs(check.difference["diameter_mm"]) < 1e-9


def test_a_stated_side_that_contradicts_the_file_is_refused() -> None:
    document = _hole()  # InternalExternal INTERNAL
    feature = document.measured_features[0]
    with pytest.raises(NotRefittedError, match=r"material_side: expected 'internal'.*InternalExternal=INTERNAL"):
        refit_feature(document, feature, material_side="external")
    assert refit_feature(document, feature, material_side="internal").diameter == pytest.approx(2 * HOLE, abs=1e-9)
    with_normals = _hole(side="NOT_APPLICABLE", normals=-RING)  # normals toward the axis: a hole
    with pytest.raises(NotRefittedError, match="outward normals"):
        refit_feature(with_normals, with_normals.measured_features[0], material_side="external")
    refit = refit_feature(with_normals, with_normals.measured_features[0], material_side="internal")
    assert refit.diameter == pytest.approx(2 * HOLE, abs=1e-9)


def test_side_from_point_normals_and_from_nominal_size() -> None:
    check = _only(_hole(side="NOT_APPLICABLE", normals=-RING))  # outward normals of a hole point to its axis
    assert check.agrees is True and "point normals" in check.compensation.source
    check = _only(_hole(side="NOT_APPLICABLE", nominal_diameter=20.01))
    assert check.agrees is True and check.compensation.inferred is True
    check = _only(_hole(side=None))  # no side anywhere: the centre does not depend on it, the diameter does
    assert check.agrees is True and check.compensation.side == "unknown"
    assert "location_distance_mm" in check.compared and "diameter_mm" not in check.difference
    assert check.difference["location_distance_mm"] < 1e-9
    ambiguous = _only(_hole(side="NOT_APPLICABLE", nominal_diameter=2 * (HOLE - R)))  # half-way: refused
    assert ambiguous.agrees is None and "does not decide" in ambiguous.reason


def test_unknown_compensation_needs_the_user() -> None:
    document = _hole(compensated=None)
    check = _only(document)
    assert check.agrees is None and "--compensated yes|no" in check.reason
    (told,) = verify_document(document, tolerance_mm=1e-9, compensated=False).features
    assert told.agrees is True and told.compensation.probe_radius_mm == R
    (surface,) = verify_document(document, tolerance_mm=1e-9, compensated=True).features
    assert surface.agrees is False  # the centres taken as surface points: short by 2 r
    assert surface.difference["diameter_mm"] == pytest.approx(-2 * R, abs=1e-9)


def test_per_point_flags_and_radii_are_applied_point_by_point() -> None:
    centres = CENTRE + (HOLE - R) * RING
    flags = np.arange(len(RING)) % 3 == 0  # every third point already on the surface
    mixed = np.where(flags[:, None], CENTRE + HOLE * RING, centres)
    actual = FeatureGeometry(location=CENTRE, normal=np.array([0.0, 0.0, 1.0]), diameter=2 * HOLE)
    check = _only(_document("circle", mixed, actual, normals=-RING, compensated=None, flags=flags))
    assert check.agrees is True and check.compensation.probe_radius_mm == 0.0
    no_normals = _only(_document("circle", mixed, actual, compensated=None, flags=flags))
    assert no_normals.agrees is None and "no normals" in no_normals.reason
    radii = np.linspace(0.5, 1.0, len(RING))
    varied = CENTRE + (HOLE - radii)[:, None] * RING
    check = _only(_document("circle", varied, actual, normals=-RING, radii=radii))
    assert check.agrees is True


def test_criteria_from_the_file() -> None:
    wobble = 0.002 * np.cos(3 * T)
    centres = CENTRE + (HOLE - R + wobble)[:, None] * RING
    actual = FeatureGeometry(location=CENTRE, normal=np.array([0.0, 0.0, 1.0]), diameter=2 * HOLE)
    for algorithm, criterion in (("MINMAX", "chebyshev"), ("MINCIRCUMSCRIBED", "mcc"), ("MAXINSCRIBED", "mic"),
                                 ("DEFAULT", "gaussian"), (None, "gaussian")):
        document = _document("circle", centres, actual, algorithm=algorithm)
        refit = refit_feature(document, document.measured_features[0])
        assert refit.method == criterion
    # MCC of the centres is the outer lobe: 2 (HOLE - R + 0.002) + 2 R
    document = _document("circle", centres, actual, algorithm="MINCIRCUMSCRIBED")
    assert refit_feature(document, document.measured_features[0]).diameter == pytest.approx(2 * HOLE + 0.004,
                                                                                           abs=1e-9)
    with pytest.raises(NotRefittedError, match="ONESIDED"):
        document = _document("circle", centres, actual, algorithm="ONESIDED")
        refit_feature(document, document.measured_features[0])
    with pytest.raises(InvalidInputError, match="circle_plane"):
        refit_feature(document, document.measured_features[0], circle_plane="best")


def test_line_and_point_move_along_their_normals() -> None:
    along = np.linspace(0.0, 30.0, 7)
    surface = np.c_[along, np.full_like(along, 4.0), np.zeros_like(along)]  # a line on the face z = 0
    up = np.array([0.0, 0.0, 1.0])
    actual = FeatureGeometry(location=surface[0], direction=np.array([1.0, 0.0, 0.0]))
    check = _only(_document("line", surface + R * up, actual, normals=np.tile(up, (7, 1)), side=None))
    assert check.agrees is True and check.compensation.method == "points along normals"
    nominal_normal = _only(_document("line", surface + R * up, actual, side=None,
                                     nominal=FeatureGeometry(location=surface[0], normal=up)))
    assert nominal_normal.agrees is True and "nominal normal" in nominal_normal.compensation.source
    point = _only(_document("point", (surface[2] + R * up)[None], FeatureGeometry(location=surface[2], normal=up),
                            side=None))
    assert point.agrees is True and point.difference["location_distance_mm"] < 1e-12
    uncompensated = _only(_document("point", (surface[2] + R * up)[None],
                                    FeatureGeometry(location=surface[2] + R * up, normal=up), side=None))
    assert uncompensated.agrees is False and "probe centre" in uncompensated.reason


def test_types_not_refitted_and_features_without_points() -> None:
    document = _document("edge_point", CENTRE[None], FeatureGeometry(location=CENTRE))
    assert _only(document).agrees is None and "not refitted" in _only(document).reason
    empty = CmmDocument("memory", "qif", results=(MeasurementResults(1, features=(
        MeasuredFeature(4, "sphere", "S", FeatureGeometry(location=CENTRE, diameter=5.0)),)),))
    check = _only(empty)
    assert (check.agrees, check.n_points) == (None, 0) and check.reported["diameter_mm"] == 5.0


def test_bad_options() -> None:
    with pytest.raises(InvalidInputError, match="tolerance_mm"):
        verify_document(_hole(), tolerance_mm=-1.0)
    with pytest.raises(InvalidInputError, match="criterion"):
        verify_document(_hole(), criterion="best")


def _ball(**options: object) -> CmmDocument:
    """Probe centres on a sphere of radius BALL + R about CENTRE: a ball touched from outside."""
    golden = np.pi * (3.0 - np.sqrt(5.0))
    k = np.arange(40)
    z = 1.0 - 2.0 * (k + 0.5) / 40
    directions = np.c_[np.sqrt(1 - z**2) * np.cos(golden * k), np.sqrt(1 - z**2) * np.sin(golden * k), z]
    actual = FeatureGeometry(location=CENTRE, diameter=2 * BALL)
    return _document("sphere", CENTRE + (BALL + R) * directions, actual, **options)  # type: ignore[arg-type]


BALL = 12.5


def test_a_sphere_without_side_is_compared_by_its_centre_and_refit_with_a_stated_side() -> None:
    """A sphere's centre does not depend on the material side: compared without it; its diameter needs it."""
    check = _only(_ball(side=None))
    assert check.agrees is True and check.compared == ("location_distance_mm",)
    assert check.compensation.side == "unknown" and "diameter_mm" not in check.difference
    # a wrong reported centre still disagrees: the comparison is real
    moved = _ball(side=None)
    feature = moved.measured_features[0]
    wrong = verify_document(_document("sphere", moved.points_of(feature).points,
                                      FeatureGeometry(location=CENTRE + np.array([0.0, 0.0, 0.01]), diameter=2 * BALL),
                                      side=None), tolerance_mm=1e-3).features[0]
    assert wrong.agrees is False and wrong.difference["location_distance_mm"] == pytest.approx(0.01, abs=1e-9)
    (stated,) = verify_document(_ball(side=None), tolerance_mm=1e-9, material_side="external").features
    assert stated.agrees is True and stated.difference["diameter_mm"] == pytest.approx(0.0, abs=1e-9)
    (inside,) = verify_document(_ball(side=None), tolerance_mm=1e-9, material_side="internal").features
    assert inside.agrees is False and inside.difference["diameter_mm"] == pytest.approx(4 * R, abs=1e-9)


@pytest.mark.parametrize("radius", [-1.0, 0.0, float("nan"), float("inf")])
def test_verify_refuses_a_probe_radius_that_is_not_a_positive_length(radius: float) -> None:
    with pytest.raises(InvalidInputError, match="probe_radius"):
        verify_document(_ball(side=None), probe_radius=radius)
