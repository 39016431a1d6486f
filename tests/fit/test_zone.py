"""Minimum-zone, MCC and MIC fits against data with known solutions and independent solvers.

Truth: :func:`pcmm_geo.fit.zone.reference.make_minimax_reference` builds data whose optimum
satisfies the KKT conditions with positive multipliers by construction; line and plane zones
are also checked against a brute-force search over the convex hull (the optimum strip /
slab touches a hull edge / facet, or two hull edges), and minimum circumscribed spheres
against trimesh's ``nsphere.minimum_nsphere``.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError, PcmmGeoError, TooFewPointsError
from pcmm_geo.fit import fit_circle, fit_cone, fit_cylinder, fit_line, fit_plane, fit_sphere, fit_torus
from pcmm_geo.fit.zone.reference import make_minimax_reference

ACCURACY = 1e-9  # mm and rad


def _angle(u: np.ndarray, v: np.ndarray) -> float:
    """Angle between two lines (sign-free), accurate for tiny angles."""
    return float(np.arctan2(np.linalg.norm(np.cross(u, v)), abs(float(u @ v))))


def _angle2(u: np.ndarray, v: np.ndarray) -> float:
    return float(np.arctan2(abs(u[0] * v[1] - u[1] * v[0]), abs(float(u @ v))))


def _fit(element: str, points: np.ndarray, criterion: str):
    if element in ("line2d", "line3d"):
        return fit_line(points, criterion=criterion)
    if element in ("circle", "circle3d"):
        return fit_circle(points, criterion=criterion)
    return {"plane": fit_plane, "sphere": fit_sphere, "cylinder": fit_cylinder, "cone": fit_cone}[element](
        points, criterion=criterion
    )


def _errors(element: str, fit, truth: dict) -> dict[str, float]:
    errors: dict[str, float] = {}
    if element in ("circle", "circle3d", "sphere"):
        errors["center"] = float(np.linalg.norm(fit.center - truth["center"]))
        errors["radius"] = abs(fit.radius - truth["radius"])
    if element == "circle3d":
        errors["normal"] = _angle(fit.normal, truth["normal"])
    if element == "line2d":
        errors["direction"] = _angle2(fit.direction, truth["direction"])
        errors["offset"] = abs(float((fit.point - truth["point"]) @ truth["normal"]))
    if element == "plane":
        errors["normal"] = _angle(fit.normal, truth["normal"])
        errors["offset"] = abs(float((fit.point - truth["point"]) @ truth["normal"]))
    if element in ("line3d", "cylinder", "cone"):
        axis = truth["direction"] if element == "line3d" else truth["axis"]
        fitted_axis = fit.direction if element == "line3d" else fit.axis
        errors["axis"] = _angle(fitted_axis, axis)
        shift = fit.point - truth["point"]
        errors["axis_position"] = float(np.linalg.norm(shift - (shift @ axis) * axis))
    if element == "cylinder":
        errors["radius"] = abs(fit.radius - truth["radius"])
    if element == "cone":
        errors["half_angle"] = abs(fit.half_angle - truth["half_angle"])
        errors["apex"] = float(np.linalg.norm(fit.apex - truth["apex"]))
    if fit.criterion == "chebyshev":
        errors["form"] = abs(fit.form - truth["form"])
    return errors


CASES = [
    ("line2d", "chebyshev"),
    ("line3d", "chebyshev"),
    ("plane", "chebyshev"),
    ("circle", "chebyshev"),
    ("circle", "mcc"),
    ("circle", "mic"),
    ("circle3d", "chebyshev"),
    ("circle3d", "mcc"),
    ("circle3d", "mic"),
    ("sphere", "chebyshev"),
    ("sphere", "mcc"),
    ("sphere", "mic"),
    ("cylinder", "chebyshev"),
    ("cylinder", "mcc"),
    ("cylinder", "mic"),
    ("cone", "chebyshev"),
]
#: (n_points, form, offset, narrow extent?)
SETTINGS = [(30, 0.01, 0.0, False), (400, 1e-4, 1000.0, True), (200, 0.5, 1000.0, False)]


def _arc(element: str, criterion: str, narrow: bool) -> float:
    if not narrow:
        return 2 * np.pi if element != "sphere" else np.pi
    if criterion != "chebyshev":
        return 1.1 * np.pi if element != "sphere" else 0.6 * np.pi
    return np.pi / 2 if element != "sphere" else np.pi / 4  # 90 degree arc; 90 degree cap


@pytest.mark.parametrize(("element", "criterion"), CASES)
@pytest.mark.parametrize(("n_points", "form", "offset", "narrow"), SETTINGS)
def test_known_solution(element: str, criterion: str, n_points: int, form: float, offset: float, narrow: bool) -> None:
    for seed in range(2):
        data = make_minimax_reference(
            element,
            criterion,
            n_points=n_points,
            size=10.0,
            form=form,
            offset=offset,
            arc=_arc(element, criterion, narrow),
            rng=seed,
        )
        fit = _fit(element, data.points, criterion)
        assert fit.converged, fit.message
        assert fit.criterion == criterion
        assert fit.certificate is not None and fit.certificate.certified
        assert fit.certificate.kkt_residual <= 1e-8
        assert np.all(fit.certificate.multipliers >= 0)
        errors = _errors(element, fit, data.parameters)
        assert max(errors.values()) <= ACCURACY, errors
        # the support points found are the constructed ones (possibly with zero-multiplier extras)
        assert set(data.contacts.tolist()) <= set(fit.contacts.tolist())


@pytest.mark.parametrize(("element", "n_points"), [("circle", 5), ("sphere", 6), ("plane", 5), ("line2d", 5)])
def test_sparse_data(element: str, n_points: int) -> None:
    data = make_minimax_reference(element, "chebyshev", n_points=n_points, form=0.05, offset=100.0, rng=7)
    fit = _fit(element, data.points, "chebyshev")
    assert fit.converged
    assert max(_errors(element, fit, data.parameters).values()) <= ACCURACY


@pytest.mark.parametrize("criterion", ["chebyshev", "mcc", "mic"])
def test_twenty_thousand_points(criterion: str) -> None:
    data = make_minimax_reference("circle", criterion, n_points=20_000, form=2e-3, offset=1000.0, rng=11)
    fit = fit_circle(data.points, criterion=criterion)
    assert fit.converged
    assert max(_errors("circle", fit, data.parameters).values()) <= ACCURACY


def test_zone_fields_and_mid_zone_element() -> None:
    data = make_minimax_reference("circle", "chebyshev", n_points=100, size=20.0, form=0.02, rng=3)
    fit = fit_circle(data.points, criterion="chebyshev")
    assert fit.r_out - fit.r_in == pytest.approx(0.02, abs=1e-12)
    assert fit.radius == pytest.approx(0.5 * (fit.r_in + fit.r_out), abs=1e-12)
    assert fit.form == pytest.approx(np.ptp(fit.residuals), abs=1e-12)
    assert np.max(np.abs(fit.residuals)) == pytest.approx(0.01, abs=1e-12)
    assert fit.to_dict()["certificate"]["certified"] is True
    gauss = fit_circle(data.points)
    assert gauss.criterion == "gaussian" and gauss.contacts.size == 0 and gauss.certificate is None
    assert np.isnan(gauss.r_in) and np.isnan(gauss.r_out)
    # the minimum zone is never wider than the Gaussian form, and the Gaussian is not the zone here
    assert fit.form <= gauss.form


def test_mcc_matches_trimesh_minimum_nsphere() -> None:
    nsphere = pytest.importorskip("trimesh.nsphere")
    rng = np.random.default_rng(5)
    directions = rng.normal(size=(3000, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    points = directions * rng.uniform(24.9, 25.0, (3000, 1)) + [300.0, -200.0, 100.0]
    fit = fit_sphere(points, criterion="mcc")
    center, radius = nsphere.minimum_nsphere(points)
    assert fit.converged
    # trimesh solves the same convex problem by a different method (Voronoi vertices + LP)
    assert np.linalg.norm(fit.center - center) <= 1e-6
    assert abs(fit.radius - radius) <= 1e-7
    assert fit.radius <= radius + 1e-12  # never larger than an enclosing sphere found independently


def _strip_width_brute_force(points: np.ndarray) -> float:
    """Narrowest strip: the optimum has one side on a hull edge (2-D)."""
    from scipy.spatial import ConvexHull

    hull = points[ConvexHull(points).vertices]
    best = np.inf
    for i in range(len(hull)):
        edge = hull[(i + 1) % len(hull)] - hull[i]
        normal = np.array([-edge[1], edge[0]]) / np.linalg.norm(edge)
        offsets = (hull - hull[i]) @ normal
        best = min(best, float(np.ptp(offsets)))
    return best


def _slab_width_brute_force(points: np.ndarray) -> float:
    """Narrowest slab: a facet with its farthest vertex, or two hull edges on parallel planes."""
    from scipy.spatial import ConvexHull

    hull = ConvexHull(points)
    vertices = points[hull.vertices]
    best = np.inf
    for equation in hull.equations:
        best = min(best, float(np.ptp(vertices @ equation[:3])))
    edges = {tuple(sorted(pair)) for simplex in hull.simplices for pair in itertools.combinations(simplex, 2)}
    edge_list = [(points[a], points[b]) for a, b in edges]
    for (p1, q1), (p2, q2) in itertools.combinations(edge_list, 2):
        normal = np.cross(q1 - p1, q2 - p2)
        norm = np.linalg.norm(normal)
        if norm < 1e-12:
            continue
        normal /= norm
        offsets = vertices @ normal
        low, high = offsets.min(), offsets.max()
        # both edges must lie on the two supporting planes
        on_one = abs(p1 @ normal - low) < 1e-12 or abs(p1 @ normal - high) < 1e-12
        on_other = abs(p2 @ normal - low) < 1e-12 or abs(p2 @ normal - high) < 1e-12
        if on_one and on_other:
            best = min(best, float(high - low))
    return best


@pytest.mark.parametrize("seed", range(4))
def test_line_zone_matches_hull_search(seed: int) -> None:
    rng = np.random.default_rng(seed)
    points = np.c_[rng.uniform(-30, 30, 60), rng.normal(0, 0.02, 60) + 0.001 * rng.uniform(-30, 30, 60) ** 2]
    fit = fit_line(points + 500.0, criterion="chebyshev")
    assert fit.converged
    assert fit.form == pytest.approx(_strip_width_brute_force(points), abs=1e-11)


@pytest.mark.parametrize("seed", range(3))
def test_plane_zone_matches_hull_search(seed: int) -> None:
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-20, 20, (25, 2))
    points = np.c_[xy, rng.normal(0, 0.01, 25) + 1e-4 * (xy**2).sum(axis=1)]
    fit = fit_plane(points - 700.0, criterion="chebyshev")
    assert fit.converged
    assert fit.form == pytest.approx(_slab_width_brute_force(points), abs=1e-11)


def test_line_zone_is_lp_optimal_for_its_normal() -> None:
    """For the reported normal, an independent LP over the two offsets reproduces the width."""
    from scipy.optimize import linprog

    rng = np.random.default_rng(2)
    points = np.c_[rng.uniform(-10, 10, 200), rng.uniform(-0.05, 0.05, 200)]
    fit = fit_line(points, criterion="chebyshev")
    normal = np.array([-fit.direction[1], fit.direction[0]])
    offsets = points @ normal
    # variables (low, high): minimise high - low with low <= offset_i <= high
    rows = np.vstack([np.c_[np.ones(200), np.zeros(200)], np.c_[np.zeros(200), -np.ones(200)]])
    lp = linprog([-1.0, 1.0], A_ub=rows, b_ub=np.concatenate([offsets, -offsets]), bounds=[(None, None)] * 2)
    assert fit.form == pytest.approx(lp.fun, abs=1e-12)


# ---------------------------------------------------------------- bad input


def test_collinear_points_circle_zone() -> None:
    points = np.c_[np.linspace(0, 10, 20), 2 * np.linspace(0, 10, 20)]
    with pytest.raises(DegenerateGeometryError, match="collinear"):
        fit_circle(points, criterion="chebyshev")


def test_too_few_points_and_nan() -> None:
    with pytest.raises(TooFewPointsError) as info:
        fit_sphere(np.eye(3), criterion="mcc")
    assert info.value.needed == 4
    points = np.c_[np.cos(np.arange(8.0)), np.sin(np.arange(8.0))]
    points[3, 1] = np.nan
    with pytest.raises(InvalidInputError, match="finite"):
        fit_circle(points, criterion="mic")


def test_unknown_and_unsupported_criteria() -> None:
    points = np.c_[np.cos(np.arange(8.0)), np.sin(np.arange(8.0)), np.arange(8.0)]
    with pytest.raises(InvalidInputError, match="expected one of 'gaussian', 'chebyshev', 'mcc', 'mic', got 'minmax'"):
        fit_cylinder(points, criterion="minmax")
    with pytest.raises(InvalidInputError, match="for a cone"):
        fit_cone(points, criterion="mcc")
    with pytest.raises(InvalidInputError, match="for a torus"):
        fit_torus(points, criterion="chebyshev")
    with pytest.raises(InvalidInputError, match="weights"):
        fit_circle(points[:, :2], criterion="chebyshev", weights=np.ones(8))


def test_mic_of_an_arc_is_refused() -> None:
    angles = np.linspace(0, np.pi / 2, 30)
    points = np.c_[10 * np.cos(angles), 10 * np.sin(angles)] + 100.0
    with pytest.raises(DegenerateGeometryError, match="do not surround") as info:
        fit_circle(points, criterion="mic")
    assert isinstance(info.value, PcmmGeoError)


def test_reference_generator_input_errors() -> None:
    with pytest.raises(InvalidInputError, match="element"):
        make_minimax_reference("ellipse")
    with pytest.raises(InvalidInputError, match="arc"):
        make_minimax_reference("circle", "mcc", arc=np.pi / 2)
    with pytest.raises(TooFewPointsError):
        make_minimax_reference("cylinder", "chebyshev", n_points=5)


def test_mcc_with_two_diametral_contacts_uses_curvature() -> None:
    """Not a vertex of the linearised problem: the Newton step needs the curvature terms."""
    points = np.array([[10.0, 0.0], [-10.0, 0.0], [0.0, 5.0], [1.0, -6.0], [3.0, 3.0]]) + np.array([250.0, -40.0])
    fit = fit_circle(points, criterion="mcc")
    assert fit.converged, fit.message
    assert fit.contacts.tolist() == [0, 1]
    assert np.linalg.norm(fit.center - [250.0, -40.0]) <= 1e-12
    assert fit.radius == pytest.approx(10.0, abs=1e-12)
    assert fit.certificate.multipliers == pytest.approx([0.5, 0.5], abs=1e-12)


def test_roundness_profiles_batch() -> None:
    from pcmm_geo.fit.zone import roundness_profiles

    sets = [
        make_minimax_reference("circle", "chebyshev", n_points=40, size=3.0, form=form, offset=50.0, rng=k)
        for k, form in enumerate([1e-4, 1e-3, 0.01, 0.05])
    ]
    stack = np.stack([data.points for data in sets])
    stack = np.concatenate([stack, np.full((1, 40, 2), np.nan)])  # a broken profile
    batch = roundness_profiles(stack)
    assert batch.converged.tolist() == [True, True, True, True, False]
    for k, data in enumerate(sets):
        assert np.linalg.norm(batch.center[k] - data.parameters["center"]) <= ACCURACY
        assert abs(batch.form[k] - data.parameters["form"]) <= ACCURACY
        assert set(data.contacts.tolist()) <= set(batch.contacts[k].tolist())
    assert np.isnan(batch.form[4]) and "finite" in batch.messages[4]
    with pytest.raises(InvalidInputError, match="shape"):
        roundness_profiles(np.zeros((3, 2)))


def test_line_zone_is_global_over_hull_edges() -> None:
    """An obtuse triangle: three hull edges, three local minima of the width over the direction."""
    rng = np.random.default_rng(8)
    weights = rng.dirichlet(np.ones(3), 400)
    corners = np.array([[0.0, 0.0], [10.0, 0.0], [12.0, 3.0]])
    points = np.vstack([corners, weights @ corners]) + 250.0
    fit = fit_line(points, criterion="chebyshev")
    assert fit.converged
    # narrowest strip: along the side (0,0)-(12,3), width 2 * area / |side| = 30 / sqrt(153)
    assert fit.form == pytest.approx(30.0 / np.sqrt(153.0), abs=1e-12)
    assert _angle2(fit.direction, np.array([12.0, 3.0]) / np.sqrt(153.0)) <= ACCURACY
    assert fit.form == pytest.approx(_strip_width_brute_force(points), abs=1e-12)


@pytest.mark.parametrize("seed", range(4))
def test_random_measured_like_data_is_certified(seed: int) -> None:
    """Lobed, noisy partial features far from the origin: every criterion certifies, and is consistent."""
    rng = np.random.default_rng(100 + seed)
    n_points = int(rng.integers(10, 300))
    noise = 10 ** rng.uniform(-4, -1.5)
    angles = rng.uniform(0, rng.uniform(np.pi / 2, 2 * np.pi), n_points)
    radii = 10 + noise * np.cos(int(rng.integers(2, 8)) * angles) + rng.normal(0, noise / 3, n_points)
    heights = rng.uniform(0, 30, n_points)
    ring = np.c_[radii * np.cos(angles), radii * np.sin(angles)] + rng.uniform(-1000, 1000, 2)
    tube = np.c_[radii * np.cos(angles), radii * np.sin(angles), heights] + rng.uniform(-1000, 1000, 3)
    for fit_function, points in ((fit_circle, ring), (fit_cylinder, tube)):
        gauss = fit_function(points)
        zone = fit_function(points, criterion="chebyshev")
        mcc = fit_function(points, criterion="mcc")
        assert zone.converged and mcc.converged, (zone.message, mcc.message)
        assert zone.form <= gauss.form + 1e-12  # the minimum zone is never wider than the Gaussian zone
        assert np.ptp(zone.residuals) == pytest.approx(zone.form, abs=1e-12)  # every point inside
        assert np.max(mcc.residuals) <= 1e-12  # the circumscribed element encloses every point
        assert mcc.radius <= gauss.radius + np.max(gauss.residuals) + 1e-12  # no larger than the Gaussian's


def test_decide_form_rests_on_value_and_proven_bound() -> None:
    from pcmm_geo.fit.zone.form import decide_form

    assert decide_form(0.010, 0.010, 0.010) == "PASS"  # on the limit counts as within
    assert decide_form(0.0100001, 0.0100001, 0.010) == "FAIL"
    assert decide_form(0.012, 0.0099, 0.010) == "NOT PROVEN"
    assert decide_form(0.012, float("nan"), 0.010) == "NOT PROVEN"
    assert decide_form(0.012, 0.0101, 0.010) == "FAIL"
    with pytest.raises(InvalidInputError, match="tolerance"):
        decide_form(0.01, 0.01, 0.0)
    with pytest.raises(InvalidInputError, match="value"):
        decide_form(float("nan"), 0.01, 0.01)


def test_evaluate_form_states_scope_bound_and_domain() -> None:
    from pcmm_geo.fit.zone import evaluate_form

    data = make_minimax_reference("plane", "chebyshev", n_points=50, size=30.0, form=0.02, offset=200.0, rng=4)
    within = evaluate_form(data.points, "plane", tolerance=0.021)
    assert within.verdict == "PASS" and within.passed is True
    assert within.scope == "global" and within.domain == "all planes"
    assert abs(within.bound - 0.02) <= 1e-9 and within.gap <= 1e-9
    beyond = evaluate_form(data.points, "plane", tolerance=0.019)
    assert beyond.verdict == "FAIL" and beyond.passed is False
    summary = beyond.to_dict()
    assert summary["verdict"] == "FAIL" and summary["scope"] == "global" and "NOT PROVEN" in summary["decision_rule"]
    assert evaluate_form(data.points, "plane").verdict == "no tolerance"
