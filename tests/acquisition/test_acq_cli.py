"""``pcmm acquire`` run as the installed command in a subprocess."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

from pcmm_runner import run_pcmm

from pcmm_geo.acquisition.acqlog import read_log

PCMM = str(Path(sys.executable).with_name("pcmm"))
FAST = ["--simulate", "--settle", "0", "--timeout", "0.06", "--move-timeout", "0.12"]


def _pcmm(*args: str) -> subprocess.CompletedProcess[str]:
    return run_pcmm(*args)


def test_simulated_run_with_faults_json(tmp_path: Path) -> None:
    out, table = tmp_path / "run.csv", tmp_path / "table.csv"
    done = _pcmm("acquire", *FAST, "--moves", "8", "--fault-rate", "0.2", "--seed", "4", "--out", str(out),
                 "--table-3-2", str(table), "--json")
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout)
    contents = read_log(out)  # strict: every row whole and numeric
    assert report["rows"] == len(contents.rows) == 16 and report["moves"] == 8
    assert [r.start_stop for r in contents.rows] == [1, 0] * 8
    assert sum(report["injected_faults"].values()) > 0 and report["retries"] > 0
    assert contents.metadata["fault_rate"] == "0.2" and contents.metadata["mode"] == "simulated"
    assert contents.metadata["zaber_2_device_id"] == "4452"  # T-LSR450B, read from the stage
    assert done.stderr == ""  # no progress bar when stderr is not a terminal
    plain = table.read_text().splitlines()
    assert plain[0] == "start_stop,probe,motor,direction,laser_a,laser_b,laser_c" and len(plain) == 17
    assert plain[1].split(",") == [str(contents.rows[0].start_stop), str(contents.rows[0].probe),
                                   str(contents.rows[0].motor), str(contents.rows[0].direction),
                                   repr(contents.rows[0].laser_a), repr(contents.rows[0].laser_b),
                                   repr(contents.rows[0].laser_c)]


def test_refuses_to_overwrite_then_resumes(tmp_path: Path) -> None:
    out = tmp_path / "run.csv"
    assert _pcmm("acquire", *FAST, "--moves", "2", "--out", str(out)).returncode == 0
    before = out.read_bytes()
    again = _pcmm("acquire", *FAST, "--moves", "2", "--out", str(out))
    assert again.returncode == 2 and "refusing to overwrite" in again.stderr
    assert len(again.stderr.strip().splitlines()) == 1 and out.read_bytes() == before
    with open(out, "a", encoding="utf-8") as handle:
        handle.write("1,0,3,")  # a torn row as after a crash
    refused = _pcmm("acquire", *FAST, "--moves", "1", "--resume", "--out", str(out))
    assert refused.returncode == 2 and "partial last row" in refused.stderr
    resumed = _pcmm("acquire", *FAST, "--moves", "3", "--resume", "--repair", "--out", str(out), "--json")
    assert resumed.returncode == 0, resumed.stderr
    report = json.loads(resumed.stdout)
    assert report["truncated_bytes"] == 6 and report["resumed"] is True
    rows = read_log(out).rows
    assert len(rows) == 4 + 6 and [r.seq for r in rows] == list(range(10))


def test_hardware_mode_needs_ports(tmp_path: Path) -> None:
    done = _pcmm("acquire", "--moves", "1", "--out", str(tmp_path / "x.csv"))
    assert done.returncode == 2 and "--port-zaber: expected a port name" in done.stderr
    assert not (tmp_path / "x.csv").exists()


def test_run_killed_with_sigkill_leaves_only_whole_rows(tmp_path: Path) -> None:
    out = tmp_path / "killed.csv"
    process = subprocess.Popen([PCMM, "acquire", *FAST, "--moves", "100000", "--out", str(out)],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            if out.exists() and sum(1 for line in out.read_text().splitlines() if line[:1].isdigit()) >= 12:
                break
            time.sleep(0.05)
        process.send_signal(signal.SIGKILL)
        process.wait(timeout=10)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == -signal.SIGKILL
    rows = read_log(out).rows  # raises on a partial or damaged row
    assert len(rows) >= 12 and [r.seq for r in rows] == list(range(len(rows)))
