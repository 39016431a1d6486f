"""Reading a text file in blocks of whole lines, with errors that name the file and the line.

The one place where pcmm_geo turns the bytes of a text file into lines.  :func:`iter_blocks`
reads a file in blocks of whole lines (bounded memory, however large the file; a first small
block, so that a reader can refuse a wrong header after reading a few kilobytes);
:func:`decode_block` turns one block into ``(line_number, text)`` pairs, refusing binary data,
control characters, bytes that are not UTF-8 and over-long lines, each with a
:class:`~pcmm_geo.errors.FileFormatError` naming the line.  A leading UTF-8 byte-order mark
(as Excel and Windows Notepad write) is dropped; ``\\r\\n`` line ends are accepted.

:mod:`pcmm_geo.io._text` builds the line, CSV and JSON readers on this; the streaming point
readers (:mod:`pcmm_geo.io._delimited`) parse the blocks directly.
"""

from __future__ import annotations

import codecs
import os
import re
import stat
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

from pcmm_geo.errors import FileFormatError

__all__ = [
    "open_regular",
    "refuse_irregular",
    "BLOCK_BYTES",
    "EXCERPT_CHARS",
    "FIRST_BLOCK_BYTES",
    "MAX_LINE_CHARS",
    "LineBlock",
    "decode_block",
    "excerpt",
    "iter_blocks",
    "text_codec",
]

#: longest line (characters) a text reader accepts; data rows are far shorter
MAX_LINE_CHARS = 65_536
#: characters of offending text an error message quotes at most
EXCERPT_CHARS = 60
#: bytes read at a time once the first block is read
BLOCK_BYTES = 1 << 22
#: bytes of the first block (headers are checked before more of the file is read)
FIRST_BLOCK_BYTES = 1 << 16

BOM = b"\xef\xbb\xbf"
# C0 control characters other than tab, line feed and carriage return, and DEL: never in a text
# data file, and str.strip() would silently remove some of them (0x0b, 0x1c-0x1f) from a number
CONTROL = re.compile(rb"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f]")
_CONTROL_TEXT = re.compile(CONTROL.pattern.decode("ascii"))


def excerpt(text: str, limit: int = EXCERPT_CHARS) -> str:
    """``repr(text)``, shortened to its first ``limit`` characters and its length when longer.

    Error messages quote offending file content through this, so that a damaged 100 MB line
    gives a message of a few dozen characters.

    Examples
    --------
    >>> excerpt("1,2,3")
    "'1,2,3'"
    >>> excerpt("7" * 1_000_000, limit=8)
    "'77777777'... (1000000 characters)"
    """
    if len(text) <= limit:
        return repr(text)
    return f"{text[:limit]!r}... ({len(text)} characters)"


@dataclass(frozen=True)
class LineBlock:
    """Whole lines of a file, as read by :func:`iter_blocks`.

    Attributes
    ----------
    offset : int
        Byte offset of the block's first line in the file.
    first_line : int
        Line number (1-based) of the block's first line.
    data : bytes
        The lines, each ending with ``b"\\n"`` (the file's last line is given one when it has
        none; see ``terminated``).  Empty only for an empty file (or nothing after ``start``).
    last : bool
        The block ends the file.
    terminated : bool
        For the last block: whether the file's last line ended with a line end (True for an
        empty file).  True for every other block.
    """

    offset: int
    first_line: int
    data: bytes
    last: bool
    terminated: bool = True

    @property
    def lines(self) -> int:
        """Number of lines in the block."""
        return self.data.count(b"\n")


_CONTINUATION = bytes(range(0x80, 0xC0))
# bytes of an over-long line counted for its message at most
_COUNT_LIMIT = 1 << 26


