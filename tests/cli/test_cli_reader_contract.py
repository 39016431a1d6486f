"""The reader contract on the command line (issue 31): refusals are one line and exit 2, never a hang."""

from __future__ import annotations

import http.server
import json
import os
import subprocess
import threading
from pathlib import Path

import pytest
from pcmm_runner import run_pcmm

DATA = Path(__file__).parents[1] / "data"
SAMPLES = DATA / "qif" / "samples"
PTS_SAMPLE = SAMPLES / "QIF_PTS_SAMPLE.QIF"
EXPLODED = SAMPLES / "Exploded_Results1.QIF"  # a public sample without FileUnits


def _refused(done: subprocess.CompletedProcess[str], command: str, *texts: str) -> str:
    assert done.returncode == 2, done.stdout + done.stderr
    assert done.stdout == "" and done.stderr.count("\n") == 1, done.stderr
    assert done.stderr.startswith(f"pcmm {command}: error: "), done.stderr
    assert "Traceback" not in done.stderr
    for text in texts:
        assert text in done.stderr, done.stderr
    return done.stderr


@pytest.mark.parametrize("radius", ["-1", "nan", "0", "inf"])
def test_qif_verify_refuses_a_probe_radius_that_is_not_positive(radius: str) -> None:
    _refused(run_pcmm("qif", "verify", PTS_SAMPLE, "--probe-radius-mm", radius), "qif verify",
             "--probe-radius-mm: expected a positive probe radius")


def test_qif_without_file_units_says_so_and_takes_units() -> None:
    done = run_pcmm("qif", "show", EXPLODED)
    assert done.returncode == 0, done.stderr
    assert "units not stated in the file, read as mm" in done.stdout and "file units mm" not in done.stdout
    assert "the QIF 3.0 schema states no default" in done.stdout
    assumed = json.loads(run_pcmm("qif", "show", EXPLODED, "--json").stdout)
    inch = json.loads(run_pcmm("qif", "show", EXPLODED, "--units", "inch", "--json").stdout)
    assert assumed["units"]["stated"] is False and inch["units"]["linear_unit"] == "inch"
    for mm, inches in zip(assumed["characteristics"], inch["characteristics"], strict=True):
        assert inches["value"] == pytest.approx(25.4 * mm["value"], rel=1e-15)
    _refused(run_pcmm("qif", "show", PTS_SAMPLE, "--units", "inch"), "qif show",
             "the file states its units (FileUnits/PrimaryUnits); --units is for a file without them")


def test_qif_verify_takes_a_material_side() -> None:
    done = run_pcmm("qif", "verify", PTS_SAMPLE, "--material-side", "internal", "--json")
    assert done.returncode in (0, 1), done.stderr
    assert json.loads(done.stdout)["features"]
    assert "--material-side" in run_pcmm("qif", "verify", "--help").stdout


# ---------------------------------------------------------------------------------------------
# non-regular files, URLs, unknown encodings: one line and exit 2 at once, nothing fetched

CMM = DATA / "cmm"


@pytest.mark.parametrize("name", ["pipe.qif", "pipe.dmo", "pipe_chr.txt", "pipe.xyz", "pipe.xml", "pipe.txt"])
@pytest.mark.parametrize("command", [("qif", "show"), ("qif", "verify"), ("fit", "circle")])
def test_a_fifo_is_refused_at_once(tmp_path: Path, name: str, command: tuple[str, ...]) -> None:
    """Nothing writes to the FIFO: reading it would block forever; it is refused before it is opened."""
    fifo = tmp_path / name
    os.mkfifo(fifo)
    extra = ("--compensated", "yes") if command[0] == "fit" else ()
    done = run_pcmm(*command, fifo, *extra)
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    assert "FIFO" in done.stderr and done.stderr.count("\n") == 1, done.stderr


def test_qif_validate_never_treats_a_path_as_a_url(tmp_path: Path) -> None:
    """A directory named like a URL: refused as a directory; neither xml.sax nor libxml2 sees the path."""
    requests: list[str] = []

    class Recorder(http.server.BaseHTTPRequestHandler):
        def do_GET(self) -> None:
            requests.append(self.path)
            self.send_response(404)
            self.end_headers()

        def log_message(self, format: str, *args: object) -> None:
            pass

    server = http.server.HTTPServer(("127.0.0.1", 0), Recorder)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        folder = tmp_path / "http:" / f"127.0.0.1:{server.server_address[1]}" / "x.qif"
        folder.mkdir(parents=True)
        relative = os.path.relpath(folder, tmp_path)  # http:/127.0.0.1:PORT/x.qif
        for action in ("validate", "show"):
            done = run_pcmm("qif", action, relative, cwd=tmp_path)
            assert done.returncode == 2 and "is a directory" in done.stderr, done.stderr
    finally:
        server.shutdown()
        server.server_close()
        thread.join(timeout=5)
    assert requests == []


