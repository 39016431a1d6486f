"""Nearly parallel lines against 60-digit truth (mpmath), down to 1e-8 rad.

The truth is computed from the *same float64 inputs* in 60-digit arithmetic, so any error
is the algorithm's.  Tolerances follow float64 conditioning:

* closest points: the only unavoidable rounding is that of ``p_b - p_a`` (``|p| eps``),
  which moves the closest points by up to ``|p| eps / angle``.  Achieved: 3e-13 mm at
  1e-3 rad ... 9e-9 mm at 1e-8 rad (lines 1 mm apart crossing 1000 mm away, 500 mm off the
  origin), about 1e-3 of that bound; the former ``1 - cos^2`` formula was 1000 mm off at
  1e-8 rad.
* nearest point to K lines: a backward-stable least-squares solver has an error of about
  ``kappa |x| eps + kappa^2 |r| eps`` (``kappa ~ 1 / angle``, ``|r|`` the residual).  For
  lines through one point (``r = 0``) the achieved error is below ``0.3 * 1000 eps / angle``
  (6e-6 mm at 1e-8 rad); lines 1 mm apart add the ``kappa^2`` term
  (7e-7 mm at 1e-5 rad, 3e-5 mm at 1e-6 rad).
"""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest

from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError, TooFewPointsError
from pcmm_geo.fit import closest_points, nearest_point_to_lines

EPS = float(np.finfo(float).eps)
ANGLES = [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8]


def _rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


def _mp(vector: np.ndarray) -> mp.matrix:
    return mp.matrix([mp.mpf(float(x)) for x in vector])


def _truth_pair(pa, da, pb, db) -> tuple[mp.matrix, mp.matrix]:
    with mp.workdps(60):
        pa, da, pb, db = map(_mp, (pa, da, pb, db))
        da, db = da / mp.norm(da), db / mp.norm(db)
        w = pb - pa
        c, along_a, along_b = (da.T * db)[0], (w.T * da)[0], (w.T * db)[0]
        den = 1 - c * c
        return pa + (along_a - c * along_b) / den * da, pb + (c * along_a - along_b) / den * db


def _truth_nearest(points, directions) -> mp.matrix:
    with mp.workdps(60):
        normal, rhs = mp.zeros(3, 3), mp.zeros(3, 1)
        for p, d in zip(points, directions, strict=True):
            d = _mp(d)
            d = d / mp.norm(d)
            projector = mp.eye(3) - d * d.T
            normal += projector
            rhs += projector * _mp(p)
        return mp.lu_solve(normal, rhs)


def _error(computed: np.ndarray, truth: mp.matrix) -> float:
    with mp.workdps(60):
        return float(mp.norm(_mp(computed) - truth))


@pytest.mark.parametrize("angle", ANGLES)
def test_closest_points_of_nearly_parallel_lines_match_60_digit_truth(angle: float) -> None:
    worst = 0.0
    for seed in range(6):
        rng = np.random.default_rng(seed)
        rotation, shift = _rotation(rng), rng.uniform(-500, 500, 3)
        # 1 mm apart, projections crossing 1000 mm from the given points
        db = np.array([np.cos(angle), np.sin(angle), 0.0])
        pa, da, pb = np.zeros(3), np.array([1.0, 0.0, 0.0]), np.array([1000.0, 0.0, 1.0]) - 1000.0 * db
        pa, pb = rotation @ pa + shift, rotation @ pb + shift
        da, db = rotation @ da * 3.7, rotation @ db * 0.2  # arbitrary lengths
        pair = closest_points(pa, da, pb, db)
        assert not pair.parallel
        truth_a, truth_b = _truth_pair(pa, da, pb, db)
        worst = max(worst, _error(pair.point_a, truth_a), _error(pair.point_b, truth_b))
        assert abs(float(pair.distance) - 1.0) <= 1e-9
    bound = 1500.0 * EPS / angle  # |p| eps / angle, |p| <= 1500 mm
    assert worst <= bound
    assert worst <= 5e-8  # achieved: 9e-9 mm at 1e-8 rad


