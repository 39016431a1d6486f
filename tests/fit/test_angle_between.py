"""fit.skew.angle_between: the one vector-angle kernel, against 60-digit mpmath and closed forms."""

from __future__ import annotations

import mpmath
import numpy as np
import pytest

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.fit.skew import angle_between


def _reference_angle(first: np.ndarray, second: np.ndarray) -> float:
    with mpmath.workdps(60):
        a = [mpmath.mpf(float(v)) for v in first]
        b = [mpmath.mpf(float(v)) for v in second]
        cross = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
        sine = mpmath.sqrt(sum(c * c for c in cross))
        return float(mpmath.atan2(sine, sum(x * y for x, y in zip(a, b, strict=True))))


@pytest.mark.parametrize("angle", [1e-12, 1e-9, 1e-6, 1e-3, 0.5, 1.5, 3.0, np.pi - 1e-9])
def test_relative_accuracy_at_every_angle(angle: float) -> None:
    rng = np.random.default_rng(7)
    for _ in range(20):
        first = rng.normal(size=3) * 400.0
        axis = np.cross(first, rng.normal(size=3))
        axis /= np.linalg.norm(axis)
        # Rodrigues rotation of `first` about `axis` by `angle` (the stored vector is the rounded one)
        second = first * np.cos(angle) + np.cross(axis, first) * np.sin(angle)
        truth = _reference_angle(first, second)
        # the kernel is relatively accurate: a few ulp of the angle, not of 1 (acos would give ~1e-8 rad at 1e-12)
        assert float(angle_between(first, second)) == pytest.approx(truth, rel=1e-13, abs=0.0)


def test_batch_shapes_and_scale_invariance() -> None:
    first = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]])
    angles = angle_between(first * 1e-5, [[0.0, 3e5, 0.0]])
    np.testing.assert_allclose(angles, [np.pi / 2, 0.0, np.pi / 4], rtol=0, atol=1e-15)
    assert angle_between(np.ones((4, 5, 3)), [1.0, -1.0, 0.5]).shape == (4, 5)


@pytest.mark.parametrize(
    ("first", "second", "fragment"),
    [
        ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], "zero vector"),
        ([1.0, np.nan, 0.0], [1.0, 0.0, 0.0], "NaN"),
        ([1.0, 0.0], [1.0, 0.0], "shape"),
        ([[1.0, 0.0, 0.0]] * 2, [[1.0, 0.0, 0.0]] * 3, "broadcasts"),
    ],
)
def test_bad_input_is_a_typed_error(first: list, second: list, fragment: str) -> None:
    with pytest.raises(InvalidInputError, match=fragment):
        angle_between(first, second)
