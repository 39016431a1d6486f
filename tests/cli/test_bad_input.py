"""Bad-input corpus against every file-reading ``pcmm`` command.

Each damaged file (empty, header only, binary, non-UTF-8, decimal-comma misuse, wrong column
count, NaN/inf, a directory, a missing file) must give exit code 2, exactly one line on stderr
that names the file, no traceback, and no output file.  The commands run in-process through
``pcmm_geo.cli.main`` to keep the corpus fast.
"""

from __future__ import annotations

from collections.abc import Callable
from importlib.resources import files
from pathlib import Path

import pytest

from pcmm_geo.cli import main

DATA = Path(str(files("pcmm_geo"))) / "data"
EXPORT = DATA / "appendix_cd" / "cmm_export.csv"
LASERS = DATA / "appendix_cd" / "lasers.csv"
STL = DATA / "examples" / "gauge_block_nominal.stl"

# name -> (argv for a bad FILE, header of the file type, one valid row, suffix of the file)
Argv = Callable[[str, Path], list[str]]
COMMANDS: dict[str, tuple[Argv, str, str, str]] = {
    "fit": (lambda f, tmp: ["fit", "sphere", f], "x,y,z", "1,2,3", ".csv"),
    "form": (lambda f, tmp: ["form", f, "--element", "plane", "--tolerance", "0.01"], "x,y,z", "1,2,3", ".csv"),
    "calibrate probings": (lambda f, tmp: ["calibrate", f, str(LASERS)], "x,y,z,d,r", "1,2,3,nan,nan", ".csv"),
    "calibrate lasers": (lambda f, tmp: ["calibrate", str(EXPORT), f], "position,laser_a,laser_b,laser_c",
                         "1,50,60,70", ".csv"),
    "calibrate sweep": (lambda f, tmp: ["calibrate", str(EXPORT), str(LASERS), "--sweep", f],
                        "position,laser_a,laser_b,laser_c", "1,50,60,70", ".csv"),
    "kinematics": (lambda f, tmp: ["kinematics", "forward", "--lasers", "50", "60", "70", "--calibration", f],
                   '{"schema": "pcmm_geo.calibration", "version": 1', "}", ".json"),
    "process-log": (lambda f, tmp: ["process-log", f], "start_stop,probe,motor,direction,laser_a,laser_b,laser_c",
                    "1,0,1,1,50,51,52", ".csv"),
    "process-log calibration": (lambda f, tmp: ["process-log", str(_valid_log(tmp)), "--calibration", f],
                                '{"schema": "pcmm_geo.calibration", "version": 1', "}", ".json"),
    "numcal": (lambda f, tmp: ["numcal", f], "moved,laser_a,laser_b,laser_c,height", "a,50,60,70,100", ".csv"),
    "sensitivity": (lambda f, tmp: ["sensitivity", "--calibration", f, "--points-per-axis", "2"],
                    '{"schema": "pcmm_geo.calibration", "version": 1', "}", ".json"),
    "gauge-block": (lambda f, tmp: ["gauge-block", f], "face,x,y,z", "face_1,1,2,3", ".csv"),
    "iso10360-2": (lambda f, tmp: ["iso10360-2", f, "--mpe-a", "2", "--mpe-k", "100"],
                   "length_id,position,repetition,calibrated_length,measured_length", "L1,x,1,10,10.0001", ".csv"),
    "iso10360-5": (lambda f, tmp: ["iso10360-5", f, "--reference-diameter", "25"], "x,y,z", "1,2,3", ".csv"),
    "iso10360-6 reference": (lambda f, tmp: ["iso10360-6", f],
                             "name,element,x,y,z,i,j,k,size,size2,half_angle", "s1,sphere,0,0,0,,,,5,,", ".csv"),
    "iso10360-6 results": (lambda f, tmp: ["iso10360-6", str(DATA / "examples" / "iso10360_6_reference.csv"), f],
                           "name,element,x,y,z,i,j,k,size,size2,half_angle", "s1,sphere,0,0,0,,,,5,,", ".csv"),
    "micrometer": (lambda f, tmp: ["micrometer", f], "point,stage_x,stage_y,stage_z,x,y,z", "p1,0,0,0,1,2,3",
                   ".csv"),
    "thermal thermistor": (lambda f, tmp: ["thermal", "thermistor", "--calibration", f, "--resistance", "10000"],
                           "temperature,resistance", "20,12000", ".csv"),
    "compare points": (lambda f, tmp: ["compare", f, str(STL)], "x,y,z", "1,2,3", ".csv"),
    "compare mesh": (lambda f, tmp: ["compare", str(DATA / "examples" / "gauge_block_scan.csv"), f],
                     "solid block", "endsolid block", ".stl"),
    "compare transform": (lambda f, tmp: ["compare", str(DATA / "examples" / "gauge_block_scan.csv"), str(STL),
                                          "--init-transform", f], "1 0 0 0", "0 1 0 0", ".txt"),
    "segment": (lambda f, tmp: ["segment", f], "x,y,z", "1,2,3", ".csv"),
    "convert": (lambda f, tmp: ["convert", f, str(tmp / "out" / "converted.ply")], "x,y,z", "1,2,3", ".csv"),
}


