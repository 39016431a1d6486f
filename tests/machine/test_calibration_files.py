"""Calibration files (versioned JSON), CSV readers, column lines and the datum frame."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pcmm_geo.errors import (
    CalibrationError,
    DegenerateGeometryError,
    FileFormatError,
    InvalidInputError,
    OutputExistsError,
)
from pcmm_geo.machine.calibration import calibrate_tetrahedron
from pcmm_geo.machine.calibration.calfile import CALIBRATION_SCHEMA, load_calibration, load_machine, save_calibration
from pcmm_geo.machine.calibration.columns import calibrate_columns
from pcmm_geo.machine.calibration.datum import DatumFrame, datum_frame
from pcmm_geo.machine.calibration.probings import read_lasers, read_probings
from pcmm_geo.machine.calibration.seed import appendix_cd_files


@pytest.fixture(scope="module")
def seed_cal():
    return calibrate_tetrahedron(*appendix_cd_files())


def test_json_round_trip_and_refusal_to_overwrite(tmp_path, seed_cal):
    path = save_calibration(seed_cal, tmp_path / "cal.json", extra={"operator": "test"})
    document = json.loads(path.read_text())
    assert document["schema"] == CALIBRATION_SCHEMA == "pcmm_geo.machine.calibration/1"
    assert document["results"]["dead_distance"]["a"] == pytest.approx(314.48, abs=0.01)
    assert document["tetrahedron"]["sliders"]["b"]["laser_scale"] == pytest.approx(
        seed_cal.slider_lines["b"].laser_scale)
    back = load_calibration(path)
    for arm in "abc":
        assert back.dead_distance[arm] == seed_cal.dead_distance[arm]
        np.testing.assert_array_equal(back.slider_lines[arm].direction, seed_cal.slider_lines[arm].direction)
    assert back.beta == seed_cal.beta
    before = path.read_text()
    with pytest.raises(OutputExistsError):
        save_calibration(seed_cal, path)
    assert path.read_text() == before
    save_calibration(seed_cal, path, overwrite=True)
    assert load_calibration(path).b_in == seed_cal.b_in


def test_machine_entry_for_the_kinematics(tmp_path, seed_cal):
    from pcmm_geo.machine.kinematics.model import RigidBodyMachine

    columns = RigidBodyMachine.from_dpkm().columns
    path = save_calibration(seed_cal, tmp_path / "cal.json", columns=columns)
    machine = load_machine(path)
    np.testing.assert_allclose(machine.tetrahedron.sliders["c"].point, seed_cal.slider_lines["c"].point, atol=0)
    np.testing.assert_allclose(machine.columns["a"].point, columns["a"].point, atol=0)
    no_machine = save_calibration(seed_cal, tmp_path / "bare.json")
    with pytest.raises(FileFormatError, match="machine"):
        load_machine(no_machine)
    with pytest.raises(InvalidInputError):
        save_calibration(seed_cal, tmp_path / "x.json", columns={"a": columns["a"]})


def test_bad_calibration_files(tmp_path, seed_cal):
    path = save_calibration(seed_cal, tmp_path / "cal.json")
    document = json.loads(path.read_text())
    edited = dict(document, results=dict(document["results"], dead_distance={"a": 300.0, "b": 1.0, "c": 2.0}))
    (tmp_path / "edited.json").write_text(json.dumps(edited))
    with pytest.raises(FileFormatError, match="edited or damaged"):
        load_calibration(tmp_path / "edited.json")
    (tmp_path / "future.json").write_text(json.dumps(dict(document, schema="pcmm_geo.machine.calibration/9")))
    with pytest.raises(FileFormatError, match="version"):
        load_calibration(tmp_path / "future.json")
    (tmp_path / "other.json").write_text(json.dumps({"schema": "something else"}))
    with pytest.raises(FileFormatError, match="schema"):
        load_calibration(tmp_path / "other.json")
    (tmp_path / "broken.json").write_text('{"schema": \n')
    with pytest.raises(FileFormatError, match=r"broken.json:2"):
        load_calibration(tmp_path / "broken.json")
    missing = dict(document)
    del missing["inputs"]
    (tmp_path / "missing.json").write_text(json.dumps(missing))
    with pytest.raises(FileFormatError, match="inputs"):
        load_calibration(tmp_path / "missing.json")


def test_malformed_csv_files_name_path_and_line(tmp_path):
    cases = {
        "feature,position,x,y,z\njoint_a,1,0,0,0\njoint_q,1,0,0,0\n": r"bad.csv:3: feature",
        "feature,position,x,y,z\njoint_a,one,0,0,0\n": r"bad.csv:2: position",
        "feature,position,x,y,z\ntip,3,0,0,0\n": r"bad.csv:2: position: expected empty",
        "feature,position,x,y,z\njoint_a,1,0,zero,0\n": r"bad.csv:2: column y",
        "feature,position,x,y,z\njoint_a,1,0,0\n": r"bad.csv:2: expected 5 fields",
        "a,b,c\n": r"bad.csv:1: expected header",
        "x,y,z,d,r\n1,2,3,4,5\n": r"3K \+ 1 sphere rows",
        "x,y,z,d,r\n1,2,inf,4,5\n": r"bad.csv:2: column z",
        "": r"empty file",
    }
    path = tmp_path / "bad.csv"
    for text, pattern in cases.items():
        path.write_text(text)
        with pytest.raises(FileFormatError, match=pattern):
            read_probings(path)
    path.write_text("position,laser_a,laser_b,laser_c\n1,1,2,3\n1,1,2,3\n")
    with pytest.raises(FileFormatError, match=r"bad.csv:3: position"):
        read_lasers(path)
    path.write_text("position,laser_a,laser_b\n")
    with pytest.raises(FileFormatError, match=r"bad.csv:1: expected header"):
        read_lasers(path)
    path.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(FileFormatError, match=r"bad.csv:1: (binary data|not UTF-8)"):
        read_lasers(path)


def test_element_export_without_header_assigns_rows_like_appendix_c(tmp_path):
    export, _ = appendix_cd_files()
    rows = export.read_text().splitlines()[1:]
    headerless = tmp_path / "CMM.csv"
    headerless.write_text("\n".join(rows) + "\n")
    features = read_probings(headerless)
    assert features.positions == (1, 2)
    values = np.array([[float(v) for v in row.split(",")[:3]] for row in rows])
    np.testing.assert_array_equal(features.joints["b"][1].centre, values[1])  # row 2 = joint b, position 1
    np.testing.assert_array_equal(features.joints["a"][2].centre, values[3])  # row 4 = joint a, position 2
    np.testing.assert_array_equal(features.tip.centre, values[6])  # row 7 = the tip
    assert np.isnan(features.tip.radius)


def test_column_lines_eqs_2_19_2_20():
    readings = np.array([0.0, 20.0, 55.0, 100.0])
    truth = {"a": (-265.0, 0.8, 0.004, -0.002), "b": (132.0, 230.0, -0.003, 0.001), "c": (133.0, -229.0, 0.0, 0.005)}
    scale = 1.001
    centres = {}
    for arm, (g, m, h, n) in truth.items():
        z = 380.0 + scale * readings / np.sqrt(1 + h * h + n * n)  # distance along the column = scale * reading
        centres[arm] = np.c_[g + h * z, m + n * z, z]
    cal = calibrate_columns(centres, np.c_[readings, readings, readings])
    for arm, (g, m, h, n) in truth.items():
        assert cal.intercepts[arm] == pytest.approx((g, m), abs=1e-9)
        assert cal.slopes[arm] == pytest.approx((h, n), abs=1e-12)
        assert cal.encoder_scale[arm] == pytest.approx(scale, abs=1e-12)
        assert cal.straightness[arm] < 1e-9
        np.testing.assert_allclose(cal.columns[arm].pivot(readings), centres[arm], atol=1e-9)
    with pytest.raises(CalibrationError, match="different heights"):
        calibrate_columns({arm: centres[arm][:1] for arm in "abc"}, {arm: readings[:1] for arm in "abc"})
    with pytest.raises(InvalidInputError):
        calibrate_columns({"a": centres["a"]}, readings)


def test_datum_frame_from_plane_and_hole():
    # a face z' = 0 and a hole along z' at (30, -10) in a frame rotated and shifted in CMM1
    rng = np.random.default_rng(3)
    angle = np.radians(25.0)
    rotation = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1.0]])
    tilt = np.array([[1, 0, 0], [0, np.cos(0.3), -np.sin(0.3)], [0, np.sin(0.3), np.cos(0.3)]])
    to_cmm = tilt @ rotation
    shift = np.array([100.0, 50.0, -20.0])
    plane_local = np.c_[rng.uniform(-60, 60, (20, 2)), np.zeros(20)]
    turns = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    hole_local = np.c_[30 + 4 * np.cos(turns), -10 + 4 * np.sin(turns), np.repeat([-2.0, -6.0, -10.0, -14.0], 4)]
    reference_local = np.array([200.0, -10.0, 150.0])  # above the face, x direction through the hole axis
    frame = datum_frame(plane_local @ to_cmm.T + shift, hole_local @ to_cmm.T + shift,
                        x_towards=to_cmm @ reference_local + shift)
    np.testing.assert_allclose(frame.origin, to_cmm @ np.array([30.0, -10.0, 0.0]) + shift, atol=1e-7)
    np.testing.assert_allclose(frame.apply(to_cmm @ reference_local + shift), [170.0, 0.0, 150.0], atol=1e-7)
    assert frame.hole_radius == pytest.approx(4.0, abs=1e-7)
    again = DatumFrame.from_dict(frame.to_dict())
    np.testing.assert_array_equal(again.rotation, frame.rotation)
    with pytest.raises(DegenerateGeometryError):
        datum_frame(np.c_[np.arange(5.0), np.zeros(5), np.zeros(5)], hole_local, x_towards=reference_local)


def test_calibration_in_the_datum_frame(tmp_path, seed_cal):
    turns = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    plane = np.array([[-50.0, -50, 5], [50, -50, 5], [50, 50, 5], [-50, 50, 5], [0, 0, 5]])
    hole = np.c_[10 + 3 * np.cos(turns), 20 + 3 * np.sin(turns), np.repeat([0.0, -4.0, -8.0], 4)]
    export, lasers = appendix_cd_files()
    cal = calibrate_tetrahedron(export, lasers, datum_plane=plane, datum_hole=hole)
    assert cal.datum is not None
    np.testing.assert_allclose(cal.datum.origin, [10.0, 20.0, 5.0], atol=1e-7)
    np.testing.assert_allclose(cal.tip_centre, cal.datum.apply(seed_cal.tip_centre), atol=1e-9)
    # distances and angles do not depend on the frame
    for arm in "abc":
        assert cal.dead_distance[arm] == pytest.approx(seed_cal.dead_distance[arm], abs=1e-9)
    for pair in ("ab", "bc", "ca"):
        assert cal.beta[pair] == pytest.approx(seed_cal.beta[pair], abs=1e-9)
    # joint a lies on the +x side of the datum frame with y = 0 (x axis through its mean centre)
    mean_a = cal.joint_centres[:, 0].mean(axis=0)
    assert mean_a[0] > 0 and abs(mean_a[1]) < 1e-9
    back = load_calibration(save_calibration(cal, tmp_path / "datum.json"))
    np.testing.assert_array_equal(back.datum.rotation, cal.datum.rotation)
    np.testing.assert_allclose(back.tip_centre, cal.tip_centre, atol=0)
