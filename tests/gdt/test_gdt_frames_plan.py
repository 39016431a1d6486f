"""Composite / stacked position frames, symmetry and profile of a line in a TOML plan and ``pcmm inspect``."""

from __future__ import annotations

import json

import numpy as np
import pytest
from pcmm_runner import run_pcmm

from pcmm_geo.errors import FileFormatError
from pcmm_geo.gdt import inspect_plan

HEAD = """units = "mm"
standard = "{standard}"
[part]
frame = "A|B|C"
[features.A]
element = "plane"
points = "A.csv"
normal = [0, 0, -1]
[features.B]
element = "plane"
points = "B.csv"
normal = [-1, 0, 0]
[features.C]
element = "plane"
points = "C.csv"
normal = [0, -1, 0]
"""
DATUMS = '[datums]\nA = "A"\nB = "B"\nC = "C"\n'
CENTRES = [(30.0, 25.0), (90.0, 25.0), (60.0, 65.0)]
OFFSETS = [(0.0, 0.0), (0.04, 0.0), (0.01, 0.03)]  # circumradius sqrt(5) * 0.01 about (0.02, 0.01)


def _save(path, pts):
    np.savetxt(path, pts, fmt="%.12f", delimiter=",")


def _part(maker, tmp_path, seed=0):
    part = maker.make_part(seed, n_points=100, n_holes=0)
    for name in "ABC":
        _save(tmp_path / f"{name}.csv", part.measured(name))
    return part


def _holes_plan(maker, tmp_path, frames, *, standard="ASME", seed=0):
    part = _part(maker, tmp_path, seed)
    rng = np.random.default_rng(seed)
    text = HEAD.format(standard=standard)
    for k, (centre, offset) in enumerate(zip(CENTRES, OFFSETS, strict=True)):
        hole = maker.Hole(f"H{k + 1}", centre, 10.0, offset, (0.0, 0.0), 10.03)
        _save(tmp_path / f"H{k + 1}.csv", maker.hole_points(rng, hole, 80) @ part.rotation.T + part.translation)
        text += (f'[features.H{k + 1}]\nelement = "cylinder"\npoints = "H{k + 1}.csv"\nside = "internal"\n'
                 f"point = [{centre[0]}, {centre[1]}, 0]\naxis = [0, 0, 1]\ndiameter = 10\nsize_tolerance = [0, 0.1]\n")
    text += DATUMS + '[[characteristics]]\nname = "3X"\nfeatures = ["H1", "H2", "H3"]\nframe = ' + \
        json.dumps(frames, ensure_ascii=False) + "\n"
    plan = tmp_path / "plan.toml"
    plan.write_text(text, encoding="utf-8")
    return plan


def test_a_composite_frame_in_a_plan_gives_pltzf_and_frtzf_per_hole(maker, tmp_path):
    plan = _holes_plan(maker, tmp_path, ["position dia 0.2 | A | B | C", "dia 0.05 | A | B"])
    result = inspect_plan(plan)
    names = [c.name for c in result.characteristics]
    assert names == [f"3X H{k} (PLTZF)" for k in (1, 2, 3)] + [f"3X H{k} (FRTZF)" for k in (1, 2, 3)]
    for c, offset in zip(result.characteristics[:3], OFFSETS, strict=True):
        assert abs(c.value_mm - 2 * np.hypot(*offset)) < 1e-9 and c.datums == ("A", "B", "C")
    for c in result.characteristics[3:]:
        # FRTZF to A|B: the enclosing circle of the offsets (translation floats), 0.0447 <= 0.05
        assert abs(c.value_mm - 2 * np.sqrt(5.0) * 0.01) < 1e-9 and c.verdict == "PASS"
        assert c.datums == ("A", "B") and c.details["segment"] == "FRTZF"
    done = run_pcmm("inspect", plan, "--json")
    assert done.returncode == 0, done.stdout + done.stderr
    data = json.loads(done.stdout)
    assert [c["segment"] for c in data["characteristics"]] == ["PLTZF"] * 3 + ["FRTZF"] * 3