def test_closest_points_exactly_parallel_and_at_1e_12_rad() -> None:
    pair = closest_points([0, 0, 0], [1, 0, 0], [5, 0, 2], [2, 0, 0])
    assert bool(pair.parallel) and float(pair.distance) == pytest.approx(2.0, abs=1e-15)
    tilted = closest_points([0, 0, 0], [1, 0, 0], [0, 0, 1], [1, 1e-12, 0])
    assert not tilted.parallel  # resolvable in float64: not declared parallel
    assert float(tilted.distance) == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("separation", [0.0, 1.0])
@pytest.mark.parametrize("angle", ANGLES)
def test_nearest_point_to_nearly_parallel_lines_match_60_digit_truth(angle: float, separation: float) -> None:
    worst = 0.0
    for seed in range(4):
        rng = np.random.default_rng(seed)
        rotation, shift = _rotation(rng), rng.uniform(-500, 500, 3)
        points, directions = [], []
        for turn, height in ((0.0, 0.0), (angle, separation), (-0.7 * angle, -0.6 * separation)):
            d = np.array([np.cos(turn), np.sin(turn), 0.0])
            points.append(rotation @ (np.array([1000.0, 0.0, height]) - 1000.0 * d) + shift)
            directions.append(rotation @ d)
        result = nearest_point_to_lines(np.array(points), np.array(directions))
        worst = max(worst, _error(result.point, _truth_nearest(points, directions)))
    kappa = 1.0 / angle
    bound = 4.0 * (kappa * 1000.0 * EPS + kappa**2 * separation * EPS) + 1e-12
    assert worst <= bound
    if separation == 0.0 or angle >= 1e-5:
        assert worst <= 1e-5  # achieved: <= 6e-6 mm (intersecting), <= 7e-7 mm (1 mm apart, >= 1e-5 rad)


def test_bad_line_inputs_get_typed_errors() -> None:
    with pytest.raises(InvalidInputError, match="broadcast"):
        closest_points(np.zeros((2, 3)), [1, 0, 0], np.zeros((3, 3)), [0, 1, 0])
    with pytest.raises(InvalidInputError, match="complex"):
        closest_points([0, 0, 1j], [1, 0, 0], [0, 0, 0], [0, 1, 0])
    with pytest.raises(InvalidInputError, match="magnitude"):
        closest_points([0, 0, 1e200], [1, 0, 0], [0, 0, 0], [0, 1, 0])
    with pytest.raises(InvalidInputError, match="non-zero"):
        closest_points([0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 1, 0])
    lines = dict(points=[[0, 0, 0], [0, 0, 1]], directions=[[1, 0, 0], [0, 1, 0]])
    with pytest.raises(InvalidInputError, match="at least one positive weight") as caught:
        nearest_point_to_lines(**lines, weights=[0, 0])
    assert caught.value.what == "weights"
    with pytest.raises(InvalidInputError, match="real numbers"):
        nearest_point_to_lines(**lines, weights=["1", "2"])
    with pytest.raises(DegenerateGeometryError, match="only one line"):
        nearest_point_to_lines(**lines, weights=[1, 0])
    with pytest.raises(TooFewPointsError):
        nearest_point_to_lines([[0, 0, 0]], [[1, 0, 0]])
    with pytest.raises(DegenerateGeometryError, match="parallel"):
        nearest_point_to_lines([[0, 0, 0], [0, 0, 1], [0, 3, 0]], [[1, 0, 0], [2, 0, 0], [-1, 0, 0]])
    # 1e-5 rad apart is not parallel (it was called so before)
    nearly = nearest_point_to_lines([[0, 0, 0], [0, 0, 0]], [[1, 0, 0], [1, 1e-5, 0]])
    assert np.allclose(nearly.point, 0.0, atol=1e-9)
