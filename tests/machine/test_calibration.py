"""Tetrahedron calibration on synthetic probings of a machine with known (skewed) geometry."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.errors import CalibrationError, DegenerateGeometryError, InvalidInputError, OutputExistsError
from pcmm_geo.machine.calibration import b_in_from_lasers, calibrate_tetrahedron
from pcmm_geo.machine.calibration.probings import write_lasers_csv, write_probings_csv

ARMS = ("a", "b", "c")
PAIRS = ("ab", "bc", "ca")
TIP = np.array([10.0, -5.0, 3.0])
RADIUS = 6.35
LASERS = np.array([[50.0, 130.0, 135.0], [25.0, 60.0, 70.0], [12.0, 3.0, 2.0]])


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def truth(skewed: bool = True) -> dict:
    """Slider lines leaving the tip upwards like the seed's arms, offset sideways when skewed."""
    directions = [_unit([-0.66, 0.0, 0.75]), _unit([0.33, 0.57, 0.75]), _unit([0.33, -0.57, 0.75])]
    sideways = [np.array([0.0, 12.0, 0.0]), np.array([-8.0, 4.0, 0.0]), np.array([5.0, 6.0, 0.0])]
    feet = []
    for w, side in zip(directions, sideways, strict=True):
        side = side - (side @ w) * w  # perpendicular to the line
        feet.append(TIP + (side if skewed else 0.0))
    scales = [1.02, 0.97, 1.0] if skewed else [1.0, 1.0, 1.0]
    offsets = [371.0, 365.0, 372.5]
    joints = np.array(
        [[feet[k] + (scales[k] * LASERS[p, k] + offsets[k]) * directions[k] for k in range(3)] for p in range(3)]
    )
    return {"directions": directions, "feet": feet, "scales": scales, "offsets": offsets, "joints": joints}


def sphere_points(centre, count: int, rng, sigma: float) -> np.ndarray:
    """Points on a ball spread over more than a hemisphere (as a CMM can reach a joint), plus noise."""
    golden = np.pi * (3.0 - np.sqrt(5.0))
    k = np.arange(count)
    z = 1.0 - 1.6 * (k + 0.5) / count  # polar range down to ~127 degrees
    r = np.sqrt(1.0 - z**2)
    unit = np.c_[r * np.cos(golden * k), r * np.sin(golden * k), z]
    return centre + RADIUS * unit + rng.normal(0.0, sigma, (count, 3)) if sigma else centre + RADIUS * unit


def probings(geometry: dict, sigma: float = 0.0, seed: int = 7, count: int = 12) -> dict:
    rng = np.random.default_rng(seed)
    data = {("tip", None): sphere_points(TIP, count, rng, sigma)}
    for p in range(3):
        for k, arm in enumerate(ARMS):
            data[(f"joint_{arm}", p + 1)] = sphere_points(geometry["joints"][p, k], count, rng, sigma)
    return data


@pytest.fixture(scope="module")
def skewed():
    geometry = truth(skewed=True)
    return geometry, calibrate_tetrahedron(probings(geometry), LASERS)


def test_noise_free_round_trip_recovers_lines_scales_and_tip(skewed):
    geometry, cal = skewed
    np.testing.assert_allclose(cal.tip_center, TIP, atol=1e-6)
    assert cal.tip.radius == pytest.approx(RADIUS, abs=1e-6)
    for k, arm in enumerate(ARMS):
        line = cal.slider_lines[arm]
        np.testing.assert_allclose(line.direction, geometry["directions"][k], atol=1e-6)
        np.testing.assert_allclose(line.point, geometry["feet"][k], atol=1e-6)
        assert line.laser_scale == pytest.approx(geometry["scales"][k], abs=1e-6)
        assert line.laser_offset == pytest.approx(geometry["offsets"][k], abs=1e-6)
        assert line.straightness < 1e-6
        assert line.tip_offset == pytest.approx(np.linalg.norm(geometry["feet"][k] - TIP), abs=1e-6)
        forms = cal.sphere_forms[arm]
        assert np.all(forms < 1e-6)
    # the rigid-body model reproduces the joints at the calibration readings
    tetra = cal.tetrahedron
    for k, arm in enumerate(ARMS):
        np.testing.assert_allclose(tetra.sliders[arm].joint(LASERS[:, k]), geometry["joints"][:, k], atol=1e-6)
    np.testing.assert_allclose(tetra.tip_center, TIP, atol=1e-6)


