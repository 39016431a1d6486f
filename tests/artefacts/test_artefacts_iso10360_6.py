"""ISO 10360-6 harness: deviations, verdicts, report, readers and pcmm_geo's own fits."""

from __future__ import annotations

import json
import math
from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.artefacts import (
    ElementParameters,
    HarnessMpe,
    ReferenceCase,
    cases_from_reference_data,
    compare_results,
    fit_with_pcmm_geo,
    load_reference_cases,
    read_element_parameters,
)
from pcmm_geo.errors import FileFormatError, InvalidInputError


def _unit(v: list[float]) -> np.ndarray:
    arr = np.asarray(v, dtype=float)
    return arr / np.linalg.norm(arr)


def test_deviation_kinds_by_hand() -> None:
    n = _unit([0.0, 0.6, 0.8])
    plane = ReferenceCase("pl", ElementParameters("plane", np.array([1.0, 2.0, 3.0]), n))
    tilt = 1e-7
    tilted = _unit([0.0, math.cos(math.atan2(0.8, 0.6) + tilt), math.sin(math.atan2(0.8, 0.6) + tilt)])
    shifted = ElementParameters("plane", np.array([1.0, 2.0, 3.0]) + 2e-6 * n, tilted)
    row = compare_results([plane], {"pl": shifted}, HarnessMpe(1e-5, 1e-6, 1e-5, 1e-6)).cases[0]
    assert row.position == pytest.approx(2e-6, rel=1e-6)
    assert row.orientation == pytest.approx(tilt, rel=1e-6)
    assert math.isnan(row.size) and math.isnan(row.angle) and row.passed

    # a cylinder given by another point on its axis and the opposite direction is the same cylinder
    cyl = ReferenceCase("cy", ElementParameters("cylinder", np.zeros(3), np.array([0.0, 0.0, 1.0]), size=5.0))
    same = ElementParameters("cylinder", np.array([0.0, 0.0, 42.0]), np.array([0.0, 0.0, -1.0]), size=5.0 + 3e-7)
    row = compare_results([cyl], {"cy": same}, HarnessMpe(1e-9, 1e-9, 1e-6, 1e-9)).cases[0]
    assert row.position == pytest.approx(0.0, abs=1e-12) and row.orientation == pytest.approx(0.0, abs=1e-12)
    assert row.size == pytest.approx(3e-7, rel=1e-6) and row.passed

    # a cone by apex (radius 0) against the same cone by a point 10 mm up its axis (radius 10 tan a)
    half = 0.3
    ref = ElementParameters("cone", np.array([0.0, 0.0, 10.0]), np.array([0.0, 0.0, 1.0]), size=10 * math.tan(half),
                            half_angle=half)
    apex_form = ElementParameters("cone", np.zeros(3), np.array([0.0, 0.0, 1.0]), size=0.0, half_angle=half + 2e-8)
    row = compare_results([ReferenceCase("co", ref)], {"co": apex_form}, HarnessMpe(1e-9, 1e-9, 1e-6, 1e-7)).cases[0]
    assert row.position == pytest.approx(0.0, abs=1e-12) and row.orientation == pytest.approx(0.0, abs=1e-12)
    assert row.angle == pytest.approx(2e-8, rel=1e-6)
    assert row.size == pytest.approx(10 * (math.tan(half + 2e-8) - math.tan(half)), rel=1e-5)
    # a cone axis pointing the wrong way (towards the apex) fails orientation
    flipped = ElementParameters("cone", np.zeros(3), np.array([0.0, 0.0, -1.0]), size=0.0, half_angle=half)
    row = compare_results([ReferenceCase("co", ref)], {"co": flipped}).cases[0]
    assert row.orientation == pytest.approx(math.pi, abs=1e-12) and not row.passed


