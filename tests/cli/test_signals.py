"""SIGTERM, SIGHUP and SIGINT end a command like Ctrl-C; what SIGKILL leaves is cleaned by the next run.

Each command runs in a child process (the real ``pcmm`` entry point) with one library call
slowed down by a small shim: the writer of ``pcmm convert`` stops half-way through its
temporary file, the acquisition log after its rows, and each announces it by creating a
marker file.  The test waits for that marker -- state it can observe, not a fixed sleep --
then sends the signal, so the signal always arrives mid-write, however loaded the machine is.
Only outcomes are asserted: exit codes, messages, the files in the folder and their contents.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pcmm_geo._signals import Interrupted, deferred, interrupt_on_signals

ROOT = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")

# the child: pcmm with a writer that stops (and says so) half-way; the parent then signals it
_SHIM = r"""
import signal, sys, time
from pathlib import Path

# a job started in the background by a non-interactive shell inherits SIGINT ignored (POSIX), and Python then
# installs no KeyboardInterrupt handler: restore it, as an interactive terminal would have it
signal.signal(signal.SIGINT, signal.default_int_handler)

marker = Path(sys.argv[1])
mode = sys.argv[2]

def hold():
    marker.touch()
    while True:
        time.sleep(0.01)

if mode == "convert":
    import pcmm_geo._atomic as atomic
    original = atomic.write_atomic

    def slow_write_atomic(path, content, *, overwrite=False):
        def half_then_hold(stream):
            stream.write(b"x,y,z\n1.0,2.0,")
            stream.flush()
            hold()
        return original(path, half_then_hold, overwrite=overwrite)

    atomic.write_atomic = slow_write_atomic
elif mode.startswith("acquire"):
    from pcmm_geo.acquisition.acqlog import AcquisitionLog
    rows = int(mode.split(":")[1])
    original = AcquisitionLog.append

    def append_then_hold(self, row):
        written = original(self, row)
        if self.rows_written - self.recovery.rows >= rows:
            hold()
        return written

    AcquisitionLog.append = append_then_hold

