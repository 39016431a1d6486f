"""The features part of written QIF: a refit keeps its file's nominal, side and size tolerance; several named features.

Truth: the numbers the public sample ``QIF_PTS_SAMPLE.QIF`` states for CIRCLE1 (nominal diameter
12 mm, location (-33.05, -4.35, ...), INTERNAL, DIA_CIRCLE1 12 +- 0.05 mm), the fits' own numbers
(read back to 1e-12 relative) and the schema (every file written is validated with lxml).
"""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pcmm_geo.cmm.export import feature_report, file_feature
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.fit import fit_circle, fit_cylinder, fit_plane, fit_sphere
from pcmm_geo.io.cmm import (
    Characteristic,
    CmmDocument,
    FeatureGeometry,
    FeatureReport,
    Tolerance,
    read_qif,
    results_document,
    validate_qif,
    write_qif,
)

SAMPLE = Path(__file__).resolve().parents[2] / "data" / "qif" / "samples" / "QIF_PTS_SAMPLE.QIF"
RTOL = 1e-12


@pytest.fixture(scope="module")
def sample() -> CmmDocument:
    return read_qif(SAMPLE)


def _close(written: object, read: object) -> None:
    """Equal to 1e-12 relative (an absolute floor of 1e-12 mm for values near zero)."""
    if written is None or read is None:
        assert written is None and read is None
        return
    np.testing.assert_allclose(np.asarray(read, dtype=float), np.asarray(written, dtype=float), rtol=RTOL,
                               atol=1e-12)


def _refit(sample: CmmDocument, file_name: str, element: str, fit: object, **options: object) -> FeatureReport:
    feature = sample.feature(file_name)
    point_set = sample.points_of(feature)
    points = point_set.points  # probe centres (Compensated=false): written so, with the file's probe radius
    return feature_report(fit(points), element, points=points,  # type: ignore[operator]
                          probe_radius=0.0 if point_set.compensated else point_set.probe_radius,
                          from_file=file_feature(sample, feature), **options)  # type: ignore[arg-type]


def _written(tmp_path: Path, reports: list[FeatureReport], name: str, unit: str = "mm") -> tuple[CmmDocument, Path]:
    document = results_document(reports)
    path = write_qif(document, tmp_path / name, linear_unit=unit)
    assert validate_qif(path) == (), path.read_text()[:2000]
    return document, path


@pytest.mark.parametrize("unit", ["mm", "inch"])
def test_refitting_circle1_keeps_its_nominal_side_and_size_tolerance(sample: CmmDocument, tmp_path: Path,
                                                                     unit: str) -> None:
    fit = fit_circle(sample.points_of(sample.feature("CIRCLE1")).points)
    report = _refit(sample, "CIRCLE1", "circle", fit_circle)
    _, path = _written(tmp_path, [report], f"circle1_{unit}.qif", unit)
    text = path.read_text()
    assert re.search(r"<Features>\s*<FeatureDefinitions n=\"1\">\s*<CircleFeatureDefinition id=\"\d+\">\s*"
                     r"<InternalExternal>INTERNAL</InternalExternal>", text)
    back = read_qif(path)
    feature = back.feature("CIRCLE1")
    assert back.item_of(feature).name == "CIRCLE1" and feature.internal_external == "INTERNAL"
    definition, nominal = back.definition_of(feature), back.nominal_of(feature).geometry
    _close(12.0, definition.diameter)  # the sample's nominal size
    _close([-33.05, -4.35, -1.309995069701], nominal.location)  # the sample's nominal location
    _close([0.0, 0.0, -1.0], nominal.normal)
    (size,) = back.characteristics_of(feature)
    assert (size.type, size.name, size.status) == ("diameter", "DIA_CIRCLE1", "NOT_ANALYZED")
    _close(12.0, size.nominal)
    _close(0.05, size.tolerance.max_value)
    _close(-0.05, size.tolerance.min_value)
    assert size.tolerance.defined_as_limit is False
    assert size.feature_item_ids == (feature.item_id,)
    _close(2.0 * fit.radius, size.value)  # the refit's value, not the file's 12.095569950907
    _close(2.0 * fit.radius, feature.actual.diameter)
    _close(np.asarray(fit.center), feature.actual.location)
    assert abs(size.value - 12.095569950907) > 1e-6  # (the CMM's own value is not what is kept)


