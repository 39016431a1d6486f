"""Member expansion (eq 4.1) and the seed's faulty delta_l (erratum 5)."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.thermal import delta_l, expanded_length, seed_delta_l


def test_delta_l_hand_values() -> None:
    # 650 mm aluminium side, +1 K: 23.1e-6 * 650 = 0.015015 mm
    assert delta_l(650.0, 1.0) == pytest.approx(0.015015, abs=1e-15)
    # 100 mm steel gauge block, -2 K
    assert delta_l(100.0, -2.0, alpha=11.5e-6) == pytest.approx(-0.0023, abs=1e-15)


def test_delta_l_broadcasts() -> None:
    out = delta_l(np.array([100.0, 200.0, 400.0]), np.array([[1.0], [2.0]]), alpha=1e-5)
    assert out.shape == (2, 3)
    np.testing.assert_allclose(out, [[1e-3, 2e-3, 4e-3], [2e-3, 4e-3, 8e-3]], rtol=1e-14)


def test_expanded_length() -> None:
    assert expanded_length(100.0, 25.0, alpha=11.5e-6) == pytest.approx(100.00575, abs=1e-12)
    assert expanded_length(100.0, 20.0) == 100.0


def test_seed_delta_l_ignores_length() -> None:
    # Appendix E: alpha * 10 * dT whatever the length
    assert seed_delta_l(650.0, 20.0, 21.0) == pytest.approx(23.1e-5, abs=1e-18)
    assert seed_delta_l(10.0, 20.0, 21.0) == seed_delta_l(4000.0, 20.0, 21.0)
    # it coincides with eq 4.1 only for a 10 mm member
    assert seed_delta_l(10.0, 293.15, 294.15) == pytest.approx(delta_l(10.0, 1.0), rel=1e-12)
    ratio = delta_l(650.0, 1.0) / seed_delta_l(650.0, 20.0, 21.0)
    assert ratio == pytest.approx(65.0, rel=1e-12)


def test_bad_input() -> None:
    with pytest.raises(InvalidInputError, match="finite"):
        delta_l(np.nan, 1.0)
    with pytest.raises(InvalidInputError, match="expected"):
        delta_l("abc", 1.0)
