"""``FitResult.summary()``: the one choice of displayed parameters that the CLI table, the QIF export and the
repr share, checked against exact constructed elements (closed forms)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pcmm_geo.fit import fit_circle, fit_cone, fit_cylinder, fit_line, fit_sphere, fit_torus


def _sphere_points(center: np.ndarray, radius: float) -> np.ndarray:
    d = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1.0],
                  [1, 1, 1], [-1, 1, -1], [1, -1, -1]], dtype=float)
    return center + radius * d / np.linalg.norm(d, axis=1, keepdims=True)


def test_sphere_rows_are_the_exact_center_radius_and_diameter() -> None:
    center = np.array([10.0, -4.0, 2.5])
    rng = np.random.default_rng(11)
    points = _sphere_points(center, 12.5)
    noisy = points + 1e-3 * rng.normal(size=points.shape)  # residuals, so u > 0
    exact = {row.name: row for row in fit_sphere(points).summary()}
    assert list(exact) == ["center_x", "center_y", "center_z", "radius", "diameter"]
    for axis, value in zip("xyz", center, strict=True):
        assert exact[f"center_{axis}"].value == pytest.approx(value, abs=1e-9)
        assert exact[f"center_{axis}"].unit == "mm" and exact[f"center_{axis}"].quantity == "center"
    assert exact["radius"].value == pytest.approx(12.5, abs=1e-9)
    assert exact["diameter"].value == pytest.approx(25.0, abs=2e-9) and exact["diameter"].derived
    fit = fit_sphere(noisy)
    rows = {row.name: row for row in fit.summary()}
    radius_u = float(np.sqrt(np.diag(fit.covariance)[fit.parameter_names.index("radius")]))
    assert radius_u > 0 and rows["radius"].u == pytest.approx(radius_u, rel=1e-12)
    assert rows["diameter"].u == pytest.approx(2 * radius_u, rel=1e-12)  # d = 2 r exactly


def test_rows_show_only_what_applies() -> None:
    theta = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    circle2d = np.c_[3 + 2 * np.cos(theta), -1 + 2 * np.sin(theta)]
    gauss = fit_circle(circle2d)
    assert [row.name for row in gauss.summary()] == ["center_x", "center_y", "radius", "diameter"]  # no normal, no zone
    zone = fit_circle(circle2d + 1e-3 * np.c_[np.cos(3 * theta), np.zeros(12)], criterion="chebyshev")
    names = [row.name for row in zone.summary()]
    assert names == ["center_x", "center_y", "radius", "r_in", "r_out", "diameter"]
    rows = {row.name: row for row in zone.summary()}
    assert rows["r_out"].value - rows["r_in"].value == pytest.approx(zone.form, rel=1e-9)
    assert math.isnan(rows["r_in"].u)  # not a fitted parameter
    line = fit_line(np.c_[np.arange(5.0), 2 * np.arange(5.0), np.zeros(5)])
    assert {row.quantity: row.unit for row in line.summary()} == {"point": "mm", "direction": "1"}


def test_cone_rows_carry_the_apex_angle_in_degrees() -> None:
    half = math.radians(20.0)
    theta = np.linspace(0, 2 * np.pi, 10, endpoint=False)
    height = np.repeat([1.0, 4.0, 7.0], 10)
    radius = 10.0 - height * math.tan(half)
    points = np.c_[radius * np.tile(np.cos(theta), 3), radius * np.tile(np.sin(theta), 3), height]
    rows = {row.name: row for row in fit_cone(points).summary()}
    assert rows["half_angle"].value == pytest.approx(half, abs=1e-9) and rows["half_angle"].unit == "rad"
    assert rows["apex_angle_deg"].value == pytest.approx(40.0, abs=1e-7) and rows["apex_angle_deg"].unit == "deg"
    assert rows["apex_z"].value == pytest.approx(10.0 / math.tan(half), abs=1e-6)
    assert "diameter" not in rows


def test_torus_and_cylinder_sizes() -> None:
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 9, endpoint=False), np.linspace(0, 2 * np.pi, 7, endpoint=False))
    u, v = u.ravel(), v.ravel()
    torus = np.c_[(20 + 3 * np.cos(v)) * np.cos(u), (20 + 3 * np.cos(v)) * np.sin(u), 3 * np.sin(v)]
    rows = {row.name: row.value for row in fit_torus(torus).summary()}
    assert rows["major_radius"] == pytest.approx(20.0, abs=1e-8)
    assert rows["minor_radius"] == pytest.approx(3.0, abs=1e-8)
    theta = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    cylinder = np.c_[4 * np.tile(np.cos(theta), 2), 4 * np.tile(np.sin(theta), 2), np.repeat([0.0, 9.0], 8)]
    rows = {row.name: row.value for row in fit_cylinder(cylinder).summary()}
    assert rows["diameter"] == pytest.approx(8.0, abs=1e-8) and abs(rows["axis_z"]) == pytest.approx(1.0, abs=1e-12)


def test_repr_and_qif_export_use_the_rows() -> None:
    from pcmm_geo.cmm.export import feature_report

    rng = np.random.default_rng(5)
    points = _sphere_points(np.array([1.0, 2.0, 3.0]), 5.0)
    fit = fit_sphere(points + 1e-3 * rng.normal(size=points.shape))
    rows = {row.name: row for row in fit.summary()}
    text = repr(fit)
    assert text.startswith("SphereFit(center=[") and f"radius={rows['radius'].value:.12g}" in text
    assert "diameter" not in text  # derived rows are for reading, not repeated in the repr
    actual = feature_report(fit, "sphere").actual
    assert actual.diameter == pytest.approx(rows["diameter"].value, rel=1e-12)
    assert actual.uncertainty["diameter"] == pytest.approx(rows["diameter"].u, rel=1e-12)
    assert actual.uncertainty["location"] == pytest.approx(max(rows[f"center_{a}"].u for a in "xyz"), rel=1e-12)
    np.testing.assert_allclose(actual.location, [rows[f"center_{a}"].value for a in "xyz"], rtol=0, atol=1e-12)


def test_rows_follow_the_element_spec() -> None:
    """Every row is a spec parameter (by kind and unit), a zone radius or a derived row; a cone's
    radius_at_point (not shown) only with complete=True, and the QIF diameter is its double."""
    from pcmm_geo.cmm.export import feature_report
    from pcmm_geo.elements import SPECS, element_of

    half = math.radians(15.0)
    theta = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    height = np.repeat([0.0, 3.0, 6.0], 12)
    radius = 8.0 - height * math.tan(half)
    points = np.c_[radius * np.tile(np.cos(theta), 3), radius * np.tile(np.sin(theta), 3), height]
    rng = np.random.default_rng(3)
    cone = fit_cone(points + 1e-3 * rng.normal(size=points.shape))
    spec = SPECS[str(element_of(cone))]
    units = {p.name: p.unit for p in spec.parameters}
    shown = cone.summary()
    assert [row.quantity for row in shown if not row.derived][:3] == ["point"] * 3  # the location field first
    assert all(row.unit == units[row.quantity] for row in shown if not row.derived)
    assert "radius_at_point" not in {row.name for row in shown}
    complete = {row.name: row for row in cone.summary(complete=True)}
    assert complete["radius_at_point"].value == pytest.approx(cone.radius_at_point, rel=1e-15)
    assert complete["diameter"].value == pytest.approx(2 * cone.radius_at_point, rel=1e-15)
    radius_u = float(np.sqrt(np.diag(cone.covariance)[cone.parameter_names.index("radius_at_point")]))
    assert radius_u > 0 and complete["diameter"].u == pytest.approx(2 * radius_u, rel=1e-12)
    # the height of the reference point: the exact cone has radius 8 at z = 0, r(z) = 8 - z tan(15 deg)
    z = complete["point_z"].value
    assert complete["radius_at_point"].value == pytest.approx(8.0 - z * math.tan(half), abs=5e-3)
    actual = feature_report(cone, "cone").actual
    assert actual.diameter == pytest.approx(complete["diameter"].value, rel=1e-15)
    assert actual.uncertainty["diameter"] == pytest.approx(complete["diameter"].u, rel=1e-12)
    assert actual.half_angle == pytest.approx(half, abs=1e-3)
    np.testing.assert_allclose(actual.direction, [complete[f"axis_{a}"].value for a in "xyz"], rtol=0, atol=1e-15)
