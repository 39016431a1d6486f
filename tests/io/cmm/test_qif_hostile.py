"""Hostile XML: refused with a typed one-line error naming the file; nothing expanded, nothing fetched."""

from __future__ import annotations

import http.server
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from pcmm_geo.errors import FileFormatError, MissingDependencyError, PcmmGeoError, QifError, UnsafeXmlError
from pcmm_geo.io.cmm import read_qif, validate_qif
from pcmm_geo.io.cmm.qif._xml import MAX_TEXT_CHARS

DATA = Path(__file__).resolve().parents[2] / "data" / "qif"
HOSTILE = DATA / "hostile"
PTS_SAMPLE = DATA / "samples" / "QIF_PTS_SAMPLE.QIF"

UNSAFE = ["billion_laughs.qif", "quadratic_blowup.qif", "external_entity_file.qif", "external_entity_http.qif",
          "external_dtd.qif", "parameter_entity.qif", "deeply_nested.qif"]
DAMAGED = ["undefined_entity.qif", "not_xml.qif", "truncated.qif"]


def test_the_fixture_list_is_the_folder() -> None:
    assert sorted(UNSAFE + DAMAGED) == sorted(p.name for p in HOSTILE.glob("*.qif"))


@pytest.mark.parametrize("name", UNSAFE)
def test_hostile_documents_are_refused_as_unsafe(name: str) -> None:
    path = HOSTILE / name
    with pytest.raises(UnsafeXmlError) as caught:
        read_qif(path)
    message = str(caught.value)
    assert message.startswith(f"{path}:") and "\n" not in message
    assert caught.value.path == str(path) and isinstance(caught.value, FileFormatError | ValueError)
    assert "lol" not in message and "root:" not in message  # nothing expanded into the message


@pytest.mark.parametrize("name", DAMAGED)
def test_damaged_documents_are_refused_naming_file_and_line(name: str) -> None:
    path = HOSTILE / name
    with pytest.raises(FileFormatError, match="not well-formed XML") as caught:
        read_qif(path)
    assert caught.value.line is not None and str(caught.value).startswith(f"{path}:{caught.value.line}:")
    assert not isinstance(caught.value, UnsafeXmlError)


class _Recorder(http.server.BaseHTTPRequestHandler):
    requests: list[str] = []  # noqa: RUF012 - class-level log the test reads

    def do_GET(self) -> None:
        type(self).requests.append(self.path)
        body = b'<!ENTITY leak "fetched">'
        self.send_response(200)
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, format: str, *args: object) -> None:  # quiet
        pass


@pytest.fixture
def local_server() -> Iterator[str]:
    """An HTTP server on 127.0.0.1 that records every request (the tests assert there is none)."""
    _Recorder.requests = []
    server = http.server.HTTPServer(("127.0.0.1", 0), _Recorder)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()
        thread.join(timeout=5)


QIF_OPEN = '<QIFDocument xmlns="http://qifstandards.org/xsd/qif3" versionQIF="3.0.0">'


@pytest.mark.parametrize("doctype", [
    '<!DOCTYPE QIFDocument [<!ENTITY remote SYSTEM "{url}/entity.xml">]>',
    '<!DOCTYPE QIFDocument SYSTEM "{url}/evil.dtd">',
    '<!DOCTYPE QIFDocument [<!ENTITY % p SYSTEM "{url}/p.dtd"> %p;]>',
])
def test_nothing_is_fetched_from_the_network(tmp_path: Path, local_server: str, doctype: str) -> None:
    path = tmp_path / "remote.qif"
    path.write_text(doctype.format(url=local_server) + QIF_OPEN + "<QPId>&remote;</QPId></QIFDocument>")
    with pytest.raises(UnsafeXmlError):
        read_qif(path)
    with pytest.raises(UnsafeXmlError):
        validate_qif(path)
    assert _Recorder.requests == []


def test_a_local_file_is_not_read_through_an_entity(tmp_path: Path) -> None:
    secret = tmp_path / "secret.txt"
    secret.write_text("TOP-SECRET-CONTENT")
    path = tmp_path / "leak.qif"
    path.write_text(f'<!DOCTYPE QIFDocument [<!ENTITY s SYSTEM "file://{secret}">]>' + QIF_OPEN +
                    "<QPId>&s;</QPId></QIFDocument>")
    with pytest.raises(UnsafeXmlError) as caught:
        read_qif(path)
    assert "TOP-SECRET" not in str(caught.value)


def test_size_and_depth_limits_are_parameters() -> None:
    size = PTS_SAMPLE.stat().st_size
    with pytest.raises(UnsafeXmlError, match=f"file of {size} bytes exceeds the limit of 1000 bytes") as caught:
        read_qif(PTS_SAMPLE, max_bytes=1000)
    assert caught.value.limit == 1000
    assert len(read_qif(PTS_SAMPLE, max_bytes=size).measured_features) == 14
    with pytest.raises(UnsafeXmlError, match="nested deeper than 5") as deep:
        read_qif(PTS_SAMPLE, max_depth=5)
    assert deep.value.line is not None
    assert len(read_qif(HOSTILE / "deeply_nested.qif", max_depth=6000).measured_features) == 0


def test_an_element_with_too_much_text_and_an_impossible_count(tmp_path: Path) -> None:
    path = tmp_path / "long.qif"
    path.write_text(QIF_OPEN + "<QPId>" + "x" * (MAX_TEXT_CHARS + 10) + "</QPId></QIFDocument>")
    with pytest.raises(UnsafeXmlError, match="more than 1048576 characters of text"):
        read_qif(path)
    path = tmp_path / "count.qif"
    path.write_text(QIF_OPEN + '<Results><MeasurementResultsSet n="1"><MeasurementResults id="1">'
                    '<MeasuredPointSets n="1"><MeasuredPointSet id="2" count="1000000000000"><Points>0 0 0</Points>'
                    "</MeasuredPointSet></MeasuredPointSets></MeasurementResults></MeasurementResultsSet></Results>"
                    "</QIFDocument>")
    with pytest.raises(QifError, match="count 1000000000000 cannot be right") as caught:  # refused before allocating
        read_qif(path)
    assert caught.value.qif_id == "2"


def test_binary_point_arrays_are_refused_not_guessed(tmp_path: Path) -> None:
    path = tmp_path / "binary.qif"
    path.write_text(QIF_OPEN + '<Results><MeasurementResultsSet n="1"><MeasurementResults id="1">'
                    '<MeasuredPointSets n="1"><MeasuredPointSet id="2" count="1">'
                    '<BinaryPoints count="3" sizeElement="8">AAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAA</BinaryPoints>'
                    "<Compensated>true</Compensated></MeasuredPointSet></MeasuredPointSets></MeasurementResults>"
                    "</MeasurementResultsSet></Results></QIFDocument>")
    with pytest.raises(QifError, match="does not state the byte order"):
        read_qif(path)


def test_missing_defusedxml_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    for module in [m for m in sys.modules if m == "defusedxml" or m.startswith("defusedxml.")]:
        monkeypatch.delitem(sys.modules, module)
    monkeypatch.setitem(sys.modules, "defusedxml", None)
    with pytest.raises(MissingDependencyError, match=r"pip install 'pcmm_geo\[qif\]'") as caught:
        read_qif(PTS_SAMPLE)
    assert (caught.value.package, caught.value.extra) == ("defusedxml", "qif")
    assert isinstance(caught.value, PcmmGeoError)
