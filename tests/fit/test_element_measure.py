"""distance / project on every element result against closed-form geometry; batch covariance; short reprs."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pcmm_geo import DegenerateGeometryError, InvalidInputError
from pcmm_geo.fit import (
    fit_circle,
    fit_circles,
    fit_cone,
    fit_cylinder,
    fit_line,
    fit_lines,
    fit_plane,
    fit_planes,
    fit_sphere,
    fit_spheres,
    fit_torus,
)
from pcmm_geo.fit.reference import make_reference_data

TOL = 1e-9  # mm: exact data, far from the origin
ROTATION = Rotation.from_rotvec([0.3, -1.1, 0.7]).as_matrix()  # local -> machine (columns: local axes)
OFFSET = np.array([1200.0, -800.0, 450.0])


def to_machine(local: np.ndarray) -> np.ndarray:
    return local @ ROTATION.T + OFFSET


def cylindrical(rho: np.ndarray, theta: np.ndarray, z: np.ndarray) -> np.ndarray:
    return np.stack([rho * np.cos(theta), rho * np.sin(theta), z], axis=-1)


def queries(rng: np.random.Generator, shape: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Angles and heights of query points, in a (..., ) shape to test vectorisation."""
    return rng.uniform(0, 2 * np.pi, shape), rng.uniform(-4, 4, shape)


def test_cylinder_distance_and_projection_are_the_radial_offset() -> None:
    theta = np.linspace(0, 2 * np.pi, 9, endpoint=False)
    data = to_machine(np.concatenate([cylindrical(np.full(9, 7.0), theta, np.full(9, z)) for z in (-5, 0, 6)]))
    fit = fit_cylinder(data)
    angle, height = queries(np.random.default_rng(1), (4, 5))
    rho = np.random.default_rng(2).uniform(0.5, 20, (4, 5))
    points = to_machine(cylindrical(rho, angle, height))
    np.testing.assert_allclose(fit.distance(points), rho - 7.0, atol=TOL)
    np.testing.assert_allclose(fit.project(points), to_machine(cylindrical(np.full_like(rho, 7.0), angle, height)),
                               atol=TOL)
    assert fit.distance(points).shape == (4, 5) and fit.project(points).shape == (4, 5, 3)


def test_circle_3d_distance_to_the_curve_and_its_sign() -> None:
    theta = np.linspace(0, 2 * np.pi, 10, endpoint=False)
    fit = fit_circle(to_machine(cylindrical(np.full(10, 4.0), theta, np.zeros(10))))
    points = to_machine(np.array([[7.0, 0, 4.0], [1.0, 0, 4.0], [0, 4.0, 2.5], [0, -3.0, 0.0]]))
    # hypot(rho - r, h), signed by rho - r; exactly |h| when rho = r
    np.testing.assert_allclose(fit.distance(points), [5.0, -5.0, 2.5, -1.0], atol=TOL)
    np.testing.assert_allclose(fit.project(points), to_machine(np.array([[4.0, 0, 0], [4.0, 0, 0], [0, 4.0, 0],
                                                                       [0, -4.0, 0]])), atol=TOL)
    projected = fit_circle(to_machine(cylindrical(np.full(10, 4.0), theta, np.zeros(10))), method="projected")
    np.testing.assert_allclose(projected.distance(points), [3.0, -3.0, 0.0, -1.0], atol=TOL)


def test_circle_2d_distance_and_projection() -> None:
    theta = np.linspace(0, 2 * np.pi, 7, endpoint=False)
    centre = np.array([-300.0, 250.0])
    fit = fit_circle(centre + 2.5 * np.c_[np.cos(theta), np.sin(theta)])
    points = centre + np.array([[6.0, 8.0], [0.0, -1.0]])
    np.testing.assert_allclose(fit.distance(points), [7.5, -1.5], atol=TOL)
    np.testing.assert_allclose(fit.project(points), centre + np.array([[1.5, 2.0], [0.0, -2.5]]), atol=TOL)


