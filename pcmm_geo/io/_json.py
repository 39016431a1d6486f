"""Typed access to parsed JSON documents: checks whose errors name the JSON path.

Documents are parsed by :func:`read_json_file` (strict: no NaN, overflow, duplicate keys or deep
nesting; defined in :mod:`pcmm_geo.io._text` and re-exported here).  :class:`JsonNode` then
walks them with checked accessors, e.g. ``cal.json: inputs.tip: expected an object, got a list``.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.errors import FileFormatError
from pcmm_geo.io._text import MAX_JSON_DEPTH, excerpt, read_json_file

__all__ = ["MAX_JSON_DEPTH", "JsonNode", "describe_json", "read_json_file"]


def describe_json(value: Any) -> str:
    """What a JSON value is, for "expected ..., got ..." messages (``a list``, ``the number 3``...).

    Examples
    --------
    >>> describe_json([1, 2]), describe_json(None), describe_json(2.5)
    ('a list', 'null', 'the number 2.5')
    >>> describe_json("x" * 100)
    "the string 'xxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxx'... (100 characters)"
    """
    if value is None:
        return "null"
    if isinstance(value, bool):
        return f"{str(value).lower()}"
    if isinstance(value, dict):
        return "an object"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, (int, float)):
        return f"the number {value!r}"
    if isinstance(value, str):
        return f"the string {excerpt(value)}"
    return type(value).__name__


class JsonNode:
    """A value inside a JSON document, with its path, and accessors that check its type.

    Every failed check raises :class:`FileFormatError` ``path: <json path>: expected ..., got ...``.

    Parameters
    ----------
    value : object
        The parsed JSON value.
    file : str
        The file, for messages.
    where : str
        JSON path of ``value`` (``""`` for the document).

    Examples
    --------
    >>> doc = JsonNode({"inputs": {"tip": [1, 2], "n": 3}}, "cal.json")
    >>> doc["inputs"]["n"].integer(low=0)
    3
    >>> try:
    ...     doc["inputs"]["tip"].object()
    ... except FileFormatError as exc:
    ...     print(exc)
    cal.json: inputs.tip: expected an object, got a list
    >>> try:
    ...     doc["inputs"]["tip"].vector(3)
    ... except FileFormatError as exc:
    ...     print(exc)
    cal.json: inputs.tip: expected a list of 3 numbers, got a list of 2
    """

    def __init__(self, value: Any, file: str, where: str = "") -> None:
        self.value, self.file, self.where = value, str(file), where

    def __repr__(self) -> str:
        return f"JsonNode({self.where or '<document>'} in {self.file})"

    def fail(self, expected: str, got: str | None = None) -> FileFormatError:
        """The error to raise for this node: ``expected ...``, ``got`` described from the value by default."""
        got = describe_json(self.value) if got is None else got
        prefix = f"{self.where}: " if self.where else ""
        return FileFormatError(self.file, f"{prefix}expected {expected}, got {got}")

    def _child(self, key: str | int) -> str:
        if isinstance(key, int):
            return f"{self.where}[{key}]"
        return f"{self.where}.{key}" if self.where else key

    # --- containers -----------------------------------------------------------------------
    def object(self) -> JsonNode:
        """This node, checked to be an object."""
        if not isinstance(self.value, dict):
            raise self.fail("an object")
        return self

    def __getitem__(self, key: str | int) -> JsonNode:
        """The member ``key`` of this object (which must exist), or element ``key`` of this list."""
        if isinstance(key, int):
            elements = self.list()
            if not -len(elements) <= key < len(elements):
                raise self.fail(f"a list of more than {key} elements", f"a list of {len(elements)}")
            return elements[key]
        members = self.object().value
        if key not in members:
            raise FileFormatError(self.file, f"{self._child(key)}: expected a value, got none (missing)")
        return JsonNode(members[key], self.file, self._child(key))

    def get(self, key: str) -> JsonNode | None:
        """The member ``key``, or None when it is missing or null."""
        members = self.object().value
        if members.get(key) is None:
            return None
        return JsonNode(members[key], self.file, self._child(key))

    def items(self) -> Iterator[tuple[str, JsonNode]]:
        """``(key, node)`` of every member of this object."""
        for key, value in self.object().value.items():
            yield key, JsonNode(value, self.file, self._child(key))

    def list(self, length: int | None = None) -> list[JsonNode]:
        """The elements of this list (exactly ``length`` of them when given)."""
        if not isinstance(self.value, list):
            raise self.fail("a list" if length is None else f"a list of {length}")
        if length is not None and len(self.value) != length:
            raise self.fail(f"a list of {length}", f"a list of {len(self.value)}")
        return [JsonNode(v, self.file, self._child(k)) for k, v in enumerate(self.value)]

    # --- scalars --------------------------------------------------------------------------
    def number(self, *, low: float | None = None, high: float | None = None, allow_null: bool = False) -> float:
        """A finite number in ``[low, high]`` (NaN for null when ``allow_null``)."""
        if self.value is None and allow_null:
            return math.nan
        if isinstance(self.value, bool) or not isinstance(self.value, (int, float)):
            raise self.fail("a number" + (" or null" if allow_null else ""))
        value = float(self.value)
        if not math.isfinite(value) or (low is not None and value < low) or (high is not None and value > high):
            bounds = f"[{'-inf' if low is None else low}, {'inf' if high is None else high}]"
            raise self.fail(f"a finite number in {bounds}")
        return value

    def integer(self, *, low: int | None = None, high: int | None = None) -> int:
        """An integer in ``[low, high]`` (``3.0`` counts; ``3.5`` and ``true`` do not)."""
        value = self.value
        if isinstance(value, float) and value.is_integer() and abs(value) < 2**53:
            value = int(value)
        if isinstance(value, bool) or not isinstance(value, int) or (low is not None and value < low) or (
                high is not None and value > high):
            bounds = "" if low is None and high is None else f" in [{low}, {high}]"
            raise self.fail(f"an integer{bounds}")
        return value

    def string(self, choices: tuple[str, ...] | None = None) -> str:
        """A string (one of ``choices`` when given)."""
        if not isinstance(self.value, str) or (choices is not None and self.value not in choices):
            raise self.fail("a string" if choices is None else f"one of {', '.join(map(repr, choices))}")
        return self.value

    def matrix(self, rows: int | None, columns: int) -> NDArray[np.float64]:
        """``rows`` lists (any number when None) of ``columns`` finite numbers each, as an array ``(rows, columns)``."""
        expected = f"a list of {'' if rows is None else f'{rows} '}lists of {columns} numbers"
        if not isinstance(self.value, list):
            raise self.fail(expected)
        if rows is not None and len(self.value) != rows:
            raise self.fail(expected, f"a list of {len(self.value)}")
        vectors = [child.vector(columns) for child in self.list()]
        return np.array(vectors, dtype=float).reshape(len(vectors), columns)

    def vector(self, length: int) -> NDArray[np.float64]:
        """A list of ``length`` finite numbers as an array ``(length,)``."""
        if not isinstance(self.value, list) or len(self.value) != length:
            got = f"a list of {len(self.value)}" if isinstance(self.value, list) else None
            raise self.fail(f"a list of {length} numbers", got)
        return np.array([child.number() for child in self.list()], dtype=float)
