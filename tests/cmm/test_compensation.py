"""Probe compensation decided once (pcmm_geo.cmm.compensation), on constructed exact cases."""

from __future__ import annotations

import numpy as np
import pytest

from pcmm_geo.cmm.compensation import Compensation, plan_compensation, side_arguments, spell_value
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.io.cmm import MeasuredPointSet

CENTRE = np.array([10.0, -5.0, 2.0])
BALL = 12.5  # surface radius of an external sphere (mm)
_GOLDEN = np.pi * (3.0 - np.sqrt(5.0))
_K = np.arange(40)
_Z = 1.0 - 2.0 * (_K + 0.5) / 40
DIRECTIONS = np.column_stack([np.sqrt(1 - _Z**2) * np.cos(_GOLDEN * _K), np.sqrt(1 - _Z**2) * np.sin(_GOLDEN * _K), _Z])


def _dashed(parameter: str, value: object = None) -> str:
    """A caller spelling its settings like a command line."""
    option = "--" + parameter.replace("_", "-")
    if value is None:
        return option
    return f"{option} {'yes' if value is True else 'no' if value is False else value}"


def _centres(radii: np.ndarray | float) -> np.ndarray:
    return CENTRE + (BALL + np.broadcast_to(radii, (len(DIRECTIONS),)))[:, None] * DIRECTIONS


def test_the_file_flag_and_radius_give_the_plan() -> None:
    centres = MeasuredPointSet(id=1, points=_centres(1.5), compensated=False, probe_radius=1.5)
    plan = plan_compensation(centres)
    assert plan.radius == 1.5 and "ProbeRadius from the file" in plan.radius_source and plan.point_radii is None
    stated = plan_compensation(centres, probe_radius=2.0)  # the caller's radius overrides the file's
    assert stated.radius == 2.0 and "probe_radius" in stated.radius_source
    surface = MeasuredPointSet(id=1, points=_centres(0.0), compensated=True, probe_radius=1.5)
    assert plan_compensation(surface).radius == 0.0
    assert plan_compensation(surface, probe_radius=2.0).radius == 0.0  # a document-wide radius: kept out
    assert plan.to_dict() == {"probe_radius_mm": 1.5, "radius_source": plan.radius_source, "per_point": False,
                              "assumed": False}


def test_per_point_radii_are_applied_along_the_normals() -> None:
    radii = np.where(np.arange(len(DIRECTIONS)) % 2 == 0, 1.0, 2.5)
    mixed = MeasuredPointSet(id=1, points=_centres(radii), normals=DIRECTIONS, compensated=False, probe_radii=radii)
    plan = plan_compensation(mixed)
    assert plan.radius == 0.0 and plan.point_radii is not None
    assert np.max(np.abs(plan.points - (CENTRE + BALL * DIRECTIONS))) < 1e-12  # every point on the ball
    flags = np.arange(len(DIRECTIONS)) % 3 == 0  # these are already surface points
    flagged = MeasuredPointSet(id=1, points=_centres(np.where(flags, 0.0, 2.0)), normals=DIRECTIONS,
                               compensated_per_point=flags, probe_radius=2.0)
    assert np.max(np.abs(plan_compensation(flagged).points - (CENTRE + BALL * DIRECTIONS))) < 1e-12
    without_normals = MeasuredPointSet(id=1, points=_centres(radii), compensated=False, probe_radii=radii)
    with pytest.raises(InvalidInputError, match="no normals"):
        plan_compensation(without_normals)


def test_statements_that_contradict_the_file_are_refused_naming_the_parameter() -> None:
    surface = MeasuredPointSet(id=1, points=_centres(0.0), compensated=True)
    with pytest.raises(InvalidInputError) as caught:
        plan_compensation(surface, compensated=False)
    assert caught.value.what == "compensated" and "Compensated=true" in str(caught.value)
    with pytest.raises(InvalidInputError, match=r"^--compensated no: expected nothing"):
        plan_compensation(surface, compensated=False, strict=True, spell_setting=_dashed)
    with pytest.raises(InvalidInputError, match=r"^--probe-radius: expected nothing"):
        plan_compensation(surface, probe_radius=1.0, strict=True, spell_setting=_dashed)
    centres = MeasuredPointSet(id=1, points=_centres(1.0), compensated=False)
    with pytest.raises(InvalidInputError, match=r"^compensated: expected False: .* got True$"):
        plan_compensation(centres, compensated=True)
    with pytest.raises(InvalidInputError, match=r"^probe_radius: expected the probe radius"):
        plan_compensation(centres)  # probe centres, no radius anywhere
    with pytest.raises(InvalidInputError, match="positive probe radius"):
        plan_compensation(centres, probe_radius=-1.0)