def test_anchor_uses_data_centroid() -> None:
    # reference line through the origin along x; data centred at x = 100; test line turned by 1e-6 rad about
    # the origin: at the anchor (100, 0, 0) it is 1e-4 mm away
    points = np.array([[90.0, 0, 0], [110.0, 0, 0]])
    case = ReferenceCase("ln", ElementParameters("line", np.zeros(3), np.array([1.0, 0, 0])), points)
    test = ElementParameters("line", np.zeros(3), np.array([math.cos(1e-6), math.sin(1e-6), 0.0]))
    row = compare_results([case], {"ln": test}, HarnessMpe(1e-3, 1e-5, 1e-3, 1e-3)).cases[0]
    assert row.position == pytest.approx(100 * math.sin(1e-6), rel=1e-6)


def test_missing_and_wrong_element_fail() -> None:
    case = ReferenceCase("s", ElementParameters("sphere", np.zeros(3), size=1.0))
    report = compare_results([case, ReferenceCase("t", case.reference)],
                             {"s": ElementParameters("plane", np.zeros(3), np.array([0, 0, 1.0]))})
    assert not report.passed and report.n_failed == 2
    assert report.cases[0].note == "result is a plane"
    assert report.cases[1].note == "missing in results"
    text = report.to_markdown()
    assert "| s | sphere |" in text and "FAIL" in text and "0/2 cases" in text


def test_example_files_and_readers(tmp_path: Path) -> None:
    examples = files("pcmm_geo") / "data/examples"
    cases = load_reference_cases(Path(str(examples / "iso10360_6_reference.csv")))
    results = read_element_parameters(Path(str(examples / "iso10360_6_results.json")))
    report = compare_results(cases, results, HarnessMpe(1e-6, 1e-6, 1e-6, 1e-6))
    verdicts = {c.name: c.passed for c in report.cases}
    # the example's cone is 4 um too large at its reference station, the rest agree within 2e-7 mm
    assert verdicts == {"plane_1": True, "sphere_1": True, "cylinder_1": True, "cone_1": False}
    cone = next(c for c in report.cases if c.name == "cone_1")
    assert cone.size == pytest.approx(4e-6, rel=1e-6)

    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps([{"name": "x", "element": "cube", "location": [0, 0, 0]}]))
    with pytest.raises(FileFormatError, match="element"):
        read_element_parameters(bad)
    broken = tmp_path / "broken.json"
    broken.write_text("[{")
    with pytest.raises(FileFormatError, match=r"broken.json:2: expected JSON"):
        read_element_parameters(broken)
    empty_dir = tmp_path / "nothing"
    empty_dir.mkdir()
    with pytest.raises(FileFormatError, match="no NIST reference pairs"):
        load_reference_cases(empty_dir)
    with pytest.raises(InvalidInputError, match="direction"):
        ElementParameters("plane", np.zeros(3))


def _write_pair(folder: Path, name: str, points: np.ndarray, fit_numbers: list[float]) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    body = "\n".join(f"{x:.12f}\t{y:.12f}\t{z:.12f}" for x, y, z in points)
    (folder / f"{name}.ds").write_text(f"{len(points)}\n{body}\n")
    (folder / f"{name}.fit").write_text("\n".join(repr(float(v)) for v in fit_numbers) + "\n")