def test_cone_distance_is_perpendicular_to_the_generator() -> None:
    alpha = np.radians(25.0)
    theta = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    local = np.concatenate([cylindrical(np.full(8, 5.0 + z * np.tan(alpha)), theta, np.full(8, z)) for z in (-3, 0, 4)])
    fit = fit_cone(to_machine(local))
    # a point at distance e outside the surface along the outward normal (cos a, -sin a) in (rho, z)
    base_z, e = np.array([1.0, -2.0, 3.0]), np.array([0.7, -0.4, 2.0])
    angle = np.array([0.3, 2.0, 4.0])
    surface_rho = 5.0 + base_z * np.tan(alpha)
    points = to_machine(cylindrical(surface_rho + e * np.cos(alpha), angle, base_z - e * np.sin(alpha)))
    np.testing.assert_allclose(fit.distance(points), e, atol=TOL)
    np.testing.assert_allclose(fit.project(points), to_machine(cylindrical(surface_rho, angle, base_z)), atol=TOL)


def test_torus_distance_and_projection() -> None:
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 9)[:-1], np.linspace(0, 2 * np.pi, 7)[:-1])
    local = np.stack([(20 + 3 * np.cos(v)) * np.cos(u), (20 + 3 * np.cos(v)) * np.sin(u), 3 * np.sin(v)],
                     axis=-1).reshape(-1, 3)
    fit = fit_torus(to_machine(local))
    tube_angle, offset, around = np.array([0.4, 2.5]), np.array([2.0, -1.0]), np.array([1.0, 3.5])
    radial = 20 + (3 + offset) * np.cos(tube_angle)
    points = to_machine(cylindrical(radial, around, (3 + offset) * np.sin(tube_angle)))
    np.testing.assert_allclose(fit.distance(points), offset, atol=1e-8)
    on_surface = to_machine(cylindrical(20 + 3 * np.cos(tube_angle), around, 3 * np.sin(tube_angle)))
    np.testing.assert_allclose(fit.project(points), on_surface, atol=1e-8)


def test_sphere_line_plane_project_and_distance() -> None:
    rng = np.random.default_rng(5)
    unit = rng.normal(size=(20, 3))
    unit /= np.linalg.norm(unit, axis=1, keepdims=True)
    sphere = fit_sphere(OFFSET + 6.0 * unit)
    points = OFFSET + np.array([[10.0, 0, 0], [0, 0, -2.0]])
    np.testing.assert_allclose(sphere.distance(points), [4.0, -4.0], atol=TOL)
    np.testing.assert_allclose(sphere.project(points), OFFSET + np.array([[6.0, 0, 0], [0, 0, -6.0]]), atol=TOL)
    plane = fit_plane(to_machine(np.c_[rng.uniform(-5, 5, (10, 2)), np.zeros(10)]))
    assert abs(abs(float(plane.distance(to_machine(np.array([1.0, 2.0, 3.5]))))) - 3.5) < TOL


