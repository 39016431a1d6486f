"""Calibration from the external CMM's QIF results (thesis ch. 7): the CSV route's numbers to 1e-9 mm.

The bundled probings (Appendix C/D rebuilt, element-level: centres only) are shipped also as QIF;
simulated raw probings (the demo's machine) are written both as CSV and as QIF with point sets, as
surface points and as probe centres.  Every route must give the same calibration.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.cli import main
from pcmm_geo.errors import FileFormatError
from pcmm_geo.machine.calibration import calibrate_tetrahedron
from pcmm_geo.machine.calibration.probings import probed_features_from_points, read_probings, write_probings_csv
from pcmm_geo.machine.calibration.qif_probings import read_feature_map, read_qif_probings, write_qif_probings
from pcmm_geo.machine.calibration.seed import appendix_cd_files

EXPORT, LASERS = appendix_cd_files()
SHIPPED_QIF = EXPORT.with_suffix(".qif")


def _numbers(summary: dict) -> np.ndarray:  # type: ignore[type-arg]
    values = [summary["dead_distance"][arm] for arm in "abc"]
    values += [summary["beta_deg"][pair] for pair in ("ab", "bc", "ca")]
    values += summary["probe_point"] + summary["tip_centre"]
    for arm in "abc":
        line = summary["slider_lines"][arm]
        values += line["point"] + line["direction"] + [line["laser_scale"], line["laser_offset"], line["tip_offset"]]
    return np.array(values, dtype=float)


def test_shipped_qif_is_the_bundled_export() -> None:
    csv, qif = read_probings(EXPORT), read_qif_probings(SHIPPED_QIF)
    assert qif.reported == ("joint_a_1", "joint_b_1", "joint_c_1", "joint_a_2", "joint_b_2", "joint_c_2", "tip")
    assert qif.refitted == () and qif.ignored == ()
    np.testing.assert_array_equal(qif.features.centers(), csv.centers())
    np.testing.assert_array_equal(qif.features.tip.center, csv.tip.center)


def test_bundled_probings_as_qif_give_the_csv_numbers(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["calibrate", str(EXPORT), str(LASERS), "--json"]) == 0
    from_csv = json.loads(capsys.readouterr().out)
    assert main(["calibrate", str(SHIPPED_QIF), str(LASERS), "--json"]) == 0
    from_qif = json.loads(capsys.readouterr().out)
    np.testing.assert_allclose(_numbers(from_qif), _numbers(from_csv), rtol=0, atol=1e-9)
    assert from_qif["qif_probings"]["reported"][-1] == "tip"
    assert main(["calibrate", str(SHIPPED_QIF), str(LASERS)]) == 0
    assert "centres as the CMM reported them" in capsys.readouterr().out


def _simulated() -> dict:  # type: ignore[type-arg]
    from pcmm_geo.demo import DemoSettings, simulate_probings, true_machine

    settings = DemoSettings()
    probings = simulate_probings(true_machine(settings), settings, np.random.default_rng(11))
    points = {("tip", None): probings["tip"]}
    for arm in "abc":
        for position, value in probings[f"joint_{arm}"].items():
            points[(f"joint_{arm}", position)] = value
    return points


@pytest.mark.parametrize("probe_radius", [None, 1.5])
def test_raw_probings_as_qif_refit_to_the_csv_numbers(tmp_path: Path, probe_radius: float | None) -> None:
    from pcmm_geo.demo import CALIBRATION_LASERS

    points = _simulated()
    csv = write_probings_csv(tmp_path / "probings.csv", points)
    lasers = tmp_path / "lasers.csv"
    lasers.write_text("position,laser_a,laser_b,laser_c\n" + "".join(
        f"{k + 1},{row[0]!r},{row[1]!r},{row[2]!r}\n" for k, row in enumerate(CALIBRATION_LASERS.tolist())))
    qif = write_qif_probings(probed_features_from_points(points), tmp_path / "probings.qif", probe_radius=probe_radius)
    read = read_qif_probings(qif)
    assert read.reported == () and len(read.refitted) == 10
    reference = calibrate_tetrahedron(csv, lasers).summary()
    calibrated = calibrate_tetrahedron(read.features, lasers).summary()
    np.testing.assert_allclose(_numbers(calibrated), _numbers(reference), rtol=0, atol=1e-9)
    tip_csv = read_probings(csv).tip.radius
    # a ball is an external sphere: probe centres lie one probe radius outside it
    assert read.features.tip.radius == pytest.approx(tip_csv - (probe_radius or 0.0), abs=1e-12)


def test_feature_map_names_the_roles(tmp_path: Path) -> None:
    from pcmm_geo.io.cmm import FeatureGeometry, FeatureReport, read_qif, results_document, write_qif

    source = read_qif(SHIPPED_QIF)
    names = {}
    reports = [FeatureReport("plane", "DATUM_A", FeatureGeometry(location=np.zeros(3), normal=np.array([0, 0, 1.0])))]
    for k, feature in enumerate(source.measured_features):
        names[f"SPH{k + 1}"] = feature.name
        reports.append(FeatureReport("sphere", f"SPH{k + 1}", feature.actual))
    reports.append(FeatureReport("sphere", "REFERENCE_BALL", FeatureGeometry(location=np.ones(3), diameter=25.0)))
    renamed = write_qif(results_document(reports), tmp_path / "renamed.qif")
    mapping = {name: ("tip" if old == "tip" else f"joint_{old[6]}:{old[8:]}") for name, old in names.items()}
    map_file = tmp_path / "map.json"
    map_file.write_text(json.dumps(mapping))
    read = read_qif_probings(renamed, feature_map=map_file)
    np.testing.assert_array_equal(read.features.centers(), read_probings(EXPORT).centers())
    assert read.ignored == ("REFERENCE_BALL",)
    with pytest.raises(FileFormatError, match=r"joint_a_1 \.\.\. joint_c_K and tip"):
        read_qif_probings(renamed)  # the default naming finds none
    bad = tmp_path / "bad_map.json"
    for content, message in ((json.dumps({"SPH1": "joint_d:1"}), "expected a role"),
                             (json.dumps({"SPH1": "tip", "SPH2": "tip"}), "given to both"),
                             (json.dumps({"NOPE": "tip"}), "does not hold"),
                             (json.dumps({"DATUM_A": "tip"}), "not a sphere"),
                             ("[1, 2]", "expected a JSON object"), ("{", "invalid JSON")):
        bad.write_text(content)
        with pytest.raises(FileFormatError, match=message):
            read_qif_probings(renamed, feature_map=read_feature_map(bad) if "does not" in message
                              or "not a sphere" in message else bad)


def test_feature_map_only_with_qif(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    map_file = tmp_path / "map.json"
    map_file.write_text('{"a": "tip"}')
    assert main(["calibrate", str(EXPORT), str(LASERS), "--feature-map", str(map_file)]) == 2
    assert "--feature-map: expected a QIF probings file" in capsys.readouterr().err
