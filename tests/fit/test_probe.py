"""Probe-radius compensation against closed forms: probe-ball centres of a known surface.

The null-space reference generator gives surface points whose least-squares element is known;
the centres of a ball of radius r touching them lie along the element's outward normals,
``c = p + r n``.  Compensating the element fitted to those centres must give back the
reference element, for either material side, to 1e-9 mm.
"""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.fit import (
    compensate_points,
    compensate_probe,
    fit_circle,
    fit_cone,
    fit_cylinder,
    fit_line,
    fit_plane,
    fit_sphere,
    material_side_from_nominal,
    material_side_from_normals,
)
from pcmm_geo.fit.reference import make_reference_data

R_PROBE = 1.5


def _radial(points: np.ndarray, centre: np.ndarray, axis: np.ndarray | None = None) -> np.ndarray:
    rel = points - centre
    if axis is not None:
        rel = rel - np.outer(rel @ axis, axis)
    return rel / np.linalg.norm(rel, axis=1, keepdims=True)


@pytest.mark.parametrize("side", ["internal", "external"])
def test_sphere_centres_give_back_the_reference_sphere(side: str) -> None:
    data = make_reference_data("sphere", n_points=40, radius=12.0, form=0.004, offset=300.0, rng=5)
    centre = data.parameters["center"]
    away = _radial(data.points, centre)
    outward = -away if side == "internal" else away  # out of the material, toward the probe
    centres = data.points + R_PROBE * outward
    fit = fit_sphere(centres)
    assert fit.radius == pytest.approx(12.0 + (-R_PROBE if side == "internal" else R_PROBE), abs=1e-9)
    comp = compensate_probe(fit, R_PROBE, side=side)
    assert comp.surface.radius == pytest.approx(12.0, abs=1e-9)
    assert np.allclose(comp.surface.center, centre, atol=1e-9)
    assert comp.surface.form == pytest.approx(data.form, abs=1e-9)
    assert comp.surface.parameters[comp.surface.parameter_names.index("radius")] == pytest.approx(12.0, abs=1e-9)
    # the side read from the normals is the one the centres were made with
    from_normals = compensate_probe(fit, R_PROBE, points=centres, outward=outward)
    assert (from_normals.side, from_normals.side_source, from_normals.inferred) == (side, "normals", False)
    # per-point compensation along the exact normals gives the surface points themselves
    assert np.allclose(compensate_points(centres, outward, R_PROBE), data.points, atol=1e-12)
    assert np.allclose(comp.surface_points(centres), data.points, atol=1e-9)


@pytest.mark.parametrize("side", ["internal", "external"])
def test_cylinder_centres(side: str) -> None:
    data = make_reference_data("cylinder", n_points=60, radius=15.0, length=30.0, form=0.003, offset=200.0, rng=9)
    axis, point = data.parameters["axis"], data.parameters["point"]
    away = _radial(data.points, point, axis)
    centres = data.points + R_PROBE * (-away if side == "internal" else away)
    comp = compensate_probe(fit_cylinder(centres), R_PROBE, side=side)
    assert comp.surface.radius == pytest.approx(15.0, abs=1e-9)
    assert abs(abs(comp.surface.axis @ axis) - 1.0) < 1e-12
    distance = np.linalg.norm(np.cross(comp.surface.point - point, axis))
    assert distance < 1e-9


@pytest.mark.parametrize("side", ["internal", "external"])
def test_circle_centres_2d_and_projected(side: str) -> None:
    sign = -1.0 if side == "internal" else 1.0
    flat = make_reference_data("circle2d", n_points=24, radius=6.0, form=0.002, offset=50.0, rng=2)
    centres = flat.points + sign * R_PROBE * _radial(flat.points, flat.parameters["center"])
    comp = compensate_probe(fit_circle(centres), R_PROBE, side=side)
    assert comp.surface.radius == pytest.approx(6.0, abs=1e-9)
    assert np.allclose(comp.surface.center, flat.parameters["center"], atol=1e-9)

    data = make_reference_data("circle3d_projected", n_points=30, radius=6.0, form=0.002, offset=80.0, rng=4)
    normal = data.parameters["normal"]
    centres = data.points + sign * R_PROBE * _radial(data.points, data.parameters["center"], normal)
    fit = fit_circle(centres, method="projected")
    comp = compensate_probe(fit, R_PROBE, side=side)
    assert comp.surface.radius == pytest.approx(6.0, abs=1e-9)
    assert comp.surface.diameter == pytest.approx(12.0, abs=2e-9)
    assert np.allclose(comp.surface.normal, fit.normal)  # the offset moves no normal


