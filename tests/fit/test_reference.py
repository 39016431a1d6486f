"""Independent checks of the null-space reference-data generator.

The generator's claim is that its reference element is the exact least-squares solution.
It is verified here without its own Jacobians: residual functions written from scratch in
a different (local, world-frame) parameterisation, differentiated by the complex step
(exact to rounding), and a brute-force ``scipy.optimize.least_squares`` refit started at
the truth and at a perturbed start.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from scipy.optimize import least_squares

from pcmm_geo.errors import (
    DegenerateGeometryError,
    FileFormatError,
    InvalidInputError,
    TooFewPointsError,
)
from pcmm_geo.fit.reference import (
    ELEMENTS,
    MIN_POINTS,
    ReferenceDataSet,
    first_order_residual,
    make_reference_data,
    random_rotation,
    read_reference_data,
    write_nist_pair,
    write_reference_data,
)
from pcmm_geo.io.nist import read_nist_pair

Residuals = Callable[[np.ndarray], np.ndarray]


# --- independent residual models (complex-safe: plain arithmetic and sqrt only) ---------


def _frame(direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.eye(3)[int(np.argmin(np.abs(direction)))]
    first = np.cross(helper, direction)
    first /= np.linalg.norm(first)
    return first, np.cross(direction, first)


def _unit(vector: np.ndarray) -> np.ndarray:
    return vector / np.sqrt(vector @ vector)


def _model(data: ReferenceDataSet) -> tuple[Residuals, np.ndarray]:
    """Residual function of local parameters x (zero offsets/tilts = the reference) and x at the truth."""
    q = data.points.astype(complex)
    p = data.parameters
    element = data.element
    if element == "line2d":
        d0 = p["direction"]
        normal0 = np.array([-d0[1], d0[0]])

        def line2d(x: np.ndarray) -> np.ndarray:
            direction = _unit(d0 + x[1] * normal0)
            normal = np.array([-direction[1], direction[0]])
            return (q - (p["point"] + x[0] * normal0)) @ normal

        return line2d, np.zeros(2)
    if element == "circle2d":

        def circle2d(x: np.ndarray) -> np.ndarray:
            w = q - x[:2]
            return np.sqrt(w[:, 0] ** 2 + w[:, 1] ** 2) - x[2]

        return circle2d, np.r_[p["center"], p["radius"]]
    if element == "sphere":

        def sphere(x: np.ndarray) -> np.ndarray:
            w = q - x[:3]
            return np.sqrt(np.sum(w * w, axis=1)) - x[3]

        return sphere, np.r_[p["center"], p["radius"]]
    axis0 = p.get("axis", p.get("normal", p.get("direction")))
    e1, e2 = _frame(axis0)

    def tilted(a: complex, b: complex) -> np.ndarray:
        return _unit(axis0 + a * e1 + b * e2)

    if element == "line3d":

        def line3d(x: np.ndarray) -> np.ndarray:
            direction = tilted(x[2], x[3])
            w = q - (p["point"] + x[0] * e1 + x[1] * e2)
            return (w - np.outer(w @ direction, direction)).ravel()

        return line3d, np.zeros(4)
    if element == "plane":

        def plane(x: np.ndarray) -> np.ndarray:
            return (q - p["point"] - x[0] * axis0) @ tilted(x[1], x[2])

        return plane, np.zeros(3)
    if element == "circle3d":

        def circle3d(x: np.ndarray) -> np.ndarray:
            normal = tilted(x[3], x[4])
            w = q - x[:3]
            h = w @ normal
            return np.r_[np.sqrt(np.sum(w * w, axis=1) - h**2) - x[5], h]

        return circle3d, np.r_[p["center"], 0.0, 0.0, p["radius"]]
    if element == "torus":

        def torus(x: np.ndarray) -> np.ndarray:
            axis = tilted(x[3], x[4])
            w = q - x[:3]
            h = w @ axis
            rho = np.sqrt(np.sum(w * w, axis=1) - h**2)
            return np.sqrt((rho - x[5]) ** 2 + h**2) - x[6]

        return torus, np.r_[p["center"], 0.0, 0.0, p["major_radius"], p["minor_radius"]]

    def axial_parts(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        axis = tilted(x[2], x[3])
        w = q - (p["point"] + x[0] * e1 + x[1] * e2)
        h = w @ axis
        return np.sqrt(np.sum(w * w, axis=1) - h**2), h

    if element == "cylinder":

        def cylinder(x: np.ndarray) -> np.ndarray:
            rho, _ = axial_parts(x)
            return rho - x[4]

        return cylinder, np.r_[0.0, 0.0, 0.0, 0.0, p["radius"]]
    assert element == "cone"

    def cone(x: np.ndarray) -> np.ndarray:
        rho, h = axial_parts(x)
        return (rho - x[4]) * np.cos(x[5]) - h * np.sin(x[5])

    return cone, np.r_[0.0, 0.0, 0.0, 0.0, p["radius_at_point"], p["half_angle"]]


def _complex_step_jacobian(fun: Residuals, x: np.ndarray) -> np.ndarray:
    step = 1e-30
    columns = []
    for j in range(x.size):
        shifted = x.astype(complex)
        shifted[j] += 1j * step
        columns.append(np.imag(fun(shifted)) / step)
    return np.column_stack(columns)


def _real(fun: Residuals) -> Residuals:
    return lambda x: np.real(fun(x.astype(complex)))


def _refit(fun: Residuals, start: np.ndarray) -> np.ndarray:
    result = least_squares(
        _real(fun),
        start,
        jac=lambda x: _complex_step_jacobian(fun, x),
        method="lm",
        xtol=1e-15,
        ftol=1e-15,
        gtol=1e-15,
    )
    # scipy stops on its relative tolerances; finish with plain Gauss-Newton steps
    x = result.x
    for _ in range(5):
        step, *_ = np.linalg.lstsq(_complex_step_jacobian(fun, x), -_real(fun)(x), rcond=None)
        x = x + step
    return x


# --- the generator's claims ------------------------------------------------------------

CASES = [
    ("line2d", {}),
    ("line3d", {}),
    ("plane", {}),
    ("circle2d", {"arc": np.pi / 3}),
    ("circle3d", {"arc": np.pi / 2}),
    ("sphere", {"cap": np.pi / 6}),
    ("cylinder", {"arc": np.pi / 2}),
    ("cone", {"arc": np.pi, "half_angle": 0.3}),
    ("torus", {"arc": np.pi, "tube_arc": np.pi}),
]


@pytest.mark.parametrize(("element", "options"), CASES, ids=[c[0] for c in CASES])
@pytest.mark.parametrize("form", [0.0, 0.05])
def test_reference_element_is_stationary_point(element: str, options: dict, form: float) -> None:
    data = make_reference_data(element, form=form, offset=700.0, rng=11, **options)
    fun, truth = _model(data)
    residual_values = np.real(fun(truth.astype(complex)))
    # the residuals of the independent model at the truth are the generator's (line3d: 3-D offsets)
    if element == "line3d":
        distances = np.linalg.norm(residual_values.reshape(-1, 3), axis=1)
        np.testing.assert_allclose(distances, np.linalg.norm(data.residuals, axis=1), atol=1e-11)
    elif element == "circle3d":
        np.testing.assert_allclose(residual_values, data.residuals.ravel(order="F"), atol=1e-11)
    else:
        np.testing.assert_allclose(np.abs(residual_values), np.abs(data.residuals), atol=1e-11)
    assert data.form == pytest.approx(form, abs=1e-15)
    jacobian = _complex_step_jacobian(fun, truth)
    gradient = jacobian.T @ residual_values
    # a non-stationary e would give |J^T e| ~ |J| |e|; allow rounding (residuals ~1e-13 mm at 700 mm)
    assert np.linalg.norm(gradient) <= 1e-12 * np.linalg.norm(jacobian) * (np.linalg.norm(residual_values) + 1.0)


@pytest.mark.parametrize(("element", "options"), CASES, ids=[c[0] for c in CASES])
def test_brute_force_refit_returns_the_reference(element: str, options: dict) -> None:
    data = make_reference_data(element, form=0.02, offset=300.0, rng=4, **options)
    fun, truth = _model(data)
    from_truth = _refit(fun, truth)
    np.testing.assert_allclose(from_truth, truth, atol=1e-9, rtol=0)
    # started away from the truth it comes back: the reference is a minimum, not a saddle
    start = truth + np.random.default_rng(1).uniform(-1e-3, 1e-3, truth.size)
    np.testing.assert_allclose(_refit(fun, start), truth, atol=1e-9, rtol=0)


def test_projected_circle_is_plane_then_2d_circle() -> None:
    data = make_reference_data("circle3d_projected", n_points=12, form=0.05, offset=900.0, arc=2.0, rng=8)
    points, normal, center = data.points, data.parameters["normal"], data.parameters["center"]
    # least-squares plane = principal axes of the centred points
    centroid = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - centroid)
    assert abs(abs(vt[2] @ normal) - 1.0) < 1e-15
    assert abs((centroid - center) @ normal) < 1e-11
    e1, e2 = _frame(normal)
    planar = np.column_stack([(points - center) @ e1, (points - center) @ e2]).astype(complex)

    def circle(x: np.ndarray) -> np.ndarray:
        w = planar - x[:2]
        return np.sqrt(w[:, 0] ** 2 + w[:, 1] ** 2) - x[2]

    solution = _refit(circle, np.array([0.3, -0.2, 9.0]))
    np.testing.assert_allclose(solution, [0.0, 0.0, data.parameters["radius"]], atol=1e-9, rtol=0)


def test_gaussian_and_projected_circles_differ() -> None:
    projected = make_reference_data("circle3d_projected", n_points=10, form=0.5, arc=1.5, rng=3)
    fun, truth = _model(
        ReferenceDataSet("circle3d", projected.points, projected.parameters, projected.residuals, projected.points)
    )
    assert np.max(np.abs(_refit(fun, truth) - truth)) > 1e-6


def test_known_geometry_without_rotation() -> None:
    # circle of radius 10 through three foot points at 0, 120, 240 degrees, no pose
    data = make_reference_data("circle2d", n_points=3, rotate=False)
    np.testing.assert_allclose(data.points[1], [10 * np.cos(2 * np.pi / 3), 10 * np.sin(2 * np.pi / 3)], atol=1e-14)
    sphere = make_reference_data("sphere", offset=250.0, form=0.0, rng=2)
    assert np.linalg.norm(sphere.parameters["center"]) == pytest.approx(250.0, abs=1e-12)
    np.testing.assert_allclose(np.linalg.norm(sphere.points - sphere.parameters["center"], axis=1), 10.0, atol=1e-12)
    cone = make_reference_data("cone", radius=8.0, half_angle=np.pi / 4, length=4.0, rotate=False, rng=2)
    # apex below the mid-section by r / tan(alpha) = 8 mm
    np.testing.assert_allclose(cone.parameters["apex"], [0.0, 0.0, -8.0], atol=1e-12)
    heights = cone.points[:, 2]
    np.testing.assert_allclose(np.hypot(cone.points[:, 0], cone.points[:, 1]), heights + 8.0, atol=1e-12)


def test_random_rotation_is_proper() -> None:
    for seed in range(5):
        rotation = random_rotation(np.random.default_rng(seed))
        np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-14)
        assert np.linalg.det(rotation) == pytest.approx(1.0, abs=1e-14)


def test_first_order_residual_measures_gradient() -> None:
    jac = np.array([[1.0, 0.0], [1.0, 1.0], [1.0, 2.0]])
    assert first_order_residual(jac, np.array([1.0, -2.0, 1.0])) == pytest.approx(0.0, abs=1e-16)
    # e = (1, 0, 0): J^T e = (1, 0), |J| = sqrt(8), |e| = 1
    assert first_order_residual(jac, np.array([1.0, 0.0, 0.0])) == pytest.approx(1 / np.sqrt(8))


def test_seeded_and_sampling_recorded() -> None:
    first = make_reference_data("torus", form=0.01, rng=7)
    second = make_reference_data("torus", form=0.01, rng=7)
    other = make_reference_data("torus", form=0.01, rng=8)
    np.testing.assert_array_equal(first.points, second.points)
    assert not np.allclose(first.points, other.points)
    assert first.sampling["seed"] == 7 and first.sampling["n_points"] == first.n == 28


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        ({"element": "ellipse"}, InvalidInputError),
        ({"element": "sphere", "n_points": 3}, TooFewPointsError),
        ({"element": "sphere", "n_points": 4, "form": 0.1}, InvalidInputError),
        ({"element": "plane", "form": -1.0}, InvalidInputError),
        ({"element": "cone", "half_angle": 1.2, "length": 40.0}, InvalidInputError),
        ({"element": "torus", "minor_radius": 12.0}, InvalidInputError),
        ({"element": "circle2d", "arc": 7.0}, InvalidInputError),
        ({"element": "sphere", "cap": 0.0}, InvalidInputError),
        ({"element": "circle2d", "arc": 1e-12}, DegenerateGeometryError),
        ({"element": "line3d", "rng": "seed"}, InvalidInputError),
    ],
)
def test_bad_input_raises_typed_errors(kwargs: dict, error: type[Exception]) -> None:
    element = kwargs.pop("element")
    with pytest.raises(error):
        make_reference_data(element, **kwargs)


def test_minimum_points_exact_for_every_element() -> None:
    for element in ELEMENTS:
        data = make_reference_data(element, n_points=MIN_POINTS[element], offset=10.0, rng=1)
        assert data.form == 0.0
        assert data.n == MIN_POINTS[element]


# --- files ---------------------------------------------------------------------------


def test_reference_file_round_trip(tmp_path) -> None:
    data = make_reference_data("circle3d", n_points=9, form=0.03, offset=123.0, rng=5)
    path = write_reference_data(data, tmp_path / "c.ref")
    back = read_reference_data(path)
    assert back.element == "circle3d"
    np.testing.assert_array_equal(back.points, data.points)
    np.testing.assert_array_equal(back.residuals, data.residuals)
    np.testing.assert_array_equal(back.parameters["normal"], data.parameters["normal"])
    assert back.parameters["radius"] == 10.0 and back.sampling["form"] == 0.03
    with pytest.raises(FileExistsError):
        write_reference_data(data, path)
    write_reference_data(data, path, overwrite=True)


def test_reference_file_errors_name_the_line(tmp_path) -> None:
    data = make_reference_data("line2d", n_points=4, rng=5)
    path = write_reference_data(data, tmp_path / "l.ref")
    lines = path.read_text().splitlines()
    lines[-2] = "1.0 2.0"
    bad = tmp_path / "bad.ref"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(FileFormatError) as info:
        read_reference_data(bad)
    assert info.value.line == len(lines) - 1
    (tmp_path / "nomagic.ref").write_text("1 2 3\n")
    with pytest.raises(FileFormatError):
        read_reference_data(tmp_path / "nomagic.ref")


@pytest.mark.parametrize("element", ["cone", "cylinder", "sphere", "plane", "line3d", "circle3d_projected"])
def test_nist_style_pair_round_trip(tmp_path, element: str) -> None:
    folder_names = {
        "cone": "Cone",
        "cylinder": "Cylinder",
        "sphere": "Sphere",
        "plane": "Plane",
        "line3d": "Line3d",
        "circle3d_projected": "Circle3d",
    }
    data = make_reference_data(element, form=0.01, offset=400.0, rng=9)
    data_path, _ = write_nist_pair(data, tmp_path / folder_names[element], "x1")
    pair = read_nist_pair(data_path)
    np.testing.assert_allclose(pair.points, data.points, atol=0, rtol=0)
    for name, value in data.parameters.items():
        np.testing.assert_allclose(pair.parameters[name], value, atol=1e-12, rtol=0)
    if element == "cone":
        # s = r cos(alpha), full apex angle in degrees
        assert pair.raw_fit[6] == pytest.approx(data.parameters["radius_at_point"] * np.cos(0.5 * np.pi / 3), abs=1e-12)
        assert pair.raw_fit[7] == pytest.approx(60.0, abs=1e-12)


def test_nist_writer_refuses_torus(tmp_path) -> None:
    with pytest.raises(InvalidInputError):
        write_nist_pair(make_reference_data("torus"), tmp_path / "Torus", "t")


@pytest.mark.slow
@pytest.mark.parametrize("element", ["circle3d", "cone", "torus", "cylinder", "sphere"])
def test_many_seeds_stationary_and_minimum(element: str) -> None:
    """Longer run: random sizes, arcs, forms and poses; gradient zero and brute-force refit at the truth."""
    rng = np.random.default_rng(2024)
    for seed in range(12):
        options = {
            "radius": float(rng.uniform(2.0, 200.0)),
            "arc": float(rng.uniform(np.pi / 3, 2 * np.pi)),
            "form": float(rng.uniform(0.0, 0.05)),
            "offset": float(rng.uniform(0.0, 1000.0)),
        }
        if element == "cone":
            options["half_angle"] = float(rng.uniform(0.1, 1.2))
            options["length"] = options["radius"] / np.tan(options["half_angle"])  # stays below the apex
        if element == "torus":
            options["minor_radius"] = options["radius"] * float(rng.uniform(0.1, 0.6))
        n_points = int(rng.integers(MIN_POINTS[element] + 2, 60))
        data = make_reference_data(element, n_points=n_points, rng=seed, **options)
        fun, truth = _model(data)
        values = np.real(fun(truth.astype(complex)))
        jacobian = _complex_step_jacobian(fun, truth)
        assert np.linalg.norm(jacobian.T @ values) <= 1e-12 * np.linalg.norm(jacobian) * (np.linalg.norm(values) + 1)
        scale = max(1.0, options["radius"])
        np.testing.assert_allclose(_refit(fun, truth), truth, atol=1e-9 * scale, rtol=0)


@pytest.mark.parametrize("element", ["line", "plane", "circle", "sphere", "cylinder", "cone", "torus"])
def test_the_fit_names_make_reference_data_the_fits_recover(element: str) -> None:
    from pcmm_geo import fit

    assert element in fit.ELEMENTS
    data = make_reference_data(element, form=0.001, offset=100.0, rng=5)
    assert data.points.shape[1] == 3  # like pcmm fit ELEMENT on a three-column file
    result = getattr(fit, f"fit_{element}")(data.points)
    for name, value in data.parameters.items():
        if name in ("point", "radius_at_point"):  # axis/line points are located by the data centroid
            continue
        got = np.asarray(getattr(result, name), dtype=float)
        expected = np.asarray(value, dtype=float)
        if name in ("axis", "normal", "direction"):
            got = got * np.sign(got @ expected)
        np.testing.assert_allclose(got, expected, atol=1e-9)


@pytest.mark.parametrize(("element", "options", "kind", "columns"), [
    ("line", {}, "line3d", 3), ("line", {"dims": 2}, "line2d", 2), ("circle", {}, "circle3d", 3),
    ("circle", {"dims": 2}, "circle2d", 2), ("circle", {"method": "projected"}, "circle3d_projected", 3),
    ("line2d", {}, "line2d", 2), ("sphere", {"dims": 3}, "sphere", 3),
])
def test_shared_names_map_to_the_data_kinds(element: str, options: dict, kind: str, columns: int) -> None:
    data = make_reference_data(element, rng=1, **options)
    assert data.element == kind and data.points.shape[1] == columns


@pytest.mark.parametrize("options", [{"element": "plane", "dims": 2}, {"element": "line", "dims": 4},
                                     {"element": "line", "method": "projected"},
                                     {"element": "line2d", "dims": 3}, {"element": "lines"}])
def test_shared_names_refuse_what_does_not_exist(options: dict) -> None:
    element = options.pop("element")
    with pytest.raises(InvalidInputError):
        make_reference_data(element, **options)
