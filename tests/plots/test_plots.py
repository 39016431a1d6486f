"""pcmm_geo.plots and the report writer, in process: geometry behind the plots, images, files, callbacks."""

from __future__ import annotations

import base64
import math
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.artefacts.gauge_block import measure_gauge_block
from pcmm_geo.cli._output import Report, Table
from pcmm_geo.cli._report import render_html, render_markdown, write_report
from pcmm_geo.errors import InvalidInputError, OutputExistsError
from pcmm_geo.plots._figure import PLOT_DPI
from pcmm_geo.plots.gauge_block import face_deviations, length_comparison


def _image(path: Path) -> np.ndarray:
    import matplotlib.image

    return matplotlib.image.imread(path)


def _assert_real_picture(path: Path, width_in: float, height_in: float) -> None:
    image = _image(path)
    assert image.shape[:2] == (round(height_in * PLOT_DPI), round(width_in * PLOT_DPI))
    rgb = image[..., :3].reshape(-1, 3)
    assert float(np.std(rgb)) > 0.05  # not blank
    assert len(np.unique(np.round(rgb, 2), axis=0)) > 20  # many colours: lines, markers, colour maps


def _tilted_face(bumps: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Points ``origin + u e1 + v e2 + bump n`` on a 3 x 3 grid of a tilted plane; returns points, u-v, n."""
    normal = np.array([0.3, -0.2, 1.0]) / np.linalg.norm([0.3, -0.2, 1.0])
    first = np.cross(normal, [0.0, 1.0, 0.0])
    first /= np.linalg.norm(first)
    second = np.cross(normal, first)
    us, vs = np.meshgrid([-4.0, 0.0, 4.0], [-7.0, 0.0, 7.0])
    flat = np.c_[us.ravel(), vs.ravel()]
    origin = np.array([10.0, -20.0, 5.0])
    points = origin + flat[:, :1] * first + flat[:, 1:] * second + bumps[:, None] * normal
    return points, flat, normal, origin


def test_face_deviations_are_the_orthogonal_bumps_and_in_plane_coordinates_are_an_isometry() -> None:
    us, vs = np.meshgrid([-1.0, 0.0, 1.0], [-1.0, 0.0, 1.0])
    # zero mean and orthogonal to 1, u, v: the least-squares plane is the unperturbed one
    bumps = 0.002 * ((us**2 - 2 / 3) * (vs**2 - 2 / 3)).ravel()
    points, flat, _, _ = _tilted_face(bumps)
    in_plane, deviation = face_deviations(points)
    sign = np.sign(deviation[np.argmax(np.abs(bumps))] * bumps[np.argmax(np.abs(bumps))])
    np.testing.assert_allclose(sign * deviation, bumps, atol=1e-12)
    distances = np.linalg.norm(in_plane[:, None] - in_plane[None], axis=2)
    np.testing.assert_allclose(distances, np.linalg.norm(flat[:, None] - flat[None], axis=2), atol=1e-10)


def _block_faces(offset_1: tuple[float, float], offset_2: tuple[float, float]) -> dict[str, np.ndarray]:
    """Perfect 100 mm block along x (35 mm wide in y, 9 mm high in z); first face points at the offsets."""
    lateral = np.array([offset_1, [10.0, 3.0], [-10.0, -3.0], [10.0, -3.0]])
    lateral_2 = np.array([offset_2, [10.0, 3.0], [-10.0, -3.0], [10.0, -3.0]])
    return {
        "face_1": np.c_[np.zeros(4), lateral],
        "face_2": np.c_[np.full(4, 100.0), lateral_2],
        "top": np.array([[10.0, 0.0, 4.5], [50.0, 10.0, 4.5], [90.0, -10.0, 4.5]]),
        "side": np.array([[10.0, 17.5, 0.0], [50.0, 17.5, 3.0], [90.0, 17.5, -3.0]]),
    }


def test_length_comparison_matches_the_closed_form_of_each_method() -> None:
    faces = _block_faces((-10.0, -3.0), (10.0, 3.0))  # first points: dy = 20, dz = 6
    rows = dict(length_comparison(measure_gauge_block(faces)))
    v2 = 100.0**2 + 20.0**2 + 6.0**2
    assert rows["ISO 3650 central length"] == pytest.approx(100.0, abs=1e-9)
    assert rows["face 1 centre to plane 2"] == pytest.approx(100.0, abs=1e-9)
    assert rows["exact projection (top x side)"] == pytest.approx(100.0, abs=1e-9)
    assert rows["two-point distance"] == pytest.approx(math.sqrt(v2), abs=1e-9)
    # |v| cos(theta_top) cos(theta_side) removes dz and dy one at a time (module docstring)
    assert rows["two-angle length (3-point planes)"] == pytest.approx(
        math.sqrt((v2 - 6.0**2) * (v2 - 20.0**2) / v2), abs=1e-9)
    assert list(rows) == ["ISO 3650 central length", "face 1 centre to plane 2", "face 2 centre to plane 1",
                          "exact projection (top x side)", "two-angle length (3-point planes)", "two-point distance"]


def test_gauge_block_plot_is_a_picture_and_is_never_overwritten(tmp_path: Path) -> None:
    from pcmm_geo.plots import plot_gauge_block

    faces = _block_faces((-10.0, -3.0), (10.0, 3.0))
    faces["face_1"] = faces["face_1"] + np.array([[0.0005, 0, 0], [-0.0003, 0, 0], [0.0002, 0, 0], [0.0, 0, 0]])
    measurement = measure_gauge_block(faces)
    path = plot_gauge_block(faces, measurement, tmp_path / "gb.png")
    _assert_real_picture(path, 3.0 * 4 + 1.5, 7.0)
    before = path.read_bytes()
    with pytest.raises(OutputExistsError):
        plot_gauge_block(faces, measurement, path)
    assert path.read_bytes() == before
    assert plot_gauge_block(faces, measurement, path, overwrite=True) == path
    with pytest.raises(InvalidInputError, match="plot file"):
        plot_gauge_block(faces, measurement, tmp_path / "gb.jpeg")
    # a missing folder is created; a path through a file is an OSError
    assert plot_gauge_block(faces, measurement, tmp_path / "new" / "gb.png").is_file()
    (tmp_path / "plain").write_text("x")
    with pytest.raises(OSError):
        plot_gauge_block(faces, measurement, tmp_path / "plain" / "gb.png")


def test_calibration_demo_and_log_plots(tmp_path: Path) -> None:
    from pcmm_geo.demo import run_demo
    from pcmm_geo.machine.analysis.logproc import process_log, synthesise_log
    from pcmm_geo.machine.kinematics.model import RigidBodyMachine
    from pcmm_geo.plots import plot_calibration, plot_demo_overview, plot_processed_log, plot_tip_errors

    steps: list[tuple[int, int, str]] = []
    result = run_demo(progress=lambda done, total, text: steps.append((done, total, text)))
    assert [(done, total) for done, total, _ in steps] == [(k, 5) for k in range(6)]  # 5 steps: + uncertainty
    assert steps[-1][2] == "done"
    _assert_real_picture(plot_calibration(result.tetrahedron_calibration, tmp_path / "cal.png"), 12.0, 6.5)
    _assert_real_picture(plot_tip_errors(result.tip_errors, tmp_path / "tips.png"), 7.0, 4.0)
    overview = plot_demo_overview(result.tetrahedron_calibration, result.tip_errors, tmp_path / "demo.svg")
    assert overview.read_text(encoding="utf-8").lstrip().startswith("<?xml")

    machine = RigidBodyMachine.from_dpkm()
    start = machine.reference_heights + np.array([0.0, 60.0, -50.0])
    log = synthesise_log(machine, start, [(1 + k % 3, 2.0 if k % 2 else -1.5, k % 4 == 0) for k in range(120)])
    calls: list[tuple[int, int]] = []
    processed = process_log(machine, log, initial_heights=start, progress=lambda *done_total: calls.append(done_total))
    assert calls == [(0, 240), (100, 240), (200, 240), (240, 240)]
    _assert_real_picture(plot_processed_log(processed, tmp_path / "log.png"), 12.0, 8.0)  # third panel: u, R, bound


def test_fit_residual_plot(tmp_path: Path) -> None:
    from pcmm_geo.fit import fit_plane
    from pcmm_geo.plots import plot_fit_residuals

    rng = np.random.default_rng(5)
    points = np.c_[rng.uniform(-5, 5, (40, 2)), rng.normal(0.0, 0.001, 40)]
    path = plot_fit_residuals(fit_plane(points), tmp_path / "res.png", points=points)
    _assert_real_picture(path, 8.0, 4.8)


class _Cells(HTMLParser):
    """Collects the text of every table cell and checks that every element is closed in order."""

    def __init__(self) -> None:
        super().__init__()
        self.open: list[str] = []
        self.cells: list[str] = []
        self.images: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag == "img":
            self.images.append(dict(attrs)["src"] or "")
        elif tag != "meta":
            self.open.append(tag)

    def handle_endtag(self, tag: str) -> None:
        assert self.open.pop() == tag

    def handle_data(self, data: str) -> None:
        if self.open and self.open[-1] in ("td", "th"):
            self.cells.append(data)


def _sample_report(plot: Path) -> Report:
    table = Table("Lengths <mm>", ["quantity", "value (mm)"], [["a|b <script>", 100.000123456], ["n", 7]])
    return Report({}, [table], ["first line with *stars* and laser_a"], plots=[str(plot)])


def test_markdown_and_html_reports(tmp_path: Path) -> None:
    from pcmm_geo.plots import plot_tip_errors

    (tmp_path / "plots").mkdir()
    plot = plot_tip_errors({"calibrated": [np.full((2, 3), 0.001)]}, tmp_path / "plots" / "t.png")
    report = _sample_report(plot)
    markdown = render_markdown(report, "pcmm test", command=["pcmm", "test"], base_dir=tmp_path)
    assert "| a\\|b \\<script> | 100.000123 |" in markdown.splitlines()
    assert "| n | 7 |" in markdown.splitlines()
    assert "| --- | ---: |" in markdown.splitlines()
    assert "- first line with \\*stars\\* and laser\\_a" in markdown.splitlines()
    assert "![t.png](plots/t.png)" in markdown.splitlines()

    page = render_html(report, "pcmm <test>", base_dir=tmp_path)
    parser = _Cells()
    parser.feed(page)
    parser.close()
    assert parser.open == []
    assert parser.cells == ["quantity", "value (mm)", "a|b <script>", "100.000123", "n", "7"]
    assert "<script>" not in page and "<title>pcmm &lt;test&gt;</title>" in page
    assert len(parser.images) == 1
    assert base64.b64decode(parser.images[0].split(",", 1)[1]) == plot.read_bytes()

    written = write_report(report, tmp_path / "r.md", title="t")
    with pytest.raises(OutputExistsError):
        write_report(report, written, title="t")
    with pytest.raises(InvalidInputError, match="report file"):
        write_report(report, tmp_path / "r.txt", title="t")
    assert write_report(report, written, title="t2", overwrite=True).read_text(encoding="utf-8").startswith("# t2")


def test_importing_plots_and_cli_loads_neither_matplotlib_nor_rich() -> None:
    code = (
        "import sys, pcmm_geo.plots, pcmm_geo.cli, pcmm_geo.cli._output, pcmm_geo.cli._progress;"
        "pcmm_geo.cli.build_parser();"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('matplotlib', 'rich')))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True)
    assert done.stdout.strip() == "[]"