@pytest.mark.parametrize("seed", [0, 1])
def test_distance_of_the_data_reproduces_the_residuals(seed: int) -> None:
    """The sign convention is the fit's: distance(data) == residuals for noisy data, every element."""
    rng = np.random.default_rng(seed)
    theta = rng.uniform(0, 2 * np.pi, 40)
    z = rng.uniform(-5, 5, 40)
    noise = rng.normal(0, 0.01, 40)
    u, v = rng.uniform(0, 2 * np.pi, (2, 60))
    tube = 2 + 0.01 * rng.normal(size=60)
    cases = [
        (fit_cylinder, to_machine(cylindrical(6 + noise, theta, z)), {}),
        (fit_cone, to_machine(cylindrical(6 + z * np.tan(0.3) + noise, theta, z)), {}),
        (fit_circle, to_machine(cylindrical(6 + noise, theta, noise[::-1])), {}),
        (fit_circle, to_machine(cylindrical(6 + noise, theta, noise[::-1])), {"method": "projected"}),
        (fit_circle, cylindrical(6 + noise, theta, z)[:, :2], {}),
        (fit_sphere, OFFSET + (5 + noise[:, None]) * np.c_[np.cos(theta) * np.cos(z), np.sin(theta) * np.cos(z),
                                                         np.sin(z)], {}),
        (fit_torus, to_machine(np.c_[(15 + tube * np.cos(v)) * np.cos(u), (15 + tube * np.cos(v)) * np.sin(u),
                                     tube * np.sin(v)]), {}),
        (fit_plane, to_machine(np.c_[theta, z, noise]), {}),
        (fit_line, to_machine(np.c_[z, noise, noise[::-1]]), {}),
        (fit_line, np.c_[z, noise], {}),
    ]
    for fit_function, data, kwargs in cases:
        fit = fit_function(data, **kwargs)
        np.testing.assert_allclose(fit.distance(data), fit.residuals, atol=1e-9, err_msg=type(fit).__name__)
        if not isinstance(fit, type(fit_line(np.c_[z, noise]))):
            on_surface = fit.project(data)
            np.testing.assert_allclose(fit.distance(on_surface), 0.0, atol=1e-9, err_msg=type(fit).__name__)
            if not fit.method.startswith("projected"):  # the projected circle's residual is in-plane only
                np.testing.assert_allclose(np.linalg.norm(data - on_surface, axis=-1), np.abs(fit.residuals),
                                           atol=1e-9, err_msg=type(fit).__name__)


def test_points_on_an_axis_and_bad_shapes_are_refused() -> None:
    theta = np.linspace(0, 2 * np.pi, 6, endpoint=False)
    fit = fit_cylinder(np.concatenate([cylindrical(np.full(6, 2.0), theta, np.full(6, z)) for z in (0, 3)]))
    with pytest.raises(DegenerateGeometryError, match="on the axis"):
        fit.project([[0.0, 0.0, 1.0]])
    with pytest.raises(InvalidInputError, match=r"points: expected shape \(\.\.\., 3\), got shape \(4, 2\)"):
        fit.distance(np.zeros((4, 2)))
    with pytest.raises(InvalidInputError, match="finite"):
        fit.distance([[np.nan, 0, 0]])


def test_batch_covariance_equals_the_single_fits() -> None:
    rng = np.random.default_rng(7)
    unit = rng.normal(size=(5, 9, 3))
    spheres = OFFSET + 4.0 * unit / np.linalg.norm(unit, axis=2, keepdims=True) + rng.normal(0, 0.003, (5, 9, 3))
    planes = rng.normal(size=(5, 8, 3)) * [10, 10, 0.01]
    lines = rng.normal(size=(5, 8, 3)) * [10, 0.02, 0.01]
    theta = rng.uniform(0, 6, (5, 9))
    circles = np.stack([3 * np.cos(theta), 3 * np.sin(theta), 0.002 * rng.normal(size=(5, 9))], axis=2)
    for batch, single, stack, kwargs in [
        (fit_spheres, fit_sphere, spheres, {}),
        (fit_planes, fit_plane, planes, {}),
        (fit_lines, fit_line, lines, {}),
        (fit_lines, fit_line, lines[:, :, :2], {}),
        (fit_circles, fit_circle, circles, {"method": "projected"}),
        (fit_circles, fit_circle, circles[:, :, :2] + 0.003 * rng.normal(size=(5, 9, 2)), {}),
    ]:
        result = batch(stack)
        assert result.covariance.shape == (5, len(result.parameter_names), len(result.parameter_names))
        for k in range(5):
            one = single(stack[k], **kwargs)
            assert result.parameter_names == one.parameter_names and result.dof == one.dof
            np.testing.assert_allclose(result.parameters[k], one.parameters, atol=1e-9)
            np.testing.assert_allclose(result.covariance[k], one.covariance, rtol=1e-7,
                                       atol=1e-9 * np.max(np.abs(one.covariance)))
            assert result.std_errors.shape == result.parameters.shape  # (K, P), like the parameters
            np.testing.assert_allclose(result.std_errors[k], one.std_errors, rtol=1e-7, atol=1e-15)