def test_a_stacked_lower_segment_constrains_translation(maker, tmp_path):
    # the same pattern under a stacked A|B segment: x is located by B, y floats
    plan = _holes_plan(maker, tmp_path, ["position dia 0.2 | A | B | C", "position dia 0.06 | A | B"])
    result = inspect_plan(plan)
    lower = result.characteristics[3:]
    # only y floats: deviations (0, 0), (0.04, 0), (0.01, 0.03) -> y shift 0.015 balances H1 and H3 at x
    # offsets 0 and 0.01: values 2 * max over k of |(dx_k, dy_k - s)|, minimised at s: H2's 0.04 dominates
    assert all(c.details["segment"] == "segment 2" for c in lower)
    assert abs(max(c.value_mm for c in lower) - 0.08) < 1e-9
    assert [c.verdict for c in lower] == ["FAIL"] * 3  # 0.08 > 0.06 whatever the y shift: proven


@pytest.mark.parametrize(("frames", "standard", "reason"), [
    (["position dia 0.2 | A | B | C", "dia 0.02 | A"], "ISO", "composite frame is ASME"),
    (["position dia 0.2 CZ | A | B | C", "position dia 0.02 CZ >< | A"], "ASME", "ISO 5458"),
    (["position dia 0.2 | A | B | C", "dia 0.02 | B"], "ASME", "repeats the upper"),
    (["position dia 0.2 | A | B | C", "dia 0.3 | A"], "ASME", "smaller than the PLTZF"),
    (["position dia 0.2 | A | B | C", "dia 0.02 | D"], "ASME", "unknown datum"),
    (["position dia 0.2 | A | B | C"], "ASME", "two or more"),
])
def test_bad_multi_segment_frames_name_the_plan_line(maker, tmp_path, frames, standard, reason):
    plan = _holes_plan(maker, tmp_path, frames, standard=standard)
    line = plan.read_text(encoding="utf-8").splitlines().index(next(
        t for t in plan.read_text(encoding="utf-8").splitlines() if t.startswith("frame = ["))) + 1
    with pytest.raises(FileFormatError, match=reason) as info:
        inspect_plan(plan)
    assert f":{line}" in str(info.value) or f"line {line}" in str(info.value)
    done = run_pcmm("inspect", plan)
    assert done.returncode == 2 and reason.split()[0] in done.stderr


def test_iso_stacked_frames_with_cz_and_orientation_only(maker, tmp_path):
    plan = _holes_plan(maker, tmp_path, ["⌖ ⌀0.2 CZ | A | B | C", "⌖ ⌀0.05 CZ >< | A | B"], standard="ISO")
    result = inspect_plan(plan)
    lower = result.characteristics[3:]
    assert all(abs(c.value_mm - 2 * np.sqrt(5.0) * 0.01) < 1e-9 for c in lower)  # as the FRTZF
    separate = _holes_plan(maker, tmp_path, ["⌖ ⌀0.2 | A | B | C", "⌖ ⌀0.05 >< | A | B"], standard="ISO")
    alone = inspect_plan(separate).characteristics[3:]
    assert all(c.value_mm < 1e-9 for c in alone)  # SZ: each zone floats on its own


def _slot_plan(maker, tmp_path, standard, e1, e2):
    part = _part(maker, tmp_path)
    rng = np.random.default_rng(5)
    for name, x in (("S1", 70.0 + e1), ("S2", 50.0 + e2)):
        y, z = rng.uniform(30, 50, 60), rng.uniform(5, 25, 60)
        _save(tmp_path / f"{name}.csv", np.c_[np.full(60, x), y, z] @ part.rotation.T + part.translation)
    text = HEAD.format(standard=standard)
    text += ('[features.S1]\nelement = "plane"\npoints = "S1.csv"\npoint = [70, 40, 15]\nnormal = [1, 0, 0]\n'
             '[features.S2]\nelement = "plane"\npoints = "S2.csv"\npoint = [50, 40, 15]\nnormal = [-1, 0, 0]\n')
    text += DATUMS + '[[characteristics]]\nname = "sym"\nfeatures = ["S1", "S2"]\nframe = "⌯ 0.05 | A | B | C"\n'
    plan = tmp_path / "plan.toml"
    plan.write_text(text, encoding="utf-8")
    return plan


def test_symmetry_in_a_plan_and_its_refusal_under_asme(maker, tmp_path):
    plan = _slot_plan(maker, tmp_path, "ISO", 0.02, 0.01)
    (c,) = inspect_plan(plan).characteristics
    assert c.characteristic == "symmetry" and abs(c.value_mm - 0.03) < 1e-9 and c.verdict == "PASS"
    done = run_pcmm("inspect", plan, "--json")
    assert done.returncode == 0 and json.loads(done.stdout)["characteristics"][0]["characteristic"] == "symmetry"
    asme = _slot_plan(maker, tmp_path, "ASME", 0.02, 0.01)
    done = run_pcmm("inspect", asme)
    assert done.returncode == 2 and "removed in ASME" in done.stderr
    assert f":{len(asme.read_text(encoding='utf-8').splitlines())}" in done.stderr  # the frame's line


