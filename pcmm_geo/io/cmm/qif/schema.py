"""Validate a QIF file against the QIF 3.0 XML schema with lxml (libxml2).

The QIF 3.0 schema travels with pcmm_geo as package data (``pcmm_geo/data/qif-3.0-xsd``: the
schema as published by the Digital Metrology Standards Consortium in its public qif-community
repository, ``bindings/CPP-Kramer/schema``, under the Boost Software License, whose text lies
beside it); ``schema_dir`` points at another copy.  libxml2 checks the schema's keys and key
references too (``xmlschema`` reports false key-reference errors on QIF's multi-line selectors).
The schema's import of the W3C signature schema names a web address: it is skipped, never fetched.

The file is untrusted here as well: within ``max_bytes``, it is first read by defusedxml's expat
parser (no DTD, so no entity and nothing external; depth and well-formedness checked, each
refusal with its line), and only then parsed by libxml2, still without DTDs, entities or
network access (``resolve_entities=False``, ``no_network=True``, ``load_dtd=False``).
"""

from __future__ import annotations

from functools import lru_cache
from importlib.resources import files
from pathlib import Path
from typing import Any, BinaryIO

from pcmm_geo._optional import require
from pcmm_geo.errors import FileFormatError, InvalidInputError, UnsafeXmlError
from pcmm_geo.io.cmm.qif._xml import DEFAULT_MAX_BYTES, DEFAULT_MAX_ELEMENTS, open_xml
from pcmm_geo.io.cmm.settings import SpellSetting, python_setting

__all__ = ["bundled_schema_dir", "validate_qif"]

#: libxml2's deepest element nesting (with ``huge_tree``); deeper documents are refused as hostile
_LIBXML2_MAX_DEPTH = 2048
_CHUNK = 1 << 20


def bundled_schema_dir() -> Path:
    """Folder of the QIF 3.0 schema shipped with pcmm_geo (``QIFDocument.xsd`` and the files it includes).

    Raises
    ------
    InvalidInputError
        The package is installed where its data are not plain files (a zip archive): pass ``schema_dir``.

    Examples
    --------
    >>> folder = bundled_schema_dir()
    >>> (folder / "QIFDocument.xsd").is_file(), (folder / "LICENSE.md").is_file()
    (True, True)
    """
    folder = Path(str(files("pcmm_geo").joinpath("data", "qif-3.0-xsd")))
    if not (folder / "QIFDocument.xsd").is_file():
        raise InvalidInputError("schema_dir", "a folder holding QIFDocument.xsd (pcmm_geo's own copy is not a "
                                "plain file here)", str(folder))
    return folder


@lru_cache(maxsize=4)
def _schema(entry: str) -> Any:
    etree = require("lxml.etree", purpose="validating QIF files against the QIF 3.0 schema")
    parser = etree.XMLParser(resolve_entities=False, no_network=True)
    return etree.XMLSchema(etree.parse(entry, parser))


