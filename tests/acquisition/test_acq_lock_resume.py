"""One session per log (an exclusive lock), and a resumed log that ``process-log`` accepts (issue 31).

Lock: real processes.  A ``pcmm acquire --resume`` child is held after its first new row by a
shim (it creates a marker file, then waits), so a second ``pcmm acquire --resume`` on the same
log runs while the first provably holds it; the second must be refused at once (exit 2, one
line naming the log) and the log must not change.  The holder is then killed with SIGKILL: the
kernel drops the lock with the process, so a third run continues the log.

Resume: a simulated session stopped after N moves and continued with ``--resume`` must leave a
log that ``process-log`` accepts, and whose processed tips lie within their stated bounds of the
simulator's truth (:func:`~pcmm_geo.acquisition.simulators.cmm.simulated_truth`, from the logged
motor positions).  Before the fix the resumed machine started again at the start pose while the
log's last row stood elsewhere: a closure residual of ~1 mm at the first rows after the resume.
"""

from __future__ import annotations

import contextlib
import io
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.acquisition.acqlog import AcquisitionLog, read_log
from pcmm_geo.acquisition.simulators.cmm import OFF_LEVEL_START_OFFSETS, simulated_truth
from pcmm_geo.cli import main
from pcmm_geo.errors import LogIntegrityError
from pcmm_geo.machine.analysis.logproc import process_log
from pcmm_geo.machine.analysis.logproc import read_log as read_table
from pcmm_geo.machine.kinematics.model import RigidBodyMachine

ROOT = Path(__file__).resolve().parents[2]
OFFSETS = [str(v) for v in OFF_LEVEL_START_OFFSETS]

_HOLDER = r"""
import sys, time
from pathlib import Path
from pcmm_geo.acquisition.acqlog import AcquisitionLog

marker = Path(sys.argv[1])
original = AcquisitionLog.append

def append_then_hold(self, row):
    written = original(self, row)
    marker.touch()
    while True:
        time.sleep(0.01)

AcquisitionLog.append = append_then_hold
from pcmm_geo.cli import main
sys.exit(main(sys.argv[2:]))
"""


def _acquire(path: Path, *extra: str, seed: int = 5, moves: int = 6) -> int:
    arguments = ["acquire", "--simulate", "--seed", str(seed), "--moves", str(moves), "--settle", "0",
                 "--start-offsets-mm", *OFFSETS, "--out", str(path), *extra]
    with contextlib.redirect_stdout(io.StringIO()):
        return main(arguments)


def _env() -> dict[str, str]:
    return dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))