def _over_long(path: str, handle: BinaryIO, partial: bytes, line: int, max_line: int) -> FileFormatError:
    """The error for a line that has grown past any accepted length (binary data, or its length).

    The length is counted to the line's end, without keeping the line, up to
    :data:`_COUNT_LIMIT` bytes (a huge file without line ends is not read to its end).
    """
    control = CONTROL.search(partial)
    if control is not None:
        return _control_error(path, partial, control.start(), line)
    characters = len(partial.translate(None, _CONTINUATION))  # UTF-8 characters: bytes that start one
    text = partial[: 4 * EXCERPT_CHARS].decode("utf-8", "replace").rstrip("\r")
    counted, more = len(partial), ""
    while True:
        if counted > _COUNT_LIMIT:
            more = "more than "
            break
        chunk = handle.read(BLOCK_BYTES)
        end = chunk.find(b"\n")
        characters += len((chunk if end < 0 else chunk[:end]).translate(None, _CONTINUATION))
        counted += len(chunk)
        if not chunk or end >= 0:
            break
    return FileFormatError(path, f"line of {more}{characters} characters (at most {max_line} accepted): "
                           f"{text[:EXCERPT_CHARS]!r}... ({more}{characters} characters)", line=line)


def _control_error(path: str, data: bytes, position: int, first_line: int) -> FileFormatError:
    """Binary data or a control character at byte ``position`` of ``data`` (which starts at ``first_line``)."""
    number = first_line + data.count(b"\n", 0, position)
    code = data[position]
    if code == 0:
        return FileFormatError(path, "binary data (NUL byte), expected a text file", line=number)
    column = position - data.rfind(b"\n", 0, position)
    return FileFormatError(path, f"control character 0x{code:02x} at column {column}, expected text", line=number)


def open_regular(path: str | Path, what: str = "a file") -> BinaryIO:
    """``path`` opened for reading bytes, when it is a regular file; anything else is refused at once.

    A FIFO would block the reader until some other process writes to it (forever, for a
    command), a device or socket may never end, a directory is no file: each is a
    :class:`FileFormatError` before anything is read.  The file is opened without blocking and
    checked again on the open descriptor, so it cannot be swapped for a FIFO in between.

    Raises
    ------
    FileFormatError
        Not a regular file (naming what it is), or it cannot be opened.
    FileNotFoundError
        The file does not exist.

    Examples
    --------
    >>> import os, tempfile
    >>> folder = tempfile.mkdtemp()
    >>> fifo = os.path.join(folder, "pipe.qif")
    >>> os.mkfifo(fifo)
    >>> try:
    ...     open_regular(fifo)
    ... except FileFormatError as exc:
    ...     print(exc.reason)
    is a FIFO (named pipe), expected a file: it could block forever
    """
    name = str(path)
    info = os.stat(path)  # FileNotFoundError passes through; stat never blocks on a FIFO
    _refuse_irregular(name, info.st_mode, what)
    try:
        handle = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    except OSError as exc:
        raise FileFormatError(name, f"cannot be read: {exc.strerror or exc}") from None
    try:
        _refuse_irregular(name, os.fstat(handle).st_mode, what)
        return os.fdopen(handle, "rb")
    except BaseException:
        os.close(handle)
        raise


def refuse_irregular(path: str | Path, what: str = "a file") -> None:
    """Refuse at once a path that exists and is not a regular file (a FIFO, a device, a directory).

    For callers that decide something before a reader opens the file; a missing file is left
    to the reader (which names it).
    """
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return
    _refuse_irregular(str(path), mode, what)


def _refuse_irregular(name: str, mode: int, what: str) -> None:
    if stat.S_ISREG(mode):
        return
    if stat.S_ISDIR(mode):
        raise FileFormatError(name, f"is a directory, expected {what}")
    kind = "a FIFO (named pipe)" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode) else \
        "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "not a regular file"
    raise FileFormatError(name, f"is {kind}, expected {what}: it could block forever")


