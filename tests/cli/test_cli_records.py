"""Reports as lab records, ``--plot``/``--report`` on every command with a result, and unit conventions.

The commands run in process through :func:`pcmm_geo.cli.main` (the same code path as the
installed ``pcmm``), with stdout captured.
"""

from __future__ import annotations

import base64
import hashlib
import platform
import re
import shlex
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.cli import main
from pcmm_geo.machine.calibration.numerical.numcal_data import (
    NumcalParameters,
    synthesise_design_data,
    write_numcal_csv,
)

EXAMPLES = Path(__file__).parents[2] / "pcmm_geo" / "data" / "examples"
NIST_SPHERE = Path(__file__).parents[1] / "data" / "nist" / "Sphere" / "sph20.ds"
APPENDIX = (EXAMPLES.parent / "appendix_cd" / "cmm_export.csv", EXAMPLES.parent / "appendix_cd" / "lasers.csv")


@pytest.fixture(scope="module")
def numcal_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    # a design that determines all nine parameters (pivots moved together over 200 mm, all pairs)
    design = np.random.default_rng(3).uniform(0.0, 200.0, (24, 3))
    data = synthesise_design_data(NumcalParameters.from_seed_table(), design, laser_sigma=1e-3, seed=3)
    return write_numcal_csv(data, tmp_path_factory.mktemp("numcal") / "numcal.csv")


def command_lines(numcal: Path) -> dict[str, list[str]]:
    """Every command with a verdict or a result worth keeping, with a typical input."""
    return {
        "iso10360-2": ["iso10360-2", str(EXAMPLES / "iso10360_2_lengths.csv"), "--mpe-a-um", "3", "--mpe-k", "250"],
        "iso10360-5": ["iso10360-5", str(EXAMPLES / "iso10360_5_sphere.csv"), "--reference-diameter-mm", "25.0004",
                       "--mpe-form-um", "3", "--mpe-size-um", "3"],
        "iso10360-6": ["iso10360-6", str(EXAMPLES / "iso10360_6_reference.csv"),
                       str(EXAMPLES / "iso10360_6_results.json")],
        "micrometer": ["micrometer", str(EXAMPLES / "micrometer_stage.csv")],
        "numcal": ["numcal", str(numcal), "--search", "multistart", "--pairs", "all"],
        "kinematics-forward": ["kinematics", "forward", "--heights-mm", "410", "395", "420"],
        "kinematics-inverse": ["kinematics", "inverse", "--tip-mm", "0", "0", "80"],
        "kinematics-trilaterate": ["kinematics", "trilaterate", "--pivots-mm", "0", "0", "0", "100", "0", "0",
                                   "0", "100",
                                   "0", "--lengths-mm", "90", "90", "90"],
        "thermal-rtd": ["thermal", "rtd", "--resistance", "107.79"],
        "thermal-thermistor": ["thermal", "thermistor", "--calibration", str(EXAMPLES / "thermistor_calibration.csv"),
                               "--resistance", "10000"],
        "thermal-correct-length": ["thermal", "correct-length", "--length-mm", "100.0021", "--temperature", "21.3",
                                   "--alpha", "11.5e-6", "--u-temperature", "0.05", "--u-alpha", "1e-6"],
        "thermal-triangle": ["thermal", "triangle", "--temperatures", "21", "20.5", "20"],
        "thermal-table": ["thermal", "table", "--points-per-axis", "2"],
        "repeatability": ["repeatability", "--readings", str(EXAMPLES / "start_readings_table_6_7.csv")],
        "laser-ratio": ["laser-ratio", "--ratios", str(EXAMPLES / "laser_ratio_table_6_8.csv")],
        "fit": ["fit", "sphere", str(NIST_SPHERE)],
        "form": ["form", str(EXAMPLES / "roundness_ring.csv"), "--element", "circle", "--two-d",
                 "--tolerance-mm", "0.010"],
        "fit-circle": ["fit", "circle", str(EXAMPLES / "roundness_ring.csv"), "--two-d"],
        "gauge-block": ["gauge-block", str(EXAMPLES / "gauge_block.csv"), "--nominal-mm", "100",
                        "--tolerance-um", "0.3", "--uncertainty-um", "0.1"],
        "uncertainty": ["uncertainty", "distance", "--trials", "2000", "--length-mm", "50"],
        "calibrate": ["calibrate", str(APPENDIX[0]), str(APPENDIX[1])],
    }