def test_several_named_features_in_one_file_read_back_equal(sample: CmmDocument, tmp_path: Path) -> None:
    reports = [
        _refit(sample, "CIRCLE1", "circle", fit_circle, name="HOLE_A"),
        _refit(sample, "CIRCLE2", "circle", fit_circle, name="HOLE_B"),
        _refit(sample, "CYL_1", "cylinder", fit_cylinder, name="BORE"),
        _refit(sample, "DATUMA", "plane", fit_plane, name="FACE"),
    ]
    rng = np.random.default_rng(7)
    directions = rng.normal(size=(30, 3))
    ball = 4.0 * directions / np.linalg.norm(directions, axis=1, keepdims=True) + [10.0, 20.0, 30.0]
    reports.append(feature_report(fit_sphere(ball), "sphere", points=ball, name="BALL"))  # no nominal: no item
    document, path = _written(tmp_path, reports, "five.qif")
    back = read_qif(path)
    assert [f.name for f in back.measured_features] == ["HOLE_A", "HOLE_B", "BORE", "FACE", "BALL"]
    assert [i.name for i in back.feature_items.values()] == ["HOLE_A", "HOLE_B", "BORE", "FACE"]
    assert len(back.feature_definitions) == len(back.feature_nominals) == 4
    for written, read in zip(document.measured_features, back.measured_features, strict=True):
        assert (read.id, read.type, read.item_id, read.internal_external) == (
            written.id, written.type, written.item_id, written.internal_external)
        for name in ("location", "normal", "direction", "diameter", "form"):
            _close(getattr(written.actual, name), getattr(read.actual, name))
        _close(written.actual.uncertainty.get("diameter"), read.actual.uncertainty.get("diameter"))
        _close(document.points_of(written).points, back.points_of(read).points)
        if written.item_id is None:
            assert back.nominal_of(read) is None
            continue
        for name in ("location", "normal", "direction"):
            _close(getattr(document.nominal_of(written).geometry, name), getattr(back.nominal_of(read).geometry, name))
        _close(document.definition_of(written).diameter, back.definition_of(read).diameter)
        assert back.definition_of(read).internal_external == document.definition_of(written).internal_external
    for file_name, name in (("CIRCLE1", "HOLE_A"), ("CIRCLE2", "HOLE_B"), ("CYL_1", "BORE")):
        stated = sample.definition_of(sample.feature(file_name))
        kept = back.definition_of(back.feature(name))
        _close(stated.diameter, kept.diameter)
        assert kept.internal_external == stated.internal_external
    for written, read in zip(document.characteristics, back.characteristics, strict=True):
        assert (read.type, read.name, read.feature_item_ids, read.feature_measurement_ids) == (
            written.type, written.name, written.feature_item_ids, written.feature_measurement_ids)
        for name in ("value", "nominal", "uncertainty"):
            _close(getattr(written, name), getattr(read, name))


def test_what_a_refit_keeps_depends_on_the_element_and_on_the_file(sample: CmmDocument) -> None:
    circle1 = sample.feature("CIRCLE1")
    points = sample.points_of(circle1).points
    kept = file_feature(sample, circle1)
    as_cylinder = feature_report(fit_circle(points), "circle", from_file=replace(kept, type="cylinder"))
    assert (as_cylinder.name, as_cylinder.nominal, as_cylinder.internal_external) == ("CIRCLE1", None, None)
    assert as_cylinder.characteristics[0].tolerance is None  # another element: only the name
    explicit = feature_report(fit_circle(points), "circle", from_file=kept, name="MINE", internal_external="EXTERNAL")
    assert (explicit.name, explicit.internal_external) == ("MINE", "EXTERNAL")
    _close(12.0, explicit.nominal.diameter)
    # a nominal without what QIF requires, two diameter characteristics: not kept, and said so
    nominal_id = sample.item_of(circle1).nominal_id
    bare = replace(sample.feature_nominals[nominal_id], geometry=FeatureGeometry(location=np.zeros(3)))
    size = next(c for c in sample.characteristics_of(circle1) if c.type == "diameter")
    twice = replace(sample.results[0], characteristics=(*sample.results[0].characteristics, replace(size, id=99999)))
    edited = replace(sample, feature_nominals={**sample.feature_nominals, nominal_id: bare}, results=(twice,))
    lost = file_feature(edited, circle1)
    assert lost.nominal is None and lost.size is None
    assert lost.notes == (f"nominal not kept: the file's nominal {nominal_id} gives no normal",
                          "size tolerance not kept: the file has 2 diameter characteristics of the feature "
                          "(DIA_CIRCLE1, DIA_CIRCLE1)")


