"""The TOML inspection plan, the frame grammar and ``pcmm inspect``."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from pcmm_runner import run_pcmm

from pcmm_geo.errors import FileFormatError
from pcmm_geo.gdt import inspect_plan, parse_frame

EXAMPLE_DIR = Path(__file__).parents[2] / "pcmm_geo" / "data" / "examples" / "gdt"


@pytest.mark.parametrize(("text", "expected"), [
    ("position dia 0.1 MMC | A | B | C", ("position", "dia", 0.1, "MMC", ("A", "B", "C"))),
    ("⌖ ⌀0.1 Ⓜ | A | B | C", ("position", "dia", 0.1, "MMC", ("A", "B", "C"))),
    ("⌖ Ø0.25Ⓛ|A|B", ("position", "dia", 0.25, "LMC", ("A", "B"))),
    ("⊥ ⌀0.02 | A", ("perpendicularity", "dia", 0.02, "RFS", ("A",))),
    ("// 0.05 | A", ("parallelism", "width", 0.05, "RFS", ("A",))),
    ("∥ 0.05 | A", ("parallelism", "width", 0.05, "RFS", ("A",))),
    ("∠ 0.1 | A | B", ("angularity", "width", 0.1, "RFS", ("A", "B"))),
    ("flatness 0.01", ("flatness", "width", 0.01, "RFS", ())),
    ("⌰ 0.03 | D", ("total runout", "width", 0.03, "RFS", ("D",))),
    ("↗ 0.03 | D", ("circular runout", "width", 0.03, "RFS", ("D",))),
    ("⌓ 0.2 | A | B | C", ("profile of a surface", "width", 0.2, "RFS", ("A", "B", "C"))),
])
def test_frames_in_ascii_and_iso_symbols(text, expected):
    spec = parse_frame(text)
    assert (spec.characteristic, spec.zone, spec.tolerance_mm, spec.modifier, spec.datums) == expected
    assert spec.modifiers_of_datums == ("RMB",) * len(spec.datums)


@pytest.mark.parametrize(("text", "datums", "modifiers"), [
    ("position dia 0.1 MMC | A | B(M) | C", ("A", "B", "C"), ("RMB", "MMB", "RMB")),
    ("position dia 0.1 | A | B MMB | C LMB", ("A", "B", "C"), ("RMB", "MMB", "LMB")),
    ("⌖ ⌀0.1 Ⓜ | A | BⓂ | CⓁ", ("A", "B", "C"), ("RMB", "MMB", "LMB")),
    ("⌖ ⌀0.1 | A | B(L) | C(S)", ("A", "B", "C"), ("RMB", "LMB", "RMB")),
    ("position dia 0.1 | A-B | C", ("A-B", "C"), ("RMB", "RMB")),
    ("◎ ⌀0.02 | A - B", ("A-B",), ("RMB",)),
])
def test_datum_feature_modifiers_and_common_datums_are_parsed(text, datums, modifiers):
    spec = parse_frame(text)
    assert spec.datums == datums and spec.datum_modifiers == modifiers


@pytest.mark.parametrize(("text", "reason"), [
    ("wobble 0.1 | A", "unknown characteristic"),
    ("position dia | A", "no tolerance"),
    ("position dia 0.1 XYZ | A", "unknown token"),
    ("position dia 0.1 | A XYZ", "unknown datum feature modifier 'XYZ'"),
    ("position dia 0.1 | B(Q)", "expected a datum letter, an optional modifier"),
    ("position dia 0.1 | A-B(M)", "common datum 'A-B' at MMB"),
    ("position dia 0.1 | A-B | B", "a datum named twice"),
    ("position dia -0.1 | A", "positive tolerance"),
    ("position dia 0.1 | A | B | C | D", "more than three"),
])
def test_frames_the_grammar_does_not_know_are_refused_naming_the_line(text, reason):
    with pytest.raises(FileFormatError, match=reason) as info:
        parse_frame(text, path="plan.toml", line=17)
    assert info.value.line == 17 and str(info.value).startswith("plan.toml:17:")


def _copy_example(tmp_path: Path) -> Path:
    for f in EXAMPLE_DIR.iterdir():
        if f.suffix in (".csv", ".toml"):
            shutil.copy(f, tmp_path / f.name)
    return tmp_path / "plan.toml"


def test_shipped_example_gives_the_constructed_answers(maker):
    part = maker.make_part(n_points=maker.EXAMPLE_POINTS)
    result = inspect_plan(EXAMPLE_DIR / "plan.toml")
    by_name = {c.name: c for c in result.characteristics}
    # the files hold coordinates rounded to 1 nm: answers to a few nm
    for hole in part.holes:
        c = by_name[f"position {hole.name}"]
        assert abs(c.value_mm - hole.position_rfs()) < 1e-8
        assert abs(c.bonus_mm - (hole.actual_diameter - 10.0)) < 1e-8
    assert abs(by_name["parallelism TOP"].value_mm - part.top_slope * part.top_extent) < 1e-8
    assert abs(by_name["perpendicularity H1"].value_mm - part.holes[0].perpendicularity()) < 1e-8
    assert abs(by_name["flatness A"].value_mm - maker.DATUM_FORM_MM) < 1e-8
    assert [c.verdict for c in result.characteristics] == ["PASS"] * 5 + ["FAIL"] + ["PASS"] * 3
    h1, h2 = part.holes[0], part.holes[1]
    assert abs(by_name["x H1"].value_mm - (h1.centre[0] + h1.offset[0])) < 1e-8
    ends1 = np.array(h1.centre) + np.array(h1.offset)
    ends2 = np.array(h2.centre) + np.array(h2.offset)
    assert abs(by_name["H1 to H2"].value_mm - np.linalg.norm(ends2 - ends1)) < 1e-8
    u = h1.axis()
    n = np.array([-part.top_slope, 0.0, 1.0]) / np.hypot(part.top_slope, 1.0)
    assert abs(by_name["H1 to TOP"].value_mm - np.arccos(abs(u @ n))) < 1e-9
    drf = result.frames["A|B|C"]
    assert np.allclose(drf.rotation, part.rotation.T, atol=1e-9) and drf.free == ()


def test_example_files_are_what_the_script_makes(maker, tmp_path):
    import subprocess
    import sys

    subprocess.run([sys.executable, str(EXAMPLE_DIR / "make_gdt_example.py"), "--out-dir", str(tmp_path)],
                   check=True)
    for f in tmp_path.iterdir():
        assert f.read_text() == (EXAMPLE_DIR / f.name).read_text(), f.name


def test_pcmm_inspect_json_table_and_exit_codes(tmp_path):
    plan = _copy_example(tmp_path)
    done = run_pcmm("inspect", plan, "--json")
    assert done.returncode == 1, done.stderr  # H3 fails
    data = json.loads(done.stdout)
    first = data["characteristics"][3]
    assert {"name", "value_mm", "tolerance_mm", "bonus_mm", "verdict", "datums"} <= set(first)
    assert first["datums"] == ["A", "B", "C"] and first["verdict"] == "PASS"
    assert "bonus_mm" not in data["characteristics"][0]
    assert set(data["datums"]) == {"A", "B", "C"} and data["datums"]["A"]["certificate"]["scope"] == "global"
    # without the position frames everything passes: exit 0, and the table
    text = plan.read_text()
    plan.write_text(text[:text.index('[[characteristics]]\nname = "position H1"')])
    done = run_pcmm("inspect", plan)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "parallelism TOP" in done.stdout and "verdict: 3 characteristics: 3 PASS" in done.stdout
    # the dimensions report their units
    angle = next(c for c in data["characteristics"] if c["characteristic"] == "angle")
    assert "value_rad" in angle and "value_mm" not in angle and abs(angle["value_deg"] - 0.0343775) < 1e-6


def _line_of(text: str, needle: str) -> int:
    return next(k for k, line in enumerate(text.splitlines(), start=1) if needle in line)


@pytest.mark.parametrize(("edit", "needle", "message"), [
    (('points = "H2.csv"', 'points = "missing.csv"'), 'points = "missing.csv"', "not found"),
    (("position dia 0.1 MMC | A | B | C", "position dia 0.1 MMC | A | B | Q"), "| Q", "unknown datum 'Q'"),
    (("parallelism 0.05 | A", "wobble 0.05 | A"), "wobble", "unknown characteristic"),
    (("position dia 0.1 MMC | A | B | C", "position dia 0.1 MMC | A | B MMB | C"), "MMB",
     "datum B: expected a cylinder along the primary A's direction to be referenced at MMB"),
    (('C = "C"', 'C = "TOP"'), "position dia", "constrains"),
    (('element = "cylinder"', 'element = "cone"'), 'element = "cone"', "element"),
    (('type = "distance"', 'type = "volume"'), 'type = "volume"', "expected one of coordinate"),
    (('features = ["H1", "H2"]', 'features = ["H1", "H9"]'), 'features = ["H1", "H9"]', "unknown feature 'H9'"),
    (('axis = "x"', 'axis = "q"'), 'axis = "q"', "axis ="),
])
def test_plan_errors_are_one_line_naming_the_plans_line_exit_2(tmp_path, edit, needle, message):
    plan = _copy_example(tmp_path)
    text = plan.read_text().replace(*edit, 1)
    plan.write_text(text)
    done = run_pcmm("inspect", plan)
    assert done.returncode == 2, done.stdout + done.stderr
    err = done.stderr.strip()
    assert len(err.splitlines()) == 1 and message in err, err
    assert f"plan.toml:{_line_of(text, needle)}:" in err, err


def test_guide_page_shows_what_pcmm_inspect_prints(tmp_path):
    page = (Path(__file__).parents[2] / "docs" / "guide" / "gdt_with_datums.rst").read_text(encoding="utf-8")
    shown = {" ".join(line.split()) for line in page.splitlines()}
    plan = _copy_example(tmp_path)
    done = run_pcmm("inspect", plan.name, cwd=tmp_path)
    printed = [" ".join(line.split()) for line in done.stdout.splitlines()]
    rows = [line for line in printed if line.startswith(("position H", "flatness A", "parallelism TOP",
                                                         "perpendicularity H1", "A plane", "B plane", "C plane",
                                                         "A|B|C", "verdict:", "x H1", "H1 to"))]
    assert len(rows) == 14
    missing = [row for row in rows if row not in shown]
    assert missing == []


def test_profile_of_a_surface_in_a_plan(maker, tmp_path):
    from test_gdt_profile import _patch

    part = maker.make_part(n_points=maker.EXAMPLE_POINTS)
    nominal, normals, measured, _, _ = _patch(np.random.default_rng(2))
    plan = _copy_example(tmp_path)
    np.savetxt(tmp_path / "S_nominal.csv", nominal, fmt="%.12f", delimiter=",")
    np.savetxt(tmp_path / "S_normals.csv", normals, fmt="%.12f", delimiter=",")
    np.savetxt(tmp_path / "S.csv", measured @ part.rotation.T + part.translation, fmt="%.12f", delimiter=",")
    text = plan.read_text()
    text = text[:text.index("[[characteristics]]")]
    text = text.replace("[datums]", '[features.S]\nelement = "surface"\npoints = "S.csv"\n'
                        'nominal_points = "S_nominal.csv"\nnominal_normals = "S_normals.csv"\n\n[datums]')
    text += '[[characteristics]]\nname = "profile S"\nfeature = "S"\nframe = "⌓ 0.025 | A | B | C"\n'
    plan.write_text(text)
    result = inspect_plan(plan)
    (c,) = result.characteristics
    assert c.characteristic == "profile of a surface" and abs(c.value_mm - 0.024) < 1e-8 and c.verdict == "PASS"


def test_a_coordinate_the_drf_cannot_place_is_refused_by_name(maker):
    from pcmm_geo.errors import InvalidInputError
    from pcmm_geo.gdt import FeatureData, associate_datum, build_drf, evaluate_coordinate
    from pcmm_geo.gdt.reference.drf import nominal_of

    part = maker.make_part(1, n_points=100, n_holes=1)
    a = associate_datum(part.measured("A"), "plane", label="A", nominal_direction=[0, 0, 1])
    drf = build_drf([(a, nominal_of([0, 0, 0], [0, 0, 1]))])
    h = part.holes[0]
    f = FeatureData("H1", "cylinder", part.measured("H1"), np.array([*h.centre, 0.0]), np.array([0, 0, 1.0]))
    with pytest.raises(InvalidInputError, match="H1: datums: expected a DRF that fixes the x translation"):
        evaluate_coordinate(f, drf, "x", 30.0, (-0.1, 0.1), name="H1")
    assert evaluate_coordinate(f, drf, "z", 0.0, (-0.1, 0.1), name="H1").verdict == "PASS"


def test_report_states_the_method_and_the_decision(tmp_path):
    plan = _copy_example(tmp_path)
    text = plan.read_text()
    plan.write_text(text[:text.index('[[characteristics]]\nname = "position H1"')])
    report = tmp_path / "inspection.md"
    done = run_pcmm("inspect", plan, "--report", report)
    assert done.returncode == 0, done.stderr
    record = report.read_text(encoding="utf-8")
    assert "ISO 1101:2017" in record and "3 characteristics: 3 PASS" in record
    assert "parallelism TOP" in record
    assert run_pcmm("inspect", plan, "--report", report).returncode == 2  # never over a file without --overwrite


def test_sphere_and_point_datums_leave_rotations_free_and_position_of_a_centre(maker):
    from pcmm_geo.gdt import FeatureData, associate_datum, build_drf, evaluate_position
    from pcmm_geo.gdt.reference.drf import nominal_of

    rng = np.random.default_rng(12)
    d = rng.standard_normal((200, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    ball = np.array([10.0, 20.0, 5.0]) + 12.5 * d
    s = associate_datum(ball, "sphere", label="S", side="external")
    assert np.allclose(s.point, [10, 20, 5], atol=1e-9) and abs(s.radius - 12.5) < 1e-9
    assert s.certificate.scope == "global"
    drf = build_drf([(s, nominal_of([0, 0, 0], None))])
    assert drf.free == ("rx", "ry", "rz") and np.allclose(drf.origin, [10, 20, 5], atol=1e-9)
    # a second centre 50 mm away nominally, 30 um further: with every rotation free only the distance counts
    other = np.array([10.0, 20.0, 5.0]) + np.array([0.6, 0.8, 0.0]) * 50.03 + 3.0 * d
    f = FeatureData("T", "sphere", other, np.array([50.0, 0, 0]), np.full(3, np.nan))
    r = evaluate_position(f, drf, 0.1, zone="dia")
    assert abs(r.value_mm - 2 * 0.03) < 1e-6 and r.verdict == "PASS"
    p = associate_datum(np.array([[1.0, 2.0, 3.0]]), "point", label="P")
    assert np.allclose(p.point, [1, 2, 3]) and build_drf([(p, nominal_of([0, 0, 0], None))]).free == ("rx", "ry", "rz")


@pytest.mark.parametrize(("u", "expected"), [(0.0, "PASS"), (0.002, "PASS"), (0.005, "NOT PROVEN")])
def test_stated_uncertainty_guards_the_verdict_iso_14253_1(tmp_path, u, expected):
    # flatness of A is 4.000 um against 10 um and parallelism of TOP 21.6 um against 25 um
    plan = _copy_example(tmp_path)
    text = plan.read_text()
    text = text[:text.index('[[characteristics]]\nname = "perpendicularity H1"')]
    text = text.replace('frame = "parallelism 0.05 | A"', f'frame = "parallelism 0.025 | A"\nuncertainty_mm = {u}')
    plan.write_text(text)
    flat, par = inspect_plan(plan).characteristics
    assert flat.verdict == "PASS" and "expanded_uncertainty_mm" not in flat.details
    assert par.verdict == expected and par.details["expanded_uncertainty_mm"] == u


def test_stated_uncertainty_proves_nonconformity_only_beyond_u(tmp_path):
    plan = _copy_example(tmp_path)
    text = plan.read_text()
    text = text[:text.index('[[characteristics]]\nname = "perpendicularity H1"')]
    for u, expected in ((0.001, "FAIL"), (0.003, "NOT PROVEN")):  # 21.6 um against 20 um
        plan.write_text(text.replace('frame = "parallelism 0.05 | A"',
                                     f'frame = "parallelism 0.020 | A"\nuncertainty_mm = {u}'))
        assert inspect_plan(plan).characteristics[1].verdict == expected
    plan.write_text(text.replace('frame = "parallelism 0.05 | A"', 'frame = "parallelism 0.020 | A"\n'
                                 'uncertainty_mm = -1'))
    with pytest.raises(FileFormatError, match="uncertainty_mm"):
        inspect_plan(plan)
