"""ISO 10360-5 probing pattern and P_FTU / P_STU evaluation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pcmm_geo.artefacts import evaluate_probing, sphere_probing_pattern
from pcmm_geo.errors import InvalidInputError


def test_pattern_layout() -> None:
    centre = np.array([5.0, -3.0, 40.0])
    pts = sphere_probing_pattern(centre, 12.5)
    assert pts.shape == (25, 3)
    rel = pts - centre
    np.testing.assert_allclose(np.linalg.norm(rel, axis=1), 12.5, atol=1e-12)
    polar_deg = np.degrees(np.arccos(np.clip(rel[:, 2] / 12.5, -1, 1)))
    counts = {angle: int(np.sum(np.isclose(polar_deg, angle, atol=1e-9))) for angle in (0, 22.5, 45, 67.5, 90)}
    assert counts == {0: 1, 22.5: 4, 45: 8, 67.5: 4, 90: 8}
    # each ring is turned 22.5 deg against the previous one: first azimuths 0, 22.5, 45, 67.5 deg
    first = {}
    for r, angle in zip(rel, polar_deg, strict=True):
        key = round(float(angle), 6)
        if key not in first and key != 0:
            first[key] = math.degrees(math.atan2(r[1], r[0])) % 360
    assert [round(first[k], 9) for k in (22.5, 45.0, 67.5, 90.0)] == [0.0, 22.5, 45.0, 67.5]
    # any pole direction: same polar angles about that pole
    pole = np.array([1.0, 1.0, 0.0]) / math.sqrt(2)
    turned = sphere_probing_pattern(centre, 12.5, pole=pole * 3.0) - centre
    polar_turned = np.degrees(np.arccos(np.clip(turned @ pole / 12.5, -1, 1)))
    np.testing.assert_allclose(np.sort(polar_turned), np.sort(polar_deg), atol=1e-9)


def _nullspace_deviations(units: np.ndarray, rng: np.random.Generator, scale: float) -> np.ndarray:
    """Radial deviations orthogonal to the sphere fit's Jacobian columns (u_x, u_y, u_z, 1)."""
    jac = np.column_stack([units, np.ones(len(units))])
    q, _ = np.linalg.qr(jac)
    raw = rng.normal(size=len(units))
    dev = raw - q @ (q.T @ raw)
    return scale * dev / np.abs(dev).max()


def test_form_and_size_errors_against_known_solution() -> None:
    rng = np.random.default_rng(105)
    centre, radius = np.array([120.0, -40.0, 75.0]), 12.5002
    units = (sphere_probing_pattern(np.zeros(3), 1.0))
    deviations = _nullspace_deviations(units, rng, 0.8e-3)
    points = centre + (radius + deviations)[:, None] * units
    result = evaluate_probing(points, 25.0, mpe_form=2e-3, mpe_size=1e-3)
    # the least-squares sphere is exactly (centre, radius): residuals are the deviations
    assert result.form_error == pytest.approx(float(np.ptp(deviations)), abs=1e-11)
    assert result.size_error == pytest.approx(2 * radius - 25.0, abs=1e-11)
    np.testing.assert_allclose(result.centre, centre, atol=1e-10)
    assert result.form_conforms and result.size_conforms and result.passed
    strict = evaluate_probing(points, 25.0, mpe_form=1e-3, mpe_size=0.3e-3)
    assert strict.form_conforms is False or strict.form_error <= 1e-3
    assert strict.size_conforms is False  # |P_STU| = 0.4 um > 0.3 um
    assert evaluate_probing(points, 25.0).passed is None


def test_bad_input() -> None:
    pts = sphere_probing_pattern(radius=10.0)
    with pytest.raises(InvalidInputError, match="reference_diameter"):
        evaluate_probing(pts, -20.0)
    with pytest.raises(InvalidInputError, match="radius"):
        sphere_probing_pattern(radius=0.0)
    with pytest.raises(InvalidInputError, match="pole"):
        sphere_probing_pattern(pole=(0.0, 0.0, 0.0))


def test_the_standards_25_points_or_an_explicit_incomplete_verdict() -> None:
    from pcmm_geo.errors import IncompleteTestError

    points = sphere_probing_pattern((5.0, -3.0, 40.0), 12.5)
    assert evaluate_probing(points, 25.0, mpe_form=1e-3).verdict == "PASS"
    with pytest.raises(IncompleteTestError, match="the standard uses 25 points on the test sphere, got 24") as info:
        evaluate_probing(points[:24], 25.0, mpe_form=1e-3)
    assert (info.value.needed, info.value.got) == (25, 24)
    partial = evaluate_probing(points[:24], 25.0, mpe_form=1e-3, allow_incomplete=True)
    assert partial.passed is None and not partial.complete
    assert partial.verdict.startswith("INCOMPLETE (24 of 25 points)") and "PASS" not in partial.verdict
    failing = evaluate_probing(points[:24], 25.01, mpe_size=1e-3, allow_incomplete=True)
    assert failing.passed is False and failing.verdict == "INCOMPLETE (24 of 25 points): FAIL"
    with pytest.raises(IncompleteTestError, match="got 26"):
        evaluate_probing(np.vstack([points, points[:1] * 1.0 + 1e-9]), 25.0)
