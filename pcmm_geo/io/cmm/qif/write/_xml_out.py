"""Writing XML text for the QIF writer: an indenting emitter and numbers in the schema's types.

``xs:double`` values (coordinates, vectors) are written as Python's shortest round-trip repr;
``xs:decimal`` values (sizes, tolerances, uncertainties, probe radii) take no exponent, so they
are written in positional notation with the same shortest digits -- both read back exactly.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from typing import IO
from xml.sax.saxutils import escape, quoteattr

import numpy as np

from pcmm_geo.errors import InvalidInputError

__all__ = ["ALGORITHMS", "CHARACTERISTIC_STATUSES", "INSPECTION_STATUSES", "QifText", "XmlText", "camel",
           "check_xml_text", "decimal_text", "double_text"]

#: QIF 3.0 enumerations the writer checks its input against
INSPECTION_STATUSES = ("PASS", "FAIL", "REWORK", "SYSERROR", "UNKNOWN", "NOT_CALCULATED", "NOT_MEASURED",
                       "UNDEFINED")
CHARACTERISTIC_STATUSES = ("PASS", "FAIL", "REWORK", "SYSERROR", "INDETERMINATE", "NOT_ANALYZED", "BASIC_OR_TED",
                           "UNDEFINED")
ALGORITHMS = ("BEZIER", "BSPLINE", "DEFAULT", "LEASTSQUARES", "MAXINSCRIBED", "MAXINNERLOCALSIZE",
               "MAXOUTERLOCALSIZE", "MINCIRCUMSCRIBED", "MININNERLOCALSIZE", "MINOUTERLOCALSIZE", "MINMAX", "NURBS",
               "ONESIDED", "UNDEFINED")


#: characters XML 1.0 cannot hold (Char production): C0 controls but tab, LF, CR; surrogates; U+FFFE, U+FFFF
_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")


def check_xml_text(text: str, what: str) -> str:
    """``text`` unchanged, or :class:`InvalidInputError` naming ``what`` when XML 1.0 cannot hold a character of it.

    Examples
    --------
    >>> check_xml_text("HOLE <A> é", "name")
    'HOLE <A> é'
    """
    found = _NOT_XML.search(text)
    if found is not None:
        raise InvalidInputError(what, "text XML 1.0 can hold (no control characters but tab and line ends, no "
                                "surrogates, no U+FFFE/U+FFFF)",
                                f"{ord(found.group()):#06x} at position {found.start()}")
    return text


def camel(snake: str) -> str:
    """``"spherical_diameter"`` -> ``"SphericalDiameter"`` (the QIF element stem)."""
    return "".join(part.capitalize() for part in snake.split("_"))


def double_text(value: float) -> str:
    """``xs:double`` text: the shortest repr that reads back as ``value``."""
    if not math.isfinite(value):
        raise InvalidInputError("value", "a finite number", repr(value))
    return repr(float(value))


def decimal_text(value: float) -> str:
    """``xs:decimal`` text (no exponent) with the shortest digits that read back as ``value``."""
    if not math.isfinite(value):
        raise InvalidInputError("value", "a finite number", repr(value))
    return np.format_float_positional(float(value), unique=True, trim="-")


class XmlText:
    """Indented XML text into a binary stream."""

    def __init__(self, stream: IO[bytes]) -> None:
        self.stream = stream
        self.depth = 0

    def raw(self, text: str) -> None:
        self.stream.write(text.encode("utf-8"))

    def open(self, tag: str, **attributes: object) -> None:
        self.raw(f"{'  ' * self.depth}<{tag}{attributes_text(attributes)}>\n")
        self.depth += 1

    def close(self, tag: str) -> None:
        self.depth -= 1
        self.raw(f"{'  ' * self.depth}</{tag}>\n")

    def leaf(self, tag: str, text: str | None = None, **attributes: object) -> None:
        pad = "  " * self.depth
        if text is None:
            self.raw(f"{pad}<{tag}{attributes_text(attributes)}/>\n")
        else:
            check_xml_text(text, f"{tag} text")
            self.raw(f"{pad}<{tag}{attributes_text(attributes)}>{escape(text)}</{tag}>\n")

    def chain(self, *tags: str, text: str | None = None) -> None:
        """Nested elements ``tags[0]/tags[1]/.../tags[-1]``, the last a leaf holding ``text``."""
        for tag in tags[:-1]:
            self.open(tag)
        self.leaf(tags[-1], text)
        for tag in reversed(tags[:-1]):
            self.close(tag)

    def ids(self, tag: str, ids: Iterable[int]) -> None:
        ids = list(ids)
        self.open(tag, n=len(ids))
        for key in ids:
            self.leaf("Id", str(key))
        self.close(tag)


def attributes_text(attributes: dict[str, object]) -> str:
    return "".join(f" {name}={quoteattr(str(value))}" for name, value in attributes.items() if value is not None)


class QifText(XmlText):
    """:class:`XmlText` that writes values in the file's units (lengths in ``unit_name``, angles in degrees).

    Parameters
    ----------
    stream : binary stream
    unit_name : str
        QIF ``UnitName`` of lengths (``"mm"``, ``"inch"``).
    mm_per_unit : float
        Millimetres per file unit (25.4 for inch).
    """

    def __init__(self, stream: IO[bytes], unit_name: str = "mm", mm_per_unit: float = 1.0) -> None:
        super().__init__(stream)
        self.unit_name = unit_name
        self.mm_per_unit = mm_per_unit

    def length(self, value: float) -> str:
        """A length (mm) as ``xs:decimal`` text in the file's unit."""
        return decimal_text(value / self.mm_per_unit)

    def angle(self, value: float) -> str:
        """An angle (rad) as ``xs:decimal`` degrees."""
        return decimal_text(math.degrees(value))

    def point(self, values: np.ndarray) -> str:
        """A point (mm, shape (3,)) as three ``xs:double`` in the file's unit."""
        return " ".join(double_text(v / self.mm_per_unit) for v in values)

    @staticmethod
    def vector(values: np.ndarray) -> str:
        """A unit vector as three ``xs:double``."""
        return " ".join(double_text(v) for v in values)

    def quantity(self, value: float, quantity: str) -> str:
        """``value`` as ``"linear"`` (mm), ``"angular"`` (rad) or ``"other"`` (as is) text."""
        return self.angle(value) if quantity == "angular" else self.length(value) if quantity == "linear" else (
            decimal_text(value))

    def measured(self, tag: str, value: float, uncertainty: float | None, quantity: str = "linear") -> None:
        """A measured value with its optional ``combinedUncertainty`` attribute (same quantity)."""
        self.leaf(tag, self.quantity(value, quantity),
                  combinedUncertainty=None if uncertainty is None else self.quantity(uncertainty, quantity))
