"""``pcmm serve``: bad input (exit 2), a short simulated run, transcript replay to a points CSV, torn transcripts."""

from __future__ import annotations

import json

import pytest
from pcmm_runner import run_pcmm

from pcmm_geo.errors import FileFormatError, LogIntegrityError, OutputExistsError
from pcmm_geo.ippdme.transcript import Transcript, measured_points, read_transcript


def _transcript(path, points=((1.0, 2.0, 3.0), (4.0, 5.0, 6.0))) -> None:
    t = Transcript(path, {"test": True})
    t.record(1, "connect", peer="x")
    for i, p in enumerate(points):
        t.record(1, "point", tag=f"{i + 1:05d}", csy="MachineCsy", reported_mm=list(p), poorly_resolved=i == 0)
    t.record(1, "point", tag="00009", error=1006, detail="no surface")
    t.close()


@pytest.mark.parametrize("args", [
    ["serve"],  # no --simulate
    ["serve", "--simulate", "--port", "70000"],
    ["serve", "--simulate", "--points-out", "x.csv"],
    ["serve", "--simulate", "--diameter-mm", "-1"],
    ["serve", "--simulate", "--workpiece", "mesh"],
    ["serve", "--replay", "missing.jsonl", "--transcript", "t.jsonl"],
    ["serve", "--simulate", "--calibration", "missing.json"],
    ["serve", "--simulate", "--port-zaber", "/dev/ttyUSB0"],  # ports and --simulate
    ["serve", "--port-zaber", "/dev/ttyUSB0"],  # four ports missing
    ["serve", "--port-zaber", "a", "--port-laser-a", "b", "--port-laser-b", "c", "--port-laser-c", "d",
     "--port-probe", "e", "--fine-step-mm", "1"],
])
def test_bad_input_is_one_line_and_exit_2(args, tmp_path) -> None:
    out = run_pcmm(*args, cwd=tmp_path)
    assert out.returncode == 2, out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and "Traceback" not in out.stderr


def test_short_simulated_run_writes_a_transcript(tmp_path) -> None:
    out = run_pcmm("serve", "--simulate", "--port", "0", "--duration-s", "0.3", "--transcript",
                   tmp_path / "t.jsonl", "--json")
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    assert data["port"] > 0 and data["homed"] is False and data["workpieces"][0]["type"] == "sphere"
    header, records = read_transcript(tmp_path / "t.jsonl")
    assert header["settings"]["seed"] == 0 and records == []
    again = run_pcmm("serve", "--simulate", "--port", "0", "--duration-s", "0.1", "--transcript", tmp_path / "t.jsonl")
    assert again.returncode == 2 and "exists" in again.stderr


def test_replay_writes_the_points_pcmm_fit_reads(tmp_path) -> None:
    _transcript(tmp_path / "s.jsonl", [(10.0 * c, 10.0 * s, 0.0) for c, s in
                                        ((1, 0), (0, 1), (-1, 0), (0, -1), (0.6, 0.8))])
    out = run_pcmm("serve", "--replay", tmp_path / "s.jsonl", "--points-out", tmp_path / "p.csv", "--json")
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    assert data["points"] == 5 and data["refused_probings"] == 1 and data["poorly_resolved"] == 1
    fit = run_pcmm("fit", "circle", tmp_path / "p.csv", "--json")
    assert fit.returncode == 0, fit.stderr
    assert json.loads(fit.stdout)["radius"] == pytest.approx(10.0, abs=1e-9)
    refused = run_pcmm("serve", "--replay", tmp_path / "s.jsonl", "--points-out", tmp_path / "p.csv")
    assert refused.returncode == 2


def test_torn_and_foreign_transcripts_are_refused(tmp_path) -> None:
    path = tmp_path / "s.jsonl"
    _transcript(path)
    with path.open("ab") as handle:
        handle.write(b'{"seq": 99, "kind": "po')  # a crash mid-record
    with pytest.raises(LogIntegrityError):
        read_transcript(path)
    _, records = read_transcript(path, allow_partial=True)
    assert len(measured_points(records).points) == 2
    out = run_pcmm("serve", "--replay", path)
    assert out.returncode == 2 and "incomplete" in out.stderr
    (tmp_path / "foreign.jsonl").write_text('{"schema": "other"}\n')
    with pytest.raises(FileFormatError):
        read_transcript(tmp_path / "foreign.jsonl")
    (tmp_path / "deep.jsonl").write_text(json.dumps({"schema": "pcmm_geo.ippdme-transcript/1"}) + "\n"
                                         + "[" * 100000 + "\n")
    with pytest.raises(FileFormatError):
        read_transcript(tmp_path / "deep.jsonl")
    with pytest.raises(OutputExistsError):
        Transcript(path, {})


def test_calibration_file_is_the_served_machine(calibration_file, tmp_path) -> None:
    import numpy as np

    from pcmm_geo.ippdme.calfile import model_from_calibration
    from pcmm_geo.machine.calibration import load_calibration

    served = model_from_calibration(calibration_file)
    cal = load_calibration(calibration_file)
    assert served.has_covariance and served.model.calibration_covariance.shape == (28, 28)
    assert served.model.tip_radius == pytest.approx(cal.tip.radius, abs=1e-12)
    np.testing.assert_allclose(served.model.machine.tetrahedron.tip_center, cal.tetrahedron.tip_center, atol=1e-12)
    out = run_pcmm("serve", "--simulate", "--calibration", calibration_file, "--port", "0", "--duration-s", "0.2",
                   "--transcript", tmp_path / "t.jsonl", "--json")
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    assert data["calibration"].startswith(str(calibration_file))
    # the home pose is the file's model at its reference heights raised 40 mm (not the demo's)
    expected = served.model.machine.forward(heights=served.model.machine.reference_heights + 40.0,
                                            lasers_hint=served.model.machine.reference_lasers).tip
    np.testing.assert_allclose(data["home_mm"], expected, atol=1e-9)
    header, _ = read_transcript(tmp_path / "t.jsonl")
    assert header["settings"]["calibration"] == data["calibration"]


def test_calibration_file_without_covariance_is_served_with_a_note_and_bad_files_exit_2(calibration_file,
                                                                                       tmp_path) -> None:
    document = json.loads(calibration_file.read_text())
    del document["covariance"]
    bare = tmp_path / "bare.json"
    bare.write_text(json.dumps(document))
    out = run_pcmm("serve", "--simulate", "--calibration", bare, "--port", "0", "--duration-s", "0.1")
    assert out.returncode == 0, out.stderr
    assert "holds no covariance" in out.stdout
    document["results"]["dead_distance"]["a"] += 1.0  # an edited file: the stored results disagree
    edited = tmp_path / "edited.json"
    edited.write_text(json.dumps(document))
    not_json = tmp_path / "not.json"
    not_json.write_text("{ not json")
    for bad in (edited, not_json):
        refused = run_pcmm("serve", "--simulate", "--calibration", bad, "--port", "0", "--duration-s", "0.1")
        assert refused.returncode == 2 and len(refused.stderr.strip().splitlines()) == 1, refused.stderr
        assert str(bad.name) in refused.stderr and "Traceback" not in refused.stderr
