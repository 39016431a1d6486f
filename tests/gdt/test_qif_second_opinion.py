"""The second opinion beyond sizes and positions: angularity, orientation to two datums, runout, coaxiality, profile,
datum shift; and the ``pcmm qif`` options of this round (alias help, --max-elements, one parse, the plot).

Exact cases are constructed (a slab on a cone of normals); the others are variants of the
public QIF_PTS_SAMPLE (qif-community, Boost licence) whose perpendicularity PERP1 is rewritten
as another characteristic type, on another feature, or to more datums.  Each expected value is
computed here independently from what :func:`read_qif` reads (the file's points and actuals)
with a few lines of numpy, or from an identity the construction guarantees.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pcmm_geo.cli import main
from pcmm_geo.gdt.qif.axial import sections
from pcmm_geo.gdt.qif.characteristics import verify_characteristics
from pcmm_geo.gdt.qif.orientation import thinnest_width_on_cone
from pcmm_geo.io.cmm import read_qif

SAMPLES = Path(__file__).resolve().parents[1] / "data" / "qif" / "samples"
PTS = SAMPLES / "QIF_PTS_SAMPLE.QIF"
#: DATUMC (a line) as the secondary datum of PERP1's frame 820
_SECONDARY_C = """        <Datum>
          <SimpleDatum>
            <DatumDefinitionId>845</DatumDefinitionId>
            <MaterialModifier>REGARDLESS</MaterialModifier>
            <ReferencedComponent>ACTUAL</ReferencedComponent>
          </SimpleDatum>
          <Precedence>
            <PrecedenceEnum>SECONDARY</PrecedenceEnum>
          </Precedence>
        </Datum>
      </Datums>
    </DatumReferenceFrame>
    <DatumReferenceFrame id="844">"""


def _variant(tmp_path: Path, kind: str = "Perpendicularity", *, feature: int | None = None, secondary: bool = False,
             datum_a: str | None = None, value: str | None = None, frame: str | None = None) -> Path:
    """QIF_PTS_SAMPLE with PERP1 (measurement 824, of CYL_1 796, to frame 820 = DATUMA) rewritten."""
    text = PTS.read_text()

    def swap(old: str, new: str) -> None:
        nonlocal text
        assert text.count(old) == 1, old
        text = text.replace(old, new)

    if kind != "Perpendicularity":
        text = text.replace("PerpendicularityCharacteristic", f"{kind}Characteristic")
    if feature is not None:
        anchor = '<CharacteristicItemId>823</CharacteristicItemId>\n              <FeatureMeasurementIds n="1">\n'
        swap(anchor + "                <Id>796</Id>", anchor + f"                <Id>{feature}</Id>")
    if secondary:
        swap("      </Datums>\n    </DatumReferenceFrame>\n    <DatumReferenceFrame id=\"844\">", _SECONDARY_C)
    if datum_a is not None:
        swap("<DatumLabel>DATUMA</DatumLabel>", f"<DatumLabel>{datum_a}</DatumLabel>")
    if value is not None:
        swap("<Value>0.000001541919</Value>", f"<Value>{value}</Value>")
    if frame is not None:
        swap("<ToleranceValue>1</ToleranceValue>\n        <DatumReferenceFrameId>820</DatumReferenceFrameId>",
             f"<ToleranceValue>1</ToleranceValue>\n        <DatumReferenceFrameId>{frame}</DatumReferenceFrameId>")
    path = tmp_path / f"{kind}_{feature}_{secondary}_{datum_a}_{value}_{frame}.qif"
    path.write_text(text)
    return path


def _check(path: Path, characteristic_id: int = 824):  # type: ignore[no-untyped-def]
    return next(c for c in verify_characteristics(read_qif(path)).checks if c.id == characteristic_id)


def _feature(document, name: str):  # type: ignore[no-untyped-def]
    return next(f for f in document.measured_features if f.name == name)


@pytest.mark.parametrize("seed", range(6))
def test_the_thinnest_zone_on_a_cone_of_normals_is_the_slab_thickness(seed: int) -> None:
    rng = np.random.default_rng(seed)
    alpha, thickness = rng.uniform(0.2, 1.3), rng.uniform(0.005, 0.05)
    u = np.array([0.0, 0.0, 1.0])
    phi = rng.uniform(0, 2 * np.pi)
    normal = np.array([np.sin(alpha) * np.cos(phi), np.sin(alpha) * np.sin(phi), np.cos(alpha)])
    e1 = np.cross(normal, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(normal, e1)
    uv = rng.uniform(-20, 20, (300, 2))
    heights = rng.uniform(-thickness / 2, thickness / 2, 300)
    # both faces touched at the patch's four corners: any tilt of the normal widens the zone
    uv[:8] = [[sx * 20.0, sy * 20.0] for sx in (-1, 1) for sy in (-1, 1)] * 2
    heights[:8] = [thickness / 2] * 4 + [-thickness / 2] * 4
    points = uv[:, :1] * e1 + uv[:, 1:] * e2 + heights[:, None] * normal
    turn = Rotation.from_rotvec(rng.uniform(-1, 1, 3)).as_matrix()
    # the minimum over the cone is the slab (any other normal on it adds in-plane extent); the refined search
    # stops within 1e-10 rad of the best angle, which moves the width by at most ~40 mm x 1e-10
    width = thinnest_width_on_cone(points @ turn.T, turn @ u, alpha)
    assert abs(width - thickness) < 1e-7
    # the other half-angle (the supplement) describes the same planes
    assert abs(thinnest_width_on_cone(points @ turn.T, turn @ u, np.pi - alpha) - thickness) < 1e-7
    # a cone that misses the slab's normal by 0.1 rad gives a wider zone
    assert thinnest_width_on_cone(points @ turn.T, turn @ u, alpha + 0.1) > thickness + 1.0


def test_sections_split_at_gaps() -> None:
    along = np.array([0.0, 10.0, 0.1, 10.2, 0.05, 20.0, 20.4])
    assert [part.tolist() for part in sections(along)] == [[0, 2, 4], [1, 3], [5, 6]]
    assert [part.tolist() for part in sections(along, gap=15.0)] == [[0, 1, 2, 3, 4, 5, 6]]


def test_angularity_and_orientation_to_two_datums_on_public_points(tmp_path: Path) -> None:
    perpendicularity = _check(PTS)
    assert perpendicularity.status == "agrees" and perpendicularity.source == "points"
    # CYL_1's nominal axis is along DATUMA's nominal normal: angularity at the nominal angle 0 is the same zone
    angularity = _check(_variant(tmp_path, "Angularity"))
    assert angularity.status == "agrees" and "nominal 0 degrees" in angularity.reason
    assert abs(angularity.recomputed - perpendicularity.recomputed) < 1e-9
    # to A|C: the frame carries the nominal axis onto A's actual normal exactly, whatever C does
    two = _check(_variant(tmp_path, secondary=True))
    assert "DATUMA" in two.reason and "DATUMC" in two.reason and "carried by the frame" in two.reason
    assert abs(two.recomputed - perpendicularity.recomputed) < 1e-9
    # parallelism of DATUMA's own points to A|C: their range along A's reported normal (the file's points)
    document = read_qif(PTS)
    datum_a = _feature(document, "DATUMA")
    points = document.points_of(datum_a).points
    expected = float(np.ptp(points @ datum_a.actual.normal))
    parallel = _check(_variant(tmp_path, "Parallelism", feature=11, secondary=True))
    assert parallel.source == "points" and abs(parallel.recomputed - expected) < 1e-9
    # a value changed by hand (tolerance 1 mm: bound 10 µm) is caught
    changed = _check(_variant(tmp_path, "Angularity", value="0.05"))
    assert changed.status == "disagrees" and abs(changed.recomputed - perpendicularity.recomputed) < 1e-9
    # without points the plane CPLANE's angularity is not computable, by name
    assert "no points" in _check(_variant(tmp_path, "Angularity", feature=838)).reason


def test_runout_coaxiality_and_profile_on_public_points(tmp_path: Path) -> None:
    document = read_qif(PTS)
    cylinder = _feature(document, "CYL_1")
    axis = cylinder.actual.direction / np.linalg.norm(cylinder.actual.direction)
    stored = document.points_of(cylinder).points
    delta = stored - cylinder.actual.location
    radii = np.linalg.norm(delta - np.outer(delta @ axis, axis), axis=1)
    # CYL_1 about its own reported axis (its datum label made CYL_1): the probe radius shifts every
    # distance alike, so the range of the stored centres' distances is the runout of the surface
    total = _check(_variant(tmp_path, "TotalRunout", datum_a="CYL_1"))
    assert total.source == "points" and abs(total.recomputed - float(np.ptp(radii))) < 1e-6
    circular = _check(_variant(tmp_path, "CircularRunout", datum_a="CYL_1"))
    parts = sections(delta @ axis)
    assert len(parts) == 2 and "2 cross-sections" in circular.reason
    assert abs(circular.recomputed - max(float(np.ptp(radii[p])) for p in parts)) < 1e-6
    # CIRCLE1's concentricity to CYL_1's axis: twice its centre's distance from it (ISO 1101)
    circle = _feature(document, "CIRCLE1")
    offset = circle.actual.location - cylinder.actual.location
    distance = float(np.linalg.norm(offset - float(offset @ axis) * axis))
    concentricity = _check(_variant(tmp_path, "Concentricity", feature=261, datum_a="CYL_1"))
    assert "ISO 1101" in concentricity.reason and abs(concentricity.recomputed - 2 * distance) < 1e-5
    # surface profile of DATUMA to A: the frame puts A's actual plane on its nominal, so the distances
    # from the nominal plane are the surface points' distances from the reported plane
    plane = _feature(document, "DATUMA")
    stored = document.points_of(plane)
    centres, radius = stored.points, stored.probe_radius  # probe-ball centres, 2.49978271104 mm outside
    normal = np.linalg.svd(centres - centres.mean(axis=0))[2][2]  # the least-squares plane of the centres
    normal *= np.sign(float(normal @ plane.actual.normal))
    side = np.sign(float(((centres - plane.actual.location) @ plane.actual.normal).mean()))
    surface = centres - side * radius * normal  # the probe radius along the refitted normal
    heights = (surface - plane.actual.location) @ plane.actual.normal
    profile = _check(_variant(tmp_path, "SurfaceProfile", feature=11))
    assert abs(profile.recomputed - 2 * float(np.abs(heights).max())) < 1e-9
    # not computable, each with its reason
    assert "needs a datum axis" in _check(_variant(tmp_path, "TotalRunout")).reason
    assert "six degrees of freedom" in _check(_variant(tmp_path, "SurfaceProfile", feature=11, frame="498")).reason
    assert "in sections" in _check(_variant(tmp_path, "LineProfile", feature=11)).reason
    # a runout changed by hand (bound 10 µm) is caught
    assert _check(_variant(tmp_path, "TotalRunout", datum_a="CYL_1", value="0.025")).status == "disagrees"


def _python30(tmp_path: Path, old: str, new: str) -> Path:
    text = (SAMPLES / "testPython30.qif").read_text()
    assert text.count(old) == 1
    path = tmp_path / "shifted.qif"
    path.write_text(text.replace(old, new))
    return path


def test_positions_to_datums_at_mmb_use_the_datum_shift(tmp_path: Path) -> None:
    checks = {c.id: c for c in verify_characteristics(read_qif(SAMPLES / "testPython30.qif")).checks}
    # B is a hole of 12.699 mm with limits 12.4 .. (its DIAM1_B), so it may shift by 12.699 - 12.4 = 0.299 mm
    assert checks[37].status == "agrees" and "shift 0.299 mm" in checks[37].reason
    assert abs(checks[37].recomputed - 0.102) < 1e-9  # the file's value: the datums fixed at their actuals
    assert checks[49].status == "agrees" and "datum C at MMB" in checks[49].reason and "rotation" in checks[49].reason
    # a value above the fixed-datum value cannot come from a shift (a shift only lowers it): caught
    high = {c.id: c for c in verify_characteristics(read_qif(
        _python30(tmp_path, "<Value>0.102</Value>", "<Value>0.2</Value>"))).checks}
    assert high[37].status == "disagrees"
    # a value below it, within what the 0.299 mm shift allows, agrees and says so
    low = {c.id: c for c in verify_characteristics(read_qif(
        _python30(tmp_path, "<Value>0.102</Value>", "<Value>0.05</Value>"))).checks}
    assert low[37].status == "agrees" and "the datum shift allows" in low[37].reason
    # WIDGET's J is a primary datum at MMB: its shift is not bounded; its reported value (0.344) is above the
    # fixed-datum value (0.017) and matches the file's coordinates without the frame
    widget = {c.id: c for c in verify_characteristics(read_qif(SAMPLES / "WIDGET_QIF_RESULTS.QIF")).checks}
    assert widget[75].status == "disagrees" and "without the datum reference frame" in widget[75].reason


def test_results_alias_help_names_the_alias(capsys: pytest.CaptureFixture[str]) -> None:
    for argv, prog in ((["results", "verify", "--help"], "pcmm results verify"),
                       (["qif", "verify", "--help"], "pcmm qif verify"),
                       (["results", "show", "--help"], "pcmm results show")):
        with pytest.raises(SystemExit) as exit_info:
            main(argv)
        assert exit_info.value.code == 0
        assert capsys.readouterr().out.startswith(f"usage: {prog} ")


def test_results_without_an_action_names_the_alias(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["results"])
    assert exit_info.value.code == 2
    assert capsys.readouterr().err.startswith("pcmm results: error: choose an action")


@pytest.mark.parametrize("bad", ["0", "-3", "abc", "1e3", "2000000000"])
def test_max_elements_is_checked(bad: str, capsys: pytest.CaptureFixture[str]) -> None:
    for action in ("show", "verify", "validate"):
        assert main(["qif", action, str(SAMPLES / "QIF_Results_Sample.QIF"), "--max-elements", bad]) == 2
        err = capsys.readouterr().err
        assert "--max-elements" in err and len(err.strip().splitlines()) == 1


def test_max_elements_bounds_the_parse(capsys: pytest.CaptureFixture[str]) -> None:
    sample = str(SAMPLES / "QIF_Results_Sample.QIF")
    assert main(["qif", "verify", sample, "--max-elements", "50"]) == 2
    err = capsys.readouterr().err
    assert "more than 50 elements" in err and "--max-elements" in err and len(err.strip().splitlines()) == 1
    assert main(["qif", "show", sample, "--max-elements", "100000", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["format"] == "qif"
    # validate counts the elements in its screening pass, before libxml2 builds a tree
    assert main(["results", "validate", sample, "--max-elements", "50"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("pcmm results validate: error:") and "more than 50 elements" in err
    assert main(["qif", "validate", sample, "--max-elements", "100000"]) == 0


def test_verify_parses_the_file_once(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    from pcmm_geo.io.cmm.qif import reader

    calls = []
    original = reader.parse_qif_tree

    def counted(*args, **kwargs):  # type: ignore[no-untyped-def]
        calls.append(args[0])
        return original(*args, **kwargs)

    monkeypatch.setattr(reader, "parse_qif_tree", counted)
    assert main(["qif", "verify", str(SAMPLES / "testPython30.qif"), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert len(calls) == 1
    # the definitions came from that parse: the datum shifts of the frames were read
    assert data["characteristics_summary"] == {"agrees": 5, "disagrees": 0, "not_computable": 2}


def test_verify_plot_draws_the_characteristics(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("matplotlib")
    from pcmm_geo.gdt.qif.characteristics import CharacteristicCheck, CharacteristicVerification
    from pcmm_geo.plots.cmm_verify import characteristic_ratios

    out = tmp_path / "second.png"
    assert main(["qif", "verify", str(SAMPLES / "WIDGET_QIF_RESULTS.QIF"), "--plot", str(out)]) == 1
    capsys.readouterr()
    assert out.stat().st_size > 10_000
    # the bars: |reported - recomputed| / bound of each recomputed characteristic, not computable left out
    checks = (CharacteristicCheck(1, "P", "position", "mm", 0.30, 0.25, "disagrees", "", bound=0.01),
              CharacteristicCheck(2, "F", "flatness", "mm", 0.05, None, "not computable", "no points", bound=0.001))
    rows = characteristic_ratios(CharacteristicVerification("f.qif", checks, ""))
    assert len(rows) == 1 and rows[0][1] == "disagrees" and abs(rows[0][2] - 5.0) < 1e-12


COMMUNITY = os.environ.get("PCMM_QIF_COMMUNITY")


@pytest.mark.skipif(COMMUNITY is None, reason="set PCMM_QIF_COMMUNITY to a checkout of qif-community")
@pytest.mark.parametrize(("name", "counts"), [
    ("bindings/CPP-Kramer/data/testCpp30.qif", (4, 1, 2)),  # an actual edited, its reported position kept
    ("samples/QIFwidget/WIDGET_QIF_RESULTS_W_QPIDS.QIF", (15, 10, 17)),
    ("samples/Results/Sheet_Metal/SheetMetal_QIF_Results_sample_3_w_UUIDs.QIF", (17, 0, 21)),
    ("samples/ExternalReferencesAndQPIds/All-in-one.QIF", (0, 0, 4)),
])
def test_counts_on_the_community_files(name: str, counts: tuple[int, int, int]) -> None:
    summary = verify_characteristics(read_qif(Path(COMMUNITY) / name)).summary()  # type: ignore[arg-type]
    assert (summary["agrees"], summary["disagrees"], summary["not_computable"]) == counts
    if name.endswith("testCpp30.qif"):
        check = _check(Path(COMMUNITY) / name, 37)  # type: ignore[arg-type]
        assert check.status == "disagrees" and abs(check.reported - 0.102) < 1e-12 and abs(check.recomputed) < 1e-9


def test_one_parse_gives_document_and_definitions_in_the_same_units(tmp_path: Path) -> None:
    import re

    from pcmm_geo.io.cmm.qif.characteristic_definitions import read_qif_definitions, read_qif_with_definitions

    text = (SAMPLES / "QIF_Results_Sample.QIF").read_text()
    path = tmp_path / "no_units.qif"
    path.write_text(re.sub(r"<FileUnits>.*?</FileUnits>", "", text, count=1, flags=re.DOTALL))
    document, definitions = read_qif_with_definitions(path, units="inch")
    alone = read_qif_definitions(path)  # no units given: mm
    assert document.units.linear_unit == "inch"
    zones = [(key, d.tolerance.value) for key, d in alone.characteristic_definitions.items()
             if d.tolerance is not None and d.tolerance.value is not None]
    assert len(zones) >= 2
    for key, value in zones:
        assert abs(definitions.characteristic_definitions[key].tolerance.value - 25.4 * value) < 1e-9
    assert definitions.counts() == alone.counts()
    assert not any("units not stated" in problem for problem in definitions.problems)  # the document's, not repeated