def test_names_are_given_once_not_empty_and_xml_can_hold_them(tmp_path: Path) -> None:
    actual = FeatureGeometry(location=np.zeros(3), diameter=5.0)
    with pytest.raises(InvalidInputError, match=r"features\[1\]\.name.*features\[0\] has it.*'BALL'"):
        results_document([FeatureReport("sphere", "BALL", actual), FeatureReport("sphere", "BALL", actual)])
    with pytest.raises(InvalidInputError, match=r"features\[0\]\.name: expected a non-empty feature name"):
        results_document([FeatureReport("sphere", " ", actual)])
    for bad, code in (("HOLE\x01", "0x0001"), ("HOLE\udcff", "0xdcff"), ("HOLE\ufffe", "0xfffe")):
        with pytest.raises(InvalidInputError, match=rf"features\[0\]\.name: expected text XML 1.0 can hold.*{code}"):
            results_document([FeatureReport("sphere", bad, actual)])
    for bad in ("HOLE\tA", "HOLE  A", " HOLE", "HOLE\nA"):  # the reader joins words with one space
        with pytest.raises(InvalidInputError, match=r"features\[0\]\.name: expected a name that reads back the same"):
            results_document([FeatureReport("sphere", bad, actual)])
    odd = 'HOLE <&> "1" \u00e9\u5b54'  # escaped, not refused
    path = write_qif(results_document([FeatureReport("sphere", odd, actual, nominal=actual)]), tmp_path / "odd.qif")
    assert validate_qif(path) == ()
    back = read_qif(path)
    assert back.measured_features[0].name == odd and next(iter(back.feature_items.values())).name == odd


def test_feature_records_that_do_not_link_are_refused(tmp_path: Path) -> None:
    hole = FeatureReport("circle", "HOLE", FeatureGeometry(location=np.zeros(3), normal=np.array([0, 0, 1.0]),
                                                           diameter=6.0),
                         nominal=FeatureGeometry(location=np.zeros(3), normal=np.array([0, 0, 1.0]), diameter=6.0))
    document = results_document([hole])
    (item_id, item), (nominal_id, nominal) = next(iter(document.feature_items.items())), next(
        iter(document.feature_nominals.items()))
    cases = {
        r"feature item \d+\.nominal_id: .* got 777, which the document does not hold":
            replace(document, feature_items={item_id: replace(item, nominal_id=777)}),
        r"feature item \d+\.nominal_id: .* which is not a sphere record":
            replace(document, feature_items={item_id: replace(item, type="sphere")}),
        r"feature nominal \d+\.definition_id: .* got None":
            replace(document, feature_nominals={nominal_id: replace(nominal, definition_id=None)}),
        r"feature measurement \d+\.item_id: .* got 555":
            replace(document, results=(replace(document.results[0], features=(
                replace(document.measured_features[0], item_id=555),)),)),
    }
    for n, (message, broken) in enumerate(cases.items()):
        with pytest.raises(InvalidInputError, match=message):
            write_qif(broken, tmp_path / f"broken{n}.qif")
        assert not (tmp_path / f"broken{n}.qif").exists()
    good = write_qif(document, tmp_path / "good.qif")  # the unbroken document is written and valid
    assert validate_qif(good) == ()


def test_a_size_tolerance_given_as_limits_is_written_as_limits(tmp_path: Path) -> None:
    geometry = FeatureGeometry(location=np.ones(3), diameter=20.004)
    ball = FeatureReport("sphere", "BALL", geometry, nominal=FeatureGeometry(location=np.ones(3), diameter=20.0),
                         internal_external="EXTERNAL", characteristics=(Characteristic(
                             id=0, type="spherical_diameter", value=20.004, nominal=20.0, status="PASS",
                             tolerance=Tolerance(max_value=20.01, min_value=19.99, defined_as_limit=True)),))
    _, path = _written(tmp_path, [ball], "limits.qif")
    back = read_qif(path)
    (size,) = back.characteristics
    assert size.tolerance.defined_as_limit is True
    _close((19.99, 20.01), size.tolerance.limits(size.nominal))
    assert back.results[0].inspection_status == "PASS" and back.definition_of(
        back.feature("BALL")).internal_external == "EXTERNAL"


_KINDS = ("circle", "cylinder", "sphere", "plane", "line", "point", "cone")


def _random_report(rng: np.random.Generator, kind: str, name: str, with_nominal: bool) -> FeatureReport:
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    nominal = {"location": rng.normal(scale=200.0, size=3)}
    if kind in ("circle", "plane", "point"):
        nominal["normal"] = axis
    if kind in ("cylinder", "line", "cone"):
        nominal["direction"] = axis
    if kind in ("circle", "cylinder", "sphere", "cone"):
        nominal["diameter"] = float(rng.uniform(0.5, 80.0))
    if kind == "cone":
        nominal["half_angle"] = float(rng.uniform(0.05, 1.2))
    actual = {key: value + rng.normal(scale=1e-3, size=np.shape(value)) for key, value in nominal.items()}
    for key in ("normal", "direction"):
        if key in actual:
            actual[key] = actual[key] / np.linalg.norm(actual[key])
    side = str(rng.choice(["INTERNAL", "EXTERNAL", "NOT_APPLICABLE"])) if kind in (
        "circle", "cylinder", "sphere", "cone") and with_nominal else None
    return FeatureReport(kind, name, FeatureGeometry(**actual), nominal=FeatureGeometry(**nominal) if with_nominal
                         else None, internal_external=side)


