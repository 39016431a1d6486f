"""``--plot``, ``--report`` and progress bars of the installed ``pcmm`` command, in subprocesses."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from pcmm_runner import run_pcmm

from pcmm_geo.machine.analysis.logproc import synthesise_log, write_log
from pcmm_geo.machine.calibration.numerical.numcal_data import (
    NumcalParameters,
    synthesise_design_data,
    write_numcal_csv,
)
from pcmm_geo.machine.calibration.seed import TABLE_7_1, appendix_cd_files
from pcmm_geo.machine.kinematics.model import RigidBodyMachine

PCMM = str(Path(sys.executable).with_name("pcmm"))
EXAMPLES = Path(__file__).parents[2] / "pcmm_geo" / "data" / "examples"
DPI = 110


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return run_pcmm(*args, cwd=cwd)


def run_with_terminal_stderr(*args: str) -> tuple[int, str, str]:
    """Run with stderr on a pseudo-terminal (as in an interactive shell) and stdout on a pipe."""
    master, slave = os.openpty()
    env = dict(os.environ, TERM="xterm-256color", COLUMNS="100")
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


def assert_picture(path: Path, width_in: float, height_in: float) -> None:
    import matplotlib.image

    image = matplotlib.image.imread(path)
    assert image.shape[:2] == (round(height_in * DPI), round(width_in * DPI))
    rgb = image[..., :3].reshape(-1, 3)
    assert float(np.std(rgb)) > 0.05
    assert len(np.unique(np.round(rgb, 2), axis=0)) > 20


def assert_refused(done: subprocess.CompletedProcess[str], path: Path) -> None:
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0] and "already exists" in lines[0] and "--overwrite" in lines[0]
    assert done.stdout == ""


class TableCells(HTMLParser):
    """Rows of every HTML table (cell texts) and the embedded images; checks that elements nest properly."""

    def __init__(self) -> None:
        super().__init__()
        self.open: list[str] = []
        self.rows: list[list[str]] = []
        self.images: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag == "img":
            self.images.append(dict(attrs)["src"] or "")
            return
        if tag != "meta":
            self.open.append(tag)
        if tag == "tr":
            self.rows.append([])

    def handle_endtag(self, tag: str) -> None:
        assert self.open.pop() == tag

    def handle_data(self, data: str) -> None:
        if self.open and self.open[-1] in ("td", "th"):
            self.rows[-1].append(data)


def parse_html(path: Path) -> TableCells:
    parser = TableCells()
    parser.feed(path.read_text(encoding="utf-8"))
    parser.close()
    assert parser.open == []
    return parser


def test_calibrate_plot_and_markdown_report(tmp_path: Path) -> None:
    probings, lasers = (str(p) for p in appendix_cd_files())
    plot, report = tmp_path / "cal.png", tmp_path / "cal.md"
    done = run("calibrate", probings, lasers, "--plot", str(plot), "--report", str(report), "--json",
               "--laboratory", "Test Lab")  # a report naming no party at all is warned about on stderr
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""
    data = json.loads(done.stdout)
    assert data["plot"] == str(plot) and data["report"] == str(report)
    assert_picture(plot, 12.0, 6.5)
    lines = report.read_text(encoding="utf-8").splitlines()
    assert lines[0] == "# pcmm calibrate"
    for arm, pair in zip("abc", ("ab", "bc", "ca"), strict=True):
        # the thesis' Table 7.1 values, in the row the terminal table shows
        assert data["dead_distance"][arm] == pytest.approx(TABLE_7_1[arm][0], abs=0.01)
        row = next(line for line in lines if line.startswith(f"| {arm} | "))
        cells = [cell.strip() for cell in row.strip("|").split("|")]
        assert cells[:4] == [arm, f"{data['dead_distance'][arm]:.6f}", pair, f"{data['beta_deg'][pair]:.6f}"]
    assert "![cal.png](cal.png)" in lines

    assert_refused(run("calibrate", probings, lasers, "--plot", str(plot)), plot)
    assert_refused(run("calibrate", probings, lasers, "--report", str(report)), report)
    again = run("calibrate", probings, lasers, "--plot", str(plot), "--report", str(report), "--overwrite")
    assert again.returncode == 0, again.stderr


def test_gauge_block_plot_and_html_report(tmp_path: Path) -> None:
    plot, page = tmp_path / "gb.png", tmp_path / "gb.html"
    example = str(EXAMPLES / "gauge_block.csv")
    done = run("gauge-block", example, "--plot", str(plot), "--report", str(page), "--json")
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)
    assert data["central_length_mm"] == pytest.approx(100.0, abs=0.002)  # the example is a 100 mm block
    assert_picture(plot, 13.5, 7.0)
    parsed = parse_html(page)
    rows = {row[0].strip(): row[1] for row in parsed.rows[1:] if len(row) >= 2}
    assert rows["central length l_c (not corrected to 20 °C)"] == f"{data['central_length_mm']:.6f}"
    # the other lengths: supplementary information in the technical annex, never certified
    assert rows["two-angle length of one point pair (three-point top and side planes)"] == \
        f"{data['seed']['length_mm']:.6f}"
    assert rows["two-point distance of that point pair"] == f"{data['seed']['two_point_distance_mm']:.6f}"
    text = page.read_text(encoding="utf-8")
    assert "thesis" not in text.lower() and "written to" not in text  # no thesis material, no console lines
    assert text.index("Certified values") < text.index("Technical annex") < text.index("Supplementary information")
    assert len(parsed.images) == 1 and parsed.images[0].startswith("data:image/png;base64,")

    before = plot.read_bytes()
    assert_refused(run("gauge-block", example, "--plot", str(plot)), plot)
    assert plot.read_bytes() == before
    # refused before any work: the missing input file is not even read
    assert_refused(run("gauge-block", str(tmp_path / "missing.csv"), "--plot", str(plot)), plot)
    bad_suffix = run("gauge-block", example, "--report", str(tmp_path / "gb.txt"))
    assert bad_suffix.returncode == 2 and "report file" in bad_suffix.stderr
    assert len(bad_suffix.stderr.strip().splitlines()) == 1


def test_fit_sensitivity_and_demo_keep_json_clean(tmp_path: Path) -> None:
    nist = Path(__file__).parents[1] / "data" / "nist" / "Sphere" / "sph20.ds"
    fit_plot = tmp_path / "fit.png"
    done = run("fit", "sphere", str(nist), "--plot", str(fit_plot), "--json")
    assert done.returncode == 0 and done.stderr == ""
    assert json.loads(done.stdout)["plot"] == str(fit_plot)
    assert_picture(fit_plot, 8.0, 4.8)
    assert_refused(run("fit", "sphere", str(nist), "--plot", str(fit_plot)), fit_plot)

    report = tmp_path / "sens.md"
    done = run(
        "sensitivity", "--points-per-axis", "3", "--plot", str(tmp_path / "sens.png"), "--report", str(report),
        "--json", "--operator", "A. Operator"
    )
    assert done.returncode == 0 and done.stderr == ""
    data = json.loads(done.stdout)
    gain = data["laser_gain"]
    assert f"| laser gain / (mm/mm) | {gain['median']:.6f} | {gain['max_finite']:.6f} | 3 |" in (
        report.read_text(encoding="utf-8").splitlines()
    )

    overview, page = tmp_path / "demo.png", tmp_path / "demo.html"
    done = run("demo", "--out", str(tmp_path / "runs"), "--plot", str(overview), "--report", str(page), "--json",
               "--operator", "A. Operator")
    assert done.returncode == 0 and done.stderr == ""
    data = json.loads(done.stdout)
    assert data["plot"] == str(overview) and len(data["plots"]) == 2
    assert_picture(overview, 13.0, 5.5)
    parsed = parse_html(page)
    assert len(parsed.images) == 3  # two plots of the run folder and the overview, embedded
    calibrated = next(row for row in parsed.rows if row[0] == "calibrated (rigid body)")
    assert calibrated[2] == f"{1000.0 * data['length_error_calibrated_mm']:.6f}"
    assert abs(data["length_error_calibrated_mm"]) < 0.005


@pytest.fixture(scope="module")
def long_log(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[str], np.ndarray]:
    machine = RigidBodyMachine.from_dpkm()
    start = machine.reference_heights + np.array([0.0, 60.0, -50.0])
    rng = np.random.default_rng(11)
    moves = [(int(rng.integers(1, 4)), float(rng.uniform(-2.0, 2.0)), bool(rng.random() < 0.2)) for _ in range(400)]
    log = synthesise_log(machine, start, moves)
    path = write_log(tmp_path_factory.mktemp("log") / "long.csv", log)
    heights = [repr(float(h)) for h in start]
    return path, heights, machine.forward(heights=log_heights(start, moves)).tip


def log_heights(start: np.ndarray, moves: list[tuple[int, float, bool]]) -> np.ndarray:
    """True pivot heights after every move that ended touching (the probe rows)."""
    heights, touching = start.astype(float).copy(), []
    for motor, change, probe in moves:
        heights[motor - 1] += change
        if probe:
            touching.append(heights.copy())
    return np.array(touching)


def test_process_log_plot_report_and_progress(long_log: tuple[Path, list[str], np.ndarray], tmp_path: Path) -> None:
    path, heights, truth = long_log
    plot, report = tmp_path / "log.png", tmp_path / "log.md"
    done = run(
        "process-log", str(path), "--initial-heights-mm", *heights, "--plot", str(plot),
                           "--report", str(report), "--json", "--operator", "A. Operator"
    )
    assert done.returncode == 0 and done.stderr == ""
    data = json.loads(done.stdout)
    np.testing.assert_allclose(data["probe_points"], truth, atol=1e-6)
    assert_picture(plot, 12.0, 8.0)  # issue 22: a third panel, u and R per row
    first = data["probe_rows"][0]
    x, y, z = data["probe_points"][0]
    assert f"| {first} | 1 | {x:.6f} | {y:.6f} | {z:.6f} |" in " ".join(report.read_text(encoding="utf-8").split())

    code, stdout, stderr = run_with_terminal_stderr("process-log", str(path), "--initial-heights-mm", *heights)
    assert code == 0
    assert "processing log rows" in stderr and "800/800" in stderr  # the bar, on the terminal only
    assert "\x1b" not in stdout and stdout.startswith("Probe points")

    code, stdout, stderr = run_with_terminal_stderr("process-log", str(path),
                                                    "--initial-heights-mm", *heights, "--json")
    assert code == 0 and stderr == ""  # --json: no bar even on a terminal
    assert json.loads(stdout)["rows"] == 800


def test_demo_and_acquire_progress_on_a_terminal(tmp_path: Path) -> None:
    code, stdout, stderr = run_with_terminal_stderr("demo", "--no-plots")
    assert code == 0 and "calibrated (rigid body)" in stdout and "\x1b" not in stdout
    assert "done" in stderr and "5/5" in stderr  # 5 steps with the uncertainty; the last state is always drawn
    code, _, stderr = run_with_terminal_stderr(
        "acquire",
        "--simulate",
        "--settle",
        "0",
        "--moves",
        "3",
        "--timeout",
        "0.06",
        "--move-timeout",
        "0.12",
        "--out",
        str(tmp_path / "a.csv"),
    )
    assert code == 0 and "acquiring" in stderr and "3/3" in stderr


# numerical calibration (pcmm numcal): the progress bar counts real work


@pytest.fixture(scope="module")
def numcal_csv(tmp_path_factory) -> str:
    design = np.random.default_rng(1).uniform(0.0, 200.0, (24, 3))  # determines all nine parameters
    data = synthesise_design_data(NumcalParameters.from_seed_table(), design)
    return str(write_numcal_csv(data, tmp_path_factory.mktemp("numcal") / "numcal.csv"))


def test_numcal_progress_on_a_terminal_only(numcal_csv):
    code, stdout, stderr = run_with_terminal_stderr("numcal", numcal_csv, "--search", "multistart", "--pairs", "all")
    assert code == 0 and "\x1b" not in stdout and "Numerical calibration" in stdout
    # 20 seeded starts, one least-squares refinement each: the last state is always drawn
    assert "numerical calibration (simultaneous, multistart)" in stderr and "20/20" in stderr
    code, stdout, stderr = run_with_terminal_stderr("numcal", numcal_csv, "--search", "multistart", "--json", "--pairs",
                                                    "all")
    assert code == 0 and stderr == ""  # --json: no bar even on a terminal
    assert json.loads(stdout)["global_search"] == "multistart"
    piped = subprocess.run(
        [PCMM, "numcal", numcal_csv, "--search", "multistart", "--pairs", "all"], capture_output=True, text=True,
        timeout=120, check=False
    )
    assert piped.returncode == 0 and piped.stderr == ""  # stderr not a terminal: no bar
