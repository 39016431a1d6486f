"""Reading untrusted text files: the public face of the helpers every reader of pcmm_geo uses.

Other packages (the calibration files, the artefact tables, log processing, the command line)
read their text through these names instead of reaching into :mod:`pcmm_geo.io`'s private
modules, where they are implemented:

:func:`read_text_lines`, :func:`iter_text_lines`, :func:`read_text_file`
    Decode a text file line by line; a binary file, bytes that are not UTF-8, a directory or an
    over-long line is one :class:`~pcmm_geo.errors.FileFormatError` naming file and line.

:func:`read_csv_rows`, :class:`CsvRows`
    CSV rows with the same checks (fields at most :data:`MAX_FIELD_CHARS`).

:func:`parse_decimal`
    An ASCII decimal number (stricter than ``float``).

:func:`read_json_file`, :class:`JsonNode`, :func:`describe_json`
    Strict JSON (no NaN, no duplicate keys, depth at most :data:`MAX_JSON_DEPTH`) and checks of its fields.

:func:`excerpt`
    A short quote of offending text for messages.

:func:`open_regular`, :func:`refuse_irregular`
    Open / refuse what is not a regular file (a FIFO would block a reader forever).

:func:`iter_blocks`, :func:`decode_block`, :class:`LineBlock`, :func:`text_codec`
    The bounded blocks the line readers are built on.

Examples
--------
>>> excerpt("x" * 100)[-16:], parse_decimal("-1.5")
('(100 characters)', -1.5)
"""

from __future__ import annotations

from pcmm_geo.io._json import JsonNode, describe_json
from pcmm_geo.io._lines import LineBlock, decode_block, iter_blocks, open_regular, refuse_irregular, text_codec
from pcmm_geo.io._text import (
    EXCERPT_CHARS,
    MAX_FIELD_CHARS,
    MAX_JSON_DEPTH,
    MAX_LINE_CHARS,
    CsvRows,
    excerpt,
    iter_text_lines,
    parse_decimal,
    read_csv_rows,
    read_json_file,
    read_text_file,
    read_text_lines,
)

__all__ = [
    "EXCERPT_CHARS",
    "MAX_FIELD_CHARS",
    "MAX_JSON_DEPTH",
    "MAX_LINE_CHARS",
    "CsvRows",
    "JsonNode",
    "LineBlock",
    "decode_block",
    "describe_json",
    "excerpt",
    "iter_blocks",
    "iter_text_lines",
    "open_regular",
    "parse_decimal",
    "read_csv_rows",
    "read_json_file",
    "read_text_file",
    "read_text_lines",
    "refuse_irregular",
    "text_codec",
]