@settings(max_examples=12, deadline=None, derandomize=True)
@given(kinds=st.lists(st.sampled_from(_KINDS), min_size=1, max_size=5),
       nominals=st.lists(st.booleans(), min_size=5, max_size=5), seed=st.integers(0, 2**31),
       unit=st.sampled_from(["mm", "inch"]))
def test_any_set_of_named_features_validates_and_reads_back(tmp_path_factory: pytest.TempPathFactory,
                                                            kinds: list[str], nominals: list[bool], seed: int,
                                                            unit: str) -> None:
    rng = np.random.default_rng(seed)
    reports = [_random_report(rng, kind, f"F {k} {kind}", nominals[k]) for k, kind in enumerate(kinds)]
    _, path = _written(tmp_path_factory.mktemp("any"), reports, "any.qif", unit)
    back = read_qif(path)
    assert [f.name for f in back.measured_features] == [r.name for r in reports]
    assert [i.name for i in back.feature_items.values()] == [r.name for r in reports if r.nominal is not None]
    for report, read in zip(reports, back.measured_features, strict=True):
        for name in ("location", "normal", "direction", "diameter", "half_angle"):
            _close(getattr(report.actual, name), getattr(read.actual, name))
        if report.nominal is None:
            assert back.nominal_of(read) is None
            continue
        geometry, definition = back.nominal_of(read).geometry, back.definition_of(read)
        for name in ("location", "normal", "direction"):
            _close(getattr(report.nominal, name), getattr(geometry, name))
        for name in ("diameter", "half_angle"):
            _close(getattr(report.nominal, name), getattr(definition, name))
        assert read.internal_external == report.internal_external


def test_every_refit_of_a_verification_goes_into_one_file_that_verifies_itself(sample: CmmDocument,
                                                                              tmp_path: Path) -> None:
    from pcmm_geo.cmm import verification_document, verify_document

    verification = verify_document(sample)
    refitted = [check for check in verification.features if check.refit_result is not None]
    assert [c.name for c in refitted] == ["DATUMA", "DATUMB", "CIRCLE1", "CIRCLE2", "POINT1", "POINT2", "POINT4",
                                          "CYL_1", "POINT6"]
    document = verification_document(sample, verification)
    path = write_qif(document, tmp_path / "refits.qif")
    assert validate_qif(path) == ()
    back = read_qif(path)
    assert [f.name for f in back.measured_features] == [c.name for c in refitted]
    assert len(back.feature_items) == 9  # every refitted feature of the sample has a nominal
    for check, read in zip(refitted, back.measured_features, strict=True):
        refit, stated = check.refit_result, sample.feature(check.id)
        _close(refit.location, read.actual.location)
        _close(refit.diameter, read.actual.diameter)
        _close(refit.half_angle, read.actual.half_angle)
        _close(sample.nominal_of(stated).geometry.location, back.nominal_of(read).geometry.location)
        _close(sample.definition_of(stated).diameter, back.definition_of(read).diameter)
        _close(sample.points_of(stated).points, back.points_of(read).points)
        if read.type in ("circle", "cylinder"):
            assert read.internal_external == refit.compensation.side.upper() == "INTERNAL"
    _close(12.0, back.characteristics_of(back.feature("CIRCLE1"))[0].nominal)
    again = verify_document(back)  # the refits of the written points are the actuals written
    assert (again.verified, again.agrees, again.summary()["disagree"]) == (9, True, 0)
    assert verification.agrees is False  # (the sample's own actuals disagree with their refits in 5 features)


def test_refitted_features_sharing_a_name_are_told_apart_by_their_id(sample: CmmDocument, tmp_path: Path) -> None:
    from pcmm_geo.cmm import verification_document, verify_document

    results = sample.results[0]
    renamed = tuple(replace(f, name="HOLE") if f.name in ("CIRCLE1", "CIRCLE2") else f for f in results.features)
    twins = replace(sample, results=(replace(results, features=renamed),))
    document = verification_document(twins, verify_document(twins))
    names = [f.name for f in document.measured_features]
    assert "HOLE_261" in names and "HOLE_509" in names and "HOLE" not in names
    assert validate_qif(write_qif(document, tmp_path / "twins.qif")) == ()
