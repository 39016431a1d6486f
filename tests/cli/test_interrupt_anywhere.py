"""Ctrl-C anywhere in a command is an interrupt: one line, exit 130, no traceback, nothing half-written (issue 31).

Each case is a child process (the real entry point, :func:`pcmm_geo.cli.main`) that sends itself a
real SIGINT at a chosen point, so the signal always arrives there however loaded the machine is:

* while ``main`` imports the sub-commands (before the command's own signal handling started:
  a KeyboardInterrupt traceback before the fix);
* while an optional package loads whose extension turns the interrupt into ``ImportError``
  (as pybind11 modules such as open3d do: "needs open3d, which is not installed" before the fix);
* while a PDF plot is written, with the writer's clean-up failing with ``zlib.error`` as the
  interrupt unwinds (the traceback seen once), and with the interrupt swallowed by that clean-up.
"""

from __future__ import annotations

import os
import subprocess
import sys
from importlib.resources import files
from pathlib import Path

import pytest

from pcmm_geo import require
from pcmm_geo._optional import OPTIONAL_MODULES

ROOT = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")

_CHILD = r"""
import os, signal, sys
# a background job of a non-interactive shell inherits SIGINT ignored: restore what a terminal gives
signal.signal(signal.SIGINT, signal.default_int_handler)
mode, point = sys.argv[1], sys.argv[2]

def interrupt_here():
    os.kill(os.getpid(), signal.SIGINT)
    for _ in range(10**6):  # the handler runs between two bytecodes
        pass

if mode == "import":  # SIGINT while `point` is being imported
    class Hook:
        def find_spec(self, name, path=None, target=None):
            if name == point:
                interrupt_here()
            return None
    sys.meta_path.insert(0, Hook())
elif mode == "pdf":  # SIGINT inside the PDF writer's stream
    import zlib
    from matplotlib.backends import backend_pdf
    original = backend_pdf.Stream.end

    def end(self):
        if point == "plain":
            interrupt_here()
        elif point == "cleanup-fails":
            try:
                interrupt_here()
            except KeyboardInterrupt:
                raise zlib.error("Error -2 while flushing: inconsistent stream state")
        elif point == "swallowed":
            try:
                interrupt_here()
            except KeyboardInterrupt:
                pass
            raise zlib.error("Error -2 while flushing: inconsistent stream state")
        return original(self)

    backend_pdf.Stream.end = end
from pcmm_geo.cli import main
sys.exit(main(sys.argv[3:]))
"""


def _child(tmp_path: Path, mode: str, point: str, *arguments: str,
           path: str = "") -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [path, str(ROOT), os.environ.get("PYTHONPATH")])))
    return subprocess.run([sys.executable, "-c", _CHILD, mode, point, *arguments], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=120)


def _assert_interrupted(done: subprocess.CompletedProcess[str]) -> None:
    assert done.returncode == 130, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].endswith("interrupted"), done.stderr
    assert "Traceback" not in done.stderr


@pytest.mark.parametrize("point", [
    "pcmm_geo.cli.measure.fit",  # the first sub-commands main registers
    "pcmm_geo.cli.acquisition.acquire",  # further on
    "pcmm_geo.cli._run",  # after parsing, before the command's own handling
])
def test_ctrl_c_while_the_command_starts_is_one_line(tmp_path: Path, point: str) -> None:
    source = tmp_path / "scan.csv"
    source.write_text("x,y,z\n" + "".join(f"{k}.5,{k},-{k}\n" for k in range(20)))
    done = _child(tmp_path, "import", point, "convert", "scan.csv", "out.csv")
    _assert_interrupted(done)
    assert done.stderr.strip() == "pcmm: interrupted"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scan.csv"]


_FAKE_EXTENSION = """
import time
from pathlib import Path
try:
    Path({marker!r}).touch()
    for _ in range(100000):
        time.sleep(0.001)
except BaseException as exc:  # what pybind11 does with an error during a module's initialisation
    raise ImportError("initialization failed") from exc
"""


def test_ctrl_c_while_an_optional_package_loads_stays_an_interrupt(tmp_path: Path) -> None:
    """A real SIGINT while a (fake, slow) open3d loads: an interrupt, not "open3d is not installed"."""
    fake = tmp_path / "fake"
    (fake / "open3d").mkdir(parents=True)
    (fake / "open3d" / "__init__.py").write_text(_FAKE_EXTENSION.format(marker=str(tmp_path / "loading")))
    script = (
        "import os, signal, sys, threading, time\n"
        "from pathlib import Path\n"
        "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "from pcmm_geo import require\n"
        "def kick():\n"
        f"    while not Path({str(tmp_path / 'loading')!r}).exists():\n"
        "        time.sleep(0.001)\n"
        "    os.kill(os.getpid(), signal.SIGINT)\n"
        "threading.Thread(target=kick, daemon=True).start()\n"
        "try:\n"
        "    require('open3d')\n"
        "except KeyboardInterrupt:\n"
        "    print('interrupt')\n"
        "except ImportError as exc:\n"
        "    print('import error:', exc)\n"
    )
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(fake), str(ROOT),
                                                                     os.environ.get("PYTHONPATH")])))
    done = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=120)
    assert done.stdout.strip() == "interrupt", (done.stdout, done.stderr)


def test_require_passes_an_interrupted_import_through(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """In process: an ImportError caused by an interrupt re-raises the interrupt; a plain one names the extra."""
    (tmp_path / "pcmm_fake_interrupted.py").write_text(
        "try:\n    raise KeyboardInterrupt\nexcept KeyboardInterrupt as exc:\n"
        "    raise ImportError('initialization failed') from exc\n")
    (tmp_path / "pcmm_fake_missing.py").write_text("raise ImportError('no such thing')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setitem(OPTIONAL_MODULES, "pcmm_fake_interrupted", ("fake", "cad"))
    monkeypatch.setitem(OPTIONAL_MODULES, "pcmm_fake_missing", ("fake", "cad"))
    with pytest.raises(KeyboardInterrupt):
        require("pcmm_fake_interrupted")
    with pytest.raises(ImportError, match="cad"):
        require("pcmm_fake_missing")


@pytest.mark.parametrize("point", ["plain", "cleanup-fails", "swallowed"])
def test_ctrl_c_while_a_pdf_plot_is_written_leaves_no_file(tmp_path: Path, point: str) -> None:
    pytest.importorskip("matplotlib")
    example = files("pcmm_geo") / "data/examples/gauge_block.csv"
    done = _child(tmp_path, "pdf", point, "gauge-block", str(example), "--plot", "plot.pdf")
    _assert_interrupted(done)
    assert done.stderr.strip() == "pcmm gauge-block: interrupted"
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # neither the plot nor its temporary file
