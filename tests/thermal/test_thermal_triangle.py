"""Frame triangle under temperature (eqs 4.2-4.9, Table 4.1)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pcmm_geo.errors import InvalidInputError, NoRealSolutionError
from pcmm_geo.thermal import expand_frame, frame_corners, seed_frame_corners


def test_table_4_1() -> None:
    tri = frame_corners(650.0, 650.0, 650.0)
    # Table 4.1 truncates to two decimals: (-375.27, 0), (187.63, 325), (187.63, -325)
    table = {"a": (-375.27, 0.0), "b": (187.63, 325.0), "c": (187.63, -325.0)}
    for name, (x, y) in table.items():
        corner = getattr(tri, name)
        assert abs(corner[0] - x) < 0.01
        assert corner[1] == pytest.approx(y, abs=1e-9)
    # closed form of the equilateral triangle centred on the origin
    assert tri.a[0] == pytest.approx(-650 / math.sqrt(3), abs=1e-12)
    assert tri.b[0] == pytest.approx(650 / (2 * math.sqrt(3)), abs=1e-12)
    assert tri.beta == pytest.approx(math.pi / 3, abs=1e-14)  # printed eq 4.5 would give 120 deg
    assert tri.psi == pytest.approx(math.pi / 6, abs=1e-14)
    assert tri.theta == pytest.approx(0.0, abs=1e-14)


def test_sides_preserved_for_any_temperatures() -> None:
    rng = np.random.default_rng(20261123)
    for _ in range(200):
        temps = rng.uniform(-30.0, 80.0, size=3)
        tri = expand_frame(temps)
        expected = 650.0 * (1.0 + 23.1e-6 * (temps - 20.0))
        np.testing.assert_allclose(tri.side_lengths(), expected, rtol=0, atol=1e-12)
        # boundary conditions: A pinned, B only slides along x
        np.testing.assert_array_equal(tri.a, [-650 / math.sqrt(3), 0.0])
        assert tri.b[1] == 325.0
        # C stays on the -y side of AB (right-handed: cross(AB, AC) < 0)
        ab, ac = tri.b - tri.a, tri.c - tri.a
        assert ab[0] * ac[1] - ab[1] * ac[0] < 0


def test_sides_preserved_for_unequal_triangle() -> None:
    tri = frame_corners(600.0, 700.0, 650.0, a=(10.0, -5.0), b_y=290.0)
    np.testing.assert_allclose(tri.side_lengths(), [600.0, 700.0, 650.0], rtol=0, atol=1e-12)


def test_uniform_expansion_closed_form() -> None:
    # uniform +1 K: equilateral with side L' = 650 (1 + 23.1e-6); b_x = a_x + sqrt(L'^2 - 325^2)
    tri = expand_frame([21.0, 21.0, 21.0])
    side = 650.0 * (1 + 23.1e-6)
    assert tri.b[0] == pytest.approx(-650 / math.sqrt(3) + math.sqrt(side**2 - 325.0**2), abs=1e-12)
    assert tri.b[0] - 650 / (2 * math.sqrt(3)) == pytest.approx(0.015015 * 650 / math.sqrt(650**2 - 325**2), rel=1e-4)


def test_seed_slip_in_eq_4_8() -> None:
    # Appendix E line 141 uses l'_AB in c_y: |BC|^2 = l_BC^2 sin^2(theta) + l_AB^2 cos^2(theta)
    correct = frame_corners(650.0, 650.0, 651.0)
    seed = seed_frame_corners(650.0, 650.0, 651.0)
    theta = correct.theta
    expected_bc = math.sqrt(651.0**2 * math.sin(theta) ** 2 + 650.0**2 * math.cos(theta) ** 2)
    assert seed.side_lengths()[2] == pytest.approx(expected_bc, abs=1e-9)
    assert abs(seed.side_lengths()[2] - 651.0) > 0.9
    same = seed_frame_corners(650.0, 640.0, 650.0)
    np.testing.assert_allclose(same.c, frame_corners(650.0, 640.0, 650.0).c, atol=1e-12)


def test_impossible_frames() -> None:
    with pytest.raises(NoRealSolutionError, match="triangle inequality"):
        frame_corners(650.0, 2000.0, 650.0)
    with pytest.raises(NoRealSolutionError, match=r"eq 4\.4"):
        frame_corners(300.0, 650.0, 650.0)
    with pytest.raises(InvalidInputError, match="positive"):
        frame_corners(-650.0, 650.0, 650.0)
    with pytest.raises(InvalidInputError, match="3 finite"):
        expand_frame([20.0, 20.0])
