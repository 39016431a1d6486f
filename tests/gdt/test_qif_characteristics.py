"""Second opinion on a QIF file's characteristics: frames from datum actuals (exact cases) and the public samples.

The samples are the qif-community results files shipped in tests/data/qif/samples (Boost
licence).  Their counts are the measured state of the second opinion (docs/guide/files_from_your_cmm.rst);
a reported value changed by hand must be caught.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pcmm_geo.cli import main
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.gdt.qif.characteristics import verify_characteristics
from pcmm_geo.gdt.qif.frames import DatumFeatureGeometry, datum_frame, frame_map
from pcmm_geo.gdt.qif.orientation import thinnest_width_perpendicular_to
from pcmm_geo.io.cmm import read_qif

SAMPLES = Path(__file__).resolve().parents[1] / "data" / "qif" / "samples"


def _moved(datum: DatumFeatureGeometry, rotation: np.ndarray, shift: np.ndarray,
           slide: np.ndarray) -> DatumFeatureGeometry:
    """The datum after the rigid motion x -> R x + t, its location slid along the feature (any point on it)."""
    location = datum.location + slide
    if datum.kind == "plane":  # slide within the plane
        location = location - float(datum.direction @ slide) * datum.direction
    elif datum.kind == "axis":  # slide along the axis
        location = datum.location + float(datum.direction @ slide) * datum.direction
    else:
        location = datum.location
    return DatumFeatureGeometry(datum.kind, rotation @ location + shift,
                                None if datum.direction is None else rotation @ datum.direction, datum.label)


ABC = [DatumFeatureGeometry("plane", np.array([10.0, 10.0, 0.0]), np.array([0.0, 0.0, 1.0]), "A"),
       DatumFeatureGeometry("plane", np.array([0.0, 5.0, 3.0]), np.array([1.0, 0.0, 0.0]), "B"),
       DatumFeatureGeometry("plane", np.array([4.0, 0.0, 2.0]), np.array([0.0, 1.0, 0.0]), "C")]


#: a plane and two bores perpendicular to it (the bores give the origin and the clocking)
A_TWO_BORES = [ABC[0], DatumFeatureGeometry("axis", np.array([0.0, 0.0, -4.0]), np.array([0.0, 0.0, 1.0]), "B"),
               DatumFeatureGeometry("axis", np.array([50.0, 0.0, 7.0]), np.array([0.0, 0.0, -1.0]), "C")]


@pytest.mark.parametrize("datums", [ABC, A_TWO_BORES], ids=["three planes", "plane and two bores"])
@pytest.mark.parametrize("seed", range(8))
def test_position_in_a_3_2_1_frame_is_exact_under_rigid_motions(seed: int, datums: list) -> None:
    rng = np.random.default_rng(seed)
    rotation = Rotation.from_rotvec(rng.uniform(-0.15, 0.15, 3)).as_matrix()  # pre-aligned: within ~15 degrees
    shift = rng.uniform(-100, 100, 3)
    actual = [_moved(d, rotation, shift, rng.uniform(-20, 20, 3)) for d in datums]
    if seed % 2:  # a reported normal or axis may point the other way
        actual[1] = DatumFeatureGeometry(actual[1].kind, actual[1].location, -actual[1].direction, "B")
    dx, dy = rng.uniform(-0.2, 0.2, 2)
    height = rng.uniform(-5, 5)
    hole_nominal = np.array([30.0, 20.0, 0.0])
    hole_actual = rotation @ (hole_nominal + np.array([dx, dy, height])) + shift
    delta = frame_map(datums, actual).deviation(hole_actual, hole_nominal)
    np.testing.assert_allclose(delta, [dx, dy, height], atol=1e-9)
    in_plane = delta[:2]
    assert abs(2 * np.hypot(*in_plane) - 2 * np.hypot(dx, dy)) < 1e-9


def test_degrees_of_freedom_the_datums_leave_float() -> None:
    rotation = Rotation.from_euler("xyz", [0.3, -0.2, 1.1]).as_matrix()
    shift = np.array([5.0, -7.0, 11.0])
    plane_a = ABC[0]
    # A only: the hole may translate in A (two free directions); only the height above A counts
    only_a = frame_map([plane_a], [_moved(plane_a, rotation, shift, np.array([3.0, -4.0, 0.0]))])
    assert len(only_a.free_translations) == 2
    nominal = np.array([30.0, 20.0, 0.0])
    delta = only_a.deviation(rotation @ (nominal + np.array([0.4, -0.3, 0.05])) + shift, nominal)
    np.testing.assert_allclose(delta, [0.0, 0.0, 0.05], atol=1e-12)
    # A | B with B a bore perpendicular to A: the rotation about B floats, the distance from B counts
    bore = DatumFeatureGeometry("axis", np.array([0.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]), "B")
    frame = frame_map([plane_a, bore], [_moved(d, rotation, shift, np.array([1.0, 2.0, 3.0])) for d in (plane_a, bore)])
    assert frame.rotation_free and len(frame.free_translations) == 0
    turned = Rotation.from_euler("z", 0.7).as_matrix() @ np.array([30.2, 0.0, 0.0])
    delta = frame.deviation(rotation @ turned + shift, np.array([30.0, 0.0, 0.0]))
    np.testing.assert_allclose(delta, [0.2, 0.0, 0.0], atol=1e-9)
    # no datums: the file's coordinates
    assert np.array_equal(datum_frame([]).rotation, np.eye(3))
    with pytest.raises(InvalidInputError, match="datums"):
        datum_frame([DatumFeatureGeometry("cone", np.zeros(3), np.array([0.0, 0.0, 1.0]))])
    with pytest.raises(InvalidInputError, match="actual"):
        frame_map([plane_a], [bore])


@pytest.mark.parametrize("seed", range(5))
def test_thinnest_zone_parallel_to_a_direction_is_the_short_side_of_a_box(seed: int) -> None:
    rng = np.random.default_rng(seed)
    box = rng.uniform(-0.5, 0.5, (400, 3)) * [10.0, 0.3, 5.0]
    box[:8] = np.array([[sx * 5.0, sy * 0.15, sz * 2.5] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    turned = box @ Rotation.from_euler("z", rng.uniform(0, np.pi)).as_matrix().T
    assert abs(thinnest_width_perpendicular_to(turned, np.array([0.0, 0.0, 1.0])) - 0.3) < 1e-9
    # about x instead: the box's extents across x are 0.3 (y) and 5 (z): 0.3 again; about y: 5 x 10 -> 5
    assert abs(thinnest_width_perpendicular_to(box, np.array([0.0, 1.0, 0.0])) - 5.0) < 1e-9


@pytest.mark.parametrize(("name", "counts"), [
    ("QIF_Results_Sample.QIF", (9, 0, 4)),
    ("QIF_PTS_SAMPLE.QIF", (20, 2, 5)),
    ("WIDGET_QIF_RESULTS.QIF", (15, 10, 17)),
    ("SheetMetal_QIF_Results_6_samples.QIF", (102, 0, 126)),
    ("testPython30.qif", (5, 0, 2)),
])
def test_counts_on_the_public_samples(name: str, counts: tuple[int, int, int]) -> None:
    verification = verify_characteristics(read_qif(SAMPLES / name))
    summary = verification.summary()
    assert (summary["agrees"], summary["disagrees"], summary["not_computable"]) == counts
    for check in verification.checks:
        assert check.reason and check.unit in ("mm", "rad", "-")
        if check.status == "agrees":
            assert abs(check.reported - check.recomputed) <= check.bound


def test_values_recomputed_from_the_actuals() -> None:
    checks = {c.id: c for c in verify_characteristics(read_qif(SAMPLES / "QIF_PTS_SAMPLE.QIF")).checks}
    # TP_CIRCLE1 from its 219 points: the refitted centre is 5.8 nm from the reported one, 2 |d| moves 1.2 nm
    assert checks[501].source == "points" and abs(checks[501].recomputed - 0.305735910302614) < 5e-6
    assert abs(checks[856].recomputed - 82.764766514306) < 1e-9  # distance along the analysis vector y
    assert abs(checks[852].recomputed - 0.6980672166877956) < 1e-9  # 40 degrees between the planes
    assert checks[761].source == "points" and abs(checks[761].recomputed - (-0.086196035032941)) < 1e-8
    # POINT3 has no points: its actual is the probe centre, 2.49978 mm off along the normal (vendor convention)
    assert checks[781].status == "disagrees" and "probe-ball centre" in checks[781].reason
    widget = {c.id: c for c in verify_characteristics(read_qif(SAMPLES / "WIDGET_QIF_RESULTS.QIF")).checks}
    # the widget reports positions in its coordinates, ignoring the datum features' actual tilts
    assert widget[57].status == "disagrees" and "without the datum reference frame" in widget[57].reason
    # MMC: the hole J of 19.007 mm (19 +-0.13) gains 19.007 - 18.87 mm; CYLINDER6 (4.878, 5 +-0.025) none
    assert "MMC bonus 0.137 mm" in widget[57].reason and "outside its limits" in widget[87].reason
    # datum J at MMB: evaluated with J fixed at its actual (0.017); the reported 0.344 is above it, which no datum
    # shift gives, and is the deviation in the file's coordinates again
    assert widget[75].status == "disagrees" and "datum J at MMB" in widget[75].reason
    assert "without the datum reference frame" in widget[75].reason


def _changed(tmp_path: Path, old: str, new: str) -> Path:
    text = (SAMPLES / "QIF_Results_Sample.QIF").read_text()
    assert text.count(old) == 1
    path = tmp_path / "changed.qif"
    path.write_text(text.replace(old, new))
    return path


def test_a_reported_value_changed_by_hand_is_caught(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["qif", "verify", str(SAMPLES / "QIF_Results_Sample.QIF")]) == 0
    capsys.readouterr()
    # diameter 9.499476 reported (tolerance +-0.4: bound 0.008 mm); the feature's actual keeps 9.499476
    changed = _changed(tmp_path, "<Value>9.499476</Value>", "<Value>9.519476</Value>")
    assert main(["qif", "verify", str(changed), "--json"]) == 1
    data = json.loads(capsys.readouterr().out)
    check = next(c for c in data["characteristics"] if c["id"] == 51)
    assert (check["status"], check["type"], check["unit"]) == ("disagrees", "diameter", "mm")
    assert abs(check["reported"] - 9.519476) < 1e-12 and abs(check["recomputed"] - 9.499476) < 1e-12
    assert data["characteristics_summary"] == {"agrees": 8, "disagrees": 1, "not_computable": 4}
    assert set(check) >= {"id", "name", "type", "unit", "reported", "recomputed", "status", "reason"}
    # a change within the stated bound (half of 1 % of the tolerance width) is not a disagreement
    within = _changed(tmp_path, "<Value>9.499476</Value>", "<Value>9.503476</Value>")
    assert main(["qif", "verify", str(within)]) == 0
    capsys.readouterr()
    # a point profile changed by 20 µm (tolerance 1.5: bound 15 µm)
    profile = _changed(tmp_path, "<Value>-0.886195693015347</Value>", "<Value>-0.866195693015347</Value>")
    assert main(["qif", "verify", str(profile)]) == 1
    assert "disagrees" in capsys.readouterr().out


def test_a_bad_agreement_fraction_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for bad in ("0", "1.5", "nan"):
        assert main(["qif", "verify", str(SAMPLES / "QIF_Results_Sample.QIF"), "--characteristic-fraction", bad]) == 2
        err = capsys.readouterr().err
        assert "--characteristic-fraction" in err and len(err.strip().splitlines()) == 1
    with pytest.raises(InvalidInputError, match="fraction"):
        verify_characteristics(read_qif(SAMPLES / "QIF_Results_Sample.QIF"), fraction=0.0)
    # the fraction is the rule: a 20 µm change of a diameter of tolerance width 0.8 mm disagrees at 1 %
    # (bound 8 µm) and agrees at 5 % (bound 40 µm)
    document = read_qif(_changed(tmp_path, "<Value>9.499476</Value>", "<Value>9.519476</Value>"))
    assert verify_characteristics(document).summary()["disagrees"] == 1
    assert verify_characteristics(document, fraction=0.05).summary()["disagrees"] == 0