def test_seed_parameters_from_the_true_geometry(skewed):
    geometry, cal = skewed
    joints = geometry["joints"]
    for k, arm in enumerate(ARMS):
        expected = np.linalg.norm(joints[:, k] - TIP, axis=1) - LASERS[:, k] - 60.0  # eq 7.3
        np.testing.assert_allclose(cal.dead_distance_per_position[arm], expected, atol=1e-6)
        assert cal.dead_distance[arm] == pytest.approx(expected.mean(), abs=1e-6)
    for k, pair in enumerate(PAIRS):
        u = joints[:, k] - TIP
        v = joints[:, (k + 1) % 3] - TIP
        cosine = np.einsum("ij,ij->i", u, v) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))
        expected = np.arccos(cosine)  # radians
        np.testing.assert_allclose(cal.beta_per_position[pair], expected, atol=1e-8)
        assert cal.beta[pair] == pytest.approx(expected.mean(), abs=1e-8)
        assert cal.beta_deg[pair] == pytest.approx(np.degrees(expected.mean()), abs=1e-6)


def test_skew_distances_closed_form(skewed):
    geometry, cal = skewed
    for k, pair in enumerate(PAIRS):
        j = (k + 1) % 3
        w1, w2 = geometry["directions"][k], geometry["directions"][j]
        normal = np.cross(w1, w2)
        expected = abs((geometry["feet"][j] - geometry["feet"][k]) @ normal) / np.linalg.norm(normal)
        assert cal.skew_distances[pair] == pytest.approx(expected, abs=1e-6)
    assert min(cal.skew_distances.values()) > 1.0  # really skewed


def test_probe_point_is_stationary_for_the_sum_of_squared_distances(skewed):
    geometry, cal = skewed

    def cost(x):
        total = 0.0
        for k in range(3):
            offset = x - geometry["feet"][k]
            w = geometry["directions"][k]
            total += offset @ offset - (offset @ w) ** 2
        return total

    best = cost(cal.probe_point)
    for step in np.eye(3) * 1e-3:
        assert cost(cal.probe_point + step) > best
        assert cost(cal.probe_point - step) > best


def test_lines_through_the_tip_are_the_seed_special_case():
    geometry = truth(skewed=False)
    sweep = np.array([[40.0, 40.0, 40.0], [10.0, 80.0, 20.0], [90.0, 5.0, 60.0], [30.0, 30.0, 100.0]])
    cal = calibrate_tetrahedron(probings(geometry), LASERS, laser_sweep=sweep)
    np.testing.assert_allclose(cal.probe_point, TIP, atol=1e-6)
    np.testing.assert_allclose(cal.probe_point_pairwise, TIP, atol=1e-6)
    assert max(cal.skew_distances.values()) < 1e-6
    for k, arm in enumerate(ARMS):
        # dead distance constant: offset - 60 for unit laser scale
        np.testing.assert_allclose(cal.dead_distance_per_position[arm], geometry["offsets"][k] - 60.0, atol=1e-6)
    # b_in (eq 7.5) = smallest joint-to-joint distance over the sweep when the lines meet at the tip
    joints = np.stack(
        [TIP + (sweep[:, k] + geometry["offsets"][k])[:, None] * geometry["directions"][k] for k in range(3)], axis=1
    )
    for k, pair in enumerate(PAIRS):
        expected = np.linalg.norm(joints[:, k] - joints[:, (k + 1) % 3], axis=1)
        assert cal.b_in[pair] == pytest.approx(expected.min(), abs=1e-6)
        assert cal.b_in_sweep_index[pair] == int(np.argmin(expected))