def test_minimax_zone_radii_move_with_the_radius() -> None:
    t = np.linspace(0, 2 * np.pi, 36, endpoint=False)
    wobble = 0.01 * np.cos(3 * t)
    centres = np.c_[(8.0 + wobble) * np.cos(t), (8.0 + wobble) * np.sin(t)]
    fit = fit_circle(centres, criterion="chebyshev")
    comp = compensate_probe(fit, R_PROBE, side="external")
    assert comp.surface.r_in == pytest.approx(fit.r_in - R_PROBE, abs=1e-12)
    assert comp.surface.r_out == pytest.approx(fit.r_out - R_PROBE, abs=1e-12)
    assert comp.surface.r_out - comp.surface.r_in == pytest.approx(0.02, abs=1e-9)  # the zone width stays


@pytest.mark.parametrize("side", ["internal", "external"])
def test_cone_apex_moves_by_r_over_sin_alpha(side: str) -> None:
    alpha = np.radians(25.0)
    data = make_reference_data("cone", n_points=48, radius=10.0, length=12.0, half_angle=alpha, offset=100.0, rng=7)
    apex, axis = data.parameters["apex"], data.parameters["axis"]
    radial = _radial(data.points, data.parameters["point"], axis)
    normal_out_of_cone = np.cos(alpha) * radial - np.sin(alpha) * axis
    sign = -1.0 if side == "internal" else 1.0
    centres = data.points + sign * R_PROBE * normal_out_of_cone
    fit = fit_cone(centres, axis_hint=axis)
    # closed form: the centres' cone has the same half-angle, its apex r / sin(alpha) along the axis
    expected_centre_apex = apex + sign * (-R_PROBE / np.sin(alpha)) * axis
    assert np.allclose(fit.apex, expected_centre_apex, atol=1e-8)
    assert fit.half_angle == pytest.approx(alpha, abs=1e-12)
    comp = compensate_probe(fit, R_PROBE, side=side)
    assert np.allclose(comp.surface.apex, apex, atol=1e-8)
    assert comp.surface.half_angle == fit.half_angle
    expected_radius = data.parameters["radius_at_point"] + (fit.point - data.parameters["point"]) @ axis * np.tan(alpha)
    assert comp.surface.radius_at_point == pytest.approx(expected_radius, abs=1e-8)
    assert np.max(np.abs(comp.surface.distance(data.points))) < 1e-8
    # point by point along the centre cone's normals: the touched points themselves
    assert np.allclose(comp.surface_points(centres), data.points, atol=1e-8)


def test_plane_moves_into_the_material_whatever_the_fit_normal_sign() -> None:
    data = make_reference_data("plane", n_points=30, length=40.0, form=0.005, offset=100.0, rng=3)
    normal = data.parameters["normal"]
    for outward in (normal, -normal):
        centres = data.points + R_PROBE * outward
        comp = compensate_probe(fit_plane(centres), R_PROBE, outward=outward)
        assert abs((comp.surface.point - data.parameters["point"]) @ normal) < 1e-9
        assert np.allclose(comp.outward, outward, atol=1e-12)
        assert comp.side == "external" and comp.side_source == "normals"
    # per-point normals (scanning) are averaged; opposing ones are refused
    noisy = np.tile(normal, (30, 1)) + 1e-3 * np.random.default_rng(1).standard_normal((30, 3))
    assert compensate_probe(fit_plane(data.points), R_PROBE, outward=noisy).outward @ normal > 0.999999
    with pytest.raises(InvalidInputError, match="opposing"):
        compensate_probe(fit_plane(data.points), R_PROBE, outward=np.vstack([normal, -normal]))
    with pytest.raises(InvalidInputError, match="outward normal"):
        compensate_probe(fit_plane(data.points), R_PROBE)


