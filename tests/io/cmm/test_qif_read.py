"""QIF 3.0 reader: the public qif-community samples, units, strictness about what it uses."""

from __future__ import annotations

import math
import re
import tracemalloc
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.errors import FileFormatError, QifError
from pcmm_geo.io.cmm import read_qif

SAMPLES = Path(__file__).resolve().parents[2] / "data" / "qif" / "samples"
PTS_SAMPLE = SAMPLES / "QIF_PTS_SAMPLE.QIF"
QIF = "{http://qifstandards.org/xsd/qif3}"


def _points_by_stdlib(path: Path) -> dict[int, np.ndarray]:
    """Every MeasuredPointSet of a trusted test file, read independently with the standard library."""
    root = ElementTree.parse(path).getroot()
    return {int(node.get("id")): np.array(node.find(QIF + "Points").text.split(), dtype=float).reshape(-1, 3)
            for node in root.iter(QIF + "MeasuredPointSet")}


def _edited(tmp_path: Path, old: str, new: str, count: int = 1) -> Path:
    text = PTS_SAMPLE.read_text(encoding="utf-8")
    assert text.count(old) >= count, old
    path = tmp_path / "edited.qif"
    path.write_text(text.replace(old, new, count), encoding="utf-8")
    return path


# ---------------------------------------------------------------------------------------------
# QIF_PTS_SAMPLE.QIF: three 219-point circles, an 18-point cylinder, Compensated=false


def test_pts_sample_circles_and_cylinder_with_their_points() -> None:
    document = read_qif(PTS_SAMPLE)
    assert document.version == "3.0.0" and document.format == "qif"
    assert (document.units.linear_unit, document.units.mm_per_linear_unit) == ("mm", 1.0)
    assert document.units.rad_per_angular_unit == pytest.approx(math.pi / 180, rel=1e-15)
    circles = [f for f in document.measured_features if f.type == "circle"]
    assert [(f.id, f.name, f.internal_external) for f in circles] == [
        (28, "DATUMB", "NOT_APPLICABLE"), (261, "CIRCLE1", "INTERNAL"), (509, "CIRCLE2", "INTERNAL")]
    assert [f.actual.diameter for f in circles] == [12.091599179226, 12.095569950907, 12.068425921099]
    cylinder = document.feature("CYL_1")
    assert cylinder.type == "cylinder" and cylinder.actual.diameter == 30.11094079809
    assert cylinder.actual.location.tolist() == [-19.460634807052, 19.61932106672, -7.0]
    assert cylinder.actual.direction.tolist() == [0.00027596187700008, -0.00120213638300035, -0.99999923935629]
    truth = _points_by_stdlib(PTS_SAMPLE)
    for feature, set_id, count in ((circles[0], 29, 219), (circles[1], 262, 219), (circles[2], 510, 219),
                                   (cylinder, 797, 18)):
        points = document.points_of(feature)
        assert (points.id, len(points), points.compensated, points.normals) == (set_id, count, False, None)
        assert points.probe_radius == 2.49978271104
        np.testing.assert_array_equal(points.points, truth[set_id])
        assert not points.points.flags.writeable


def test_pts_sample_points_are_probe_centers_of_the_reported_internal_circles() -> None:
    """Independent truth: the CMM's own report. The probe-ball centres of an internal circle lie on a
    circle of radius D/2 - r_probe about the reported centre, in the reported plane."""
    document = read_qif(PTS_SAMPLE)
    for name in ("CIRCLE1", "CIRCLE2"):
        feature = document.feature(name)
        points = document.points_of(feature)
        offsets = points.points - feature.actual.location
        offsets -= np.outer(offsets @ feature.actual.normal, feature.actual.normal)
        radius = np.linalg.norm(offsets, axis=1).mean()
        assert radius == pytest.approx(feature.actual.diameter / 2 - points.probe_radius, abs=1e-8)