def iter_blocks(path: str | Path, *, start: int = 0, first_line: int = 1, block_bytes: int = BLOCK_BYTES,
                first_block_bytes: int = FIRST_BLOCK_BYTES, max_line: int | None = MAX_LINE_CHARS,
                stop: int | None = None) -> Iterator[LineBlock]:
    """Blocks of whole lines of ``path`` from byte ``start`` (line ``first_line``) to the end (or byte ``stop``).

    ``stop`` must be the end of a line (or of the file): a chunk of a file split at line ends.

    At least one block is yielded (the last one has ``last=True``).  Only the bytes are split;
    :func:`decode_block` checks them.  A line that cannot be shorter than ``max_line``
    characters (more than 4 bytes a character) is refused here, its length counted without
    keeping it; ``max_line=None`` accepts lines of any length.

    Raises
    ------
    FileFormatError
        ``path`` is a directory, a FIFO or another file that is not a regular one, or holds an
        over-long line (named, with its length).
    FileNotFoundError
        The file does not exist.
    """
    file = Path(path)
    with open_regular(file, "a text file") as handle:
        handle.seek(start)
        offset, line, carry, size = start, first_line, b"", first_block_bytes
        if start == 0:
            head = handle.read(len(BOM))
            if head == BOM:
                offset = len(BOM)
            else:
                carry = head
        while True:
            chunk = handle.read(size if stop is None else max(0, min(size, stop - handle.tell())))
            size = block_bytes
            data = carry + chunk
            if not chunk:  # end of file
                terminated = not data or data.endswith(b"\n")
                yield LineBlock(offset, line, data if terminated else data + b"\n", True, terminated)
                return
            cut = data.rfind(b"\n") + 1
            carry = data[cut:]
            if max_line is not None and len(carry) > 4 * max_line + 4:
                raise _over_long(str(file), handle, carry, line + data.count(b"\n", 0, cut), max_line)
            if cut:
                block = data[:cut]
                yield LineBlock(offset, line, block, False)
                offset += cut
                line += block.count(b"\n")


def text_codec(path: str | Path, encoding: str) -> str:
    """The codec name of ``encoding`` (e.g. ``'cp1252'``), refused unless known and ASCII-compatible.

    Line ends, digits, signs and separators must be the ASCII bytes for the line and number
    parsers to work, so UTF-16 and the like are refused.

    Raises
    ------
    FileFormatError
        Unknown or not ASCII-compatible (naming ``path``).

    Examples
    --------
    >>> text_codec("x.dmo", "Windows-1252"), text_codec("x.dmo", "UTF8")
    ('cp1252', 'utf-8')
    """
    try:
        name = codecs.lookup(encoding).name
    except LookupError:
        raise FileFormatError(str(path), f"unknown text encoding {encoding!r}") from None
    if "\n".encode(name, errors="replace") != b"\n" or "Az09,.+-".encode(name) != b"Az09,.+-":
        raise FileFormatError(str(path), f"encoding {encoding!r} is not ASCII-compatible; text data files are")
    return name


def decode_block(path: str | Path, block: LineBlock, max_line: int | None = MAX_LINE_CHARS,
                 encoding: str | None = None) -> list[tuple[int, str]]:
    """The lines of ``block`` as ``(line_number, text)``, line ends removed; every line checked.

    ``encoding`` None reads UTF-8; a codec name (checked by :func:`text_codec`) reads that
    encoding, for readers that let the caller name it (CMM software on Windows often writes
    cp1252): a byte that does not decode is then refused with a hint that another encoding
    can be given, never replaced.

    Raises
    ------
    FileFormatError
        A NUL byte (binary data) or another control character (not tab, CR, LF), a line that is
        not valid in the encoding or longer than ``max_line`` characters; the message names the line.
    """
    data = block.data
    codec, hint = ("utf-8", "") if encoding is None else (encoding, " (another encoding can be given, e.g. cp1252)")
    label = "UTF-8" if codec == "utf-8" else codec
    bytewise = codec == "utf-8"  # in UTF-8 a control byte is always that character; other codecs are checked decoded
    if bytewise:
        control = CONTROL.search(data)
        if control is not None:  # one scan of the block; the line is counted only when needed
            raise _control_error(str(path), data, control.start(), block.first_line)
    lines: list[tuple[int, str]] = []
    for number, raw in enumerate(data.split(b"\n")[:-1], start=block.first_line):
        try:
            text = raw.decode(codec)
        except UnicodeDecodeError as exc:
            raise FileFormatError(
                str(path), f"not {label} text: byte 0x{raw[exc.start]:02x} at column {exc.start + 1}{hint}",
                line=number,
            ) from None
        if not bytewise:
            control_char = _CONTROL_TEXT.search(text)
            if control_char is not None:
                raise _control_error(str(path), text.encode("latin-1", "replace"), control_char.start(), number)
        if max_line is not None and len(text) > max_line:
            raise FileFormatError(
                str(path), f"line of {len(text)} characters (at most {max_line} accepted): {excerpt(text)}",
                line=number,
            )
        lines.append((number, text.rstrip("\r")))
    return lines
