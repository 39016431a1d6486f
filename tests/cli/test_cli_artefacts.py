"""``pcmm gauge-block``, ``iso10360-2/-5/-6`` and ``micrometer``, run as the installed command."""

from __future__ import annotations

import json
import subprocess
from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest
from pcmm_runner import run_pcmm

EXAMPLES = files("pcmm_geo") / "data/examples"


def example(name: str) -> str:
    return str(EXAMPLES / name)


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return run_pcmm(*args)


def assert_usage_error(proc: subprocess.CompletedProcess[str], text: str) -> None:
    assert proc.returncode == 2, proc.stdout
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and text in lines[0], proc.stderr


def test_gauge_block(tmp_path: Path) -> None:
    proc = run("gauge-block", example("gauge_block.csv"), "--json")
    assert proc.returncode == 0, proc.stderr
    data = json.loads(proc.stdout)
    # the example is a 100 mm block with 0.3 um noise
    assert abs(data["central_length_mm"] - 100.0) < 1e-3
    assert abs(data["projected_length_mm"] - 100.0) < 2e-3
    assert data["seed"]["phi_deg"] == pytest.approx(90.0, abs=0.5)
    assert data["n_points"] == {"face_1": 9, "face_2": 9, "top": 5, "side": 5}
    text = run("gauge-block", example("gauge_block.csv"))
    assert text.returncode == 0 and "central length l_c (not corrected to 20 °C)" in text.stdout
    bad = tmp_path / "bad.csv"
    bad.write_text("face,x,y\nface_1,0,0\n")
    assert_usage_error(run("gauge-block", str(bad)), "missing z")
    assert_usage_error(run("gauge-block", str(tmp_path / "absent.csv")), "No such file")


def test_iso10360_2() -> None:
    ok = run("iso10360-2", example("iso10360_2_lengths.csv"), "--mpe-a-um", "2", "--mpe-k", "100", "--json")
    assert ok.returncode == 0, ok.stderr
    data = json.loads(ok.stdout)
    assert data["passed"] and data["n_values"] == 105
    # independent recomputation of the largest error from the file
    rows = [line.split(",") for line in Path(example("iso10360_2_lengths.csv")).read_text().splitlines()
            if line and not line.startswith(("#", "length_id"))]
    worst = max(abs(float(r[4]) - float(r[3])) for r in rows) * 1000
    assert data["max_abs_error_um"] == pytest.approx(worst, abs=1e-9)
    tight = run("iso10360-2", example("iso10360_2_lengths.csv"), "--mpe-a-um", "0.1", "--mpe-k", "100000")
    assert tight.returncode == 1 and "FAIL" in tight.stdout
    assert_usage_error(run("iso10360-2", example("iso10360_2_lengths.csv"), "--mpe-a-um", "2", "--mpe-k", "0"),
                       "mpe K: expected a positive number")
    assert_usage_error(run("iso10360-2", example("gauge_block.csv"), "--mpe-a-um", "2", "--mpe-k", "100"),
                       "expected columns length_id")


def test_iso10360_5(tmp_path: Path) -> None:
    proc = run("iso10360-5", example("iso10360_5_sphere.csv"), "--reference-diameter-mm", "25.0004", "--json")
    assert proc.returncode == 0, proc.stderr
    data = json.loads(proc.stdout)
    assert data["n_points"] == 25
    assert 0 < data["p_ftu_um"] < 3.0 and abs(data["p_stu_um"]) < 1.0  # 0.4 um probing noise
    # the diameter stated in the file (25.0004 mm) is used; a contradicting option is refused
    stated = json.loads(run("iso10360-5", example("iso10360_5_sphere.csv"), "--json").stdout)
    assert stated["reference_diameter_mm"] == 25.0004 and stated["verdict"] == "no MPE stated"
    assert stated["p_stu_um"] == pytest.approx(data["p_stu_um"], abs=1e-9)
    assert_usage_error(run("iso10360-5", example("iso10360_5_sphere.csv"), "--reference-diameter-mm", "25"),
                       "expected the 25.0004 mm that")
    # the standard's 25 exact points on a sphere of radius 10.0005: P_FTU 0, P_STU = +1 um against 20 mm
    from pcmm_geo.artefacts import sphere_probing_pattern

    pts = tmp_path / "exact.csv"
    coords = sphere_probing_pattern((1.0, 2.0, 3.0), 10.0005)
    pts.write_text("x,y,z\n" + "\n".join(",".join(f"{v:.12f}" for v in p) for p in coords) + "\n")
    exact = json.loads(run("iso10360-5", str(pts), "--reference-diameter-mm", "20", "--mpe-size-um", "0.5",
                           "--json").stdout)
    assert exact["p_ftu_um"] == pytest.approx(0.0, abs=1e-6)
    assert exact["p_stu_um"] == pytest.approx(1.0, abs=1e-6)
    assert exact["passed"] is False and exact["verdict"] == "FAIL"
    assert run("iso10360-5", str(pts), "--reference-diameter-mm", "20", "--mpe-size-um", "0.5").returncode == 1
    assert_usage_error(run("iso10360-5", str(pts), "--reference-diameter-mm", "-20"), "reference_diameter")
    # 5 of the 25 points: refused, or with --allow-incomplete an INCOMPLETE verdict, never a plain PASS
    few = tmp_path / "few.csv"
    few.write_text("x,y,z\n" + "\n".join(",".join(f"{v:.12f}" for v in p) for p in coords[::5]) + "\n")
    assert_usage_error(run("iso10360-5", str(few), "--reference-diameter-mm", "20.001", "--mpe-size-um", "5"),
                       "ISO 10360-5: the standard uses 25 points on the test sphere, got 5")
    partial = run("iso10360-5", str(few), "--reference-diameter-mm", "20.001", "--mpe-size-um", "5",
                  "--allow-incomplete")
    assert partial.returncode == 0 and "verdict: ISO 10360-5: INCOMPLETE (5 of 25 points)" in partial.stdout
    assert "PASS" not in partial.stdout
    partial_json = json.loads(run("iso10360-5", str(few), "--reference-diameter-mm", "20.001", "--mpe-size-um", "5",
                                  "--allow-incomplete", "--json").stdout)
    assert partial_json["complete"] is False and partial_json["passed"] is None
    assert partial_json["verdict"].startswith("INCOMPLETE (5 of 25 points)")


