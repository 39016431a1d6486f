"""Untrusted XML in, a small tree out: defusedxml's expat parser, bounded depth and size, streamed number lists.

A CMM file (or the XML section of a scanner's E57 file) is untrusted input.  :func:`parse_xml`
(:func:`parse_xml_chunks` for XML that is part of a larger file) parses it with defusedxml's parser
(``forbid_dtd``, ``forbid_entities``, ``forbid_external``: no DTD at all, so no entity
expansion and nothing fetched from a file or the network) and refuses, with an
:class:`~pcmm_geo.errors.UnsafeXmlError` naming the file and line:

- a document type declaration, an entity declaration or an external reference;
- nesting deeper than ``max_depth`` elements;
- more than ``max_elements`` elements (the tree's memory, some 250 bytes an element);
- a file larger than ``max_bytes`` (checked before parsing and while reading: a scanner's
  point cloud is a legitimate large file, so the limit is a parameter);
- more than :data:`MAX_TEXT_CHARS` characters of text in one ordinary element.

XML that is not well formed is a :class:`~pcmm_geo.errors.FileFormatError` naming the line.

The tree is built by a parser *target* (no ElementTree tree): ordinary elements become small
:class:`Node` objects, while the text of the elements a caller marks as number lists (QIF
``Points``, ``Normals``, ...) is converted chunk by chunk straight into one preallocated
float64 array, so a document of 10^7 points holds its coordinates once (24 bytes a point)
plus one parser buffer, never the text of the whole list.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

import numpy as np

from pcmm_geo._optional import require
from pcmm_geo.errors import FileFormatError, UnsafeXmlError
from pcmm_geo.io._lines import open_regular
from pcmm_geo.io.cmm.settings import SpellSetting, python_setting

__all__ = ["DEFAULT_MAX_BYTES", "DEFAULT_MAX_DEPTH", "DEFAULT_MAX_ELEMENTS", "MAX_TEXT_CHARS", "XS_DOUBLE",
           "DuplicateElementError", "Node", "NumberList", "open_xml", "parse_xml", "parse_xml_chunks"]

#: default largest file read (bytes); pass ``max_bytes=`` for larger scanner files
DEFAULT_MAX_BYTES = 1 << 30
#: default most elements in one document: each costs some 250 bytes of tree (a QIF file keeps
#: its bulk, the points, in streamed number lists; its elements number thousands, rarely 10^5)
DEFAULT_MAX_ELEMENTS = 1_000_000
#: default deepest element nesting (QIF documents nest about 12 deep)
DEFAULT_MAX_DEPTH = 64
#: most characters of text in an element that is not a streamed number list
MAX_TEXT_CHARS = 1 << 20
_READ_CHUNK = 1 << 20
#: the lexical space of ``xs:double`` (XML Schema part 2, 3.2.5), ASCII digits only
XS_DOUBLE = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|[+-]?INF|NaN")
_BOOLEAN_WORDS = {"true": 1.0, "false": 0.0, "1": 1.0, "0": 0.0}


class NumberListError(ValueError):
    """A number list that cannot be read; ``reason`` says why, ``line`` where."""

    def __init__(self, reason: str, line: int | None) -> None:
        super().__init__(reason)
        self.reason = reason
        self.line = line


@dataclass
class NumberList:
    """Numbers of one element's text, parsed while the file streams by.

    ``expected`` numbers are preallocated when the file states how many (QIF ``count``);
    otherwise the list grows.  ``boolean`` lists accept ``true``/``false``/``1``/``0``.
    ``first_line`` is the line the text starts on; errors name the line of the offending token.
    """

    expected: int | None
    boolean: bool = False
    first_line: int = 1
    values: np.ndarray = field(init=False)
    filled: int = 0
    _tail: str = ""
    _newlines: int = 0
    _parts: list[np.ndarray] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.values = np.empty(self.expected if self.expected is not None else 0, dtype=np.float64)

    def feed(self, text: str) -> None:
        text = self._tail + text
        cut = len(text)
        while cut and not text[cut - 1].isspace():
            cut -= 1
        self._tail = text[cut:]
        if len(self._tail) > 4096:
            raise NumberListError(f"a number of more than 4096 characters ({self._tail[:40]!r}...)",
                                  self.first_line + self._newlines + text[:cut].count("\n"))
        segment = text[:cut]
        self._store(segment)
        self._newlines += segment.count("\n")

    def finish(self, line: int | None) -> np.ndarray:
        if self._tail:
            self._store(self._tail)
            self._tail = ""
        if self.expected is None:
            return np.concatenate(self._parts) if self._parts else np.empty(0)
        return self.values[: self.filled]

    def _line_of_token(self, segment: str, index: int) -> int:
        """Line of the ``index``-th token of ``segment`` (slow path, errors only)."""
        for number, match in enumerate(re.finditer(r"\S+", segment)):
            if number == index:
                return self.first_line + self._newlines + segment[: match.start()].count("\n")
        return self.first_line + self._newlines + segment.count("\n")

    def _store(self, segment: str) -> None:
        tokens = segment.split()
        if not tokens:
            return
        numbers = self._convert(tokens, segment)
        if self.expected is None:
            self._parts.append(numbers)
            self.filled += len(numbers)
            return
        end = self.filled + len(numbers)
        if end > self.expected:
            raise NumberListError(f"more than the {self.expected} numbers stated",
                                  self._line_of_token(segment, self.expected - self.filled))
        self.values[self.filled:end] = numbers
        self.filled = end

    def _convert(self, tokens: list[str], segment: str) -> np.ndarray:
        if self.boolean:
            bad = next((k for k, t in enumerate(tokens) if t not in _BOOLEAN_WORDS), None)
            if bad is not None:
                raise NumberListError(f"expected true or false, got {tokens[bad][:40]!r}",
                                      self._line_of_token(segment, bad))
            return np.array([_BOOLEAN_WORDS[t] for t in tokens])
        try:
            if not segment.isascii() or "_" in segment:  # float() reads 3_3.2 and non-ASCII digits: xs:double not
                raise ValueError(segment)
            numbers = np.array(tokens, dtype=np.float64)
        except ValueError:
            bad = next((k for k, t in enumerate(tokens) if not _is_float(t)), None)
            if bad is None:  # a separator that is not XML whitespace (a no-break space)
                odd = next(c for c in segment if not c.isascii())
                raise NumberListError(f"expected numbers separated by XML white space, got {odd!r}",
                                      self.first_line + self._newlines) from None
            raise NumberListError(f"expected a number (xs:double), got {tokens[bad][:40]!r}",
                                  self._line_of_token(segment, bad)) from None
        if not np.isfinite(numbers).all():
            bad = int(np.flatnonzero(~np.isfinite(numbers))[0])
            raise NumberListError(f"expected a finite number, got {tokens[bad][:40]!r}",
                                  self._line_of_token(segment, bad))
        return numbers


def _is_float(token: str) -> bool:
    """``token`` is in the lexical space of ``xs:double`` (ASCII digits, no ``_``)."""
    return XS_DOUBLE.fullmatch(token) is not None


class Node:
    """One element: local ``tag`` (namespace dropped), ``attrib``, ``children``, ``text``, ``line``.

    ``numbers`` holds the parsed values of a streamed number list (then ``text`` is empty).
    """

    __slots__ = ("attrib", "children", "line", "numbers", "parent", "stream", "tag", "text")

    def __init__(self, tag: str, attrib: dict[str, str], parent: Node | None, line: int) -> None:
        self.tag = tag
        self.attrib = attrib
        self.parent = parent
        self.line = line
        self.children: list[Node] = []
        self.text = ""
        self.numbers: np.ndarray | None = None
        self.stream: NumberList | None = None

    def path(self) -> str:
        """``QIFDocument/Results/...`` from the root to this element."""
        parts = []
        node: Node | None = self
        while node is not None:
            parts.append(node.tag)
            node = node.parent
        return "/".join(reversed(parts))

    def child(self, tag: str) -> Node | None:
        """The one child named ``tag`` (None if absent).

        Raises :class:`DuplicateElementError` when there are two: an element the reader takes
        once (a ``Diameter``, ``Points``, ``ProbeRadius``) is never picked first- or last-wins.
        Repeated elements are read with :meth:`all`.
        """
        found = None
        for candidate in self.children:
            if candidate.tag == tag:
                if found is not None:
                    raise DuplicateElementError(found, candidate)
                found = candidate
        return found

    def all(self, tag: str) -> list[Node]:
        """Every child named ``tag``."""
        return [c for c in self.children if c.tag == tag]

    def __repr__(self) -> str:
        return f"<Node {self.tag} line {self.line} ({len(self.children)} children)>"


class DuplicateElementError(ValueError):
    """Two children of one name where one is read (:meth:`Node.child`); the reader names the second."""

    def __init__(self, first: Node, second: Node) -> None:
        super().__init__(f"a second {second.tag} element (the first on line {first.line}) where one is read: "
                         "which one is meant?")
        self.first, self.second = first, second


#: decides whether an element's text is a streamed number list: (node) -> NumberList or None
StreamRule = Callable[[Node], "NumberList | None"]


class _Target:
    """Parser target building :class:`Node` objects, streaming marked number lists."""

    def __init__(self, path: str, max_depth: int, stream_rule: StreamRule,
                 max_elements: int = DEFAULT_MAX_ELEMENTS, elements_setting: str = "max_elements") -> None:
        self.path = path
        self.elements_setting = elements_setting
        self.max_depth = max_depth
        self.max_elements = max_elements
        self.elements = 0
        self.stream_rule = stream_rule
        self.expat = None
        self.root: Node | None = None
        self.current: Node | None = None
        self.depth = 0
        self.namespace: str | None = None

    def line(self) -> int | None:
        return None if self.expat is None else self.expat.CurrentLineNumber

    def start(self, tag: str, attrib: dict[str, str]) -> None:
        self.elements += 1
        if self.elements > self.max_elements:
            raise UnsafeXmlError(self.path, f"more than {self.max_elements} elements (the tree would need some "
                                 f"{self.max_elements * 250 >> 20} MiB); refused (raise {self.elements_setting} for "
                                 "larger files)", self.line(), limit=self.max_elements)
        self.depth += 1
        if self.depth > self.max_depth:
            raise UnsafeXmlError(self.path, f"elements nested deeper than {self.max_depth}", self.line(),
                                 limit=self.max_depth)
        namespace, _, local = tag.rpartition("}")
        if self.root is None:
            self.namespace = namespace.lstrip("{") or None
        node = Node(local, {k.rpartition("}")[2]: v for k, v in attrib.items()}, self.current, self.line() or 0)
        if self.current is None:
            self.root = node
        else:
            if self.current.stream is not None:
                raise _StreamFailure(self.current, NumberListError(f"expected numbers, got the element {local}",
                                                                   self.line()))
            self.current.children.append(node)
        self.current = node
        node.stream = self.stream_rule(node)
        if node.stream is not None:
            node.stream.first_line = node.line

    def end(self, tag: str) -> None:
        node = self.current
        assert node is not None
        if node.stream is not None:
            try:
                node.numbers = node.stream.finish(self.line())
            except NumberListError as exc:
                exc.line = exc.line or self.line()
                raise _StreamFailure(node, exc) from None
            node.stream = None
        self.current = node.parent
        self.depth -= 1

    def data(self, text: str) -> None:
        node = self.current
        if node is None:
            return
        if node.stream is not None:
            try:
                node.stream.feed(text)
            except NumberListError as exc:
                raise _StreamFailure(node, exc) from None
            return
        if len(node.text) + len(text) > MAX_TEXT_CHARS:
            raise UnsafeXmlError(self.path, f"element {node.tag} holds more than {MAX_TEXT_CHARS} characters of text",
                                 self.line(), limit=MAX_TEXT_CHARS)
        node.text += text

    def close(self) -> Node | None:
        return self.root


class _StreamFailure(Exception):
    def __init__(self, node: Node, error: NumberListError) -> None:
        super().__init__(error.reason)
        self.node = node
        self.error = error


class NumberListFailure(FileFormatError):
    """A streamed number list could not be read (the caller turns it into its own typed error)."""

    def __init__(self, path: str, node: Node, reason: str, line: int | None) -> None:
        super().__init__(path, f"{node.path()}: {reason}", line)
        self.node = node
        self.list_reason = reason


def parse_xml(path: str | Path, *, max_bytes: int = DEFAULT_MAX_BYTES, max_depth: int = DEFAULT_MAX_DEPTH,
              stream_rule: StreamRule = lambda node: None, spell_setting: SpellSetting = python_setting,
              max_elements: int = DEFAULT_MAX_ELEMENTS) -> tuple[Node, str | None]:
    """Parse an untrusted XML file into a :class:`Node` tree (see the module docstring).

    Parameters
    ----------
    path : str or Path
    max_bytes : int
        Largest file accepted (bytes).
    max_depth : int
        Deepest element nesting accepted.
    max_elements : int
        Most elements accepted (:data:`DEFAULT_MAX_ELEMENTS`): the tree's memory is bounded by it,
        whatever the file's size (a file of empty elements would need 60 times its size).
    stream_rule : callable
        ``rule(node) -> NumberList | None``, called at each element's start: a :class:`NumberList`
        makes that element's text a streamed number list.
    spell_setting : callable
        How the refusals name ``max_bytes`` and ``max_elements`` (:mod:`pcmm_geo.io.cmm.settings`).

    Returns
    -------
    (Node, str or None)
        The root element and its namespace URI.

    Raises
    ------
    UnsafeXmlError
        DTD, entity or external reference; too deep; too large; an over-long text.
    NumberListFailure
        A streamed number list with a non-number, a non-finite value or more numbers than stated.
    FileFormatError
        Not well-formed XML, an empty file, or a file that cannot be read.
    MissingDependencyError
        defusedxml is not installed (extra ``qif``).
    """
    name = str(path)
    stream = open_xml(path, max_bytes, spell_setting)

    def chunks() -> Iterator[bytes]:
        with stream:
            while chunk := stream.read(_READ_CHUNK):
                yield chunk

    return parse_xml_chunks(name, chunks(), max_bytes=max_bytes, max_depth=max_depth, stream_rule=stream_rule,
                            max_elements=max_elements, spell_setting=spell_setting)


def open_xml(path: str | Path, max_bytes: int, spell_setting: SpellSetting = python_setting) -> BinaryIO:
    """``path`` opened for reading bytes: a regular file (never a FIFO, a directory or a URL) of at most ``max_bytes``.

    Raises
    ------
    FileFormatError
        Missing, unreadable or not a regular file (a FIFO would block forever).
    UnsafeXmlError
        Larger than ``max_bytes``.
    """
    name = str(path)
    try:
        stream = open_regular(path, "an XML file")
    except FileNotFoundError as exc:
        raise FileFormatError(name, f"cannot be read: {exc.strerror or exc}") from None
    size = os.fstat(stream.fileno()).st_size
    if size > max_bytes:
        stream.close()
        raise UnsafeXmlError(name, f"file of {size} bytes exceeds the limit of {max_bytes} bytes "
                             f"(raise {spell_setting('max_bytes')} for larger files)", limit=max_bytes)
    return stream


def parse_xml_chunks(name: str, chunks: Iterable[bytes], *, max_bytes: int = DEFAULT_MAX_BYTES,
                     max_depth: int = DEFAULT_MAX_DEPTH, stream_rule: StreamRule = lambda node: None,
                     max_elements: int = DEFAULT_MAX_ELEMENTS, spell_setting: SpellSetting = python_setting,
                     ) -> tuple[Node, str | None]:
    """Parse untrusted XML arriving as byte chunks (e.g. the XML section of an E57 file) as :func:`parse_xml` does.

    ``name`` is the file named in errors; ``chunks`` are read one by one, never joined, and
    refused once they add up to more than ``max_bytes``.  An ``OSError`` raised while the
    chunks are read becomes a :class:`~pcmm_geo.errors.FileFormatError`; any other error of
    the chunk source passes through unchanged.  Raises what :func:`parse_xml` raises.

    Examples
    --------
    >>> root, namespace = parse_xml_chunks("memory.xml", [b"<a xmlns='urn:x'><b>1</b>", b"</a>"])
    >>> root.tag, namespace, root.child("b").text
    ('a', 'urn:x', '1')
    >>> try:
    ...     parse_xml_chunks("memory.xml", [b"<!DOCTYPE a [<!ENTITY e 'x'>]><a>&e;</a>"])
    ... except UnsafeXmlError as exc:
    ...     print(exc.reason[:44])
    has a document type declaration (DTD); refus
    """
    defused = require("defusedxml.ElementTree", purpose="reading XML files from CMMs and scanners")
    defused_common = require("defusedxml.common", purpose="reading XML files from CMMs and scanners")
    target = _Target(name, max_depth, stream_rule, max_elements, spell_setting("max_elements"))
    parser = defused.DefusedXMLParser(target=target, forbid_dtd=True, forbid_entities=True, forbid_external=True)
    target.expat = parser.parser
    parser.parser.buffer_size = _READ_CHUNK
    read = 0
    try:
        for chunk in chunks:
            read += len(chunk)
            if read > max_bytes:
                raise UnsafeXmlError(name, f"file exceeds the limit of {max_bytes} bytes while reading",
                                     limit=max_bytes)
            parser.feed(chunk)
        root = parser.close()
    except defused_common.DTDForbidden:
        raise UnsafeXmlError(name, "has a document type declaration (DTD); refused: QIF and E57 need none and "
                             "a DTD can declare entities or fetch external files", target.line()) from None
    except defused_common.EntitiesForbidden as exc:
        raise UnsafeXmlError(name, f"declares the entity {exc.name!r}; refused (entity expansion)",
                             target.line()) from None
    except defused_common.ExternalReferenceForbidden as exc:
        raise UnsafeXmlError(name, f"refers to the external resource {exc.sysid!r}; refused (nothing is fetched)",
                             target.line()) from None
    except defused_common.DefusedXmlException as exc:
        raise UnsafeXmlError(name, f"refused: {exc}", target.line()) from None
    except _StreamFailure as failure:
        raise NumberListFailure(name, failure.node, failure.error.reason, failure.error.line) from None
    except defused.ParseError as exc:
        line = exc.position[0] if getattr(exc, "position", None) else None
        message = str(exc).split(":")[0]
        raise FileFormatError(name, f"not well-formed XML: {message}", line) from None
    except OSError as exc:
        raise FileFormatError(name, f"cannot be read: {exc.strerror or exc}") from None
    except LookupError as exc:  # expat asks Python for the codec the XML declaration names
        raise FileFormatError(name, f"the XML declaration names an encoding Python does not know ({exc})",
                              target.line()) from None
    except RecursionError:  # pragma: no cover - the depth limit stops nesting long before
        raise UnsafeXmlError(name, "nesting too deep", target.line()) from None
    if root is None:
        raise FileFormatError(name, "holds no XML element")
    return root, target.namespace