def test_b_in_closed_form_equilateral():
    b, index = b_in_from_lasers([[40.0, 40.0, 40.0], [45.0, 45.0, 45.0]], dict.fromkeys(ARMS, 0.0),
                                dict.fromkeys(PAIRS, 60.0))
    assert all(value == pytest.approx(100.0, abs=1e-12) for value in b.values())
    assert set(index.values()) == {0}


@pytest.mark.parametrize("sigma", [1e-4, 1e-3])
def test_error_grows_with_probing_noise(sigma):
    """Seeded noise on every probed point: errors grow linearly with sigma.

    Measured (12 points per sphere, 3 slider positions, worst of 20 seeds), in units of
    the probing noise sigma: tip centre 1.5 sigma, slider direction 0.065 sigma/mm, laser
    scale 0.035 sigma/mm, laser offset 2.0 sigma, dead distance 1.8 sigma, beta
    0.35 sigma deg/mm -- identical ratios at sigma = 1e-4, 1e-3 and 1e-2 mm.
    """
    geometry = truth(skewed=True)
    cal = calibrate_tetrahedron(probings(geometry, sigma=sigma, seed=11), LASERS)
    assert np.linalg.norm(cal.tip_center - TIP) < 5 * sigma
    for k, arm in enumerate(ARMS):
        line = cal.slider_lines[arm]
        assert np.linalg.norm(line.direction - geometry["directions"][k]) < 0.5 * sigma
        assert line.laser_scale == pytest.approx(geometry["scales"][k], abs=0.5 * sigma)
        assert line.laser_offset == pytest.approx(geometry["offsets"][k], abs=10 * sigma)
        assert 0.0 < line.straightness < 10 * sigma
        assert np.all(cal.sphere_forms[arm] > sigma)  # noise shows as form error
    exact = calibrate_tetrahedron(probings(geometry), LASERS)
    for arm in ARMS:
        assert abs(cal.dead_distance[arm] - exact.dead_distance[arm]) < 10 * sigma
    for pair in PAIRS:
        assert abs(cal.beta_deg[pair] - exact.beta_deg[pair]) < 2 * sigma


def test_csv_round_trip_gives_the_same_calibration(tmp_path, skewed):
    geometry, cal = skewed
    probe_file = write_probings_csv(tmp_path / "probings.csv", probings(geometry))
    laser_file = write_lasers_csv(tmp_path / "lasers.csv", (1, 2, 3), LASERS)
    from_files = calibrate_tetrahedron(probe_file, laser_file)
    for arm in ARMS:
        assert from_files.dead_distance[arm] == pytest.approx(cal.dead_distance[arm], abs=1e-12)
    with pytest.raises(OutputExistsError):
        write_lasers_csv(laser_file, (1, 2, 3), LASERS)


def test_array_forms_of_the_inputs(skewed):
    geometry, cal = skewed
    pts = probings(geometry)
    nested = {f"joint_{arm}": [pts[(f"joint_{arm}", p)] for p in (1, 2, 3)] for arm in ARMS}
    nested["tip"] = pts[("tip", None)]
    laser_map = {p + 1: LASERS[p] for p in range(3)}
    other = calibrate_tetrahedron(nested, laser_map)
    assert other.beta == pytest.approx(cal.beta, abs=1e-12)


def test_fixed_laser_scale_fits_only_offsets():
    geometry = truth(skewed=False)
    cal = calibrate_tetrahedron(probings(geometry), LASERS, laser_scale=1.0)
    for k, arm in enumerate(ARMS):
        assert cal.slider_lines[arm].laser_scale == 1.0
        assert cal.slider_lines[arm].laser_offset == pytest.approx(geometry["offsets"][k], abs=1e-6)