def assert_real_picture(path: Path) -> None:
    import matplotlib.image

    image = matplotlib.image.imread(path)
    rgb = image[..., :3].reshape(-1, 3)
    assert image.shape[0] > 300 and image.shape[1] > 500
    assert float(np.std(rgb)) > 0.05  # not blank
    assert len(np.unique(np.round(rgb, 2), axis=0)) > 20  # lines, markers, colour maps


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


@pytest.mark.parametrize("name", list(command_lines(Path("numcal.csv"))))
def test_every_command_writes_a_plot_and_a_report(
    name: str, numcal_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from matplotlib.figure import Figure

    from pcmm_geo.plots._figure import data_under_legends

    saved: list[Figure] = []
    original = Figure.savefig
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: (original(self, *a, **k), saved.append(self))[0])
    suffix = ".html" if sum(map(ord, name)) % 2 else ".md"  # both formats over the set
    plot, report = tmp_path / f"{name}.png", tmp_path / f"{name}{suffix}"
    argv = [*command_lines(numcal_file)[name], "--plot", str(plot), "--report", str(report)]
    code, out, err = run(argv, capsys)
    assert code in (0, 1), err  # 1: the verdict is "fail" (the example software results fail on purpose)
    assert_real_picture(plot)
    assert len(saved) == 1 and data_under_legends(saved[0]) == []  # no legend covers data
    text = report.read_text(encoding="utf-8")
    assert "Record" in text and "Software" in text
    if suffix == ".md":
        assert text.count(f"]({plot.name})") == 1
    else:
        encoded = base64.b64encode(plot.read_bytes()).decode("ascii")
        assert text.count("data:image/png;base64,") == 1 and encoded in text
    assert f"report written to {report}" in out
    # a second run refuses to replace either file
    assert run(argv, capsys)[0] == 2