@pytest.mark.parametrize("command", [("qif", "show"), ("qif", "verify"), ("qif", "validate"), ("fit", "circle")])
def test_an_unknown_xml_encoding_is_a_file_format_error(tmp_path: Path, command: tuple[str, ...]) -> None:
    path = tmp_path / "encoding.qif"
    path.write_text('<?xml version="1.0" encoding="x-nonexistent"?>\n<QIFDocument '
                    'xmlns="http://qifstandards.org/xsd/qif3" versionQIF="3.0.0"/>\n')
    done = run_pcmm(*command, path)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert "names an encoding Python does not know" in done.stderr and done.stderr.count("\n") == 1


# ---------------------------------------------------------------------------------------------
# size limits and formats told by content


def test_max_mb_applies_to_dmis_and_calypso_in_qif_show(tmp_path: Path) -> None:
    for source in (CMM / "standard.dmo", CMM / "flange_chr.txt"):
        size = source.stat().st_size
        limit = f"{(size - 100) / (1 << 20):.6f}"
        extra = ("--units", "mm", "--angle-unit", "degree") if source.suffix == ".txt" else ()
        _refused(run_pcmm("qif", "show", source, "--max-mb", limit, *extra), "qif show",
                 f"file of {size} bytes exceeds the limit", "raise --max-mb")
        assert run_pcmm("qif", "show", source, "--max-mb", "1", *extra).returncode == 0


def test_formats_are_told_by_content_and_can_be_stated(tmp_path: Path) -> None:
    report = tmp_path / "GEOPAK_REPORT.IGS"
    report.write_bytes((CMM / "geopak_style.dmo").read_bytes())
    done = run_pcmm("qif", "show", report, "--units", "inch", "--angle-unit", "degree", "--json")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["format"] == "dmis"
    utf16 = tmp_path / "export.xml"
    text = PTS_SAMPLE.read_text(encoding="utf-8").replace('encoding="UTF-8"', 'encoding="UTF-16"')
    assert text.startswith('<?xml version="1.0" encoding="UTF-16"')
    utf16.write_bytes(text.encode("utf-16"))
    shown = json.loads(run_pcmm("qif", "show", utf16, "--json").stdout)
    assert shown["format"] == "qif" and len(shown["features"]) == 14
    # a file whose start says nothing: --format states it
    silent = tmp_path / "report.txt"
    silent.write_text("$$ report\n" * 500 + (CMM / "standard.dmo").read_text())
    assert json.loads(run_pcmm("qif", "show", silent, "--format", "dmis", "--json").stdout)["format"] == "dmis"
    _refused(run_pcmm("qif", "show", silent), "qif show", "not a CMM results file")


def test_convert_reads_a_pcdmis_xyzijk_file(tmp_path: Path) -> None:
    out = tmp_path / "ring.csv"
    done = run_pcmm("convert", CMM / "ring_xyzijk_metric.xyz", out)
    assert done.returncode == 0, done.stderr
    rows = [line.split(",") for line in out.read_text().split()[1:]]
    assert len(rows) == 5 and [float(v) for v in rows[0]] == [10.0, 0.0, 5.0]


def test_multi_sample_files_name_each_sample_and_status_only_files_are_read() -> None:
    sheet = json.loads(run_pcmm("qif", "show", SAMPLES / "SheetMetal_QIF_Results_6_samples.QIF", "--json").stdout)
    serials = [f"SN580280{k}" for k in range(1, 7)]
    assert [r["serial_numbers"] for r in sheet["results"]] == [[s] for s in serials]
    assert [r["inspection_status"] for r in sheet["results"]] == ["PASS", "FAIL", "FAIL", "PASS", "PASS", "FAIL"]
    named = [(f["name"], f["sample"]) for f in sheet["features"] if f["name"] == "W1RFTMRA02"]
    assert sorted(named) == [("W1RFTMRA02", s) for s in serials]  # six measurements, each with its sample
    text = run_pcmm("qif", "show", SAMPLES / "SheetMetal_QIF_Results_6_samples.QIF").stdout
    assert "W1RFTMRA02 [SN5802806]" in text
    status = run_pcmm("qif", "show", SAMPLES / "mitutoyo_results_serialized_pass_fail_sample.QIF", "--json")
    assert status.returncode == 0, status.stderr
    only = json.loads(status.stdout)
    assert only["results"] == [{"id": 2, "sample": None, "serial_numbers": ["SN#1234-56789"],
                                "inspection_status": "PASS"}]
    assert only["features"] == [] and only["characteristics"] == []