from pcmm_geo.cli import main
sys.exit(main(sys.argv[3:]))
"""


def _start(tmp_path: Path, mode: str, *arguments: str) -> tuple[subprocess.Popen[str], Path]:
    marker = tmp_path / f"marker-{time.monotonic_ns()}"
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    child = subprocess.Popen([sys.executable, "-c", _SHIM, str(marker), mode, *arguments], cwd=tmp_path, env=env,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 300  # only a bound against a hang: the wait ends when the marker appears
    while not marker.exists():
        if child.poll() is not None:
            pytest.fail(f"the command ended before it was signalled: {child.communicate()}")
        if time.monotonic() > deadline:
            child.kill()
            pytest.fail("the command never reached the point to signal")
        time.sleep(0.005)
    marker.unlink()
    return child, marker


def _pcmm(tmp_path: Path, *arguments: str) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "pcmm_geo", *arguments], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=600)


def _points(tmp_path: Path) -> Path:
    source = tmp_path / "scan.csv"
    source.write_text("x,y,z\n" + "".join(f"{k}.5,{k},-{k}\n" for k in range(200)))
    return source


def _hidden(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


@pytest.mark.parametrize(("signum", "code", "said"), [
    (signal.SIGTERM, 143, "interrupted by SIGTERM"),
    (signal.SIGHUP, 129, "interrupted by SIGHUP"),
    (signal.SIGINT, 130, "interrupted"),
])
def test_signal_mid_write_leaves_the_old_output_and_no_temporary_file(tmp_path: Path, signum: int, code: int,
                                                                     said: str) -> None:
    _points(tmp_path)
    old = tmp_path / "out.csv"
    old.write_text("x,y,z\n9,9,9\n")
    child, _ = _start(tmp_path, "convert", "convert", "scan.csv", "out.csv", "--overwrite")
    assert any(name.startswith(".out-") and name.endswith(".tmp.csv") for name in _hidden(tmp_path))  # mid-write
    child.send_signal(signum)
    _, stderr = child.communicate(timeout=300)
    assert child.returncode == code
    assert stderr.strip().endswith(said) and "Traceback" not in stderr
    assert old.read_text() == "x,y,z\n9,9,9\n"
    assert _hidden(tmp_path) == []


def test_a_new_output_is_not_left_half_written(tmp_path: Path) -> None:
    _points(tmp_path)
    child, _ = _start(tmp_path, "convert", "convert", "scan.csv", "new.csv")
    child.send_signal(signal.SIGTERM)
    child.communicate(timeout=300)
    assert child.returncode == 143
    assert sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith("marker")) == ["scan.csv"]


def test_sigkill_leftovers_are_removed_by_the_next_run_but_not_while_their_run_lives(tmp_path: Path) -> None:
    _points(tmp_path)
    old = tmp_path / "out.csv"
    old.write_text("x,y,z\n9,9,9\n")
    first, _ = _start(tmp_path, "convert", "convert", "scan.csv", "out.csv", "--overwrite")
    [temporary] = _hidden(tmp_path)
    # another run over the same output while the first is alive: its temporary file is not touched
    refused = _pcmm(tmp_path, "convert", "scan.csv", "out.csv")
    assert refused.returncode == 2 and "already exists" in refused.stderr and "note:" not in refused.stderr
    assert _hidden(tmp_path) == [temporary]
    first.kill()  # SIGKILL: nothing can clean up
    first.communicate(timeout=300)
    assert _hidden(tmp_path) == [temporary] and old.read_text() == "x,y,z\n9,9,9\n"
    again = _pcmm(tmp_path, "convert", "scan.csv", "out.csv", "--overwrite")
    assert again.returncode == 0, again.stderr
    assert f"note: removed {temporary}, a temporary file left by an interrupted run" in again.stderr
    assert _hidden(tmp_path) == [] and old.read_text().startswith("x,y,z\n0.5,0.0,-0.0\n")


_ACQUIRE = ("acquire", "--simulate", "--moves", "40", "--settle", "0", "--seed", "3", "--out", "run.csv")


def _log_rows(path: Path) -> int:
    from pcmm_geo.acquisition.acqlog import read_log

    return len(read_log(path).rows)


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGHUP, signal.SIGINT])
def test_an_interrupted_acquisition_keeps_its_rows_and_resumes(tmp_path: Path, signum: int) -> None:
    child, _ = _start(tmp_path, "acquire:5", *_ACQUIRE)
    child.send_signal(signum)
    _, stderr = child.communicate(timeout=300)
    assert child.returncode == 128 + signum, stderr
    assert "5 measured row(s) are a record" in stderr
    assert _log_rows(tmp_path / "run.csv") == 5  # every row written is there, whole
    resumed = _pcmm(tmp_path, *_ACQUIRE[:-2], "--moves", "2", "--out", "run.csv", "--resume")
    assert resumed.returncode == 0, resumed.stderr
    assert _log_rows(tmp_path / "run.csv") > 5
    assert _hidden(tmp_path) == []


def test_acquire_overwrite_interrupted_puts_the_old_log_back_beside_the_new_one(tmp_path: Path) -> None:
    done = _pcmm(tmp_path, *_ACQUIRE[:3], "3", *_ACQUIRE[4:])
    assert done.returncode == 0, done.stderr
    old_rows = (tmp_path / "run.csv").read_bytes()
    child, _ = _start(tmp_path, "acquire:4", *_ACQUIRE, "--overwrite")
    child.send_signal(signal.SIGTERM)
    _, stderr = child.communicate(timeout=300)
    assert child.returncode == 143
    [visible] = [p for p in tmp_path.iterdir() if p.name.startswith("run.replaced-")]
    assert f"kept as {visible.name}" in stderr or f"kept as {visible}" in stderr
    assert visible.read_bytes() == old_rows and _log_rows(tmp_path / "run.csv") == 4
    assert _hidden(tmp_path) == []


@pytest.mark.parametrize("rows", [0, 4])
def test_acquire_overwrite_killed_is_put_right_by_the_next_run(tmp_path: Path, rows: int) -> None:
    done = _pcmm(tmp_path, *_ACQUIRE[:3], "3", *_ACQUIRE[4:])
    assert done.returncode == 0, done.stderr
    old_rows = (tmp_path / "run.csv").read_bytes()
    if rows:
        child, _ = _start(tmp_path, f"acquire:{rows}", *_ACQUIRE, "--overwrite")
    else:  # killed before the first row: the new log holds its header only
        child, _ = _start(tmp_path, "acquire:1", *_ACQUIRE, "--overwrite")
        with open(tmp_path / "run.csv", "r+b") as log:  # as if killed before the row was written
            data = log.read()
            log.seek(0)
            log.truncate(data.rindex(b"\n", 0, len(data) - 1) + 1)
    child.kill()
    child.communicate(timeout=300)
    [backup] = [name for name in _hidden(tmp_path) if name.endswith(".replaced")]
    assert backup.startswith(".run.csv.")
    resumed = _pcmm(tmp_path, *_ACQUIRE[:-2], "--moves", "1", "--out", "run.csv", "--resume")
    assert resumed.returncode == 0, resumed.stderr
    assert _hidden(tmp_path) == []
    if rows:  # the new log is a record and stays; the old one comes back under a visible name
        assert "kept run.csv, the log an interrupted run was writing" in resumed.stderr
        [visible] = [p for p in tmp_path.iterdir() if p.name.startswith("run.replaced-")]
        assert visible.read_bytes() == old_rows
        assert _log_rows(tmp_path / "run.csv") > rows
    else:  # nothing was recorded: the old log is restored, then resumed
        assert "restored run.csv from the backup left by an interrupted run" in resumed.stderr
        assert (tmp_path / "run.csv").read_bytes().startswith(old_rows)


def test_signals_are_held_inside_a_deferred_section_and_raised_after_it() -> None:
    steps = []
    with interrupt_on_signals(), pytest.raises(Interrupted) as info:
        with deferred():
            os.kill(os.getpid(), signal.SIGTERM)
            for _ in range(100_000):  # the handler has had every chance to run: it must hold the signal
                pass
            steps.append("section finished")
        steps.append("not reached")
    assert steps == ["section finished"] and info.value.exit_code == 143


def test_a_signal_ignored_at_start_stays_ignored(tmp_path: Path) -> None:
    """``nohup pcmm ...``: SIGHUP is ignored before the command starts and must stay so."""
    _points(tmp_path)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    marker = tmp_path / "marker"
    child = subprocess.Popen([sys.executable, "-c", _SHIM, str(marker), "convert", "convert", "scan.csv", "new.csv"],
                             cwd=tmp_path, env=env, stderr=subprocess.PIPE, text=True,
                             preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN))
    deadline = time.monotonic() + 300
    while not marker.exists() and child.poll() is None and time.monotonic() < deadline:
        time.sleep(0.005)
    child.send_signal(signal.SIGHUP)  # ignored: the SIGTERM after it ends the command
    child.send_signal(signal.SIGTERM)
    _, stderr = child.communicate(timeout=300)
    assert child.returncode == 143, stderr
    assert not (tmp_path / "new.csv").exists() and _hidden(tmp_path) == []