def test_pts_sample_ranges_singles_and_the_wrong_kind_of_reference() -> None:
    document = read_qif(PTS_SAMPLE)
    truth = _points_by_stdlib(PTS_SAMPLE)
    plane = document.feature("DATUMA")  # RangePointSetId range="3 8" of an 8-point set
    np.testing.assert_array_equal(document.points_of(plane).points, truth[12][2:8])
    line = document.feature(255)  # SinglePointSetId index 1 and 2 of set 256
    assert [(r.point_set_id, r.start, r.stop) for r in line.point_set_refs] == [(256, 0, 1), (256, 1, 2)]
    np.testing.assert_array_equal(document.points_of(line).points, truth[256])
    assert line.actual.direction is None and line.actual.normal is not None  # the file writes <Normal>, kept so
    assert document.points_of(document.feature("POINT3")) is None  # no PointList
    point5 = document.feature("POINT5")  # its PointList names 828, itself, not the point set 829
    assert point5.point_set_refs == () and document.points_of(point5) is None
    assert len(point5.problems) == 1 and "WholePointSetId 828 names a PointFeatureMeasurement" in point5.problems[0]
    assert document.problems == point5.problems


def test_pts_sample_characteristics_in_mm_and_radians() -> None:
    document = read_qif(PTS_SAMPLE)
    assert len(document.characteristics) == 27
    diameter = next(c for c in document.characteristics if c.name == "DIA_CIRCLE1")
    assert (diameter.type, diameter.value, diameter.nominal, diameter.status) == (
        "diameter", 12.095569950907, 12.0, "FAIL")
    assert diameter.tolerance.limits(diameter.nominal) == pytest.approx((11.95, 12.05), abs=1e-14)
    assert diameter.feature_measurement_ids == (261,) and diameter.feature_item_ids == (260,)
    flatness = next(c for c in document.characteristics if c.type == "flatness")
    assert (flatness.value, flatness.tolerance.value, flatness.status) == (0.00676025187, 0.01, "PASS")
    angle = next(c for c in document.characteristics if c.type == "angle_between")
    assert angle.quantity == "angular" and angle.nominal == pytest.approx(math.radians(40.0), rel=1e-13)
    # the file's +-2.864788975654 degrees is 0.05 rad
    assert angle.tolerance.max_value == pytest.approx(0.05, rel=1e-11)
    assert document.characteristics_of(document.feature("CIRCLE1"))[0].name == "X_CIRCLE1"


@pytest.mark.parametrize(("name", "features", "characteristics", "results"), [
    ("QIF_Results_Sample.QIF", 6, 13, 1),
    ("SheetMetal_QIF_Results_6_samples.QIF", 126, 228, 6),
    ("WIDGET_QIF_RESULTS.QIF", 19, 42, 1),
    ("testPython30.qif", 4, 7, 1),
    ("mitutoyo_results_serialized_pass_fail_sample.QIF", 0, 0, 1),
    ("Exploded_Results1.QIF", 0, 2, 1),
])
def test_other_public_result_samples(name: str, features: int, characteristics: int, results: int) -> None:
    document = read_qif(SAMPLES / name)
    assert (len(document.measured_features), len(document.characteristics), len(document.results)) == (
        features, characteristics, results)
    truth = ElementTree.parse(SAMPLES / name).getroot()
    statuses = [node.text.strip() for node in truth.iter(QIF + "CharacteristicStatusEnum")]
    assert [c.status for c in document.characteristics] == statuses


def test_widget_cylinders_and_external_references() -> None:
    widget = read_qif(SAMPLES / "WIDGET_QIF_RESULTS.QIF")
    cylinders = [f for f in widget.measured_features if f.type == "cylinder"]
    assert len(cylinders) == 6 and all(f.actual.diameter > 0 and f.actual.direction is not None for f in cylinders)
    exploded = read_qif(SAMPLES / "Exploded_Results1.QIF")  # items live in another document: recorded, not guessed
    assert [c.value for c in exploded.characteristics] == [25.008279671621, 0.251457258827]
    assert all(c.item_id is None for c in exploded.characteristics)
    assert any("external document 1" in p for p in exploded.problems)
    assert any("units not stated in the file" in p for p in exploded.problems) and not exploded.units.stated


# ---------------------------------------------------------------------------------------------
# strict about what it uses


def test_count_that_disagrees_with_the_points(tmp_path: Path) -> None:
    with pytest.raises(QifError) as fewer:
        read_qif(_edited(tmp_path, 'id="29" count="219"', 'id="29" count="220"'))
    assert fewer.value.qif_id in ("29", 29) and fewer.value.element.endswith("MeasuredPointSet/Points")
    assert "count 220 disagrees with the points: expected 660 numbers, got 657" in str(fewer.value)
    with pytest.raises(QifError, match="more than the 654 numbers stated") as more:
        read_qif(_edited(tmp_path, 'id="29" count="219"', 'id="29" count="218"'))
    assert more.value.line is not None and str(more.value).startswith(str(tmp_path / "edited.qif"))


