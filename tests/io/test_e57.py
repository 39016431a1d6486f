"""Untrusted E57 files: header, page checksums and the XML section are checked before libE57Format reads them.

The hostile files are made here from a valid E57 written by pye57: its XML section is replaced
by another one (written after the last page, in 1020-byte logical pages each followed by its
CRC-32C), the header's lengths and checksum set to match.  The same rewrite with the original
XML must still read as the original points, so a refusal is the guard's doing and not a broken
rewrite.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.errors import FileFormatError, UnsafeXmlError
from pcmm_geo.io import read_points

pye57 = pytest.importorskip("pye57")
google_crc32c = pytest.importorskip("google_crc32c")

HEADER = struct.Struct("<8sIIQQQQ")
PAGE, LOGICAL = 1024, 1020


def _crc(data: bytes) -> bytes:
    return int(google_crc32c.value(data)).to_bytes(4, "big")


def _valid_e57(path: Path) -> np.ndarray:
    metres = np.random.default_rng(5).uniform(-1.0, 1.0, (300, 3))
    e57 = pye57.E57(str(path), mode="w")
    e57.write_scan_raw({"cartesianX": metres[:, 0], "cartesianY": metres[:, 1], "cartesianZ": metres[:, 2]})
    e57.close()
    return read_points(path)


def _xml_section(data: bytes) -> bytes:
    """The logical bytes of the XML section (checksums left out), read independently of the library."""
    _, _, _, _, offset, length, _ = HEADER.unpack_from(data)
    logical = b"".join(data[k:k + LOGICAL] for k in range(0, len(data), PAGE))
    start = (offset // PAGE) * LOGICAL + offset % PAGE
    return logical[start:start + length]


def _with_xml(source: Path, target: Path, xml: bytes) -> Path:
    """``source`` with its XML section replaced by ``xml``, appended in new pages; header and checksums fixed."""
    data = bytearray(source.read_bytes())
    offset = len(data)
    for start in range(0, len(xml), LOGICAL):
        page = xml[start:start + LOGICAL].ljust(LOGICAL, b"\x00")
        data += page + _crc(page)
    signature, major, minor, _, _, _, page_size = HEADER.unpack_from(data)
    HEADER.pack_into(data, 0, signature, major, minor, len(data), offset, len(xml), page_size)
    data[LOGICAL:PAGE] = _crc(bytes(data[:LOGICAL]))
    target.write_bytes(bytes(data))
    return target


def _with_doctype(xml: bytes, doctype: bytes) -> bytes:
    declaration_end = xml.index(b"?>") + 2
    return xml[:declaration_end] + b"\n" + doctype + xml[declaration_end:]


@pytest.fixture
def scan(tmp_path: Path) -> tuple[Path, np.ndarray]:
    path = tmp_path / "scan.e57"
    return path, _valid_e57(path)


def test_a_rewritten_xml_section_still_reads_as_the_original(scan: tuple[Path, np.ndarray], tmp_path: Path) -> None:
    path, points = scan
    moved = _with_xml(path, tmp_path / "moved.e57", _xml_section(path.read_bytes()))
    assert moved.stat().st_size > path.stat().st_size
    np.testing.assert_array_equal(read_points(moved), points)
    assert len(points) == 300


BILLION_LAUGHS = b"""<!DOCTYPE e57Root [
 <!ENTITY lol "lol">
 <!ENTITY lol1 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">
 <!ENTITY lol2 "&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;">
 <!ENTITY lol3 "&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;">
 <!ENTITY lol9 "&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;">
]>"""
EXTERNAL = b'<!DOCTYPE e57Root [<!ENTITY secret SYSTEM "file:///etc/passwd">]>'


@pytest.mark.parametrize(("doctype", "entity_use"), [(BILLION_LAUGHS, b"&lol9;"), (EXTERNAL, b"&secret;")],
                         ids=["billion-laughs", "external-entity"])
def test_hostile_xml_section_is_refused_before_libe57format(scan: tuple[Path, np.ndarray], tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch, doctype: bytes,
                                                            entity_use: bytes) -> None:
    path, _ = scan
    xml = _xml_section(path.read_bytes())
    hostile_xml = _with_doctype(xml, doctype).replace(b"pye57 v", entity_use + b" v", 1)
    assert entity_use in hostile_xml
    hostile = _with_xml(path, tmp_path / "hostile.e57", hostile_xml)
    opened: list[str] = []
    monkeypatch.setattr(pye57, "E57", lambda *args, **kwargs: opened.append(args[0]))
    with pytest.raises(UnsafeXmlError, match=r"hostile\.e57: XML section line 2: has a document type declaration"):
        read_points(hostile)
    assert opened == []  # pye57 / libE57Format never saw the file


def test_hostile_e57_on_the_command_line_is_one_line_and_exit_2(scan: tuple[Path, np.ndarray], tmp_path: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    from pcmm_geo.cli import main

    path, _ = scan
    hostile = _with_xml(path, tmp_path / "hostile.e57", _with_doctype(_xml_section(path.read_bytes()), EXTERNAL))
    report = tmp_path / "out" / "fit.md"
    assert main(["fit", "sphere", str(hostile), "--report", str(report)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "hostile.e57: XML section line 2: has a document type declaration" in err
    assert not report.exists()


def test_deeply_nested_xml_section_is_refused(scan: tuple[Path, np.ndarray], tmp_path: Path) -> None:
    path, _ = scan
    xml = _xml_section(path.read_bytes())
    nested = xml.replace(b"</e57Root>", b"<a>" * 200 + b"</a>" * 200 + b"</e57Root>")
    with pytest.raises(UnsafeXmlError, match=r"nested\.e57: XML section line \d+: elements nested deeper than 64"):
        read_points(_with_xml(path, tmp_path / "nested.e57", nested))


def test_xml_section_that_is_not_e57_or_not_xml_is_refused(scan: tuple[Path, np.ndarray], tmp_path: Path) -> None:
    path, _ = scan
    with pytest.raises(FileFormatError, match=r"other\.e57: XML section: expected the root element e57Root, got 'QIF"):
        read_points(_with_xml(path, tmp_path / "other.e57", b"<QIFDocument/>"))
    with pytest.raises(FileFormatError, match=r"broken\.e57: XML section line 1: not well-formed XML"):
        read_points(_with_xml(path, tmp_path / "broken.e57", b"<e57Root><a></e57Root>"))
    # safe XML that libE57Format cannot use: its own error, still one typed error naming the file
    empty = b'<e57Root type="Structure" xmlns="http://www.astm.org/COMMIT/E57/2010-e57-v1.0"/>'
    with pytest.raises(FileFormatError, match=r"empty\.e57: not a readable E57 file: E57Exception: ") as info:
        read_points(_with_xml(path, tmp_path / "empty.e57", empty))
    assert "\n" not in str(info.value)  # one line: libE57Format's debug trace left out


def test_damaged_checksums_are_named_by_page(scan: tuple[Path, np.ndarray], tmp_path: Path) -> None:
    path, points = scan
    data = bytearray(path.read_bytes())
    offset = HEADER.unpack_from(data)[4]
    xml_page = offset // PAGE
    flipped = bytearray(data)
    flipped[xml_page * PAGE + 10] ^= 0x01  # one bit of XML text
    (tmp_path / "xml_bit.e57").write_bytes(bytes(flipped))
    with pytest.raises(FileFormatError, match=rf"xml_bit\.e57: page {xml_page} .* fails its CRC-32C checksum"):
        read_points(tmp_path / "xml_bit.e57")
    header_bit = bytearray(data)
    header_bit[100] ^= 0x80  # inside page 0, after the header fields
    (tmp_path / "header_bit.e57").write_bytes(bytes(header_bit))
    with pytest.raises(FileFormatError, match=r"header_bit\.e57: page 0 .* fails its CRC-32C checksum"):
        read_points(tmp_path / "header_bit.e57")
    np.testing.assert_array_equal(read_points(path), points)  # the undamaged file still reads


def _with_header(source: Path, target: Path, **fields: int) -> Path:
    data = bytearray(source.read_bytes())
    names = ("major", "minor", "length", "offset", "xml_length", "page_size")
    values = dict(zip(names, HEADER.unpack_from(data)[1:], strict=True)) | fields
    HEADER.pack_into(data, 0, b"ASTM-E57", *(values[name] for name in names))
    data[LOGICAL:PAGE] = _crc(bytes(data[:LOGICAL]))
    target.write_bytes(bytes(data))
    return target


def test_lengths_are_checked_against_the_file(scan: tuple[Path, np.ndarray], tmp_path: Path) -> None:
    path, _ = scan
    size = path.stat().st_size
    _, _, _, _, offset, length, _ = HEADER.unpack_from(path.read_bytes())
    cases = {
        "xml_length": (dict(xml_length=size), r"XML section of \d+ bytes from offset \d+ would end at byte \d+, "
                       rf"beyond the file's {size} bytes"),
        "xml_zero": (dict(xml_length=0), "XML section of length 0"),
        "offset": (dict(offset=size + 5 * PAGE), rf"XML section offset {size + 5 * PAGE} is outside"),
        "in_checksum": (dict(offset=PAGE + LOGICAL + 1), "XML section offset 2045 is outside"),
        "file_length": (dict(length=size + PAGE), rf"header states a file of {size + PAGE} bytes, the file has {size}"),
        "version": (dict(major=2), "expected E57 version 1.x, got 2.0"),
        "page_size": (dict(page_size=4096), "expected a page size of 1024 bytes"),
    }
    for name, (fields, message) in cases.items():
        bad = _with_header(path, tmp_path / f"{name}.e57", **fields)
        with pytest.raises(FileFormatError, match=rf"{name}\.e57: {message}"):
            read_points(bad)
    truncated = tmp_path / "truncated.e57"
    truncated.write_bytes(path.read_bytes()[:-PAGE])
    with pytest.raises(FileFormatError, match=rf"truncated\.e57: header states a file of {size} bytes, the file has "
                       rf"{size - PAGE} \(truncated"):
        read_points(truncated)
    assert offset + length <= size  # the valid file's own section is inside it


def test_xml_section_size_limit(scan: tuple[Path, np.ndarray]) -> None:
    from pcmm_geo.io._e57 import check_e57

    path, _ = scan
    header = check_e57(path)
    assert header.file_physical_length == path.stat().st_size
    with pytest.raises(UnsafeXmlError, match=r"XML section of \d+ bytes exceeds the limit of 100 bytes") as info:
        check_e57(path, max_xml_bytes=100)
    assert info.value.limit == 100