def _frame(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = helper - (helper @ axis) * axis
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(axis, e1)


def test_pcmm_geo_passes_at_1e9(tmp_path: Path) -> None:
    """pcmm_geo's own fits on exact-data reference pairs in NIST format (known solutions by construction)."""
    rng = np.random.default_rng(6)
    root = tmp_path / "pairs"
    # plane
    n = _unit([0.2, -0.3, 0.93])
    e1, e2 = _frame(n)
    centre = np.array([120.0, -35.0, 410.0])
    uv = rng.uniform(-40, 40, (30, 2))
    _write_pair(root / "Plane", "pla", centre + uv[:, :1] * e1 + uv[:, 1:] * e2, [*centre, *n])
    # sphere, a 60 deg cap (partial feature)
    c, r = np.array([-50.0, 300.0, 20.0]), 12.5
    theta = rng.uniform(0, math.radians(60), 40)
    phi = rng.uniform(0, 2 * math.pi, 40)
    dirs = np.c_[np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)]
    _write_pair(root / "Sphere", "sph", c + r * dirs, [*c, 2 * r])
    # cylinder
    axis = _unit([0.1, 0.95, 0.2])
    e1, e2 = _frame(axis)
    base = np.array([10.0, 20.0, 30.0])
    t = rng.uniform(-30, 30, (50, 1))
    ang = rng.uniform(0, 2 * math.pi, (50, 1))
    _write_pair(root / "Cylinder", "cyl", base + t * axis + 8.0 * (np.cos(ang) * e1 + np.sin(ang) * e2),
                [*base, *axis, 16.0])
    # line
    d = _unit([1.0, 2.0, -0.5])
    p0 = np.array([5.0, 5.0, 5.0])
    _write_pair(root / "Line3d", "lin", p0 + rng.uniform(-50, 50, (20, 1)) * d, [*p0, *d])
    # cone: apex at A, half angle 0.4 rad; NIST gives a point 20 mm up the axis and the orthogonal distance
    apex, axis, half = np.array([-5.0, 7.0, 100.0]), _unit([0.3, -0.2, 1.0]), 0.4
    e1, e2 = _frame(axis)
    s = rng.uniform(10, 40, (60, 1))
    ang = rng.uniform(0, 2 * math.pi, (60, 1))
    pts = apex + s * axis + s * math.tan(half) * (np.cos(ang) * e1 + np.sin(ang) * e2)
    station = apex + 20.0 * axis
    _write_pair(root / "Cone", "con", pts, [*station, *axis, 20.0 * math.tan(half) * math.cos(half),
                                            math.degrees(2 * half)])
    cases = load_reference_cases(root)
    assert sorted(c.name for c in cases) == ["con", "cyl", "lin", "pla", "sph"]
    report = compare_results(cases, fit_with_pcmm_geo(cases), HarnessMpe(1e-9, 1e-9, 1e-9, 1e-9))
    assert report.passed, report.to_markdown()
    assert report.max_deviation("position") < 1e-9


def test_pcmm_geo_passes_null_space_reference_data() -> None:
    """Null-space data sets (pcmm_geo.fit.reference) have known Gaussian solutions."""
    from pcmm_geo.fit.reference import make_reference_data

    sets = [
        make_reference_data("line3d", form=2e-3, offset=300.0, rng=1),
        make_reference_data("plane", form=2e-3, offset=300.0, rng=2),
        make_reference_data("circle2d", form=2e-3, arc=math.pi, offset=300.0, rng=3),
        make_reference_data("circle3d_projected", form=2e-3, offset=300.0, rng=4),
        make_reference_data("sphere", form=2e-3, cap=math.pi / 2, offset=300.0, rng=5),
        make_reference_data("cylinder", form=2e-3, offset=300.0, rng=6),
        make_reference_data("cone", form=2e-3, offset=300.0, rng=7),
        make_reference_data("torus", form=2e-3, offset=300.0, rng=8),
    ]
    cases = cases_from_reference_data(sets)
    report = compare_results(cases, fit_with_pcmm_geo(cases), HarnessMpe(1e-9, 1e-9, 1e-9, 1e-9))
    assert report.passed, report.to_markdown()
    # a deliberately wrong result is caught
    wrong = dict(fit_with_pcmm_geo(cases[4:5]))
    name = cases[4].name
    bad = ElementParameters("sphere", wrong[name].location, size=wrong[name].size + 2e-9)
    assert not compare_results(cases[4:5], {name: bad}).passed


def test_nist_reference_pairs(data_dir: Path) -> None:
    cases = load_reference_cases(data_dir / "nist")
    assert len(cases) >= 37
    report = compare_results(cases, fit_with_pcmm_geo(cases), HarnessMpe(1e-9, 1e-9, 1e-9, 1e-9))
    assert report.passed, report.to_markdown()
