"""Residual maps of fits (angle, height, in-plane coordinates), sensitivity small multiples, calibration legend."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pcmm_geo import fit
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.plots._figure import new_figure
from pcmm_geo.plots.fit_residuals import _angles_heights, _frame, plot_fit_residuals


def _picture(path: Path) -> np.ndarray:
    import matplotlib.image

    image = matplotlib.image.imread(path)
    rgb = image[..., :3].reshape(-1, 3)
    assert float(np.std(rgb)) > 0.05 and len(np.unique(np.round(rgb, 2), axis=0)) > 20
    return image


def test_unrolled_coordinates_match_the_construction() -> None:
    axis = np.array([0.3, -0.5, 0.81])
    axis /= np.linalg.norm(axis)
    first, second = _frame(axis)
    np.testing.assert_allclose([first @ axis, second @ axis, first @ second], 0.0, atol=1e-15)
    np.testing.assert_allclose(np.cross(first, second), axis, atol=1e-15)  # right-handed
    origin = np.array([1000.0, -250.0, 40.0])
    angle = np.radians(np.linspace(5.0, 355.0, 36))
    height = np.linspace(-20.0, 30.0, 36)
    points = origin + 7.5 * (np.outer(np.cos(angle), first) + np.outer(np.sin(angle), second)) + np.outer(height, axis)
    got_angle, got_height = _angles_heights(points, origin, axis)
    np.testing.assert_allclose(got_angle, np.degrees(angle), atol=1e-9)
    np.testing.assert_allclose(got_height, height, atol=1e-9)


@pytest.mark.parametrize("element", ["line", "plane", "circle", "sphere", "cylinder", "cone", "torus"])
def test_every_element_has_a_residual_map(element: str, tmp_path: Path) -> None:
    rng = np.random.default_rng(4)
    u, v = rng.uniform(0.0, 2 * np.pi, (2, 120))
    h = rng.uniform(0.0, 20.0, 120)
    bump = 0.002 * np.cos(3 * u)
    clouds = {
        "line": np.c_[np.linspace(0, 40, 120), 0.001 * np.sin(h), 0.001 * np.cos(h)],
        "plane": np.c_[rng.uniform(-10, 10, (120, 2)), bump],
        "circle": np.c_[(8 + bump) * np.cos(u), (8 + bump) * np.sin(u)],
        "sphere": None,
        "cylinder": np.c_[(5 + bump) * np.cos(u), (5 + bump) * np.sin(u), h],
        "cone": np.c_[(2 + 0.4 * h + bump) * np.cos(u), (2 + 0.4 * h + bump) * np.sin(u), h],
        "torus": np.c_[(30 + (4 + bump) * np.cos(v)) * np.cos(u), (30 + (4 + bump) * np.cos(v)) * np.sin(u),
                       (4 + bump) * np.sin(v)],
    }
    direction = rng.normal(size=(120, 3))
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    clouds["sphere"] = (12.5 + bump)[:, None] * direction
    points = clouds[element]
    result = getattr(fit, f"fit_{element}")(points)
    path = plot_fit_residuals(result, tmp_path / f"{element}.png", points=points)
    _picture(path)
    with pytest.raises(InvalidInputError, match="points"):
        plot_fit_residuals(result, tmp_path / "bad.png", points=points[:-1])


def test_sensitivity_plot_shows_every_point_and_counts_the_singular_ones(tmp_path: Path) -> None:
    from pcmm_geo.machine.analysis.sensitivity import sensitivity_over_cube
    from pcmm_geo.plots.machine.sensitivity import plot_sensitivity, z_levels

    sensitivity = sensitivity_over_cube(points_per_axis=5)
    levels, index = z_levels(sensitivity.points - sensitivity.centre)
    assert len(levels) == 5 and np.bincount(index).tolist() == [25] * 5  # 125 points, 25 per panel
    _picture(plot_sensitivity(sensitivity, tmp_path / "s.png"))
    assert int(np.sum(~np.isfinite(sensitivity.laser_gain))) == 5  # one blind point per level (the axis)


def test_calibration_legend_lists_only_what_can_be_seen() -> None:
    from pcmm_geo.machine.calibration import calibrate_tetrahedron
    from pcmm_geo.machine.calibration.seed import appendix_cd_files
    from pcmm_geo.plots.machine.calibration import draw_calibration_3d

    calibration = calibrate_tetrahedron(*appendix_cd_files())
    axes = new_figure(6, 6).add_subplot(projection="3d")
    draw_calibration_3d(axes, calibration)
    labels = axes.get_legend_handles_labels()[1]
    # at the machine's scale (about 700 mm) the 5-20 mm perpendiculars and the two probe points,
    # a few mm apart, cannot be told apart: no legend entry for what is not visible
    assert "common perpendiculars" not in labels
    assert sum("probe point" in label for label in labels) == 1
    assert len(labels) == 5
    spans = [np.ptp(limits) for limits in (axes.get_xlim(), axes.get_ylim(), axes.get_zlim())]
    np.testing.assert_allclose(spans, spans[0], rtol=1e-12)  # equal scaling on x, y and z