def test_line_offset_uses_the_normal_part_across_the_line() -> None:
    data = make_reference_data("line3d", n_points=12, length=50.0, rng=1)
    direction = data.parameters["direction"]
    helper = np.cross(direction, [0.3, 0.5, 0.8])
    surface_normal = helper / np.linalg.norm(helper)
    centres = data.points + R_PROBE * surface_normal
    tilted = surface_normal + 0.2 * direction  # an IJK with a component along the line
    comp = compensate_probe(fit_line(centres), R_PROBE, outward=tilted)
    assert np.allclose(comp.outward, surface_normal, atol=1e-12)
    assert np.linalg.norm(np.cross(comp.surface.point - data.parameters["point"], direction)) < 1e-9
    with pytest.raises(InvalidInputError, match="parallel to the line"):
        compensate_probe(fit_line(centres), R_PROBE, outward=direction)
    with pytest.raises(InvalidInputError, match="side"):
        compensate_probe(fit_line(centres), R_PROBE, outward=surface_normal, side="internal")


def test_side_inferred_from_the_nominal_size_only_when_unambiguous() -> None:
    t = np.linspace(0, 2 * np.pi, 20, endpoint=False)
    centres = np.c_[3.5458 * np.cos(t), 3.5458 * np.sin(t)]  # a 12.09 mm hole probed with r = 2.49978
    comp = compensate_probe(fit_circle(centres), 2.49978, nominal_diameter=12.0)
    assert (comp.side, comp.side_source, comp.inferred) == ("internal", "nominal size", True)
    assert comp.surface.diameter == pytest.approx(2 * 3.5458 + 2 * 2.49978, abs=1e-12)
    assert material_side_from_nominal(7.0, 2.1, 2.5) == "external"
    with pytest.raises(InvalidInputError, match="nominal size does not decide"):
        compensate_probe(fit_circle(centres), 2.49978, nominal_diameter=7.09)  # half-way between the readings
    with pytest.raises(InvalidInputError, match="material side"):
        compensate_probe(fit_circle(centres), 2.49978)
    # cones: the readings differ by 2 r / cos(alpha) at a section
    assert material_side_from_nominal(10.0, 10.0 + 2 * 2 / np.cos(0.5), 2.0, cone_half_angle=0.5) == "internal"


def test_normals_that_disagree_about_the_side_are_refused() -> None:
    data = make_reference_data("sphere", n_points=20, radius=5.0, rng=1)
    away = _radial(data.points, data.parameters["center"])
    mixed = away.copy()
    mixed[:3] *= -1
    fit = fit_sphere(data.points)
    assert material_side_from_normals(fit, data.points, away) == "external"
    with pytest.raises(InvalidInputError, match="17 pointing away, 3 toward"):
        material_side_from_normals(fit, data.points, mixed)


def test_probe_radius_uncertainty_enters_the_size_variance() -> None:
    data = make_reference_data("sphere", n_points=30, radius=5.0, form=0.002, rng=2)
    fit = fit_sphere(data.points)
    comp = compensate_probe(fit, 1.0, side="external", probe_radius_u=0.0002)
    radius, center_x = (fit.parameter_names.index(name) for name in ("radius", "center_x"))
    assert comp.surface.std_errors[radius] ** 2 == pytest.approx(fit.std_errors[radius] ** 2 + 0.0002**2, rel=1e-12)
    assert comp.surface.std_errors[center_x] == fit.std_errors[center_x]
    assert "probe_radius_u" in repr(comp) and "outward" not in repr(comp)


def test_bad_arguments() -> None:
    fit = fit_sphere(make_reference_data("sphere", n_points=10, rng=1).points)
    for bad in (0.0, -1.0, float("nan"), "2", [1.0]):
        with pytest.raises(InvalidInputError, match="probe_radius"):
            compensate_probe(fit, bad, side="internal")  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="side"):
        compensate_probe(fit, 1.0, side="inside")  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="points"):
        compensate_probe(fit, 1.0, outward=np.ones((10, 3)))
    with pytest.raises(InvalidInputError, match="element"):
        compensate_probe(object(), 1.0, side="internal")  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="outward normals"):
        compensate_points(np.zeros((3, 3)), np.zeros((3, 3)), 1.0)
    with pytest.raises(InvalidInputError, match="one per point"):
        compensate_points(np.zeros((3, 3)), np.ones((2, 3)), 1.0)
    with pytest.raises(InvalidInputError, match="probe_radius"):
        compensate_points(np.zeros((3, 3)), np.ones((3, 3)), [1.0, -1.0, 1.0])
    # zero radius (already compensated points, QIF ProbeRadii) leaves the points alone
    assert compensate_points([[1.0, 2.0, 3.0]], [0, 0, 1], [0.0]).tolist() == [[1.0, 2.0, 3.0]]
