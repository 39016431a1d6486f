"""``pcmm repeatability`` and ``pcmm laser-ratio`` run as the installed command on the bundled printed
tables, on simulated acquisition logs and on a model-generated height-gauge record."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest
from pcmm_runner import run_pcmm

from pcmm_geo.machine.analysis.laser_ratio import ReadingLimits
from pcmm_geo.machine.analysis.laser_ratio_model import synthesise_ratio_record

EXAMPLES = Path(__file__).resolve().parents[2] / "pcmm_geo" / "data" / "examples"


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return run_pcmm(*args)


def run_json(*args: str) -> dict:
    proc = run(*args, "--json")
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def assert_usage_error(proc: subprocess.CompletedProcess[str], text: str) -> None:
    assert proc.returncode == 2, proc.stdout
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and text in lines[0], proc.stderr


def test_repeatability_of_the_printed_tables(tmp_path: Path) -> None:
    seven = run_json("repeatability", "--readings", str(EXAMPLES / "start_readings_table_6_7.csv"),
                     "--plot", str(tmp_path / "r.png"))
    assert [seven["arms"][arm]["range"] for arm in "abc"] == pytest.approx([0.40, 0.29, 0.32], abs=1e-9)
    assert seven["outlier_limit_mm"] == pytest.approx(0.10) and len(seven["flagged"]) == 9
    assert (tmp_path / "r.png").stat().st_size > 10_000
    report = tmp_path / "r.md"
    proc = run("repeatability", "--readings", str(EXAMPLES / "start_readings_table_6_7.csv"), "--report", str(report))
    assert proc.returncode == 0, proc.stderr
    text = report.read_text(encoding="utf-8")
    assert "start\\_readings\\_table\\_6\\_7.csv" in text and "s (ddof 1)" in text and "flagged: test 5 laser a" in text
    six = run_json("repeatability", "--readings", str(EXAMPLES / "start_readings_table_6_6.csv"))
    assert [(f["test"], f["arm"], f["value"]) for f in six["flagged"]] == [("test 2", "a", 33.41)]
    assert six["arms"]["a"]["sigma_sample"] == pytest.approx(np.std([33.70, 33.41, 33.70], ddof=1), rel=1e-12)


def _acquire(path: Path, seed: int, *extra: str) -> Path:
    proc = run("acquire", "--simulate", "--moves", "1", "--settle", "0", "--seed", str(seed), "--out", str(path),
               *extra)
    assert proc.returncode == 0, proc.stderr
    return path


def test_repeatability_of_simulated_acquisition_logs(tmp_path: Path) -> None:
    # without defects the rigid body returns to one pose: every start reading is the same (zero spread)
    clean = [str(_acquire(tmp_path / f"clean{k}.csv", k)) for k in range(3)]
    out = run_json("repeatability", *clean)
    assert all(out["arms"][arm]["range"] == pytest.approx(0.0, abs=1e-12) for arm in "abc")
    assert out["presequence"] == [True, True, True] and out["flagged"] == []
    # --defects: settling offsets uniform in +-0.225 mm, 2 um laser noise, ~12 um laser output step
    rough = [str(_acquire(tmp_path / f"rough{k}.csv", k, "--defects")) for k in range(5)]
    out = run_json("repeatability", *rough)
    for arm in "abc":
        assert 0.0 < out["arms"][arm]["range"] <= 0.45 + 0.03
    # a log without the pre-sequence cannot be pooled with the others
    bare = str(_acquire(tmp_path / "bare.csv", 9, "--no-presequence"))
    assert_usage_error(run("repeatability", *clean, bare), "pre-sequence")


def test_repeatability_input_errors(tmp_path: Path) -> None:
    assert_usage_error(run("repeatability"), "either LOG files or --readings")
    only = str(_acquire(tmp_path / "one.csv", 1))
    assert_usage_error(run("repeatability", only), "at least 2")
    stop_first = tmp_path / "stop.csv"
    stop_first.write_text("start_stop,probe,motor,direction,laser_a,laser_b,laser_c\n0,0,1,1,34,32,37\n")
    assert_usage_error(run("repeatability", only, str(stop_first)), "not a start reading")


def test_laser_ratio_of_the_printed_table(tmp_path: Path) -> None:
    out = run_json("laser-ratio", "--ratios", str(EXAMPLES / "laser_ratio_table_6_8.csv"), "--plot",
                   str(tmp_path / "q.png"))
    assert [out["arms"][arm]["sigma_population"] for arm in "abc"] == pytest.approx([0.1945, 0.0679, 0.0395],
                                                                                    abs=1e-4)
    assert [out["arms"][arm]["mean"] for arm in "abc"] == pytest.approx([5.298, 6.312, 5.59], abs=1e-12)
    assert [out["predictions"][arm]["height_per_laser"] for arm in "abc"] == pytest.approx([5.239, 5.287, 5.553],
                                                                                          abs=1e-3)
    assert (tmp_path / "q.png").stat().st_size > 10_000
    report = tmp_path / "q.html"
    proc = run("laser-ratio", "--ratios", str(EXAMPLES / "laser_ratio_table_6_8.csv"), "--report", str(report))
    assert proc.returncode == 0, proc.stderr
    page = report.read_text(encoding="utf-8")
    assert "laser_ratio_table_6_8.csv" in page and "6.312" in page and "mean - model" in page


def test_laser_ratio_of_a_model_generated_height_gauge_record(tmp_path: Path) -> None:
    limits = ReadingLimits()
    record = synthesise_ratio_record(travel=[100.0, 98.5, 101.2, 99.3], runs_per_arm=4, height_resolution=0.01,
                                     laser_resolution=limits.laser_resolution)
    path = tmp_path / "hg.csv"
    path.write_text("moved,laser_a,laser_b,laser_c,height\n" + "".join(
        f"{arm},{row[0]!r},{row[1]!r},{row[2]!r},{height:.2f}\n"
        for arm, row, height in zip(record.moved, record.lasers.tolist(), record.heights.tolist(), strict=True)))
    out = run_json("laser-ratio", str(path))
    assert len(out["runs"]) == 12
    for run_out in out["runs"]:
        # laser output steps of <= 12.5 um over ~19 mm: measured and model agree within 4 standard uncertainties
        assert abs(run_out["deviation"]) <= 4 * run_out["u_resolution"]
        assert run_out["height_per_laser"] == pytest.approx(run_out["height_change"] / run_out["laser_change"])
    assert out["predicted_spread"] == pytest.approx(0.31, abs=0.02)
    assert_usage_error(run("laser-ratio", str(path), "--ratios", str(path)), "either FILE or --ratios")
    assert_usage_error(run("laser-ratio", str(path), "--travel-mm", "50"), "only with --ratios")
    path.write_text("moved,laser_a,laser_b,laser_c,height\na,30,31,32,0\n")
    assert_usage_error(run("laser-ratio", str(path)), "single row")
