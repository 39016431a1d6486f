"""Every command's outputs as one set: checked before any work, per-output overwrite, all-or-nothing.

In-process runs of :func:`pcmm_geo.cli.main`; ``pcmm fit`` (``--plot``, ``--report``) and
``pcmm calibrate`` (``--out``, ``--plot``, ``--report``) stand for every command built on
:func:`pcmm_geo.cli._output.add_overwrite_flag`.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pcmm_geo.cli import _run, main
from pcmm_geo.machine.calibration.seed import appendix_cd_files

EXAMPLES = Path(__file__).parents[2] / "pcmm_geo" / "data" / "examples"
SPHERE = str(EXAMPLES / "iso10360_5_sphere.csv")


def _tree(folder: Path) -> dict[str, bytes | None]:
    return {str(p.relative_to(folder)): (p.read_bytes() if p.is_file() else None) for p in sorted(folder.rglob("*"))}


def test_per_output_overwrite(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    plot, report = tmp_path / "fit.png", tmp_path / "fit.md"
    assert main(["fit", "sphere", SPHERE, "--plot", str(plot), "--report", str(report)]) == 0
    first_plot, first_report = plot.read_bytes(), report.read_bytes()
    capsys.readouterr()
    # only the plot may be replaced: the existing report refuses the whole command, nothing changes
    assert main(["fit", "sphere", SPHERE, "--plot", str(plot), "--report", str(report), "--overwrite-plot"]) == 2
    assert "use --overwrite-report to replace it" in capsys.readouterr().err
    assert plot.read_bytes() == first_plot and report.read_bytes() == first_report
    # a new report next to a replaced plot
    report.unlink()
    assert main(["fit", "sphere", SPHERE, "--plot", str(plot), "--report", str(report), "--overwrite-plot"]) == 0
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and report.read_text().startswith("# pcmm fit")
    assert main(["fit", "sphere", SPHERE, "--plot", str(plot), "--report", str(report), "--overwrite-plot",
                 "--overwrite-report"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fit.md", "fit.png"]  # no backup or temporary left


def test_a_later_output_that_cannot_be_written_leaves_no_earlier_output(tmp_path: Path,
                                                                        capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "blocker").write_bytes(b"a file, not a folder\n")
    (tmp_path / "old.png").write_bytes(b"an earlier plot\n")
    before = _tree(tmp_path)
    probings, lasers = appendix_cd_files()
    runs = [
        ["fit", "sphere", SPHERE, "--plot", str(tmp_path / "new" / "fit.png"),
         "--report", str(tmp_path / "blocker" / "fit.md")],
        ["fit", "sphere", SPHERE, "--plot", str(tmp_path / "old.png"), "--overwrite",
         "--report", str(tmp_path / "blocker" / "deeper" / "fit.md")],
        ["calibrate", str(probings), str(lasers), "--out", str(tmp_path / "cal.json"),
         "--plot", str(tmp_path / "old.png"), "--overwrite-plot", "--report", str(tmp_path / "blocker" / "c.md")],
        ["calibrate", str(probings), str(lasers), "--out", str(tmp_path / "old.png"), "--overwrite",
         "--plot", str(tmp_path / "old.png")],
    ]
    for argv in runs:
        assert main(argv) == 2, argv
        error = capsys.readouterr().err.strip()
        assert len(error.splitlines()) == 1 and ("--report" in error or "same file as --out" in error), error
        assert _tree(tmp_path) == before, argv  # nothing created, nothing changed, byte for byte


def test_a_failure_while_writing_rolls_every_output_back(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    probings, lasers = appendix_cd_files()
    (tmp_path / "cal.json").write_bytes(b'{"an": "earlier calibration"}\n')
    before = _tree(tmp_path)

    def disk_full(*args: object, **kwargs: object) -> Path:
        raise OSError(28, "No space left on device", str(tmp_path / "out" / "cal.md"))

    monkeypatch.setattr(_run, "write_report", disk_full)  # the report is written last, after --out and --plot
    code = main(["calibrate", str(probings), str(lasers), "--out", str(tmp_path / "cal.json"), "--overwrite-out",
                 "--plot", str(tmp_path / "out" / "cal.png"), "--report", str(tmp_path / "out" / "cal.md")])
    assert code == 2
    error = capsys.readouterr().err.strip()
    assert error == f"pcmm calibrate: error: {tmp_path / 'out' / 'cal.md'}: No space left on device"
    assert _tree(tmp_path) == before  # cal.json restored byte for byte, the plot and its new folder removed

    monkeypatch.undo()
    assert main(["calibrate", str(probings), str(lasers), "--out", str(tmp_path / "cal.json"), "--overwrite-out",
                 "--plot", str(tmp_path / "out" / "cal.png"), "--report", str(tmp_path / "out" / "cal.md")]) == 0
    assert b"earlier calibration" not in (tmp_path / "cal.json").read_bytes()
    assert sorted(_tree(tmp_path)) == ["cal.json", "out", "out/cal.md", "out/cal.png"]


def test_demo_output_folder_is_checked_before_the_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "blocker").write_bytes(b"a file, not a folder\n")
    before = _tree(tmp_path)
    assert main(["demo", "--out", str(tmp_path / "blocker" / "demo"), "--plot", str(tmp_path / "demo.png")]) == 2
    error = capsys.readouterr().err.strip()
    assert error == (f"pcmm demo: error: --out {tmp_path / 'blocker' / 'demo'}: expected a path of folders, "
                     f"got '{tmp_path / 'blocker'}', which is a file, not a folder")
    assert _tree(tmp_path) == before
