"""DMIS syntax, read in one pass per line: statements, ``$`` continuations, comments, labels, rounding.

No pattern here backtracks: a statement is split by hand and the one regular expression used
(a word, a label start) matches in time linear in its input, so a long hostile line costs its
length, never its square or cube.  A statement is bounded by :data:`MAX_STATEMENT_CHARS`
(``$``-continued lines included).
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

from pcmm_geo.errors import FileFormatError
from pcmm_geo.io._lines import decode_block, iter_blocks, text_codec
from pcmm_geo.io._text import excerpt

__all__ = ["MAX_STATEMENT_CHARS", "half_unit", "is_statement", "output_labels", "split_statement", "statements"]

#: longest statement read (characters, after joining ``$``-continued lines)
MAX_STATEMENT_CHARS = 65_536
_WORD = re.compile(r"[A-Z][A-Z0-9_]*", re.IGNORECASE)
_LABEL_START = re.compile(r"\b(FA|TA)[ \t]*\(", re.IGNORECASE)


def statements(path: str | Path, encoding: str) -> Iterator[tuple[int, str]]:
    """Statements with their first line: comments dropped, ``$``-continued lines joined (streamed).

    A statement longer than :data:`MAX_STATEMENT_CHARS` is refused; so is a last line without a
    line end that holds a statement (the file was cut in the middle of it: the last number may be
    torn, ``11.113`` read as ``11.1``).
    """
    pending: list[str] = []
    size, first = 0, 0
    codec = text_codec(path, encoding)
    for block in iter_blocks(path):
        for number, text in decode_block(path, block, encoding=codec):
            code = _without_comment(text).rstrip()
            if not code and not pending:
                continue
            if block.last and not block.terminated and number == block.first_line + block.lines - 1:
                raise FileFormatError(str(path), "the file ends in the middle of a line (no line end after it): its "
                                      f"last statement may be cut short: {excerpt(code)}", number)
            if not pending:
                first = number
            continued = code.endswith("$")
            part = code[:-1] if continued else code
            size += len(part)
            if size > MAX_STATEMENT_CHARS:
                raise FileFormatError(str(path), f"a statement of more than {MAX_STATEMENT_CHARS} characters (lines "
                                      f"joined by $): {excerpt(part)}", first)
            pending.append(part)
            if continued:
                continue
            yield first, "".join(pending)
            pending, size = [], 0
    if pending:
        raise FileFormatError(str(path), "the last statement ends with $ but nothing continues it", first)


def _without_comment(text: str) -> str:
    quoted = False
    for index, character in enumerate(text):
        if character == "'":
            quoted = not quoted
        elif not quoted and text.startswith("$$", index):
            return text[:index]
    return text


def split_statement(text: str) -> tuple[str, str, str, str] | None:
    """``(kind, label, major word, rest)`` of ``F|FA|T|TA(label)=WORD/rest``, or None (another statement).

    Read by hand in one pass (no backtracking pattern: a long line costs its length, never more).
    """
    body = text.lstrip()
    word = _WORD.match(body)
    if word is None or word.group().upper() not in ("F", "FA", "T", "TA"):
        return None
    after = body[word.end():].lstrip()
    if not after.startswith("("):
        return None
    close = after.find(")")
    if close < 0:
        return None
    label, after = after[1:close].strip(), after[close + 1:].lstrip()
    if not after.startswith("="):
        return None
    major, slash, rest = after[1:].partition("/")
    major = major.strip()
    if not slash or not major.isascii() or not major.isalpha():
        return None
    return word.group().upper(), label, major.upper(), rest.lstrip()


def is_statement(text: str) -> bool:
    """``WORD``, ``WORD/...``, ``WORD=...`` or ``WORD(...)`` followed by one of them (no backtracking)."""
    body = text.lstrip()
    word = _WORD.match(body)
    if word is None:
        return False
    after = body[word.end():].lstrip()
    if after.startswith("("):
        close = after.find(")")
        if close < 0:
            return False
        after = after[close + 1:].lstrip()
    return not after or after[0] in "=/"


def output_labels(path: str, line: int, text: str) -> list[tuple[str, str]]:
    """The ``FA(label)`` and ``TA(label)`` an OUTPUT statement names, in order (linear scan)."""
    labels = []
    for start in _LABEL_START.finditer(text):
        close = text.find(")", start.end())
        if close < 0:
            raise FileFormatError(path, f"{start.group(1).upper()}( without its closing parenthesis: "
                              f"{excerpt(text[start.start():])}", line)
        labels.append((start.group(1).upper(), text[start.end():close].strip()))
    return labels


def half_unit(text: str) -> float:
    """Half a unit in the last decimal written (the rounding of ``text``): ``"0.0082"`` -> 5e-5."""
    mantissa, _, exponent = text.strip().lower().partition("e")
    decimals = len(mantissa.partition(".")[2])
    return 0.5 * 10.0 ** (-decimals + (int(exponent) if exponent.lstrip("+-").isdigit() else 0))
