"""I++ DME 1.4.3 line protocol: command lines in, response lines out (spec §6.1, §6.2, §8.2).

A command line is ``TTTTT Method(args)``: a five-character tag (``00001``..``99999`` for the
normal queue, ``E0001``..``E9999`` for event commands), one space, a method name and an argument
list whose items are strings (``"Probe1"``), numbers, properties (``Tool.PtMeasPar.Speed(5)``,
``X()``), event tags (``E0007``) or bare names (``PartCsy``).  Response lines are ``TTTTT &``
(acknowledge), ``TTTTT # data``, ``TTTTT %`` (transaction complete) and ``TTTTT ! Error(sev,
nnnn, "method", "text")``; the server's own unsolicited lines use tag ``E0000``.

Only printable ASCII (32..126) is allowed inside a line (error 0007 otherwise); the line
terminator is CR LF (a bare LF is accepted here).  This module is pure: no I/O, no state.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

__all__ = [
    "ERRORS",
    "MAX_LINE_BYTES",
    "SERVER_TAG",
    "Command",
    "EventTag",
    "Name",
    "ProtocolError",
    "Property",
    "Text",
    "format_error",
    "format_number",
    "parse_command",
]

#: longest accepted line, bytes without the terminator (spec §6.2: a line should not exceed 65536 characters)
MAX_LINE_BYTES = 65536
#: the server's tag for unsolicited events (spec §6.2.1)
SERVER_TAG = "E0000"

#: spec §8.2 predefined errors used by this server: number -> (severity, short text)
ERRORS: dict[int, tuple[int, str]] = {
    0: (0, "Buffer full"),
    1: (2, "Illegal tag"),
    2: (2, "No space at pos. 6"),
    6: (2, "Transaction aborted (Use ClearAllErrors to Continue)"),
    7: (3, "Illegal character"),
    8: (3, "Protocol error"),
    501: (3, "Unsupported command"),
    502: (3, "Incorrect arguments"),
    503: (9, "Controller communications failure"),
    504: (1, "Argument out of range"),
    505: (3, "Argument not recognized"),
    506: (3, "Argument not supported"),
    507: (3, "Illegal command"),
    508: (3, "Bad context"),
    509: (3, "Bad argument"),
    510: (3, "Bad property"),
    511: (3, "Error processing method"),
    512: (1, "No daemons are active"),
    513: (2, "Daemon does not exist"),
    514: (2, "Use ClearAllErrors to continue"),
    515: (2, "Daemon already exists"),
    1005: (3, "Error during home"),
    1006: (2, "Surface not found"),
    1007: (3, "Theta out of range"),
    1008: (3, "Target position out of machine volume"),
    1010: (2, "Vector has no norm"),
    1011: (2, "Unable to move"),
    1502: (3, "Tool not found"),
    2002: (3, "Type of probe does not allow this operation"),
    1503: (3, "Tool not defined"),
    2500: (3, "Machine limit encountered [Move Out Of Limits]"),
    2502: (3, "Axis position error"),
    2503: (9, "Scale read head failure"),
    2504: (3, "Collision"),
}

_TAG = re.compile(r"(?:(?!00000)\d{5}|E(?!0000)\d{4})\Z")
_NAME = re.compile(r"[A-Za-z][A-Za-z0-9]*(?:\.[A-Za-z][A-Za-z0-9]*)*")
_BASIC = re.compile(r"[A-Za-z][A-Za-z0-9]*\Z")
_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d{1,3})?")
_ETAG = re.compile(r"E\d{4}\Z")


class ProtocolError(Exception):
    """A line the server answers with an error: ``number`` (spec §8.2), ``detail`` and the tag if one was read."""

    def __init__(self, number: int, detail: str, tag: str | None = None, method: str = "") -> None:
        super().__init__(f"{number:04d}: {detail}")
        self.number = number
        self.detail = detail
        self.tag = tag
        self.method = method


@dataclass(frozen=True)
class Property:
    """``Name(n1, n2, ...)``: a dotted property name with zero or more numbers (``X()``, ``Tool.GoToPar.Speed(5)``)."""

    name: str
    values: tuple[float, ...]


@dataclass(frozen=True)
class Text:
    """A double-quoted string argument (``"Probe1"``), without the quotes."""

    value: str


@dataclass(frozen=True)
class EventTag:
    """An event-tag argument (``StopDaemon(E0007)``)."""

    value: str


@dataclass(frozen=True)
class Name:
    """A bare enumeration name (``SetCoordSystem(PartCsy)``)."""

    value: str


Argument = Property | Text | EventTag | Name | float


@dataclass(frozen=True)
class Command:
    """One parsed command line: ``tag`` (5 characters), ``method`` and ``args`` in order."""

    tag: str
    method: str
    args: tuple[Argument, ...]

    @property
    def is_event(self) -> bool:
        """Sent with an event tag (``E....``): the fast queue."""
        return self.tag.startswith("E")


def format_number(value: float) -> str:
    """A number as the protocol writes it: fixed 6 decimals (micrometre data keep 0.001 um), ``-0`` as ``0``."""
    text = f"{float(value):.6f}"
    return "0.000000" if text == "-0.000000" else text


def format_error(tag: str, number: int, method: str) -> str:
    """``TTTTT ! Error(severity, nnnn, "method", "text")`` for a spec error number.

    The text is the spec's own for the number (§8.2): clients and the NIST response parser
    check it; the server's details go to the transcript.
    """
    severity, text = ERRORS.get(number, (3, "Error"))
    method = "".join(ch for ch in method if ch.isalnum())[:64] or "Server"
    return f'{tag} ! Error({severity}, {number:04d}, "{method}", "{text}")'


def parse_command(raw: bytes) -> Command:
    """Parse one command line (terminator removed) into a :class:`Command`.

    Raises
    ------
    ProtocolError
        0007 for a byte outside 32..126, 0001 for a bad tag, 0002 for no space at position 6,
        0008 for a line that is not ``Method(args)``, 0502 for malformed arguments.  ``tag``
        is set when the tag itself was valid (the error then goes back with it).
    """
    if len(raw) > MAX_LINE_BYTES:
        raise ProtocolError(8, f"line longer than {MAX_LINE_BYTES} bytes")
    tag_text = raw[:5].decode("ascii", "replace")
    tag = tag_text if _TAG.match(tag_text) else None
    bad = next((i for i, byte in enumerate(raw) if byte < 32 or byte > 126), None)
    if bad is not None:
        raise ProtocolError(7, f"byte {raw[bad]} at position {bad + 1}", tag)
    line = raw.decode("ascii")
    if tag is None:
        raise ProtocolError(1, f"bad tag {line[:5]!r}")
    if len(line) < 6 or line[5] != " ":
        raise ProtocolError(2, "expected a space after the tag", tag)
    body = line[6:]
    match = _NAME.match(body)
    if match is None or not _BASIC.match(match.group(0)):
        raise ProtocolError(8, "expected Method(arguments) at position 7", tag)
    method = match.group(0)
    pos = _skip(body, match.end())
    if pos >= len(body) or body[pos] != "(":
        raise ProtocolError(8, "expected '(' after the method name", tag, method)
    args, pos = _arguments(body, pos + 1, tag, method)
    if pos != len(body):
        raise ProtocolError(8, f"unexpected text after ')' at position {pos + 7}", tag, method)
    return Command(tag, method, tuple(args))


def _skip(text: str, pos: int) -> int:
    while pos < len(text) and text[pos] == " ":
        pos += 1
    return pos


def _number(text: str, pos: int, tag: str, method: str) -> tuple[float, int]:
    match = _NUMBER.match(text, pos)
    if match is None:
        raise ProtocolError(502, f"expected a number at position {pos + 7}", tag, method)
    token = match.group(0)
    mantissa = re.split(r"[eE]", token)[0]
    if sum(ch.isdigit() for ch in mantissa) > 16:
        raise ProtocolError(502, f"more than 16 digits at position {pos + 7}", tag, method)
    value = float(token)
    if not math.isfinite(value):
        raise ProtocolError(502, f"number out of range at position {pos + 7}", tag, method)
    return value, match.end()


def _arguments(text: str, pos: int, tag: str, method: str) -> tuple[list[Argument], int]:
    """Arguments up to and including the closing ``)``; returns them and the position after it."""
    args: list[Argument] = []
    pos = _skip(text, pos)
    if pos < len(text) and text[pos] == ")":
        return args, pos + 1
    while True:
        if len(args) >= 256:
            raise ProtocolError(502, "more than 256 arguments", tag, method)
        pos = _skip(text, pos)
        if pos >= len(text):
            raise ProtocolError(502, "missing ')'", tag, method)
        char = text[pos]
        if char == '"':
            end = text.find('"', pos + 1)
            if end < 0:
                raise ProtocolError(502, f"unterminated string at position {pos + 7}", tag, method)
            args.append(Text(text[pos + 1:end]))
            pos = end + 1
        elif char.isalpha():
            match = _NAME.match(text, pos)
            assert match is not None
            name, after = match.group(0), _skip(text, match.end())
            if after < len(text) and text[after] == "(":
                values, pos = _property_values(text, after + 1, tag, method)
                args.append(Property(name, tuple(values)))
            elif _ETAG.match(name):
                args.append(EventTag(name))
                pos = match.end()
            elif _BASIC.match(name):
                args.append(Name(name))
                pos = match.end()
            else:
                raise ProtocolError(502, f"bad argument {name!r}", tag, method)
        else:
            value, pos = _number(text, pos, tag, method)
            args.append(value)
        pos = _skip(text, pos)
        if pos < len(text) and text[pos] == ",":
            pos += 1
            continue
        if pos < len(text) and text[pos] == ")":
            return args, pos + 1
        raise ProtocolError(502, f"expected ',' or ')' at position {pos + 7}", tag, method)


def _property_values(text: str, pos: int, tag: str, method: str) -> tuple[list[float], int]:
    values: list[float] = []
    pos = _skip(text, pos)
    if pos < len(text) and text[pos] == ")":
        return values, pos + 1
    while True:
        if len(values) >= 64:
            raise ProtocolError(502, "more than 64 numbers in a property", tag, method)
        value, pos = _number(text, _skip(text, pos), tag, method)
        values.append(value)
        pos = _skip(text, pos)
        if pos < len(text) and text[pos] == ",":
            pos += 1
            continue
        if pos < len(text) and text[pos] == ")":
            return values, pos + 1
        raise ProtocolError(502, f"expected ',' or ')' in a property at position {pos + 7}", tag, method)
