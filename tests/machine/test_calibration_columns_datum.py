"""Column lines from probed pivots (eqs 2.19-2.20) and the datum frame (thesis 7.1) on known synthetic geometry."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.machine.calibration.columns import calibrate_columns
from pcmm_geo.machine.calibration.datum import datum_frame

ARMS = ("a", "b", "c")


def ball_points(centre: np.ndarray, radius: float, count: int) -> np.ndarray:
    """Noise-free points on a spiral over the upper 3/4 of a ball, as a CMM reaches a pivot."""
    golden = np.pi * (3.0 - np.sqrt(5.0))
    k = np.arange(count)
    z = 1.0 - 1.5 * (k + 0.5) / count
    ring = np.sqrt(1.0 - z**2)
    return centre + radius * np.c_[ring * np.cos(golden * k), ring * np.sin(golden * k), z]


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def test_tilted_column_lines_and_encoder_scales_from_pivot_probings():
    # three columns, each tilted its own way, with its own encoder scale (distance along the column per reading)
    truth = {
        "a": (np.array([-268.0, 0.8, 380.0]), np.array([0.004, -0.0025, 1.0]), 1.0008),
        "b": (np.array([123.3, 231.8, 372.0]), np.array([-0.003, 0.0015, 1.0]), 0.9991),
        "c": (np.array([129.6, -231.5, 390.0]), np.array([0.0012, 0.005, 1.0]), 1.0003),
    }
    readings = np.array([0.0, 30.0, 65.0, 100.0])
    points, true_pivots = {}, {}
    for arm, (start, slope, scale) in truth.items():
        direction = slope / np.linalg.norm(slope)
        true_pivots[arm] = start + scale * readings[:, None] * direction
        points[arm] = [ball_points(centre, 6.35, 12) for centre in true_pivots[arm]]
    cal = calibrate_columns(points, {arm: readings for arm in ARMS})
    for arm, (start, slope, scale) in truth.items():
        # eqs 2.19-2.20: x = g + h z, y = m + n z; the line crosses z = 0 at (g, m)
        h, n = slope[0] / slope[2], slope[1] / slope[2]
        g, m = start[0] - h * start[2], start[1] - n * start[2]
        assert cal.slopes[arm] == pytest.approx((h, n), abs=1e-9)
        assert cal.intercepts[arm] == pytest.approx((g, m), abs=1e-6)
        assert cal.encoder_scale[arm] == pytest.approx(scale, abs=1e-9)
        assert cal.straightness[arm] < 1e-6
        np.testing.assert_allclose(cal.direction(arm), slope / np.linalg.norm(slope), atol=1e-9)
        np.testing.assert_allclose(cal.centres[arm], true_pivots[arm], atol=1e-6)
        # the rigid-body column line puts the pivot where it truly is, also between and beyond the probed heights
        other = np.array([-20.0, 12.5, 47.0, 140.0])
        direction = slope / np.linalg.norm(slope)
        np.testing.assert_allclose(cal.columns[arm].pivot(other), start + scale * other[:, None] * direction,
                                   atol=1e-6)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_datum_frame_of_a_random_pose_is_recovered(seed):
    """A face z' = 0 and a hole along z' in a frame with a random rotation and translation in the CMM."""
    rng = np.random.default_rng(seed)
    to_cmm = random_rotation(rng)
    shift = rng.uniform(-300.0, 300.0, 3)
    hole_xy = rng.uniform(-20.0, 20.0, 2)
    radius = 4.0

    def cmm(local: np.ndarray) -> np.ndarray:
        return local @ to_cmm.T + shift

    plane_local = np.c_[rng.uniform(-60.0, 60.0, (25, 2)), np.zeros(25)]
    turns = np.linspace(0.0, 2 * np.pi, 8, endpoint=False)
    depths = np.repeat([-2.0, -6.0, -10.0, -14.0], turns.size)
    hole_local = np.c_[hole_xy[0] + radius * np.cos(np.tile(turns, 4)),
                       hole_xy[1] + radius * np.sin(np.tile(turns, 4)), depths]
    # the reference fixes x: above the face, straight out along +x' from the hole
    reference_local = np.array([hole_xy[0] + 150.0, hole_xy[1], 80.0])
    frame = datum_frame(cmm(plane_local), cmm(hole_local), x_towards=cmm(reference_local))
    # truth: axes = the columns of to_cmm (rows of the datum rotation), origin where the hole meets the face
    np.testing.assert_allclose(frame.rotation, to_cmm.T, atol=1e-9)
    np.testing.assert_allclose(frame.origin, cmm(np.array([*hole_xy, 0.0])), atol=1e-9)
    assert frame.hole_radius == pytest.approx(radius, abs=1e-9)
    assert frame.plane_form < 1e-9
    # any point maps to its local coordinates measured from the hole
    probe = rng.uniform(-100.0, 100.0, (10, 3))
    np.testing.assert_allclose(frame.apply(cmm(probe)), probe - [*hole_xy, 0.0], atol=1e-9)
