"""The element spec (:mod:`pcmm_geo.elements`) is the one list every consumer reads.

Adding an element is one row of ``SPECS`` plus its fit: here every consumer's element set --
the fits, the criterion and form tables, the reference generators, probe compensation, the
QIF writer and the refit of CMM files, the plots, the ``pcmm`` options -- is checked to be the
spec's, and each row is checked against its fit's result (field names, kinds and values on
constructed exact data).  The QIF tables are checked against QIF 3.0 written out by hand.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import inspect
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any, get_args

import numpy as np
import pytest

from pcmm_geo import elements, fit
from pcmm_geo.elements import (
    AXIAL,
    CRITERIA,
    ELEMENTS,
    FEATURE_TYPES,
    SIZED_FEATURES,
    SPECS,
    Criterion,
    Element,
    ElementSpec,
    FeatureType,
    Parameter,
    check_criterion,
    check_element,
    element_of,
    spec,
)
from pcmm_geo.errors import InvalidInputError

REPO_ROOT = Path(__file__).resolve().parents[1]

# ---------------------------------------------------------------------------------------------
# the spec against the fits


def parameter_mismatches(row: ElementSpec, result_type: type) -> list[str]:
    """How a spec row differs from its fit result class: the geometric fields, in order, one line each.

    The result's own fields are those it adds to :class:`~pcmm_geo.fit.FitResult`, less the
    per-criterion extras (zone radii ``r_in`` / ``r_out``, a circle's ``residual_components``).
    """
    base = {f.name for f in dataclasses.fields(fit.FitResult)}
    extras = {"r_in", "r_out", "residual_components"}
    own = [f.name for f in dataclasses.fields(result_type) if f.name not in base | extras]
    named = [p.name for p in row.parameters]
    problems = []
    if own != named:
        problems.append(f"{row.name}: the spec lists {named}, {result_type.__name__} has {own}")
    for field_name in (row.size, row.axis_field, row.location_field):
        if field_name is not None and field_name not in named:
            problems.append(f"{row.name}: {field_name!r} is no parameter of the spec")
    return problems


def test_the_parameter_check_catches_a_wrong_row() -> None:
    good = SPECS["sphere"]
    assert parameter_mismatches(good, fit.SphereFit) == []
    wrong = dataclasses.replace(good, parameters=(Parameter("center", "position"), Parameter("diameter", "length")),
                                size="diameter")
    assert parameter_mismatches(wrong, fit.SphereFit) == [
        "sphere: the spec lists ['center', 'diameter'], SphereFit has ['center', 'radius']"]
    assert parameter_mismatches(dataclasses.replace(good, axis_field="axis"), fit.SphereFit) == [
        "sphere: 'axis' is no parameter of the spec"]


@pytest.mark.parametrize("name", ELEMENTS)
def test_each_row_is_its_fits_result(name: str) -> None:
    row = SPECS[name]
    result_type = getattr(fit, str(row.result))
    assert parameter_mismatches(row, result_type) == []
    signature = inspect.signature(getattr(fit, f"fit_{name}"))
    assert signature.return_annotation == row.result
    assert signature.parameters["criterion"].annotation == "Criterion"
    # a fixed-radius fit exactly where the size parameter is the radius (circle, sphere, cylinder)
    assert ("radius" in signature.parameters) == (row.size == "radius")


#: exact data of each element whose parameters are known in closed form
def _exact(name: str) -> tuple[np.ndarray, dict[str, Any]]:
    t = np.linspace(0.0, 2 * np.pi, 12, endpoint=False)
    ring = np.c_[np.cos(t), np.sin(t)]
    z = np.repeat([-4.0, 0.0, 4.0], 12)
    if name == "line":
        return np.c_[np.arange(5.0), 2 * np.arange(5.0), np.zeros(5)], {"direction": np.array([1, 2, 0]) / np.sqrt(5)}
    if name == "plane":
        grid = np.array([[x, y, 3.0] for x in range(3) for y in range(3)])
        return grid, {"normal": np.array([0.0, 0.0, 1.0])}
    if name == "circle":
        return np.c_[7.5 * ring, np.full(12, 2.0)], {"radius": 7.5, "normal": np.array([0.0, 0.0, 1.0])}
    if name == "sphere":
        poles = np.array([[0, 0, 6.0], [0, 0, -6.0]])
        return np.vstack([np.c_[6 * ring, np.zeros(12)], poles]), {"radius": 6.0, "center": np.zeros(3)}
    if name == "cylinder":
        return np.c_[np.tile(5 * ring, (3, 1)), z], {"radius": 5.0, "axis": np.array([0.0, 0.0, 1.0])}
    if name == "cone":  # apex at z = 10, half angle 30 degrees: radius (10 - z) tan 30
        radius = (10 - z) * np.tan(np.pi / 6)
        return np.c_[np.tile(ring, (3, 1)) * radius[:, None], z], {"half_angle": np.pi / 6,
                                                                   "apex": np.array([0.0, 0.0, 10.0])}
    assert name == "torus"  # the generator's exact torus (its start search is quick on these points)
    from pcmm_geo.fit import reference

    data = reference.make_reference_data("torus", radius=20.0, minor_radius=4.0)
    return data.points, {"major_radius": 20.0, "minor_radius": 4.0, "center": data.parameters["center"]}


@functools.cache
def _fitted(name: str) -> Any:
    points, _ = _exact(name)
    hint = {"axis_hint": np.array([0.0, 0.1, 1.0])} if name in ("cylinder", "cone") else {}
    return getattr(fit, f"fit_{name}")(points, **hint)


@pytest.mark.parametrize("name", ELEMENTS)
def test_the_parameter_kinds_hold_on_exact_data(name: str) -> None:
    _, truth = _exact(name)
    result = _fitted(name)
    assert element_of(result) == name
    for parameter in SPECS[name].parameters:
        value = getattr(result, parameter.name)
        if parameter.kind in ("position", "direction"):
            assert np.shape(value) == (3,)
        if parameter.kind == "direction":
            assert abs(np.linalg.norm(value) - 1.0) < 1e-12
        if parameter.kind in ("length", "angle"):
            assert isinstance(value, float) and value > 0
        if parameter.kind == "angle":
            assert value < np.pi / 2
    for field_name, expected in truth.items():
        value = np.asarray(getattr(result, field_name), dtype=float)
        if SPECS[name].parameters[[p.name for p in SPECS[name].parameters].index(field_name)].kind == "direction":
            value = value * np.sign(value @ expected)  # a direction's sign is free
        assert np.allclose(value, expected, atol=1e-7), (field_name, value, expected)
    if SPECS[name].size is not None:  # the diameter of the QIF writer and the CLI: twice the size field
        assert getattr(result, SPECS[name].size) > 0


def test_the_reference_generator_names_the_spec_parameters() -> None:
    from pcmm_geo.fit import reference

    for name in ELEMENTS:
        data = reference.make_reference_data(name)
        assert set(data.parameters) == {p.name for p in SPECS[name].parameters}, name


# ---------------------------------------------------------------------------------------------
# every consumer's element set is the spec's


def test_the_type_aliases_are_the_tables() -> None:
    assert get_args(Element) == ELEMENTS == ("line", "plane", "circle", "sphere", "cylinder", "cone", "torus")
    assert get_args(Criterion) == CRITERIA == ("gaussian", "chebyshev", "mcc", "mic")
    assert get_args(FeatureType) == FEATURE_TYPES
    assert set(FEATURE_TYPES) == {name for name, row in SPECS.items() if row.qif}
    assert SIZED_FEATURES == ("circle", "cylinder", "sphere", "cone")
    assert AXIAL == ("cylinder", "cone", "torus")
    assert list(SPECS) == [*ELEMENTS, "point"]


def test_the_fits_and_their_criteria_read_the_spec() -> None:
    from pcmm_geo.fit import zone
    from pcmm_geo.fit.zone import _common, form
    from pcmm_geo.fit.zone import reference as zone_reference

    assert fit.ELEMENTS == ELEMENTS
    assert zone.CRITERIA == CRITERIA
    assert _common.SUPPORTED == {name: SPECS[name].criteria for name in ELEMENTS}
    assert form.CHARACTERISTICS == {"line": "straightness", "plane": "flatness", "circle": "roundness",
                                    "sphere": "sphericity", "cylinder": "cylindricity", "cone": "conicity"}
    # the minimax reference kinds (line2d, circle3d, ...) offer criteria of their element only
    for kind, criteria in zone_reference.ELEMENTS.items():
        base = re.sub(r"[23]d$", "", kind)
        assert set(criteria) <= set(SPECS[base].criteria) - {"gaussian"}, kind


@pytest.mark.parametrize("name", ELEMENTS)
def test_a_fit_refuses_exactly_the_criteria_the_spec_does_not_list(name: str) -> None:
    points, _ = _exact(name)
    for criterion in CRITERIA:
        if criterion in SPECS[name].criteria:
            continue
        with pytest.raises(InvalidInputError, match=f"criterion: expected one of .* for a {name}, got '{criterion}'"):
            getattr(fit, f"fit_{name}")(points, criterion=criterion)


def test_probe_compensation_offsets_exactly_the_elements_with_an_offset_surface() -> None:
    from pcmm_geo.fit import compensate_probe

    offsets = {}
    for name in ELEMENTS:
        result = _fitted(name)
        try:
            flat = SPECS[name].offset == "normal"
            comp = compensate_probe(result, 0.5, **({"outward": [0.0, 0.0, 1.0]} if flat else {"side": "external"}))
        except InvalidInputError as error:
            offsets[name] = "refused: " + error.what
            continue
        if SPECS[name].size is not None:  # external: the surface is one probe radius nearer the axis
            offsets[name] = round(getattr(result, SPECS[name].size) - getattr(comp.surface, SPECS[name].size), 12)
        else:
            offsets[name] = round(float(np.linalg.norm(comp.surface.point - result.point)), 12)
    cone_shift = round(0.5 / np.cos(np.pi / 6), 12)  # radius at a fixed section moves by r / cos(alpha)
    assert offsets == {"line": 0.5, "plane": 0.5, "circle": 0.5, "sphere": 0.5, "cylinder": 0.5, "cone": cone_shift,
                       "torus": "refused: element"}
    assert {name for name, value in offsets.items() if value != "refused: element"} == {
        name for name in ELEMENTS if SPECS[name].offset in ("radial", "conical", "normal")}


#: QIF 3.0 feature nominals and definitions (FeatureNominal placement; Definition Diameter / HalfAngle), by hand
QIF_NOMINAL_NEEDS = {
    "circle": ("location", "normal", "diameter"),
    "cylinder": ("location", "direction", "diameter"),
    "sphere": ("location", "diameter"),
    "plane": ("location", "normal"),
    "line": ("location", "direction"),
    "point": ("location",),
    "cone": ("location", "direction", "diameter", "half_angle"),
}


def test_the_qif_writer_and_the_cmm_refit_read_the_spec() -> None:
    from pcmm_geo.cmm import export, refit, verify
    from pcmm_geo.io.cmm import FEATURE_TYPES as IO_FEATURE_TYPES
    from pcmm_geo.io.cmm.qif.write import _features_out, build

    assert IO_FEATURE_TYPES == FEATURE_TYPES == ("circle", "cylinder", "sphere", "plane", "line", "point", "cone")
    assert build.NOMINAL_NEEDS == QIF_NOMINAL_NEEDS
    assert export._NOMINAL_NEEDS == QIF_NOMINAL_NEEDS
    assert _features_out._PLACEMENT == {kind: needs[:2] if len(needs) > 1 and needs[1] in ("normal", "direction")
                                        else needs[:1] for kind, needs in QIF_NOMINAL_NEEDS.items()}
    assert set(_features_out._SIZES) == set(_features_out.SIZED) == set(build._SIZED) == set(SIZED_FEATURES)
    assert export.ELEMENTS == ("circle", "cylinder", "sphere", "plane", "line", "cone")
    assert export.FORM_CHARACTERISTICS == {"circle": "circularity", "plane": "flatness", "cylinder": "cylindricity",
                                           "sphere": "sphericity", "line": "straightness", "cone": "conicity"}
    assert set(export._SIZE_CHARACTERISTICS) <= set(SIZED_FEATURES)
    assert set(export.ALGORITHMS) == set(CRITERIA) == set(refit.CRITERIA_BY_ALGORITHM.values())
    assert refit.REFITTED_TYPES == FEATURE_TYPES and set(refit._REFITTERS) == set(FEATURE_TYPES)
    assert verify is not None


def test_feature_report_writes_the_spec_geometry() -> None:
    from pcmm_geo.cmm.export import feature_report

    expected_fields = {"circle": {"normal", "diameter"}, "cylinder": {"direction", "diameter"}, "sphere": {"diameter"},
                       "plane": {"normal"}, "line": {"direction"}, "cone": {"direction", "diameter", "half_angle"}}
    for name in ELEMENTS:
        _, truth = _exact(name)
        result = _fitted(name)
        if name not in expected_fields:
            with pytest.raises(InvalidInputError, match="QIF has no torus feature record"):
                feature_report(result, name)
            continue
        actual = feature_report(result, name).actual
        given = {f for f in ("normal", "direction", "diameter", "half_angle") if getattr(actual, f) is not None}
        assert given == expected_fields[name], name
        if "diameter" in given:
            assert abs(actual.diameter - 2 * truth.get("radius", getattr(result, SPECS[name].size))) < 1e-7


def test_the_plots_know_every_fit_result() -> None:
    for name in ELEMENTS:
        assert element_of(type(SPECS[name].result, (), {})()) == name
    assert element_of(object()) is None


def _choices(parser: argparse.ArgumentParser, command: str, dest: str) -> tuple[str, ...]:
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    action = next(a for a in sub.choices[command]._actions if a.dest == dest)
    return tuple(action.choices)


def test_the_pcmm_options_read_the_spec() -> None:
    from pcmm_geo.cli import build_parser
    from pcmm_geo.cli.measure import batch

    parser = build_parser()
    assert _choices(parser, "fit", "element") == ELEMENTS
    assert _choices(parser, "fit", "criterion") == CRITERIA
    assert _choices(parser, "form", "element") == tuple(name for name in ELEMENTS if SPECS[name].form)
    assert batch.TASKS[: len(ELEMENTS)] == tuple(f"fit-{name}" for name in ELEMENTS)
    qif = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices["qif"]
    assert _choices(qif, "verify", "criterion") == CRITERIA


# ---------------------------------------------------------------------------------------------
# strings from outside


def test_strings_from_outside_get_the_typed_error() -> None:
    assert check_element("torus") == "torus" and check_criterion("mic") == "mic"
    with pytest.raises(InvalidInputError, match=r"^element: expected one of line, plane, circle, sphere, cylinder, "
                                                 r"cone, torus, got 'cube'$"):
        check_element("cube")
    with pytest.raises(InvalidInputError, match=r"^feature\.type: expected one of circle, point, got 'line'$"):
        check_element("line", "feature.type", ("circle", "point"))
    with pytest.raises(InvalidInputError, match=r"^criterion: expected one of 'gaussian', 'chebyshev', 'mcc', 'mic', "
                                                 r"got 3$"):
        check_criterion(3)
    with pytest.raises(InvalidInputError, match=r"element: expected one of line, .*, point, got 'cube'"):
        spec("cube")
    assert spec("cone").nominal_fields == QIF_NOMINAL_NEEDS["cone"]
    assert Parameter("half_angle", "angle").unit == "rad" and Parameter("radius", "length").unit == "mm"
    assert set(elements.__all__) <= set(dir(elements))


@pytest.mark.slow
def test_mypy_holds_the_literals(tmp_path: Path) -> None:
    """A misspelt criterion or element is a type error; the spelt ones type-check."""
    pytest.importorskip("mypy", reason="mypy comes with the test extra")
    source = tmp_path / "use_the_literals.py"
    source.write_text(textwrap.dedent("""
        import numpy as np
        from pcmm_geo.elements import Criterion, Element
        from pcmm_geo.fit import fit_sphere
        from pcmm_geo.fit.zone import evaluate_form

        points = np.zeros((5, 3))
        criterion: Criterion = "mcc"
        element: Element = "cylinder"
        fit_sphere(points, criterion=criterion)
        evaluate_form(points, element)
        fit_sphere(points, criterion="minimum-zone")  # wrong
        evaluate_form(points, "cube")  # wrong
    """), encoding="utf-8")
    import pcmm_geo

    tree = Path(pcmm_geo.__file__).resolve().parents[1]
    env = dict(os.environ) if tree.name in ("site-packages", "dist-packages") else {**os.environ, "MYPYPATH": str(tree)}
    out = subprocess.run(
        [sys.executable, "-m", "mypy", "--follow-imports=silent", "--no-error-summary", "--hide-error-context",
         "--cache-dir", str(REPO_ROOT / ".mypy_cache"), "--python-version", "3.11", str(source)],
        capture_output=True, text=True, cwd=tmp_path, env=env,
    )
    errors = [line for line in out.stdout.splitlines() if ": error:" in line]
    assert [int(line.split(":")[1]) for line in errors] == [12, 13], out.stdout + out.stderr
    assert "'minimum-zone'" in errors[0] and "'cube'" in errors[1]