def test_report_is_a_lab_record(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import matplotlib
    import numpy
    import scipy

    import pcmm_geo

    plot, report = tmp_path / "fit.png", tmp_path / "fit.md"
    argv = ["fit", "sphere", str(NIST_SPHERE), "--plot", str(plot), "--report", str(report)]
    before = datetime.now(UTC).replace(microsecond=0)
    assert run(argv, capsys)[0] == 0
    after = datetime.now(UTC)
    lines = report.read_text(encoding="utf-8").splitlines()

    def cells(first: str, start: int = 0) -> list[str]:
        row = next(line for line in lines[start:] if line.startswith(f"| {first} |"))
        return [cell.strip() for cell in row.strip("|").split(" | ")]

    stamp = datetime.fromisoformat(cells("run started (UTC)")[1])
    assert stamp.utcoffset() == timedelta(0) and before <= stamp <= after
    assert cells("command line")[1] == shlex.join(["pcmm", *argv]).replace("_", "\\_")
    digest = hashlib.sha256(NIST_SPHERE.read_bytes()).hexdigest()
    row = cells(str(NIST_SPHERE.resolve()).replace("_", "\\_"))
    assert row[1] == digest and int(row[2]) == NIST_SPHERE.stat().st_size
    versions = {name.replace("\\_", "_"): cells(name)[1] for name in ("python", "pcmm\\_geo version", "numpy",
                                                                      "scipy", "matplotlib")}
    assert versions == {"python": platform.python_version(), "pcmm_geo version": pcmm_geo.__version__,
                        "numpy": numpy.__version__, "scipy": scipy.__version__, "matplotlib": matplotlib.__version__}
    # optional libraries are listed when the run imported them (in this test process: whatever ran before)
    import sys

    assert any(line.startswith("| open3d |") for line in lines) == ("open3d" in sys.modules)
    assert sum(line == f"![fit.png]({plot.name})" for line in lines) == 1
    # the fit's uncertainties: correlation matrix of the parameters, unit diagonal
    header = lines.index("## sphere fit parameters: correlation coefficients")
    names = ("center\\_x", "center\\_y", "center\\_z", "radius")
    matrix = np.array([[float(v) for v in cells(name, header)[1:]] for name in names])
    np.testing.assert_allclose(np.diag(matrix), 1.0, atol=1e-3)
    np.testing.assert_allclose(matrix, matrix.T, atol=1e-3)
    assert np.all(np.abs(matrix) <= 1.0 + 1e-3)


def test_each_figure_once_and_folder_inputs_hashed(tmp_path: Path) -> None:
    from pcmm_geo.cli._output import Report
    from pcmm_geo.cli._record import describe_input, input_paths, start_provenance
    from pcmm_geo.cli._report import render_html, render_markdown
    from pcmm_geo.plots._figure import new_figure, save_figure

    figure = new_figure(2, 2)
    figure.add_subplot().plot([0, 1], [0, 1])
    plot = save_figure(figure, tmp_path / "a.png")
    same = str(tmp_path / "." / "a.png")
    report = Report({}, plots=[str(plot), same, str(plot)])
    assert render_markdown(report, "t", base_dir=tmp_path).count("](a.png)") == 1
    assert render_html(report, "t", base_dir=tmp_path).count("<img ") == 1

    folder = tmp_path / "refs"
    (folder / "sub").mkdir(parents=True)
    (folder / "b.txt").write_bytes(b"beta")
    (folder / "sub" / "a.txt").write_bytes(b"alpha")
    lines = [f"b.txt\0{hashlib.sha256(b'beta').hexdigest()}\n", f"sub/a.txt\0{hashlib.sha256(b'alpha').hexdigest()}\n"]
    described = describe_input(folder)
    assert described.sha256 == hashlib.sha256("".join(lines).encode()).hexdigest()
    assert (described.files, described.size) == (2, 9)

    import argparse

    args = argparse.Namespace(file=str(folder / "b.txt"), plot=str(plot), report=None, calibration=None,
                              handler=print, values=[str(folder), "7"])
    assert input_paths(args) == [str(folder / "b.txt"), str(folder)]  # the existing plot is an output
    record = start_provenance(["pcmm", "x"], input_paths(args))
    assert [Path(f.path) for f in record.inputs] == [(folder / "b.txt").resolve(), folder.resolve()]


def test_iso10360_6_markdown_is_a_deprecated_alias(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["iso10360-6", str(EXAMPLES / "iso10360_6_reference.csv"), str(EXAMPLES / "iso10360_6_results.json")]
    code, out, err = run([*argv, "--markdown"], capsys)
    assert code in (0, 1) and out.startswith("# ISO 10360-6 software test")
    assert "--markdown is deprecated" in err and "--report FILE.md" in err


# ---------------------------------------------------------------- units written one way

_BAD_UNIT = re.compile(r"\((?:mm|µm|um|nm|rad|deg|mdeg|K|1/K|mm/mm|ohm|ppm)\)|\[[^\]]*\]|\bum\b|degC|\bmicrons?\b")


def printed_headers(text: str) -> list[str]:
    """Header cells of every table printed by :func:`pcmm_geo.cli._output.render_table`."""
    lines = text.splitlines()
    headers = []
    for k, line in enumerate(lines[1:], start=1):
        if line and set(line) <= {"-", " "} and "--" in line:
            headers += [cell for cell in re.split(r"\s{2,}", lines[k - 1].strip()) if cell]
    return headers


def test_text_output_writes_units_one_way(numcal_file: Path, capsys: pytest.CaptureFixture[str]) -> None:
    extra = {
        "calibrate": ["calibrate", *(str(p) for p in __import__(
            "pcmm_geo.machine.calibration.seed", fromlist=["x"]).appendix_cd_files())],
        "gauge-block": ["gauge-block", str(EXAMPLES / "gauge_block.csv")],
        "sensitivity": ["sensitivity", "--points-per-axis", "2"],
        "failing iso10360-2": ["iso10360-2", str(EXAMPLES / "iso10360_2_lengths.csv"), "--mpe-a-um", "0.5", "--mpe-k",
                               "1000"],
    }
    seen = 0
    for name, argv in {**command_lines(numcal_file), **extra}.items():
        code, out, err = run(argv, capsys)
        assert code in (0, 1), (name, err)
        headers = printed_headers(out)
        for cell in headers:
            assert not _BAD_UNIT.search(cell), (name, cell)
            if " / " in cell:  # "quantity / unit": a unit follows, nothing after it
                assert cell.split(" / ")[-1].strip(), (name, cell)
        assert not re.search(r"(?<![-\w])um\b|degC", out), (name, out)  # "--uncertainty-um" is an option
        seen += len(headers)
    assert seen > 60


def test_unit_helper_picks_readable_units() -> None:
    from pcmm_geo.plots._figure import length_unit

    assert length_unit([0.0]) == (1000.0, "µm")
    assert length_unit([]) == (1000.0, "µm")
    assert length_unit([np.nan, 0.0004, -0.0007]) == (1e6, "nm")
    assert length_unit([0.001]) == (1000.0, "µm")
    assert length_unit([-0.999]) == (1000.0, "µm")
    assert length_unit([1.0, np.inf]) == (1.0, "mm")
    # the shown numbers keep at most three digits before the decimal point
    for value in (3e-6, 4.2e-5, 0.0123, 0.5, 2.0, 75.0):
        factor, _ = length_unit([value])
        assert 1.0 <= factor * value < 1000.0
