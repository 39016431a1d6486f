"""Text files from CMM software, line by line: encoding given, lines bounded, errors naming file and line.

CMM software writes text in the encoding of the machine it runs on (CALYPSO and PC-DMIS on
Windows often write Windows-1252), so the readers take an ``encoding`` (default UTF-8) and a
byte that does not decode is a :class:`~pcmm_geo.errors.FileFormatError` naming the line --
never silently replaced.  The file is streamed: a scanner's million-point export is never held
as one text.
"""

from __future__ import annotations

import codecs
import re
from collections.abc import Iterator
from pathlib import Path

from pcmm_geo.errors import FileFormatError
from pcmm_geo.io._text import MAX_LINE_CHARS, excerpt

__all__ = ["iter_text_lines"]

_CONTROL = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f]")


def iter_text_lines(path: str | Path, *, encoding: str = "utf-8",
                    max_line: int = MAX_LINE_CHARS) -> Iterator[tuple[int, str]]:
    """``(line_number, text)`` of each line (from 1; line end and a leading BOM removed).

    Raises
    ------
    FileFormatError
        A directory, a file that cannot be read, bytes that are not ``encoding``, NUL bytes or
        other control characters, a line longer than ``max_line`` characters, an unknown encoding.
    """
    name = str(path)
    try:
        decoder = codecs.lookup(encoding)
    except LookupError:
        raise FileFormatError(name, f"unknown text encoding {encoding!r}") from None
    if "\n".encode(decoder.name, errors="replace") != b"\n" or "Az09,.".encode(decoder.name) != b"Az09,.":
        raise FileFormatError(name, f"encoding {encoding!r} is not ASCII-compatible; CMM text files are")
    if Path(path).is_dir():
        raise FileFormatError(name, "is a directory, expected a text file")
    try:
        with open(path, "rb") as stream:
            number = 0
            while True:
                number += 1
                raw = stream.readline(4 * max_line + 8)
                if not raw:
                    return
                if not raw.endswith(b"\n") and len(raw) > 4 * max_line:
                    raise FileFormatError(name, f"line longer than {max_line} characters", number)
                if number == 1 and raw.startswith(codecs.BOM_UTF8):
                    raw = raw[len(codecs.BOM_UTF8):]
                try:
                    text = raw.decode(decoder.name).rstrip("\r\n")
                except UnicodeDecodeError as exc:
                    raise FileFormatError(name, f"not {encoding} text: byte 0x{raw[exc.start]:02x} at column "
                                          f"{exc.start + 1} (pass the file's encoding, e.g. encoding='cp1252')",
                                          number) from None
                if len(text) > max_line:
                    raise FileFormatError(name, f"line of {len(text)} characters (at most {max_line} accepted): "
                                          f"{excerpt(text)}", number)
                control = _CONTROL.search(text)
                if control is not None:
                    code = ord(control.group())
                    what = "binary data (NUL byte)" if code == 0 else f"control character 0x{code:02x}"
                    raise FileFormatError(name, f"{what} at column {control.start() + 1}, expected text", number)
                yield number, text
    except OSError as exc:
        raise FileFormatError(name, f"cannot be read: {exc.strerror or exc}") from None
