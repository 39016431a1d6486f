"""Validate a QIF file against the QIF 3.0 XML schema with lxml (libxml2).

The schema is not bundled with pcmm_geo: pass the folder holding ``QIFDocument.xsd`` (the QIF
3.0 schema as published by the Digital Metrology Standards Consortium in its public
qif-community repository, ``bindings/CPP-Kramer/schema``, Boost Software License).  libxml2
checks the schema's keys and key references too (``xmlschema`` reports false key-reference
errors on QIF's multi-line selectors).

The file is parsed without DTDs, entities or network access (``resolve_entities=False``,
``no_network=True``, ``load_dtd=False``) and within ``max_bytes``; it is untrusted here as well.
"""

from __future__ import annotations

import os
from functools import lru_cache
from pathlib import Path
from typing import Any

from pcmm_geo._optional import require
from pcmm_geo.errors import FileFormatError, InvalidInputError, UnsafeXmlError
from pcmm_geo.io.cmm.qif._xml import DEFAULT_MAX_BYTES

__all__ = ["validate_qif"]


@lru_cache(maxsize=4)
def _schema(entry: str) -> Any:
    etree = require("lxml.etree", purpose="validating QIF files against the QIF 3.0 schema")
    parser = etree.XMLParser(resolve_entities=False, no_network=True)
    return etree.XMLSchema(etree.parse(entry, parser))


def validate_qif(path: str | Path, schema_dir: str | Path, *, max_bytes: int = DEFAULT_MAX_BYTES) -> tuple[str, ...]:
    """Schema errors of a QIF file (empty when it is valid QIF 3.0).

    Parameters
    ----------
    path : str or Path
        The QIF file.
    schema_dir : str or Path
        Folder holding ``QIFDocument.xsd`` and the files it includes.
    max_bytes : int
        Largest file accepted.

    Returns
    -------
    tuple of str
        ``"line N: message"`` per error, in file order; ``()`` when the file is valid.

    Raises
    ------
    InvalidInputError
        ``schema_dir`` holds no ``QIFDocument.xsd``.
    UnsafeXmlError
        The file is larger than ``max_bytes`` or has a DTD.
    FileFormatError
        The file is not well-formed XML or cannot be read.
    MissingDependencyError
        lxml is not installed (``pip install 'pcmm_geo[qif]'``).

    Examples
    --------
    >>> from pathlib import Path
    >>> tests = Path(__file__).resolve().parents[3] / "tests" / "data" / "qif"
    >>> validate_qif(tests / "samples" / "QIF_PTS_SAMPLE.QIF", tests / "xsd")  # doctest: +SKIP
    ()
    """
    entry = Path(schema_dir) / "QIFDocument.xsd"
    if not entry.is_file():
        raise InvalidInputError("schema_dir", "a folder holding QIFDocument.xsd (the QIF 3.0 schema)",
                                str(schema_dir))
    schema = _schema(str(entry.resolve()))
    etree = require("lxml.etree", purpose="validating QIF files against the QIF 3.0 schema")
    name = str(path)
    try:
        size = os.stat(path).st_size
    except OSError as exc:
        raise FileFormatError(name, f"cannot be read: {exc.strerror or exc}") from None
    if size > max_bytes:
        raise UnsafeXmlError(name, f"file of {size} bytes exceeds the limit of {max_bytes} bytes", limit=max_bytes)
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, huge_tree=True)
    try:
        document = etree.parse(name, parser)
    except etree.XMLSyntaxError as exc:
        raise FileFormatError(name, f"not well-formed XML: {exc.msg}", exc.lineno) from None
    except OSError as exc:
        raise FileFormatError(name, f"cannot be read: {exc}") from None
    if document.docinfo.internalDTD is not None or document.docinfo.system_url:
        raise UnsafeXmlError(name, "has a document type declaration (DTD); refused")
    if schema.validate(document):
        return ()
    return tuple(f"line {error.line}: {error.message}" for error in schema.error_log)
