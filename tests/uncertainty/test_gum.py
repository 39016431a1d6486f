"""GUM linear propagation against GTC and ``uncertainties`` (independent implementations) and closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.uncertainty import coverage_factor, jacobian, propagate, propagate_covariance, welch_satterthwaite


def test_propagate_matches_gtc_with_welch_satterthwaite() -> None:
    import GTC as gtc  # the GUM Tree Calculator: an independent implementation of the GUM
    a = gtc.ureal(20.0, 0.01, 4, label="a")
    b = gtc.ureal(10.0, 0.02, 12, label="b")
    y = a * b / (a + b)
    result = propagate(lambda v: v[0] * v[1] / (v[0] + v[1]), [20.0, 10.0], [0.01, 0.02], dof=[4, 12])
    assert result.value == pytest.approx(gtc.value(y), rel=1e-12)
    assert result.standard_uncertainty == pytest.approx(gtc.uncertainty(y), rel=1e-7)
    assert result.dof == pytest.approx(gtc.dof(y), rel=1e-6)
    from scipy import stats

    assert result.coverage_factor == pytest.approx(stats.t.ppf(0.975, gtc.dof(y)), rel=1e-6)


def test_propagate_with_correlation_matches_uncertainties_package() -> None:
    import uncertainties as unc
    cov = [[0.01, 0.006], [0.006, 0.04]]
    x1, x2 = unc.correlated_values([1.5, 2.0], cov)
    reference = (x1 * x2 + x1**2).s
    result = propagate(lambda v: v[0] * v[1] + v[0] ** 2, [1.5, 2.0], cov, names=["x1", "x2"])
    assert result.standard_uncertainty == pytest.approx(reference, rel=1e-7)
    assert sum(entry.share for entry in result.budget) == pytest.approx(1.0, abs=1e-12)


def test_budget_lines_closed_form() -> None:
    # y = 3 a - 2 b: c = (3, -2), u_i(y) = |c_i| u_i
    result = propagate(lambda v: 3 * v[0] - 2 * v[1], [1.0, 1.0], [0.1, 0.3], names=["a", "b"])
    a, b = result.budget
    assert (a.sensitivity, b.sensitivity) == pytest.approx((3.0, -2.0), abs=1e-9)
    assert (a.contribution, b.contribution) == pytest.approx((0.3, 0.6), abs=1e-12)
    assert a.share == pytest.approx(0.09 / 0.45, abs=1e-12)
    assert result.expanded_uncertainty == pytest.approx(1.959964 * math.sqrt(0.45), rel=1e-6)
    assert result.coverage_interval[0] == pytest.approx(1.0 - result.expanded_uncertainty, abs=1e-12)


def test_propagate_covariance_rotation_is_exact() -> None:
    # a rotation by 30 deg is linear: U_y = R U_x R^T exactly
    angle = math.radians(30.0)
    rot = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
    cov_x = np.array([[4e-6, 1e-6], [1e-6, 9e-6]])
    _, cov_y, jac = propagate_covariance(lambda v: rot @ v, [3.0, 4.0], cov_x)
    np.testing.assert_allclose(jac, rot, atol=1e-9)
    np.testing.assert_allclose(cov_y, rot @ cov_x @ rot.T, atol=1e-15)


def test_helpers_and_errors() -> None:
    _, jac = jacobian(lambda v: np.array([np.sin(v[0]), v[0] * v[1]]), [0.3, 2.0])
    np.testing.assert_allclose(jac, [[math.cos(0.3), 0.0], [2.0, 0.3]], atol=1e-8)
    assert welch_satterthwaite([0.1, 0.2], [math.inf, math.inf]) == math.inf
    assert coverage_factor(math.inf, 0.99) == pytest.approx(2.5758, abs=1e-4)
    with pytest.raises(InvalidInputError, match="positive semi-definite"):
        propagate(lambda v: v[0], [1.0, 2.0], [[1.0, 2.0], [2.0, 1.0]])
    with pytest.raises(InvalidInputError, match="uncertainty"):
        propagate(lambda v: v[0], [1.0, 2.0], [0.1, -0.1])
    with pytest.raises(InvalidInputError, match="x"):
        propagate(lambda v: v[0], [1.0, math.nan], [0.1, 0.1])
