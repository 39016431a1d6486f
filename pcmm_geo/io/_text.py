"""Decoding text files line by line with errors that name the file and the line.

Every text reader of pcmm_geo goes through :func:`read_text_lines`, so a binary file,
bytes that are not UTF-8, a directory or an empty file give one :class:`FileFormatError`
(``path:line: reason``) instead of a bare ``UnicodeDecodeError``.
"""

from __future__ import annotations

from pathlib import Path

from pcmm_geo.errors import FileFormatError

__all__ = ["read_json_file", "read_text_file", "read_text_lines"]


def read_text_lines(path: str | Path) -> list[tuple[int, str]]:
    """The lines of a UTF-8 text file as ``(line_number, text)``, line numbers from 1.

    A leading byte-order mark is dropped; line ends (``\\n``, ``\\r\\n``) are removed.

    Raises
    ------
    FileFormatError
        The path is a directory, the file holds NUL bytes (binary data), or a line is not
        valid UTF-8; the message names the line and the offending byte.
    FileNotFoundError
        The file does not exist.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "t.csv")
    >>> _ = open(path, "wb").write(b"x,y,z\\r\\n1,2,3\\n")
    >>> read_text_lines(path)
    [(1, 'x,y,z'), (2, '1,2,3')]
    >>> _ = open(path, "wb").write(b"x,y,z\\n1,2,\\xb53\\n")
    >>> try:
    ...     read_text_lines(path)
    ... except FileFormatError as exc:
    ...     print(exc.line, exc.reason)
    2 not UTF-8 text: byte 0xb5 at column 5
    """
    file = Path(path)
    if file.is_dir():
        raise FileFormatError(str(file), "is a directory, expected a text file")
    data = file.read_bytes()
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    lines: list[tuple[int, str]] = []
    for number, raw in enumerate(data.split(b"\n"), start=1):
        if b"\x00" in raw:
            raise FileFormatError(str(file), "binary data (NUL byte), expected a text file", line=number)
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise FileFormatError(
                str(file), f"not UTF-8 text: byte 0x{raw[exc.start]:02x} at column {exc.start + 1}", line=number
            ) from None
        lines.append((number, text.rstrip("\r")))
    if lines and lines[-1][1] == "":
        lines.pop()  # the newline that ends the last line
    return lines


def read_text_file(path: str | Path) -> str:
    """The whole text of a UTF-8 file (BOM dropped, ``\\r\\n`` as ``\\n``), checked as :func:`read_text_lines` does.

    Raises
    ------
    FileFormatError
        Directory, binary data or non-UTF-8 bytes (the message names the line).
    FileNotFoundError
        The file does not exist.
    """
    return "".join(text + "\n" for _, text in read_text_lines(path))


def read_json_file(path: str | Path) -> object:
    """Parse a UTF-8 JSON file strictly: ``NaN``/``Infinity`` (not JSON, though Python writes them) are refused.

    Raises
    ------
    FileFormatError
        Not text, a syntax error or a non-finite number; the message names the file and line.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "c.json")
    >>> _ = open(path, "w").write('{"radius": 5.0,\\n "form": NaN}')
    >>> try:
    ...     read_json_file(path)
    ... except FileFormatError as exc:
    ...     print(exc.line, exc.reason)
    2 expected JSON, got the non-finite number NaN
    """
    import json

    text = read_text_file(path)

    def refuse(token: str) -> None:
        raise ValueError(token)

    try:
        return json.loads(text, parse_constant=refuse)
    except json.JSONDecodeError as exc:
        raise FileFormatError(str(path), f"expected JSON, got {exc.msg}", line=exc.lineno) from None
    except ValueError as exc:
        token = str(exc)
        line = next((n for n, t in enumerate(text.splitlines(), 1) if token in t), None)
        raise FileFormatError(str(path), f"expected JSON, got the non-finite number {token}", line=line) from None