def test_bad_inputs_raise_typed_errors(skewed):
    geometry, _ = skewed
    pts = probings(geometry)
    with pytest.raises(CalibrationError, match="laser readings for slider positions"):
        calibrate_tetrahedron(pts, {1: LASERS[0], 2: LASERS[1]})
    with pytest.raises(CalibrationError, match="change between slider positions"):
        calibrate_tetrahedron(pts, np.tile(LASERS[0], (3, 1)))
    with pytest.raises(InvalidInputError, match="shape"):
        calibrate_tetrahedron(pts, LASERS[:, :2])
    without_tip = {k: v for k, v in pts.items() if k[0] != "tip"}
    with pytest.raises(CalibrationError, match="tip"):
        calibrate_tetrahedron(without_tip, LASERS)
    few = dict(pts)
    few[("joint_b", 2)] = pts[("joint_b", 2)][:3]
    with pytest.raises(CalibrationError, match="joint_b position 2"):
        calibrate_tetrahedron(few, LASERS)
    same = dict(pts)
    for p in (2, 3):
        same[("joint_a", p)] = pts[("joint_a", 1)]
    with pytest.raises(DegenerateGeometryError):
        calibrate_tetrahedron(same, LASERS)
    with pytest.raises(InvalidInputError):
        calibrate_tetrahedron(42, LASERS)
    with pytest.raises(InvalidInputError, match="datum"):
        calibrate_tetrahedron(pts, LASERS, datum_plane=np.zeros((4, 3)))


def test_calibrated_tetrahedron_drives_the_rigid_body_model(skewed):
    """Forward kinematics with the calibrated tetrahedron equals that of the true one."""
    from pcmm_geo.machine.kinematics.model import RigidBodyMachine, SliderLine, Tetrahedron

    geometry, cal = skewed
    sliders = {
        arm: SliderLine(geometry["feet"][k], geometry["directions"][k], geometry["scales"][k], geometry["offsets"][k])
        for k, arm in enumerate(ARMS)
    }
    columns = RigidBodyMachine.from_dpkm().columns
    level = np.full(3, 400.0)  # pivots about 400 mm up: inside the seed's column travel (277-727 mm)
    true_machine = RigidBodyMachine(Tetrahedron(sliders, TIP), columns, reference_heights=level)
    calibrated = RigidBodyMachine(cal.tetrahedron, columns, reference_heights=level)
    tips = np.array([[0.0, 0.0, 50.0], [-20.0, 30.0, 30.0]])
    readings = true_machine.inverse(tips)
    assert np.all(readings.converged)
    solved = calibrated.forward(lasers=readings.lasers, heights=readings.heights)
    np.testing.assert_allclose(solved.tip, tips, atol=1e-6)
    lasers_only = calibrated.forward(lasers=readings.lasers)
    np.testing.assert_allclose(lasers_only.tip, true_machine.forward(lasers=readings.lasers).tip, atol=1e-6)


def test_column_lines_from_probed_pivot_points():
    from pcmm_geo.machine.calibration.columns import calibrate_columns

    rng = np.random.default_rng(5)
    readings = np.array([0.0, 40.0, 80.0])
    bases = {"a": (-268.0, 0.8), "b": (123.3, 231.8), "c": (129.6, -231.5)}
    slope = (0.003, -0.002)
    points = {}
    for arm, (g, m) in bases.items():
        z = 380.0 + readings
        centres = np.c_[g + slope[0] * z, m + slope[1] * z, z]
        points[arm] = [sphere_points(c, 10, rng, 0.0) for c in centres]
    cal = calibrate_columns(points, {arm: readings * np.sqrt(1 + slope[0] ** 2 + slope[1] ** 2) for arm in ARMS})
    for arm, (g, m) in bases.items():
        assert cal.intercepts[arm] == pytest.approx((g, m), abs=1e-6)
        assert cal.slopes[arm] == pytest.approx(slope, abs=1e-9)
        assert cal.encoder_scale[arm] == pytest.approx(1.0, abs=1e-9)
