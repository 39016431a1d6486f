"""QIF writer: schema-valid QIF 3.0, exact round trip (1e-12 mm), inch files, refusals."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.errors import InvalidInputError, OutputExistsError
from pcmm_geo.io.cmm import (
    Characteristic,
    CmmDocument,
    FeatureGeometry,
    FeatureReport,
    MeasuredPointSet,
    Tolerance,
    read_qif,
    results_document,
    validate_qif,
    write_qif,
)

DATA = Path(__file__).resolve().parents[2] / "data" / "qif"
FORM = {"circle": "circularity", "cylinder": "cylindricity", "sphere": "sphericity", "plane": "flatness",
        "line": "straightness", "cone": "conicity"}


def _unit(vector: list[float]) -> np.ndarray:
    vector = np.asarray(vector, dtype=float)
    return vector / np.linalg.norm(vector)


def _reports(seed: int = 3) -> list[FeatureReport]:
    """One feature of each type with awkward numbers: 17 significant digits, tiny and large values."""
    rng = np.random.default_rng(seed)
    reports = []
    for kind in ("circle", "cylinder", "sphere", "plane", "line", "point", "cone"):
        location = rng.normal(scale=300.0, size=3)
        axis = _unit(rng.normal(size=3))
        actual = {"location": location + 1e-4 * rng.normal(size=3)}
        nominal = {"location": location}
        if kind in ("circle", "plane", "point"):
            actual["normal"], nominal["normal"] = _unit(axis + 1e-5), axis
        if kind in ("cylinder", "line", "cone"):
            actual["direction"], nominal["direction"] = _unit(axis + 1e-5), axis
        if kind in ("circle", "cylinder", "sphere", "cone"):
            nominal["diameter"] = float(rng.uniform(1, 100))
            actual["diameter"] = nominal["diameter"] + float(rng.normal(scale=1e-3))
        if kind == "cone":
            actual["half_angle"], nominal["half_angle"] = 0.3 + 1e-7, 0.3
        if kind == "line":
            actual["length"] = 57.123456789012345
        if kind != "point":
            actual["form"] = float(rng.uniform(1e-7, 1e-2))
        n = 40
        points = MeasuredPointSet(
            None, rng.normal(scale=50.0, size=(n, 3)) + location,
            normals=np.array([_unit(v) for v in rng.normal(size=(n, 3))]),
            compensated=bool(kind != "sphere") if kind != "plane" else None,
            compensated_per_point=(np.arange(n) % 2 == 0) if kind == "plane" else None,
            probe_radius=1.4999999999999998 if kind != "cone" else None,
            probe_radii=rng.uniform(0.5, 2.5, size=n) if kind == "cone" else None)
        characteristics = []
        if "diameter" in actual:
            characteristics.append(Characteristic(
                id=0, type="spherical_diameter" if kind == "sphere" else "diameter", value=actual["diameter"],
                nominal=nominal["diameter"], tolerance=Tolerance(max_value=0.01, min_value=-0.02),
                status="PASS", uncertainty=1.2345678901234567e-4))
        if kind in FORM:
            characteristics.append(Characteristic(
                id=0, type=FORM[kind], value=actual["form"], tolerance=Tolerance(value=0.005), status="INDETERMINATE",
                uncertainty=3e-6, zone_shape="diametrical" if kind == "line" else None))
        reports.append(FeatureReport(
            type=kind, name=f"{kind.upper()}_1", actual=FeatureGeometry(**actual, uncertainty={"location": 2e-4}),
            nominal=FeatureGeometry(**nominal), points=points, characteristics=tuple(characteristics),
            internal_external={"circle": "INTERNAL", "cylinder": "EXTERNAL", "cone": "INTERNAL"}.get(kind),
            substitute_algorithm="MINMAX" if kind == "plane" else "LEASTSQUARES"))
    reports.append(FeatureReport("sphere", "BARE_SPHERE", FeatureGeometry(location=np.zeros(3), diameter=5.0),
                                 points=MeasuredPointSet(None, rng.normal(size=(5, 3)), compensated=True)))
    return reports


def _assert_same(written: CmmDocument, read: CmmDocument, tolerance: float = 1e-12) -> None:
    def close(a: object, b: object) -> None:
        if a is None or b is None:
            assert a is None and b is None
        else:
            np.testing.assert_allclose(np.asarray(b, dtype=float), np.asarray(a, dtype=float), rtol=0,
                                       atol=tolerance)

    def geometry(a: FeatureGeometry, b: FeatureGeometry) -> None:
        for name in ("location", "normal", "direction", "diameter", "length", "half_angle", "form"):
            close(getattr(a, name), getattr(b, name))
        assert set(a.uncertainty) == set(b.uncertainty)
        for name in a.uncertainty:
            close(a.uncertainty[name], b.uncertainty[name])

    assert len(read.measured_features) == len(written.measured_features)
    for a, b in zip(written.measured_features, read.measured_features, strict=True):
        assert (a.id, a.type, a.name, a.internal_external, a.substitute_algorithm) == (
            b.id, b.type, b.name, b.internal_external, b.substitute_algorithm)
        geometry(a.actual, b.actual)
        nominal_a, nominal_b = written.nominal_of(a), read.nominal_of(b)
        assert (nominal_a is None) == (nominal_b is None)
        if nominal_a is not None:
            for name in ("location", "normal", "direction"):
                close(getattr(nominal_a.geometry, name), getattr(nominal_b.geometry, name))
            for name in ("diameter", "half_angle"):
                close(getattr(written.definition_of(a), name), getattr(read.definition_of(b), name))
        points_a, points_b = written.points_of(a), read.points_of(b)
        close(points_a.points, points_b.points)
        close(points_a.normals, points_b.normals)
        close(points_a.probe_radius, points_b.probe_radius)
        close(points_a.probe_radii, points_b.probe_radii)
        assert points_a.compensated == points_b.compensated
        if points_a.compensated_per_point is not None:
            assert points_b.compensated_per_point.tolist() == points_a.compensated_per_point.tolist()
    for a, b in zip(written.characteristics, read.characteristics, strict=True):
        assert (a.id, a.type, a.name, a.status, a.zone_shape, a.feature_measurement_ids, a.feature_item_ids) == (
            b.id, b.type, b.name, b.status, b.zone_shape, b.feature_measurement_ids, b.feature_item_ids)
        for name in ("value", "nominal", "uncertainty"):
            close(getattr(a, name), getattr(b, name))
        for name in ("max_value", "min_value", "value"):
            close(getattr(a.tolerance, name), getattr(b.tolerance, name))


@pytest.mark.parametrize("unit", ["mm", "inch"])
def test_written_files_validate_and_read_back_to_1e_12_mm(tmp_path: Path, unit: str) -> None:
    document = results_document(_reports())
    path = write_qif(document, tmp_path / f"results_{unit}.qif", linear_unit=unit)
    assert validate_qif(path) == ()
    back = read_qif(path)
    assert back.problems == () and back.units.linear_unit == unit
    _assert_same(document, back)
    assert {c.status for c in back.characteristics} == {"PASS", "INDETERMINATE"}
    assert back.results[0].inspection_status == "UNKNOWN"  # no failure, but not every verdict proven


def test_a_read_document_writes_back_unchanged(tmp_path: Path) -> None:
    first = write_qif(results_document(_reports(seed=11)), tmp_path / "first.qif", linear_unit="inch")
    document = read_qif(first)
    second = write_qif(document, tmp_path / "second.qif")
    assert validate_qif(second) == ()
    _assert_same(document, read_qif(second))


def test_numbers_are_written_in_the_schema_types(tmp_path: Path) -> None:
    """xs:decimal takes no exponent; xs:double keeps the shortest round-trip digits."""
    geometry = FeatureGeometry(location=np.array([1e-20, -3e-300, 1.0]), diameter=1.25e-7, form=1e-12,
                               uncertainty={"diameter": 5e-9})
    tiny = FeatureReport("sphere", "TINY", geometry)
    path = write_qif(results_document([tiny]), tmp_path / "tiny.qif")
    text = path.read_text(encoding="utf-8")
    assert "<Diameter combinedUncertainty=\"0.000000005\">0.000000125</Diameter>" in text
    assert "<Location>1e-20 -3e-300 1.0</Location>" in text
    assert validate_qif(path) == ()
    sphere = read_qif(path).feature("TINY")
    assert sphere.actual.location.tolist() == [1e-20, -3e-300, 1.0]
    assert (sphere.actual.diameter, sphere.actual.form, sphere.actual.uncertainty) == (1.25e-7, 1e-12,
                                                                                       {"diameter": 5e-9})


def test_the_validator_finds_what_is_wrong(tmp_path: Path) -> None:
    path = write_qif(results_document(_reports()[:1]), tmp_path / "ok.qif")
    broken = tmp_path / "broken.qif"
    broken.write_text(path.read_text(encoding="utf-8").replace("<InternalExternal>INTERNAL</InternalExternal>", ""),
                      encoding="utf-8")
    errors = validate_qif(broken)
    assert len(errors) == 1 and "Expected is one of" in errors[0] and "InternalExternal" in errors[0]
    assert errors[0].startswith("line ")
    with pytest.raises(InvalidInputError, match=r"QIFDocument\.xsd"):
        validate_qif(path, tmp_path)


def test_the_public_samples_validate() -> None:
    for name in ("QIF_PTS_SAMPLE.QIF", "WIDGET_QIF_RESULTS.QIF", "SheetMetal_QIF_Results_6_samples.QIF"):
        assert validate_qif(DATA / "samples" / name) == ()


def test_a_file_is_not_overwritten_unless_asked(tmp_path: Path) -> None:
    document = results_document(_reports()[:1])
    path = write_qif(document, tmp_path / "once.qif")
    before = path.read_bytes()
    with pytest.raises(OutputExistsError):
        write_qif(document, path)
    assert path.read_bytes() == before
    write_qif(document, path, overwrite=True, qpid="12345678-1234-1234-1234-123456789abc")
    assert "<QPId>12345678-1234-1234-1234-123456789abc</QPId>" in path.read_text(encoding="utf-8")


def test_what_the_writer_refuses(tmp_path: Path) -> None:
    circle = _reports()[0]
    with pytest.raises(InvalidInputError, match="torus"):
        results_document([FeatureReport("torus", "T", circle.actual)])
    with pytest.raises(InvalidInputError, match="a circle nominal with location, normal, diameter"):
        results_document([FeatureReport("circle", "C", circle.actual, nominal=FeatureGeometry(location=np.zeros(3)))])
    with pytest.raises(InvalidInputError, match="QIF keeps the material side in the feature definition"):
        results_document([FeatureReport("circle", "C", circle.actual, internal_external="INTERNAL")])
    with pytest.raises(InvalidInputError, match="one of INTERNAL, EXTERNAL, NOT_APPLICABLE"):
        results_document([FeatureReport("circle", "C", circle.actual, nominal=circle.nominal, internal_external="in")])
    no_zone = FeatureReport("plane", "P", FeatureGeometry(location=np.zeros(3), normal=np.array([0.0, 0, 1])),
                            characteristics=(Characteristic(id=0, type="flatness", value=0.01),))
    with pytest.raises(InvalidInputError, match="a tolerance zone value"):
        write_qif(results_document([no_zone]), tmp_path / "a.qif")
    line = FeatureReport("line", "L", FeatureGeometry(location=np.zeros(3), direction=np.array([1.0, 0, 0])),
                         characteristics=(Characteristic(id=0, type="straightness", value=0.01,
                                                         tolerance=Tolerance(value=0.02)),))
    with pytest.raises(InvalidInputError, match="'diametrical'"):
        write_qif(results_document([line]), tmp_path / "b.qif")
    unknown_flag = FeatureReport("sphere", "S", FeatureGeometry(location=np.zeros(3), diameter=1.0),
                                 points=MeasuredPointSet(None, np.zeros((4, 3))))
    with pytest.raises(InvalidInputError, match="QIF requires the flag"):
        write_qif(results_document([unknown_flag]), tmp_path / "c.qif")
    with pytest.raises(InvalidInputError, match="a finite number"):
        write_qif(results_document([FeatureReport("sphere", "S", FeatureGeometry(location=np.zeros(3),
                                                                                 diameter=math.nan))]),
                  tmp_path / "d.qif")
    assert not any(tmp_path.glob("*.qif"))  # nothing half-written is left


def test_the_pts_sample_characteristics_are_not_all_writable() -> None:
    document = read_qif(DATA / "samples" / "QIF_PTS_SAMPLE.QIF")
    with pytest.raises(InvalidInputError, match="'linear_coordinate'"):
        write_qif(document, DATA / "never_written.qif")
    assert not (DATA / "never_written.qif").exists()


def test_missing_lxml_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    import sys

    from pcmm_geo.errors import MissingDependencyError
    from pcmm_geo.io.cmm.qif import schema

    schema._schema.cache_clear()
    for module in [m for m in sys.modules if m == "lxml" or m.startswith("lxml.")]:
        monkeypatch.delitem(sys.modules, module)
    monkeypatch.setitem(sys.modules, "lxml", None)
    try:
        with pytest.raises(MissingDependencyError, match=r"pip install 'pcmm_geo\[qif\]'") as caught:
            validate_qif(DATA / "samples" / "QIF_PTS_SAMPLE.QIF")
        assert (caught.value.package, caught.value.extra) == ("lxml", "qif")
    finally:
        schema._schema.cache_clear()