def test_iso10360_2_incomplete(tmp_path: Path) -> None:
    lines = Path(example("iso10360_2_lengths.csv")).read_text().splitlines()
    three = tmp_path / "three.csv"
    three.write_text("\n".join([line for line in lines if line.startswith("length_id")] +
                               [line for line in lines if line.startswith("L1,x,")]) + "\n")
    assert_usage_error(run("iso10360-2", str(three), "--mpe-a-um", "2", "--mpe-k", "100"),
                       "ISO 10360-2: the standard uses 105 values, got 3 (1 of 5 lengths, 1 of 7 positions)")
    partial = run("iso10360-2", str(three), "--mpe-a-um", "2", "--mpe-k", "100", "--allow-incomplete", "--json")
    data = json.loads(partial.stdout)
    assert partial.returncode == 0 and data["passed"] is None and data["complete"] is False
    assert data["verdict"].startswith("INCOMPLETE (3 of 105 values") and "PASS" not in data["verdict"]
    text = run("iso10360-2", str(three), "--mpe-a-um", "2", "--mpe-k", "100", "--allow-incomplete").stdout
    assert text.startswith("verdict: ISO 10360-2: INCOMPLETE (3 of 105 values") and "PASS" not in text


def _nist_pair(folder: Path) -> None:
    folder.mkdir(parents=True)
    rng = np.random.default_rng(1)
    d = rng.normal(size=(30, 3))
    pts = np.array([4.0, -2.0, 9.0]) + 6.0 * d / np.linalg.norm(d, axis=1)[:, None]
    (folder / "sph1.ds").write_text(f"{len(pts)}\n" + "\n".join("\t".join(f"{v:.15f}" for v in p) for p in pts))
    (folder / "sph1.fit").write_text("4\n-2\n9\n12\n")


def test_iso10360_6(tmp_path: Path) -> None:
    proc = run("iso10360-6", example("iso10360_6_reference.csv"), example("iso10360_6_results.json"),
               "--mpe-position-mm", "1e-6", "--mpe-orientation-rad", "1e-6", "--mpe-size-mm", "1e-6",
                   "--mpe-angle-rad", "1e-6",
               "--json")
    assert proc.returncode == 1
    data = json.loads(proc.stdout)
    failed = [c["name"] for c in data["cases"] if not c["passed"]]
    assert failed == ["cone_1"]
    assert "| cone_1 | cone |" in data["markdown"]
    _nist_pair(tmp_path / "Sphere")
    self_test = run("iso10360-6", str(tmp_path), "--markdown")
    assert self_test.returncode == 0, self_test.stderr
    assert "PASS" in self_test.stdout
    assert_usage_error(run("iso10360-6", str(tmp_path / "none"), example("iso10360_6_results.json")), "no such file")
    assert_usage_error(run("iso10360-6", example("iso10360_6_reference.csv"), example("gauge_block.csv")),
                       "expected columns name")


def test_micrometer() -> None:
    proc = run("micrometer", example("micrometer_stage.csv"), "--json")
    assert proc.returncode == 0, proc.stderr
    data = json.loads(proc.stdout)
    # thesis Table 8.1 (errors 1.61, 2.59, 0.27, 3.78, 3.73 up to the rounding of the table's distances)
    assert [p["pair"] for p in data["pairs"]] == ["1-2", "2-3", "3-4", "1-3", "1-4"]
    np.testing.assert_allclose([p["error_mm"] for p in data["pairs"]], [1.61, 2.59, 0.27, 3.78, 3.73], atol=0.0101)
    every = json.loads(run("micrometer", example("micrometer_stage.csv"), "--pairs", "all", "--json").stdout)
    assert len(every["pairs"]) == 6
    assert_usage_error(run("micrometer", example("gauge_block.csv")), "expected columns point")