def test_dangling_id_names_the_feature_and_element(tmp_path: Path) -> None:
    with pytest.raises(QifError, match="dangling id") as caught:
        read_qif(_edited(tmp_path, "<WholePointSetId>262</WholePointSetId>",
                         "<WholePointSetId>99999</WholePointSetId>"))
    error = caught.value
    assert error.qif_id == "261" and error.element.endswith("CircleFeatureMeasurement/PointList/WholePointSetId")
    assert "WholePointSetId 99999" in str(error)
    with pytest.raises(QifError, match="FeatureItemId 4242 is a dangling id"):
        read_qif(_edited(tmp_path, "<FeatureItemId>260</FeatureItemId>", "<FeatureItemId>4242</FeatureItemId>"))


@pytest.mark.parametrize("bad", ["-33.1.5", "nan", "inf", "1e999", "x"])
def test_non_numeric_coordinate(tmp_path: Path, bad: str) -> None:
    text = PTS_SAMPLE.read_text(encoding="utf-8")
    first = re.search(r'id="262" count="219">\s*<!--[^>]*-->\s*<Points>\s*(\S+)', text)
    path = tmp_path / "bad.qif"
    path.write_text(text[: first.start(1)] + bad + text[first.end(1):], encoding="utf-8")
    with pytest.raises(QifError, match=r"expected a (finite )?number") as caught:
        read_qif(path)
    line = text[: first.start(1)].count("\n") + 1
    assert (caught.value.qif_id, caught.value.line) == ("262", line)


def test_point_range_outside_its_set_and_non_unit_vectors(tmp_path: Path) -> None:
    with pytest.raises(QifError, match="points 3 to 9 lie outside MeasuredPointSet 12 of 8 points"):
        read_qif(_edited(tmp_path, 'range="3 8"', 'range="3 9"'))
    with pytest.raises(QifError, match="expected a unit vector") as caught:
        read_qif(_edited(tmp_path, "<Normal>0 0 -1</Normal>\n              <Diameter>12.095569950907",
                         "<Normal>0 0 -2</Normal>\n              <Diameter>12.095569950907"))
    assert caught.value.qif_id == "261"


def test_documents_that_are_not_qif_3(tmp_path: Path) -> None:
    with pytest.raises(QifError, match="expected a QIF 3 document"):
        read_qif(_edited(tmp_path, 'versionQIF="3.0.0"', 'versionQIF="2.9.1"'))
    with pytest.raises(QifError, match=re.escape("namespace 'http://qifstandards.org/xsd/qif2'")):
        read_qif(_edited(tmp_path, "http://qifstandards.org/xsd/qif3", "http://qifstandards.org/xsd/qif2"))
    other = tmp_path / "other.xml"
    other.write_text("<svg/>")
    with pytest.raises(QifError, match="expected a QIFDocument, got the XML element svg"):
        read_qif(other)
    with pytest.raises(FileFormatError, match="cannot be read"):
        read_qif(tmp_path / "missing.qif")
    with pytest.raises(FileFormatError, match="is a directory"):
        read_qif(tmp_path)


def test_duplicate_ids_and_unknown_units(tmp_path: Path) -> None:
    with pytest.raises(QifError, match="id 262 is used twice"):
        read_qif(_edited(tmp_path, '<MeasuredPointSet id="510"', '<MeasuredPointSet id="262"'))
    with pytest.raises(QifError, match=re.escape("unit 'mm' with the conversion factor 0.0254")):
        read_qif(_edited(tmp_path, "<Factor>0.001</Factor>", "<Factor>0.0254</Factor>"))
    with pytest.raises(QifError, match="unknown unit 'furlong'"):
        read_qif(_edited(tmp_path, "<UnitName>mm</UnitName>\n        <UnitConversion>\n"
                         "          <Factor>0.001</Factor>\n        </UnitConversion>", "<UnitName>furlong</UnitName>"))


# ---------------------------------------------------------------------------------------------
# units: inch files, degrees, point-set units, PMI units