def test_profile_of_a_line_in_a_plan(maker, tmp_path):
    part = _part(maker, tmp_path)
    t = 2 * np.pi * np.arange(180) / 180
    curve = np.c_[60 + 30 * np.cos(t), 40 + 15 * np.sin(t)]
    normals = np.c_[15 * np.cos(t), 30 * np.sin(t)]
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    nominal = np.vstack([np.c_[curve, np.full(180, h)] for h in (10.0, 20.0)])
    nominal_n = np.vstack([np.c_[normals, np.zeros(180)]] * 2)
    delta = np.random.default_rng(3).uniform(-0.01, 0.01, 360)
    measured = nominal + delta[:, None] * nominal_n
    _save(tmp_path / "L.csv", measured @ part.rotation.T + part.translation)
    _save(tmp_path / "L_nominal.csv", nominal)
    _save(tmp_path / "L_normals.csv", nominal_n)
    text = HEAD.format(standard="ISO") + ('[features.L]\nelement = "surface"\npoints = "L.csv"\n'
                                          'nominal_points = "L_nominal.csv"\nnominal_normals = "L_normals.csv"\n')
    text += DATUMS + ('[[characteristics]]\nname = "line L"\nfeature = "L"\nframe = "⌒ 0.05 | A | B | C"\n'
                      'section = [0, 0, 1]\n')
    plan = tmp_path / "plan.toml"
    plan.write_text(text, encoding="utf-8")
    (c,) = inspect_plan(plan).characteristics
    assert abs(c.value_mm - 2 * np.abs(delta).max()) < 1e-9 and c.verdict == "PASS"
    assert len(c.details["sections"]) == 2
    plan.write_text(text.replace("section = [0, 0, 1]\n", ""), encoding="utf-8")
    with pytest.raises(FileFormatError, match="section = \\[x, y, z\\]"):
        inspect_plan(plan)


def test_qif_of_composite_symmetry_and_line_profile_is_schema_valid_and_says_what_it_left_out(maker, tmp_path):
    from pcmm_geo.gdt.qif.results import inspection_to_qif
    from pcmm_geo.io.cmm.qif.schema import validate_qif

    plan = _holes_plan(maker, tmp_path, ["position dia 0.2 | A | B | C", "dia 0.05 | A | B"])
    result = inspect_plan(plan)
    export = inspection_to_qif(result, tmp_path / "composite.qif")
    assert validate_qif(export.path) == ()
    assert export.written == tuple(f"3X H{k} ({s})" for s in ("PLTZF", "FRTZF") for k in (1, 2, 3))
    assert export.not_written == ()
    # each hole's position carries its FRTZF as the second composite segment (value, status, frame A|B)
    from lxml import etree

    ns = {"q": "http://qifstandards.org/xsd/qif3"}
    tree = etree.parse(str(export.path))
    segments = tree.findall(".//q:SecondCompositeSegmentPositionMeasurement", ns)
    assert len(segments) == 3 and len(tree.findall(".//q:SecondCompositeSegmentPositionDefinition", ns)) == 3
    values = sorted(float(m.find("q:Value", ns).text) for m in segments)
    expected = sorted(c.value_mm for c in result.characteristics[3:])
    assert max(abs(a - b) for a, b in zip(values, expected, strict=True)) < 1e-9
    frames = {f.get("id"): len(f.findall(".//q:Datum", ns)) for f in tree.findall(".//q:DatumReferenceFrame", ns)}
    lower = tree.find(".//q:SecondCompositeSegmentPositionDefinition/q:DatumReferenceFrameId", ns).text
    assert frames[lower] == 2
    slot = _slot_plan(maker, tmp_path, "ISO", 0.02, 0.01)
    export = inspection_to_qif(inspect_plan(slot), tmp_path / "symmetry.qif")
    assert validate_qif(export.path) == () and export.written == ("sym",)
    text = export.path.read_text(encoding="utf-8")
    assert "<SymmetryCharacteristicDefinition" in text and "<SymmetryCharacteristicMeasurement" in text
    done = run_pcmm("inspect", slot, "--json", "--qif", tmp_path / "cli.qif")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["qif"]["written"] == ["sym"]