@pytest.mark.skipif(sys.platform == "win32", reason="flock and POSIX signals")
def test_a_second_session_on_a_held_log_is_refused_at_once_and_a_killed_holder_leaves_no_lock(
        tmp_path: Path) -> None:
    log = tmp_path / "run.csv"
    assert _acquire(log, moves=3) == 0
    marker = tmp_path / "held"
    arguments = ["acquire", "--simulate", "--seed", "6", "--moves", "3", "--settle", "0", "--start-offsets-mm",
                 *OFFSETS, "--out", str(log), "--resume"]
    holder = subprocess.Popen([sys.executable, "-c", _HOLDER, str(marker), *arguments], cwd=tmp_path, env=_env(),
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120  # a bound against a hang only: the wait ends at the marker
        while not marker.exists():
            assert holder.poll() is None, holder.communicate()
            assert time.monotonic() < deadline, "the holder never wrote its first row"
            time.sleep(0.005)
        before = log.read_bytes()
        started = time.monotonic()
        second = subprocess.run([sys.executable, "-m", "pcmm_geo", *arguments], cwd=tmp_path, env=_env(),
                                capture_output=True, text=True, timeout=120)
        assert second.returncode == 2
        lines = second.stderr.strip().splitlines()
        assert len(lines) == 1 and str(log) in lines[0] and "in use by another acquisition session" in lines[0]
        assert "Traceback" not in second.stderr
        assert time.monotonic() - started < 60  # refused, not queued behind the holder (which never ends)
        assert log.read_bytes() == before
    finally:
        holder.send_signal(signal.SIGKILL)
        holder.wait(timeout=30)
    assert holder.returncode == -signal.SIGKILL
    # the kernel released the killed holder's lock: the log continues, rows numbered without repeats
    third = subprocess.run([sys.executable, "-m", "pcmm_geo", *arguments], cwd=tmp_path, env=_env(),
                           capture_output=True, text=True, timeout=120)
    assert third.returncode == 0, third.stderr
    rows = read_log(log).rows
    assert [row.seq for row in rows] == list(range(len(rows))) and len(rows) == 6 + 1 + 6


@pytest.mark.skipif(sys.platform == "win32", reason="flock")
def test_two_sessions_started_together_never_interleave(tmp_path: Path) -> None:
    """Whatever the order: either both ran one after the other or one was refused; rows are never mixed."""
    log = tmp_path / "run.csv"
    assert _acquire(log, moves=2) == 0
    arguments = ["acquire", "--simulate", "--moves", "15", "--settle", "0.002", "--transport", "pty",
                 "--start-offsets-mm", *OFFSETS, "--out", str(log), "--resume"]
    children = [subprocess.Popen([sys.executable, "-m", "pcmm_geo", *arguments, "--seed", str(seed)], cwd=tmp_path,
                                 env=_env(), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
                for seed in (7, 8)]
    errors = [child.communicate(timeout=300)[1] for child in children]
    codes = sorted(child.returncode for child in children)
    assert codes in ([0, 0], [0, 2]), errors
    rows = read_log(log).rows
    assert [row.seq for row in rows] == list(range(len(rows)))
    assert len(rows) == 4 + 30 * codes.count(0)
    if codes == [0, 2]:
        assert any("in use by another acquisition session" in text for text in errors)


def test_the_library_refuses_a_second_open_log(tmp_path: Path) -> None:
    path = tmp_path / "run.csv"
    with AcquisitionLog.create(path, {"note": "first"}):
        with pytest.raises(LogIntegrityError, match="in use by another acquisition session"):
            AcquisitionLog.resume(path)
        with pytest.raises(LogIntegrityError, match="in use"):
            AcquisitionLog.create(path, overwrite=True)
    AcquisitionLog.resume(path).close()  # closed: free again


def _process(path: Path):
    start = [float(v) for v in read_log(path).metadata["start_heights_mm"].split()]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return process_log(RigidBodyMachine.from_dpkm(), read_table(path), initial_heights=start)


@pytest.mark.parametrize(("seed", "first", "more"), [(3, 10, 10), (5, 7, 9)])
def test_a_resumed_log_is_accepted_by_process_log_and_covers_the_truth(tmp_path: Path, seed: int, first: int,
                                                                       more: int,
                                                                       capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "run.csv"
    assert _acquire(path, seed=seed, moves=first) == 0
    assert _acquire(path, "--resume", seed=seed, moves=more) == 0
    contents = read_log(path)
    assert len(contents.rows) == 2 * (first + more)
    assert contents.metadata["continued_from_seq"] == str(2 * first - 1)
    # the first row after the resume stands where the last one before it stood
    assert contents.rows[2 * first].pos_usteps == contents.rows[2 * first - 1].pos_usteps
    capsys.readouterr()
    assert main(["process-log", str(path)]) == 0, capsys.readouterr().err
    out = _process(path)
    _, truth = simulated_truth(path)
    error = np.linalg.norm(out.tips - truth, axis=1)
    assert not out.inconsistent.any()
    assert np.all(error <= out.bound + 1e-9), np.max(error - out.bound)


def test_a_log_cut_after_a_start_row_continues_from_that_pose(tmp_path: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    """A run killed between a move's start row and its stop row: the log ends on a start row."""
    path = tmp_path / "run.csv"
    assert _acquire(path, seed=4, moves=8) == 0
    lines = path.read_bytes().splitlines(keepends=True)
    path.write_bytes(b"".join(lines[:-1]))  # the stop row of the last move never written
    assert read_log(path).rows[-1].start_stop == 1
    assert _acquire(path, "--resume", seed=9, moves=6) == 0
    capsys.readouterr()
    assert main(["process-log", str(path)]) == 0, capsys.readouterr().err
    out = _process(path)
    _, truth = simulated_truth(path)
    assert np.all(np.linalg.norm(out.tips - truth, axis=1) <= out.bound + 1e-9)


def test_resuming_with_other_start_offsets_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "run.csv"
    assert _acquire(path, moves=2) == 0
    before = path.read_bytes()
    capsys.readouterr()
    code = main(["acquire", "--simulate", "--moves", "2", "--settle", "0", "--start-offsets-mm", "0", "0", "0",
                 "--out", str(path), "--resume"])
    assert code == 2
    assert "--start-offsets-mm" in capsys.readouterr().err
    assert path.read_bytes() == before