def test_an_inch_file_is_read_in_mm(tmp_path: Path) -> None:
    """The sample with its lengths declared in inch: every length is 25.4 times the number written."""
    inch = _edited(tmp_path, "<UnitName>mm</UnitName>\n        <UnitConversion>\n          <Factor>0.001</Factor>",
                   "<UnitName>inch</UnitName>\n        <UnitConversion>\n          <Factor>0.0254</Factor>")
    as_mm, as_inch = read_qif(PTS_SAMPLE), read_qif(inch)
    assert (as_inch.units.linear_unit, as_inch.units.mm_per_linear_unit) == ("inch", 25.4)
    for name in ("CIRCLE1", "CYL_1", "DATUMA"):
        mm, inch_feature = as_mm.feature(name), as_inch.feature(name)
        np.testing.assert_allclose(inch_feature.actual.location, 25.4 * mm.actual.location, rtol=1e-15)
        if mm.actual.diameter is not None:
            assert inch_feature.actual.diameter == pytest.approx(25.4 * mm.actual.diameter, rel=1e-15)
        np.testing.assert_allclose(as_inch.points_of(inch_feature).points, 25.4 * as_mm.points_of(mm).points,
                                   rtol=1e-15)
        assert as_inch.points_of(inch_feature).probe_radius == pytest.approx(25.4 * 2.49978271104, rel=1e-15)
    direction_mm, direction_inch = as_mm.feature("CYL_1").actual.direction, as_inch.feature("CYL_1").actual.direction
    np.testing.assert_array_equal(direction_inch, direction_mm)  # unit vectors are not lengths
    dia = next(c for c in as_inch.characteristics if c.name == "DIA_CYL")
    assert dia.value == pytest.approx(25.4 * 30.11094079809, rel=1e-15)
    assert dia.tolerance.max_value == pytest.approx(25.4 * 0.05, rel=1e-15)


def _tiny(body: str, units: str = "") -> str:
    return ('<QIFDocument xmlns="http://qifstandards.org/xsd/qif3" versionQIF="3.0.0">' + units +
            '<Results><MeasurementResultsSet n="1"><MeasurementResults id="1">' + body +
            "</MeasurementResults></MeasurementResultsSet></Results></QIFDocument>")


def test_cone_angles_pmi_units_and_a_point_set_in_its_own_units(tmp_path: Path) -> None:
    units = ("<FileUnits><PrimaryUnits>"
             "<AngularUnit><SIUnitName>radian</SIUnitName><UnitName>degree</UnitName></AngularUnit>"
             "<LinearUnit><SIUnitName>meter</SIUnitName><UnitName>mm</UnitName></LinearUnit>"
             "<PMILinearUnit><SIUnitName>meter</SIUnitName><UnitName>inch</UnitName></PMILinearUnit>"
             "</PrimaryUnits></FileUnits>")
    body = ('<MeasuredFeatures n="1"><ConeFeatureMeasurement id="2"><FeatureName>C</FeatureName>'
            '<PointList n="1"><WholePointSetId>3</WholePointSetId></PointList>'
            "<Axis><AxisPoint>1 2 3</AxisPoint><Direction>0 0 1</Direction></Axis>"
            "<Diameter>10</Diameter><FullAngle>60</FullAngle></ConeFeatureMeasurement></MeasuredFeatures>"
            '<MeasuredPointSets n="1"><MeasuredPointSet id="3" count="2">'
            "<Units><LinearUnit><SIUnitName>meter</SIUnitName><UnitName>m</UnitName></LinearUnit></Units>"
            "<Points>0 0 0.001 0 0 0.002</Points><Normals>0 0 1 1 0 0</Normals>"
            "<Compensations>true true</Compensations><ProbeRadii>0.0005 0.0006</ProbeRadii></MeasuredPointSet>"
            "</MeasuredPointSets><MeasuredCharacteristics><CharacteristicMeasurements n=\"1\">"
            '<DiameterCharacteristicMeasurement id="4"><Status><CharacteristicStatusEnum>PASS'
            "</CharacteristicStatusEnum></Status><CharacteristicItemId>2</CharacteristicItemId>"
            '<Value combinedUncertainty="0.0001">0.5</Value></DiameterCharacteristicMeasurement>'
            "</CharacteristicMeasurements></MeasuredCharacteristics>")
    path = tmp_path / "cone.qif"
    path.write_text(_tiny(body, units), encoding="utf-8")
    document = read_qif(path)
    cone = document.feature("C")
    assert cone.actual.half_angle == pytest.approx(math.radians(30.0), rel=1e-15)
    points = document.points_of(cone)
    np.testing.assert_allclose(points.points, [[0, 0, 1.0], [0, 0, 2.0]], rtol=1e-15)
    assert points.compensated is True and points.compensated_per_point is None
    np.testing.assert_allclose(points.probe_radii, [0.5, 0.6], rtol=1e-15)
    assert points.normals.tolist() == [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]
    characteristic = document.characteristics[0]  # PMI units: inch for characteristics
    assert characteristic.value == pytest.approx(12.7, rel=1e-15)
    assert characteristic.uncertainty == pytest.approx(0.00254, rel=1e-15)
    assert characteristic.item_id is None and "not a CharacteristicItem" in document.problems[0]