def _valid_log(tmp: Path) -> Path:
    path = tmp / "valid_log.csv"
    if not path.exists():
        rows = ["start_stop,probe,motor,direction,laser_a,laser_b,laser_c"]
        rows += [f"{1 - k % 2},0,{1 + (k // 2) % 3},1,{50 + k * 0.01},{60 + k * 0.01},{70 + k * 0.01}"
                 for k in range(12)]
        path.write_text("\n".join(rows) + "\n")
    return path


def _corpus(header: str, row: str) -> dict[str, bytes | None]:
    """Damaged contents by name (None: a directory or a missing file)."""
    width = header.count(",") + 1
    semicolon_header = header.replace(",", ";")
    comma_row = ";".join(["12,5"] * width)
    return {
        "empty": b"",
        "header-only": (header + "\n").encode(),
        "binary": bytes(range(256)) * 4,
        "non-utf8": (header + "\n").encode() + "1,2,3,é,ü\n".encode("latin-1"),
        "decimal-comma": f"{semicolon_header}\n{comma_row}\n{';'.join(['12.5'] * width)}\n12,5,3\n".encode(),
        "wrong-columns": f"{header}\n{row}\n{row},1,2\n".encode(),
        "nan-inf": f"{header}\n{row}\n{_non_finite(row)}\n".encode(),
        "directory": None,
        "missing": None,
    }


def _non_finite(row: str) -> str:
    """``row`` with its last numeric field NaN and the one before it inf."""
    fields = row.split(",")
    numeric = [k for k, f in enumerate(fields) if f.replace(".", "", 1).replace("-", "", 1).isdigit()]
    for k, value in zip(reversed(numeric), ("nan", "inf"), strict=False):
        fields[k] = value
    return ",".join(fields)


CASES = [(command, case) for command in COMMANDS for case in _corpus("a,b", "1,2")]


@pytest.mark.parametrize(("command", "case"), CASES, ids=[f"{c}-{k}" for c, k in CASES])
def test_bad_file_gives_one_line_naming_it_and_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                      command: str, case: str) -> None:
    build, header, row, suffix = COMMANDS[command]
    content = _corpus(header, row)[case]
    bad = tmp_path / f"bad_{case}{suffix}"
    if case == "directory":
        bad.mkdir()
    elif case != "missing":
        bad.write_bytes(content or b"")
    (tmp_path / "out").mkdir()
    code = main(build(str(bad), tmp_path))
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert code == 2, f"exit {code}; stderr: {captured.err}"
    assert "Traceback" not in captured.err
    assert len(lines) == 1, captured.err
    assert str(bad) in lines[0] or bad.name in lines[0], lines[0]
    assert list((tmp_path / "out").iterdir()) == []  # nothing written, nothing half-written