def validate_qif(path: str | Path, schema_dir: str | Path | None = None, *,
                 max_bytes: int = DEFAULT_MAX_BYTES, spell_setting: SpellSetting = python_setting,
                 max_elements: int = DEFAULT_MAX_ELEMENTS) -> tuple[str, ...]:
    """Schema errors of a QIF file (empty when it is valid QIF 3.0).

    Parameters
    ----------
    path : str or Path
        The QIF file.
    schema_dir : str or Path, optional
        Folder holding ``QIFDocument.xsd`` and the files it includes; default: the copy shipped
        with pcmm_geo (:func:`bundled_schema_dir`).
    max_bytes : int
        Largest file accepted.
    max_elements : int
        Most elements accepted (counted by the screening pass before libxml2 builds its tree).
    spell_setting : callable
        How a size refusal names ``max_bytes`` (:mod:`pcmm_geo.io.cmm.settings`).

    Returns
    -------
    tuple of str
        ``"line N: message"`` per error, in file order; ``()`` when the file is valid.

    Raises
    ------
    InvalidInputError
        ``schema_dir`` holds no ``QIFDocument.xsd``.
    UnsafeXmlError
        The file is larger than ``max_bytes``, has a DTD or nests deeper than libxml2 accepts (2048).
    FileFormatError
        The file is not well-formed XML or cannot be read.
    MissingDependencyError
        lxml is not installed (``pip install 'pcmm_geo[qif]'``).

    Examples
    --------
    >>> from importlib.resources import files
    >>> validate_qif(files("pcmm_geo") / "data/appendix_cd/cmm_export.qif")  # doctest: +SKIP
    ()
    """
    if schema_dir is None:
        schema_dir = bundled_schema_dir()
    entry = Path(schema_dir) / "QIFDocument.xsd"
    if not entry.is_file():
        raise InvalidInputError("schema_dir", "a folder holding QIFDocument.xsd (the QIF 3.0 schema)",
                                str(schema_dir))
    schema = _schema(str(entry.resolve()))
    etree = require("lxml.etree", purpose="validating QIF files against the QIF 3.0 schema")
    name = str(path)
    # the bytes are read here from a regular file and handed over as a stream: neither the screen
    # (xml.sax) nor libxml2 ever sees a path, which they could take for a URL and fetch
    with open_xml(path, max_bytes, spell_setting) as stream:
        _screen(name, stream, max_elements, spell_setting("max_elements"))
        stream.seek(0)
        parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, huge_tree=True)
        try:
            document = etree.parse(stream, parser)
        except etree.XMLSyntaxError as exc:
            if "Excessive depth" in str(exc.msg):
                raise UnsafeXmlError(name, f"elements nested deeper than {_LIBXML2_MAX_DEPTH}; refused",
                                     line=exc.lineno, limit=_LIBXML2_MAX_DEPTH) from None
            raise FileFormatError(name, f"not well-formed XML: {exc.msg}", exc.lineno) from None
        except OSError as exc:
            raise FileFormatError(name, f"cannot be read: {exc}") from None
    if schema.validate(document):
        return ()
    return tuple(f"line {error.line}: {error.message}" for error in schema.error_log)


def _screen(name: str, stream: BinaryIO, max_elements: int = DEFAULT_MAX_ELEMENTS,
            elements_setting: str = "max_elements") -> None:
    """Read the file once with defusedxml's expat parser before libxml2 sees it.

    A document type declaration (so any entity or external reference), nesting deeper than
    libxml2 accepts, more than ``max_elements`` elements, or XML that is not well formed is refused
    here with its line; the element events are counted, nothing is kept.
    """
    expatreader = require("defusedxml.expatreader", purpose="reading untrusted QIF files safely")
    defused = require("defusedxml", purpose="reading untrusted QIF files safely")
    # only the exception and the handler base class come from xml.sax; the parser is defusedxml's
    from xml.sax import SAXParseException
    from xml.sax.handler import ContentHandler

    parser = expatreader.create_parser(forbid_dtd=True, forbid_entities=True, forbid_external=True)

    class Depth(ContentHandler):
        level = 0
        elements = 0

        def startElementNS(self, element: object, qualified: object, attributes: object) -> None:
            self.level += 1
            self.elements += 1
            if self.elements > max_elements:
                raise UnsafeXmlError(name, f"more than {max_elements} elements; refused (raise {elements_setting} "
                                     "for larger files)", line=parser.getLineNumber(), limit=max_elements)
            if self.level > _LIBXML2_MAX_DEPTH:
                raise UnsafeXmlError(name, f"elements nested deeper than {_LIBXML2_MAX_DEPTH}; refused",
                                     line=parser.getLineNumber(), limit=_LIBXML2_MAX_DEPTH)

        def endElementNS(self, element: object, qualified: object) -> None:
            self.level -= 1

    parser.setFeature("http://xml.org/sax/features/namespaces", True)
    parser.setContentHandler(Depth())
    try:
        while chunk := stream.read(_CHUNK):
            parser.feed(chunk)
        parser.close()
    except defused.DTDForbidden:
        raise UnsafeXmlError(name, "has a document type declaration (DTD); refused",
                             line=parser.getLineNumber()) from None
    except SAXParseException as exc:
        raise FileFormatError(name, f"not well-formed XML: {exc.getMessage()}", exc.getLineNumber()) from None
    except OSError as exc:
        raise FileFormatError(name, f"cannot be read: {exc.strerror or exc}") from None
    except LookupError as exc:  # expat asks Python for the codec the XML declaration names
        raise FileFormatError(name, f"the XML declaration names an encoding Python does not know ({exc})",
                              parser.getLineNumber()) from None
