"""Tests of pcmm_geo.testing: the comparison must pass on equal geometry and FAIL on perturbed geometry."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.fit.reference import write_nist_pair
from pcmm_geo.testing import (
    assert_fit_close,
    fit_deviations,
    fit_nist_pair,
    make_reference_data,
    nist_pairs,
)


def _rotated(vector: np.ndarray, angle: float) -> np.ndarray:
    """Tilt a unit vector by ``angle`` rad (about an axis perpendicular to it)."""
    helper = np.eye(vector.size)[int(np.argmin(np.abs(vector)))]
    if vector.size == 2:
        perpendicular = np.array([-vector[1], vector[0]])
    else:
        perpendicular = np.cross(vector, helper)
        perpendicular /= np.linalg.norm(perpendicular)
    return np.cos(angle) * vector + np.sin(angle) * perpendicular


def _perpendicular(vector: np.ndarray) -> np.ndarray:
    return _rotated(vector, np.pi / 2)


ELEMENTS = ["line2d", "line3d", "plane", "circle2d", "circle3d", "sphere", "cylinder", "cone", "torus"]


@pytest.mark.parametrize("element", ELEMENTS)
def test_identical_geometry_passes_and_each_perturbation_fails(element: str) -> None:
    data = make_reference_data(element, form=0.01, offset=600.0, rng=2)
    params = data.parameters
    assert_fit_close(dict(params), data)
    direction_name = next((n for n in ("direction", "normal", "axis") if n in params), None)
    perturbed = []
    if direction_name is not None:
        perturbed.append({**params, direction_name: _rotated(params[direction_name], 3e-9)})
    for name in ("center", "point"):
        if name in params:
            if direction_name == "normal":  # a plane point may slide in the plane: move it off the plane
                shift = params["normal"]
            elif direction_name is not None:
                shift = _perpendicular(params[direction_name])
            else:
                shift = np.eye(params[name].size)[0]
            perturbed.append({**params, name: params[name] + 3e-9 * shift})
    for name in ("radius", "major_radius", "minor_radius", "half_angle", "radius_at_point"):
        if name in params:
            perturbed.append({**params, name: params[name] + 3e-9})
    assert perturbed
    for candidate in perturbed:
        with pytest.raises(AssertionError, match="differs from reference"):
            assert_fit_close(candidate, data)


def test_deviation_values_are_geometric() -> None:
    axis = np.array([0.0, 0.6, 0.8])
    reference = {"point": np.array([1.0, 2.0, 3.0]), "axis": axis, "radius": 4.0}
    # point slid 7 mm along the axis and moved 2e-6 mm across it, axis flipped and tilted by 1e-7 rad
    across = np.array([1.0, 0.0, 0.0])
    fitted = {
        "point": reference["point"] + 7.0 * axis + 2e-6 * across,
        "axis": -_rotated(axis, 1e-7),
        "radius": 4.0 + 5e-10,
    }
    deviations = fit_deviations(fitted, reference)
    # the tilt (perpendicular to `across`) moves the fitted line by 7 mm * 1e-7 rad at the reference station
    assert deviations["point"] == pytest.approx(np.hypot(2e-6, 7e-7), rel=1e-6)
    assert deviations["axis"] == pytest.approx(1e-7, rel=1e-6)
    assert deviations["radius"] == pytest.approx(5e-10, rel=1e-5)
    with pytest.raises(AssertionError, match=r"point 2\.1189\de-06 > 1e-09 mm"):
        assert_fit_close(fitted, reference)
    assert_fit_close(fitted, reference, position_mm=3e-6, angle_rad=2e-7)


def test_plane_point_may_move_within_the_plane() -> None:
    reference = {"point": np.zeros(3), "normal": np.array([0.0, 0.0, 1.0])}
    assert_fit_close({"point": np.array([5.0, -3.0, 0.0]), "normal": np.array([0.0, 0.0, -1.0])}, reference)
    with pytest.raises(AssertionError, match="point"):
        assert_fit_close({"point": np.array([5.0, -3.0, 1e-8]), "normal": np.array([0.0, 0.0, 1.0])}, reference)


def test_cone_axis_sign_matters_and_radius_is_compared_at_same_station() -> None:
    data = make_reference_data("cone", form=0.0, rng=3, half_angle=0.4)
    params = data.parameters
    axis, half_angle = params["axis"], params["half_angle"]
    # another point on the axis, with the radius there: the same cone
    moved = {
        **params,
        "point": params["point"] + 2.5 * axis,
        "radius_at_point": params["radius_at_point"] + 2.5 * np.tan(half_angle),
    }
    assert_fit_close(moved, data)
    with pytest.raises(AssertionError, match="radius_at_point"):
        assert_fit_close({**moved, "radius_at_point": params["radius_at_point"]}, data)
    with pytest.raises(AssertionError, match="axis"):
        assert_fit_close({**params, "axis": -axis}, data)


def test_bad_arguments_raise_typed_errors() -> None:
    with pytest.raises(InvalidInputError):
        fit_deviations({"center": np.zeros(3)}, [1, 2, 3])
    with pytest.raises(InvalidInputError, match="radius"):
        fit_deviations({"center": np.zeros(3)}, {"center": np.zeros(3), "radius": 1.0})
    with pytest.raises(InvalidInputError, match="axis"):
        fit_deviations(object(), {"axis": np.array([0.0, 0.0, 1.0])})


def test_real_fit_against_generated_nist_pair(tmp_path) -> None:
    from pcmm_geo.fit import fit_cylinder

    data = make_reference_data("cylinder", n_points=40, form=0.02, offset=500.0, arc=np.pi, rng=6)
    write_nist_pair(data, tmp_path / "Cylinder", "c1")
    pairs = list(nist_pairs(tmp_path))
    assert [pair.name for pair in pairs] == ["c1"]
    result = fit_nist_pair(pairs[0])
    assert_fit_close(result, pairs[0])
    assert_fit_close(fit_cylinder(data.points), data)
    # the same fit must fail against a reference moved by 1e-8 mm
    shifted = {**data.parameters, "point": data.parameters["point"] + 1e-8 * _perpendicular(data.parameters["axis"])}
    with pytest.raises(AssertionError):
        assert_fit_close(result, shifted)
