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