def test_ragged_batch_is_named_as_such() -> None:
    sets = [[*np.eye(3).tolist(), [0, 0, -1.0]], [[1.0, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]]]
    with pytest.raises(InvalidInputError, match="ragged: fits need the same number of points") as caught:
        fit_spheres(sets)
    assert caught.value.got == "2 sets of 4, 5 points"


def test_reprs_are_short() -> None:
    rng = np.random.default_rng(3)
    unit = rng.normal(size=(1000, 12, 3))
    batch = fit_spheres(25.0 * unit / np.linalg.norm(unit, axis=2, keepdims=True) + rng.normal(0, 1e-3, (1000, 12, 3)))
    text = repr(batch)
    assert len(text) < 300, text
    assert text.startswith("SphereBatchFit(K=1000, n=12, centers=<(1000, 3)>, radii=[")
    assert "converged=1000/1000" in text
    theta = rng.uniform(0, 6, 500)
    circle = fit_circle(np.c_[np.cos(theta), np.sin(theta), 1e-3 * rng.normal(size=500)])
    cylinder = fit_cylinder(np.c_[np.cos(theta), np.sin(theta), rng.uniform(0, 3, 500)])
    for fit in (circle, cylinder):
        assert len(repr(fit)) < 300, repr(fit)
        assert "n=500" in repr(fit)


def test_std_errors_are_an_array_like_parameters_with_a_deprecated_dict_path() -> None:
    import pickle
    import warnings

    data = make_reference_data("cylinder", n_points=40, form=0.01, rng=4)
    fit = fit_cylinder(data.points)
    u = fit.std_errors
    assert isinstance(u, np.ndarray) and u.shape == fit.parameters.shape == (len(fit.parameter_names),)
    # independent truth: the square roots of the covariance diagonal, in parameter_names order
    np.testing.assert_array_equal(np.asarray(u), np.sqrt(np.diag(fit.covariance)))
    assert type(u * 2) is np.ndarray and type(u[:3]) is np.ndarray and repr(u).startswith("array(")
    assert fit.to_dict()["std_errors"] == np.sqrt(np.diag(fit.covariance)).tolist()
    radius = fit.parameter_names.index("radius")
    with pytest.warns(DeprecationWarning, match=r"CylinderFit.std_errors\['radius'\] \(a dict until 0.1\) is "
                                                r"deprecated.*parameter_names.index"):
        assert u["radius"] == u[radius]
    for old in (lambda: u.keys(), lambda: list(u.items()), lambda: u.values(), lambda: u.get("radius"),
                lambda: "radius" in u):
        with pytest.warns(DeprecationWarning, match="deprecated since pcmm_geo 0.2.0"):
            old()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        assert u.keys() == list(fit.parameter_names) and dict(u.items())["radius"] == u[radius]
        with pytest.raises(KeyError):
            u["no_such_parameter"]
    np.testing.assert_array_equal(pickle.loads(pickle.dumps(u)), u)
    batch = fit_spheres(np.stack([make_reference_data("sphere", n_points=12, form=0.01, rng=s).points
                                  for s in range(3)]))
    with pytest.warns(DeprecationWarning):
        np.testing.assert_array_equal(batch.std_errors["radius"], batch.std_errors[:, 3])


def test_a_repr_shows_only_the_fields_that_apply() -> None:
    circle = fit_circle(make_reference_data("circle2d", n_points=12, form=0.01, rng=2).points)
    text = repr(circle)
    assert text.startswith("CircleFit(center=[") and "radius=" in text
    for absent in ("normal", "r_in", "r_out", "nan", "None", "residual_components", "criterion"):
        assert absent not in text, (absent, text)
    cylinder = make_reference_data("cylinder", n_points=30, form=0.01, rng=2).points
    assert "r_in" not in repr(fit_cylinder(cylinder))
    zone = repr(fit_cylinder(cylinder, criterion="chebyshev"))
    assert "r_in=" in zone and "r_out=" in zone and "criterion='chebyshev'" in zone and "nan" not in zone
