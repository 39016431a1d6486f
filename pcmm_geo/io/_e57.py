"""The E57 file header and XML section checked before libE57Format reads the file (ASTM E2807).

An E57 file is a sequence of 1024-byte *physical pages*; the last 4 bytes of every page are a
CRC-32C checksum (stored big-endian) of the page's first 1020 bytes, which are the *logical*
content.  The file starts with a 48-byte header, all numbers little-endian:

======  ======  ===========================================================
offset  bytes   field
======  ======  ===========================================================
0       8       signature ``ASTM-E57``
8       4       major version (1)
12      4       minor version
16      8       file physical length (bytes; the whole file)
24      8       XML physical offset (where the XML section starts)
32      8       XML logical length (bytes of XML, checksums not counted)
40      8       page size (1024)
======  ======  ===========================================================

pye57 hands the XML section to libE57Format, whose XML parser was not written for hostile
input.  :func:`check_e57` therefore reads the header, checks every length against the file's
size, verifies the checksum of the header page and of every page the XML section touches, and
streams the XML section page by page through the project's hostile-XML guard
(:func:`pcmm_geo.io.cmm.qif._xml.parse_xml_chunks`: no DTD, no entity, no external
reference, bounded depth and size).  Only a file that passes is given to pye57.  The binary
sections (the points) are checked by libE57Format itself as it reads them.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import BinaryIO

from pcmm_geo._optional import require
from pcmm_geo.errors import FileFormatError, UnsafeXmlError

__all__ = ["DEFAULT_MAX_XML_BYTES", "E57Header", "check_e57", "read_e57_header"]

SIGNATURE = b"ASTM-E57"
PAGE_BYTES = 1024
CHECKSUM_BYTES = 4
LOGICAL_PAGE_BYTES = PAGE_BYTES - CHECKSUM_BYTES
_HEADER = struct.Struct("<8sIIQQQQ")
#: largest XML section accepted by default (bytes); the XML of an E57 file describes its scans and
#: images (a few kB each), the points are in binary sections
DEFAULT_MAX_XML_BYTES = 1 << 28
#: deepest XML nesting accepted (E57 documents nest about 10 deep)
MAX_XML_DEPTH = 64
_PAGES_PER_READ = 1024


@dataclass(frozen=True)
class E57Header:
    """The header fields of an E57 file (ASTM E2807), lengths in bytes."""

    major_version: int
    minor_version: int
    file_physical_length: int
    xml_physical_offset: int
    xml_logical_length: int
    page_size: int


def _crc32c() -> ModuleType:
    return require("google_crc32c", purpose="checking the page checksums of E57 files")


def _check_page(name: str, page: bytes, index: int, crc32c: ModuleType) -> None:
    stored = int.from_bytes(page[LOGICAL_PAGE_BYTES:], "big")
    computed = int(crc32c.value(page[:LOGICAL_PAGE_BYTES]))
    if stored != computed:
        raise FileFormatError(name, f"page {index} (bytes {index * PAGE_BYTES}-{(index + 1) * PAGE_BYTES - 1}) "
                              f"fails its CRC-32C checksum: stored 0x{stored:08x}, computed 0x{computed:08x} "
                              "(a damaged or truncated E57 file)")


def read_e57_header(path: str | Path) -> E57Header:
    """The header of an E57 file, every length checked against the file (see the module docstring).

    Raises
    ------
    FileFormatError
        Not an E57 file (signature), an unsupported version or page size, a stated length
        that disagrees with the file's size, an XML section outside the file or starting in a
        checksum, or a header page that fails its checksum.
    FileNotFoundError
        The file does not exist.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "scan.e57")
    >>> _ = open(path, "wb").write(b"PK\\x03\\x04" + bytes(2044))
    >>> try:
    ...     read_e57_header(path)
    ... except FileFormatError as exc:
    ...     print(exc.reason)
    not an E57 file: expected the signature 'ASTM-E57' at its start, got b'PK\\x03\\x04\\x00\\x00\\x00\\x00'
    """
    name = str(path)
    file = Path(path)
    if file.is_dir():
        raise FileFormatError(name, "is a directory, expected an E57 file")
    size = file.stat().st_size
    with open(file, "rb") as handle:
        first = handle.read(PAGE_BYTES)
    if first[:8] != SIGNATURE:
        raise FileFormatError(name, f"not an E57 file: expected the signature 'ASTM-E57' at its start, "
                              f"got {first[:8]!r}")
    if len(first) < PAGE_BYTES:
        raise FileFormatError(name, f"E57 file of {size} bytes, shorter than its first {PAGE_BYTES}-byte page "
                              "(truncated)")
    header = E57Header(*_HEADER.unpack_from(first)[1:])
    if header.major_version != 1:
        raise FileFormatError(name, f"expected E57 version 1.x, got {header.major_version}.{header.minor_version}")
    if header.page_size != PAGE_BYTES:
        raise FileFormatError(name, f"expected a page size of {PAGE_BYTES} bytes (ASTM E2807), "
                              f"got {header.page_size}")
    _check_page(name, first, 0, _crc32c())
    if header.file_physical_length != size:
        raise FileFormatError(name, f"header states a file of {header.file_physical_length} bytes, the file has "
                              f"{size} (truncated or appended to)")
    if size % PAGE_BYTES:
        raise FileFormatError(name, f"file of {size} bytes is not a whole number of {PAGE_BYTES}-byte pages")
    offset, length = header.xml_physical_offset, header.xml_logical_length
    if not _HEADER.size <= offset < size or offset % PAGE_BYTES >= LOGICAL_PAGE_BYTES:
        raise FileFormatError(name, f"XML section offset {offset} is outside the data of the file's "
                              f"{size // PAGE_BYTES} pages (after the header, not in a checksum)")
    if length == 0:
        raise FileFormatError(name, "XML section of length 0, expected the E57 XML")
    end = _physical_end(offset, length)
    if end > size:
        raise FileFormatError(name, f"XML section of {length} bytes from offset {offset} would end at byte {end}, "
                              f"beyond the file's {size} bytes")
    return header


def _physical_end(offset: int, length: int) -> int:
    """Physical offset just after ``length`` logical bytes starting at physical ``offset``."""
    logical_start = (offset // PAGE_BYTES) * LOGICAL_PAGE_BYTES + offset % PAGE_BYTES
    logical_end = logical_start + length
    pages, rest = divmod(logical_end, LOGICAL_PAGE_BYTES)
    return pages * PAGE_BYTES + rest


def _xml_chunks(name: str, handle: BinaryIO, header: E57Header, crc32c: ModuleType | None) -> Iterator[bytes]:
    """The XML section's logical bytes, a block of pages at a time (each page's checksum verified with ``crc32c``)."""
    offset, remaining = header.xml_physical_offset, header.xml_logical_length
    page = offset // PAGE_BYTES
    skip = offset % PAGE_BYTES
    handle.seek(page * PAGE_BYTES)
    while remaining > 0:
        pages = min(_PAGES_PER_READ, -(-(skip + remaining) // LOGICAL_PAGE_BYTES))
        data = handle.read(pages * PAGE_BYTES)
        if len(data) < pages * PAGE_BYTES:  # pragma: no cover - read_e57_header checked the length
            raise FileFormatError(name, "the XML section ends beyond the end of the file")
        logical = bytearray()
        for k in range(pages):
            raw = data[k * PAGE_BYTES:(k + 1) * PAGE_BYTES]
            if crc32c is not None:
                _check_page(name, raw, page + k, crc32c)
            logical += raw[skip:LOGICAL_PAGE_BYTES]
            skip = 0
        page += pages
        chunk = bytes(logical[:remaining])
        remaining -= len(chunk)
        yield chunk


def check_e57(path: str | Path, *, max_xml_bytes: int = DEFAULT_MAX_XML_BYTES) -> E57Header:
    """Refuse an E57 file whose header, checksums or XML section are damaged or hostile.

    Reads the header (:func:`read_e57_header`), then streams the XML section through the
    hostile-XML guard, verifying the checksum of every page it touches.  Nothing is handed to
    libE57Format here; :func:`pcmm_geo.io.clouds.read_e57` calls this first.

    Parameters
    ----------
    path : str or Path
    max_xml_bytes : int
        Largest XML section accepted (bytes).

    Returns
    -------
    E57Header

    Raises
    ------
    UnsafeXmlError
        The XML section has a DTD, an entity or an external reference, nests deeper than
        :data:`MAX_XML_DEPTH` or is longer than ``max_xml_bytes``; the message names the line of
        the XML section.
    FileFormatError
        See :func:`read_e57_header`; a page of the XML section fails its checksum; XML that is
        not well formed or whose root is not ``e57Root``.
    MissingDependencyError
        defusedxml or google-crc32c is not installed (extra ``e57``).
    """
    from pcmm_geo.io.cmm.qif._xml import parse_xml_chunks

    name = str(path)
    require("defusedxml", purpose="checking the XML section of E57 files", extra="e57")  # for parse_xml_chunks
    crc32c = _crc32c()
    header = read_e57_header(path)
    if header.xml_logical_length > max_xml_bytes:
        raise UnsafeXmlError(name, f"XML section of {header.xml_logical_length} bytes exceeds the limit of "
                             f"{max_xml_bytes} bytes", limit=max_xml_bytes)
    with open(path, "rb") as handle:
        for _ in _xml_chunks(name, handle, header, crc32c):  # every checksum first, then the content
            pass
        try:
            root, _ = parse_xml_chunks(name, _xml_chunks(name, handle, header, None), max_bytes=max_xml_bytes,
                                       max_depth=MAX_XML_DEPTH)
        except UnsafeXmlError as exc:
            raise UnsafeXmlError(name, f"XML section{_where(exc.line)}: {exc.reason}", limit=exc.limit) from None
        except FileFormatError as exc:
            raise FileFormatError(name, f"XML section{_where(exc.line)}: {exc.reason}") from None
    if root.tag != "e57Root":
        raise FileFormatError(name, f"XML section: expected the root element e57Root, got {root.tag!r}")
    return header


def _where(line: int | None) -> str:
    return "" if line is None else f" line {line}"