@pytest.mark.parametrize("case", ["binary", "nan-inf", "wrong-columns"])
def test_failed_run_leaves_an_existing_output_untouched(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                        case: str) -> None:
    bad = tmp_path / f"bad{case}.csv"
    bad.write_bytes(_corpus("x,y,z", "1,2,3")[case] or b"")
    kept = {tmp_path / "out.ply": b"precious ply", tmp_path / "cal.json": b"{\"precious\": 1}\n"}
    for path, content in kept.items():
        path.write_bytes(content)
    assert main(["convert", str(bad), str(tmp_path / "out.ply"), "--overwrite"]) == 2
    probings = tmp_path / "probings.csv"
    probings.write_bytes(_corpus("x,y,z,d,r", "1,2,3,nan,nan")[case] or b"")
    assert main(["calibrate", str(probings), str(LASERS), "--out", str(tmp_path / "cal.json"), "--overwrite"]) == 2
    capsys.readouterr()
    for path, content in kept.items():
        assert path.read_bytes() == content
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []  # no temporary files left


ACQLOG_HEADER = ("# pcmm_geo acquisition log\n# schema: pcmm_geo.acqlog/1\nstart_stop,probe,motor,direction,laser_a,"
                 "laser_b,laser_c,seq,t_utc,pos_a_usteps,pos_b_usteps,pos_c_usteps,laser_a_raw,laser_b_raw,laser_c_raw")
ACQLOG_ROW = "1,0,1,1,50,60,70,0,2026-01-01T00:00:00.000Z,1,2,3,4,5,6"


@pytest.mark.parametrize("case", ["empty", "binary", "non-utf8", "decimal-comma", "wrong-columns", "nan-inf",
                                  "directory"])
def test_acquire_resume_refuses_a_damaged_log_untouched(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                         case: str) -> None:
    bad = tmp_path / f"bad_{case}.csv"
    content = _corpus(ACQLOG_HEADER, ACQLOG_ROW)[case]
    if case == "directory":
        bad.mkdir()
    else:
        bad.write_bytes(content or b"")
    code = main(["acquire", "--simulate", "--settle", "0", "--moves", "1", "--resume", "--out", str(bad)])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and bad.name in lines[0], lines
    if case != "directory":
        assert bad.read_bytes() == (content or b"")  # nothing appended, nothing cut


def test_decimal_comma_files_are_read_not_misread(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import json

    import numpy as np

    from pcmm_geo.artefacts import sphere_probing_pattern

    points = sphere_probing_pattern((12.5, 3.25, 7.75), 5.0)
    semicolons = tmp_path / "european.csv"
    semicolons.write_text("x;y;z\n" + "".join(";".join(f"{v:.12f}".replace(".", ",") for v in p) + "\n"
                                                for p in points))
    spaces = tmp_path / "european.txt"
    spaces.write_text("".join(" ".join(f"{v:.12f}".replace(".", ",") for v in p) + "\n" for p in points))
    for path, extra in ((semicolons, []), (spaces, []), (semicolons, ["--decimal", ","])):
        assert main(["fit", "sphere", str(path), "--json", *extra]) == 0
        fitted = json.loads(capsys.readouterr().out)
        np.testing.assert_allclose(fitted["center"], [12.5, 3.25, 7.75], rtol=0, atol=1e-9)
        assert fitted["radius"] == pytest.approx(5.0, abs=1e-9)
    # told the decimal mark is '.', the same file is refused, never read as other numbers
    assert main(["fit", "sphere", str(semicolons), "--decimal", "."]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{semicolons}:2: decimal comma in" in err[0]
    assert main(["iso10360-5", str(semicolons), "--reference-diameter", "10", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["p_stu_um"] == pytest.approx(0.0, abs=1e-6)


@pytest.mark.parametrize("command", ["kinematics", "process-log calibration", "sensitivity"])
def test_json_with_non_finite_numbers_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                 command: str) -> None:
    bad = tmp_path / "nan.json"
    bad.write_text('{"schema": "pcmm_geo.machine.calibration/1",\n "kind": "tetrahedron",\n "scale": NaN}\n')
    (tmp_path / "out").mkdir()
    assert main(COMMANDS[command][0](str(bad), tmp_path)) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and f"{bad}:3: expected JSON, got the non-finite number NaN" in lines[0]
