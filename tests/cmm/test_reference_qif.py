"""The second opinion and the QIF output against the library's own reference data wrapped in QIF.

The null-space generator gives surface points whose least-squares element is known exactly.  Each
set is written as a QIF results file the way a CMM would: the known element as the CMM's actuals,
the points as probe-ball centres (``Compensated=false``, ``ProbeRadius``) or as surface points
(``Compensated=true``), the material side stated (``INTERNAL``/``EXTERNAL``) or ``NOT_APPLICABLE``
with a nominal size, in mm or in inch.  ``verify`` must refit the known element to 1e-9 mm and
agree; a reported diameter 1 um off must disagree.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.cmm import fit_results_document, verify_qif
from pcmm_geo.fit import fit_circle, fit_cone, fit_cylinder, fit_plane, fit_sphere
from pcmm_geo.fit.reference import make_reference_data
from pcmm_geo.io.cmm import (
    FeatureGeometry,
    FeatureReport,
    MeasuredPointSet,
    read_qif,
    results_document,
    validate_qif,
    write_qif,
)

R_PROBE = 1.0


def _radial(points: np.ndarray, centre: np.ndarray, axis: np.ndarray | None = None) -> np.ndarray:
    rel = points - centre
    if axis is not None:
        rel = rel - np.outer(rel @ axis, axis)
    return rel / np.linalg.norm(rel, axis=1, keepdims=True)


def _case(kind: str, side: str) -> tuple[np.ndarray, np.ndarray, FeatureGeometry]:
    """Surface points, their outward normals (out of the material) and the known element as QIF actuals."""
    sign = -1.0 if side == "internal" else 1.0  # the outward normal of a hole points to its axis
    if kind == "circle":
        data = make_reference_data("circle3d_projected", n_points=40, radius=8.0, form=0.004, offset=150.0, rng=11)
        p = data.parameters
        outward = sign * _radial(data.points, p["center"], p["normal"])
        return data.points, outward, FeatureGeometry(location=p["center"], normal=p["normal"],
                                                     diameter=2 * p["radius"])
    if kind == "sphere":
        data = make_reference_data("sphere", n_points=40, radius=12.5, form=0.003, offset=220.0, rng=12)
        p = data.parameters
        return data.points, sign * _radial(data.points, p["center"]), \
            FeatureGeometry(location=p["center"], diameter=2 * p["radius"])
    if kind == "cylinder":
        data = make_reference_data("cylinder", n_points=48, radius=10.0, length=25.0, form=0.003, offset=90.0,
                                   rng=13)
        p = data.parameters
        return data.points, sign * _radial(data.points, p["point"], p["axis"]), \
            FeatureGeometry(location=p["point"], direction=p["axis"], diameter=2 * p["radius"])
    if kind == "cone":
        alpha = np.radians(20.0)
        data = make_reference_data("cone", n_points=48, radius=9.0, length=10.0, half_angle=alpha, offset=60.0,
                                   rng=14)
        p = data.parameters
        normal = np.cos(alpha) * _radial(data.points, p["point"], p["axis"]) - np.sin(alpha) * p["axis"]
        return data.points, sign * normal, FeatureGeometry(location=p["point"], direction=p["axis"],
                                                           diameter=2 * p["radius_at_point"], half_angle=alpha)
    data = make_reference_data("plane", n_points=30, length=40.0, form=0.005, offset=75.0, rng=15)
    p = data.parameters
    return data.points, np.tile(p["normal"], (len(data.points), 1)), \
        FeatureGeometry(location=p["point"], normal=p["normal"])


def _write(tmp_path: Path, kind: str, side: str, *, compensated: bool, stated: bool, unit: str,
           diameter_error: float = 0.0, normals: bool = False) -> Path:
    surface, outward, actual = _case(kind, side)
    points = surface if compensated else surface + R_PROBE * outward
    if diameter_error:
        actual = FeatureGeometry(location=actual.location, normal=actual.normal, direction=actual.direction,
                                 diameter=actual.diameter + diameter_error, half_angle=actual.half_angle)
    nominal = None
    internal_external = None
    if kind in ("circle", "sphere", "cylinder", "cone"):
        # nominal: the known element rounded to 0.01 mm (a drawing's size), side stated or left to inference
        nominal = FeatureGeometry(location=actual.location, normal=actual.normal, direction=actual.direction,
                                  diameter=round(float(actual.diameter), 2), half_angle=actual.half_angle)
        internal_external = side.upper() if stated else "NOT_APPLICABLE"
    point_set = MeasuredPointSet(id=0, points=points, normals=outward if normals else None, compensated=compensated,
                                 probe_radius=None if compensated else R_PROBE)
    report = FeatureReport(type=kind, name=f"{kind.upper()}_1", actual=actual, nominal=nominal,
                           internal_external=internal_external, points=point_set)
    path = tmp_path / f"{kind}_{side}_{'comp' if compensated else 'centres'}_{unit}.qif"
    return write_qif(results_document([report]), path, linear_unit=unit)


CASES = [("circle", "internal"), ("circle", "external"), ("sphere", "internal"), ("sphere", "external"),
         ("cylinder", "internal"), ("cylinder", "external"), ("cone", "internal"), ("cone", "external"),
         ("plane", "external")]


@pytest.mark.parametrize(("kind", "side"), CASES)
@pytest.mark.parametrize("variant", ["centres-stated-mm", "centres-inferred-inch", "surface-inch", "normals-mm"])
def test_refit_gives_the_known_element(tmp_path: Path, kind: str, side: str, variant: str) -> None:
    compensated = variant.startswith("surface")
    stated = "stated" in variant or "normals" in variant
    unit = variant.rsplit("-", 1)[1]
    path = _write(tmp_path, kind, side, compensated=compensated, stated=stated and "normals" not in variant,
                  unit=unit, normals="normals" in variant)
    assert validate_qif(path) == ()
    (check,) = verify_qif(path, tolerance_mm=1e-9).features
    assert check.agrees is True, check.reason
    assert check.type == kind and check.n_points > 20
    compensation = check.compensation
    if compensated:
        assert (compensation.side, compensation.probe_radius_mm) == ("none", 0.0)
    else:
        assert compensation.probe_radius_mm == pytest.approx(R_PROBE, abs=1e-12)
        assert compensation.side == side
        inferred = kind != "plane" and "inferred" in variant
        assert compensation.inferred is inferred
        if "normals" in variant and kind != "plane":
            assert "point normals" in compensation.source
    if "diameter_mm" in check.difference:
        assert abs(check.difference["diameter_mm"]) < 1e-9
    assert check.difference["location_distance_mm"] < 1e-9


@pytest.mark.parametrize("kind", ["circle", "cylinder", "sphere"])
def test_a_diameter_one_micrometre_off_disagrees(tmp_path: Path, kind: str) -> None:
    path = _write(tmp_path, kind, "internal", compensated=False, stated=True, unit="mm", diameter_error=0.001)
    (check,) = verify_qif(path).features
    assert check.agrees is False
    assert check.difference["diameter_mm"] == pytest.approx(-0.001, abs=1e-9)
    assert "diameter differs by -0.001 mm" in check.reason


def test_the_wrong_material_side_is_diagnosed(tmp_path: Path) -> None:
    path = _write(tmp_path, "cylinder", "internal", compensated=False, stated=True, unit="mm")
    text = path.read_text().replace("<InternalExternal>INTERNAL</InternalExternal>",
                                    "<InternalExternal>EXTERNAL</InternalExternal>")
    wrong = tmp_path / "wrong_side.qif"
    wrong.write_text(text)
    (check,) = verify_qif(wrong).features
    assert check.agrees is False
    assert check.difference["diameter_mm"] == pytest.approx(-4 * R_PROBE, abs=1e-9)
    assert "other material side" in check.reason


FITS = {"circle": lambda p: fit_circle(p, method="projected"), "sphere": fit_sphere, "cylinder": fit_cylinder,
        "plane": fit_plane, "cone": fit_cone}


@pytest.mark.parametrize("kind", list(FITS))
@pytest.mark.parametrize("unit", ["mm", "inch"])
def test_written_fit_validates_and_reads_back_to_1e_12(tmp_path: Path, kind: str, unit: str) -> None:
    surface, outward, _ = _case(kind, "external")
    fit = FITS[kind](surface)
    document = fit_results_document(fit, kind, points=surface, normals=outward, name="F1")
    path = write_qif(document, tmp_path / f"{kind}.qif", linear_unit=unit)
    assert validate_qif(path) == ()
    back = read_qif(path)
    feature = back.feature("F1")
    actual = feature.actual
    tolerance = 1e-12 * (1.0 if unit == "mm" else 10.0)  # inch: one more rounding of x / 25.4 * 25.4
    points = back.points_of(feature).points
    assert np.max(np.abs(points - surface)) <= tolerance * max(1.0, np.max(np.abs(surface)))
    location = getattr(fit, "center", None)
    location = fit.point if location is None else location
    assert np.max(np.abs(actual.location - location)) <= tolerance * max(1.0, np.max(np.abs(location)))
    if kind in ("circle", "sphere", "cylinder"):
        assert abs(actual.diameter - 2 * fit.radius) <= tolerance * 100
    if kind == "cone":
        assert abs(actual.half_angle - fit.half_angle) <= 1e-14
        assert abs(actual.diameter - 2 * fit.radius_at_point) <= tolerance * 100
    assert feature.substitute_algorithm == "LEASTSQUARES"
    (check,) = verify_qif(path, tolerance_mm=1e-9).features
    assert check.agrees is True, check.reason


@pytest.mark.parametrize("kind", ["circle", "plane", "cylinder", "sphere", "cone", "line"])
def test_form_evaluation_is_written_with_its_verdict(tmp_path: Path, kind: str) -> None:
    from pcmm_geo.fit.zone.form import evaluate_form

    if kind == "line":
        data = make_reference_data("line3d", n_points=15, length=40.0, form=0.004, offset=20.0, rng=16)
        surface = data.points
    else:
        surface, _, _ = _case(kind, "external")
    evaluation = evaluate_form(surface, kind, tolerance=0.004)
    document = fit_results_document(evaluation.fit, kind, points=surface, evaluation=evaluation, name="F1")
    path = write_qif(document, tmp_path / f"{kind}_form.qif")
    assert validate_qif(path) == ()
    back = read_qif(path)
    feature = back.feature("F1")
    assert feature.substitute_algorithm == "MINMAX"
    assert abs(feature.actual.form - evaluation.deviation) <= 1e-15
    (form,) = [c for c in back.characteristics if c.type not in ("diameter", "spherical_diameter")]
    expected = {True: "PASS", False: "FAIL", None: "INDETERMINATE"}[evaluation.passed]
    assert (form.value, form.tolerance.value, form.status) == (pytest.approx(evaluation.deviation, abs=1e-15),
                                                               0.004, expected)