def test_unflagged_points_need_a_statement_or_are_assumed_surface_points() -> None:
    unflagged = MeasuredPointSet(id=1, points=_centres(0.0))
    with pytest.raises(InvalidInputError, match=r"^--compensated: expected yes or no: bore.txt does not say"):
        plan_compensation(unflagged, where="bore.txt", spell_setting=_dashed)
    assumed = plan_compensation(unflagged, unstated="surface")
    assert assumed.assumed and assumed.radius == 0.0
    assert plan_compensation(unflagged, unstated="surface", probe_radius=0.5).radius == 0.5
    assert plan_compensation(unflagged, compensated=False, probe_radius=0.5).radius == 0.5
    with pytest.raises(InvalidInputError, match="no radius with compensated=True"):
        plan_compensation(unflagged, compensated=True, probe_radius=0.5, strict=True)


def test_the_material_side_in_order_of_authority() -> None:
    points, normals = _centres(1.0), DIRECTIONS
    assert side_arguments("internal") == ({"side": "internal"}, "material_side")
    assert side_arguments(None, file_side="external", internal_external="EXTERNAL", normals=normals,
                          points=points) == ({"side": "external"}, "the file's InternalExternal")
    kwargs, source = side_arguments(None, normals=normals, points=points, nominal_diameter=25.0)
    assert source == "the point normals" and kwargs["outward"] is normals
    assert side_arguments(None, nominal_diameter=25.0)[0] == {"nominal_diameter": 25.0}
    assert side_arguments(None, required=False) == ({}, "")
    with pytest.raises(InvalidInputError, match=r"^material_side: expected 'internal' \(or no material_side\)"):
        side_arguments("external", file_side="internal", internal_external="INTERNAL")
    with pytest.raises(InvalidInputError, match=r"^--material-side: expected internal or external"):
        side_arguments(None, spell_setting=_dashed)


def test_one_record_for_every_route() -> None:
    from pcmm_geo.fit import fit_sphere
    from pcmm_geo.fit.probe import compensate_probe

    result = compensate_probe(fit_sphere(_centres(1.0)), 1.0, side="external")
    record = Compensation.from_probe(result, "probe centres (Compensated=false), ProbeRadius from the file",
                                     "the file's InternalExternal")
    assert result.surface.radius == pytest.approx(BALL, abs=1e-9)
    data = record.to_dict()
    assert (data["probe_radius_mm"], data["side"], data["method"], data["side_source"]) == (
        1.0, "external", "element offset", "the file's InternalExternal")
    assert record.describe().startswith("probe compensation: radius 1 mm (probe centres")
    assert spell_value(_dashed, "compensated", True) == "yes"


def test_calibration_balls_use_the_same_plan() -> None:
    from pcmm_geo.fit import fit_sphere
    from pcmm_geo.machine.calibration.inputs import _ball_points

    radii = np.where(np.arange(len(DIRECTIONS)) % 2 == 0, 1.0, 2.5)  # one radius per point: not one ball radius
    mixed = MeasuredPointSet(id=1, points=_centres(radii), normals=DIRECTIONS, compensated=False, probe_radii=radii)
    points, left, note = _ball_points(mixed, "joint_a_1")
    assert left == 0.0 and "per-point ProbeRadii" in note
    assert fit_sphere(points).radius == pytest.approx(BALL, abs=1e-9)
    one = MeasuredPointSet(id=1, points=_centres(1.5), compensated=False, probe_radius=1.5)
    points, left, note = _ball_points(one, "tip")
    assert fit_sphere(points).radius - left == pytest.approx(BALL, abs=1e-9) and "1.5 mm" in note
    unknown = MeasuredPointSet(id=1, points=_centres(1.5), compensated=False)  # no radius: centre only
    points, left, note = _ball_points(unknown, "tip")
    assert left == 0.0 and "the centre is the same either way" in note