def test_point_set_transform_maps_points_into_the_common_frame(tmp_path: Path) -> None:
    """TranformId names a transform X = R x + O (R's columns: XDirection, YDirection, ZDirection)."""
    transforms = ('<Transforms n="1"><Transform id="9"><Rotation><XDirection>0 1 0</XDirection>'
                  "<YDirection>-1 0 0</YDirection><ZDirection>0 0 1</ZDirection></Rotation>"
                  "<Origin>10 20 30</Origin></Transform></Transforms>")
    body = ('<MeasuredFeatures n="1"><PointFeatureMeasurement id="2"><FeatureName>P</FeatureName>'
            '<PointList n="1"><WholePointSetId>3</WholePointSetId></PointList><Location>0 0 0</Location>'
            '</PointFeatureMeasurement></MeasuredFeatures><MeasuredPointSets n="1">'
            '<MeasuredPointSet id="3" count="1"><TranformId>9</TranformId><Points>1 2 3</Points>'
            "<Normals>1 0 0</Normals><Compensated>true</Compensated></MeasuredPointSet></MeasuredPointSets>")
    units = "<FileUnits><PrimaryUnits><LinearUnit><SIUnitName>meter</SIUnitName><UnitName>inch</UnitName>" \
            "</LinearUnit></PrimaryUnits></FileUnits>"
    text = _tiny(body, units).replace("<Results>", transforms + "<Results>")
    path = tmp_path / "moved.qif"
    path.write_text(text, encoding="utf-8")
    document = read_qif(path)
    point = document.feature("P")
    stored = document.points_of(point, frame="stored")
    np.testing.assert_allclose(stored.points, [[25.4, 50.8, 76.2]], rtol=1e-15)
    common = document.points_of(point)
    np.testing.assert_allclose(common.points, [[254.0 - 50.8, 508.0 + 25.4, 762.0 + 76.2]], rtol=1e-15)
    np.testing.assert_allclose(common.normals, [[0.0, 1.0, 0.0]], atol=1e-16)
    np.testing.assert_allclose(document.transforms[9].matrix @ [25.4, 50.8, 76.2, 1.0],
                               [*common.points[0], 1.0], rtol=1e-15)


@pytest.mark.slow
def test_a_large_point_set_is_held_once(tmp_path: Path) -> None:
    """Points stream into one preallocated array: peak memory stays near the array itself, not the text
    (the text of 200 000 points is ~12 MB, the array 4.8 MB; a tree of strings would need several times both)."""
    rng = np.random.default_rng(7)
    n = 200_000
    points = rng.normal(scale=100.0, size=(n, 3))
    path = tmp_path / "large.qif"
    with open(path, "w", encoding="utf-8") as stream:
        stream.write(_tiny("").split("</MeasurementResults>")[0])
        stream.write(f'<MeasuredPointSets n="1"><MeasuredPointSet id="2" count="{n}"><Points>')
        np.savetxt(stream, points, fmt="%.17g")
        stream.write("</Points><Compensated>true</Compensated></MeasuredPointSet></MeasuredPointSets>")
        stream.write("</MeasurementResults></MeasurementResultsSet></Results></QIFDocument>")
    tracemalloc.start()
    try:
        document = read_qif(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    np.testing.assert_array_equal(document.point_sets[2].points, points)
    assert peak < points.nbytes + 12 * 2**20, peak
    assert path.stat().st_size > 2 * points.nbytes  # the text alone would have exceeded the bound
