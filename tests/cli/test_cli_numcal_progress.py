"""``pcmm numcal``: progress bar of the global search on a terminal, none for pipes or --json."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from pcmm_geo.machine.numcal import NumcalParameters, synthesise_numcal_data

PCMM = str(Path(sys.executable).with_name("pcmm"))


def run_with_terminal_stderr(*args: str) -> tuple[int, str, str]:
    """Run with stderr on a pseudo-terminal (an interactive shell) and stdout on a pipe."""
    master, slave = os.openpty()
    env = dict(os.environ, TERM="xterm-256color", COLUMNS="120")
    proc = subprocess.Popen([PCMM, *args], stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=slave, env=env)
    os.close(slave)
    received: list[bytes] = []

    def drain() -> None:
        while True:
            try:
                chunk = os.read(master, 65536)
            except OSError:  # EIO once the child closed its end
                return
            if not chunk:
                return
            received.append(chunk)

    reader = threading.Thread(target=drain)
    reader.start()
    stdout, _ = proc.communicate(timeout=300)
    reader.join(timeout=30)
    os.close(master)
    return proc.returncode, stdout.decode(), b"".join(received).decode(errors="replace")


@pytest.fixture(scope="module")
def numcal_csv(tmp_path_factory) -> str:
    truth = NumcalParameters.from_seed_table()
    data = synthesise_numcal_data(truth, seed=1)
    rows = ["moved,laser_a,laser_b,laser_c,height"]
    rows += [f"{m},{a!r},{b!r},{c!r},{h!r}" for m, (a, b, c), h in
             zip(data.moved, data.lasers.tolist(), data.heights.tolist(), strict=True)]
    path = tmp_path_factory.mktemp("numcal") / "numcal.csv"
    path.write_text("\n".join(rows) + "\n")
    return str(path)


def test_numcal_progress_on_a_terminal_only(numcal_csv):
    code, stdout, stderr = run_with_terminal_stderr("numcal", numcal_csv, "--search", "multistart")
    assert code == 0 and "\x1b" not in stdout and "Numerical calibration" in stdout
    # 20 seeded starts, one least-squares refinement each: the last state is always drawn
    assert "numerical calibration (simultaneous, multistart)" in stderr and "20/20" in stderr
    code, stdout, stderr = run_with_terminal_stderr("numcal", numcal_csv, "--search", "multistart", "--json")
    assert code == 0 and stderr == ""  # --json: no bar even on a terminal
    assert json.loads(stdout)["global_search"] == "multistart"
    piped = subprocess.run([PCMM, "numcal", numcal_csv, "--search", "none"], capture_output=True, text=True,
                           timeout=120, check=False)
    assert piped.returncode == 0 and piped.stderr == ""  # stderr not a terminal: no bar
