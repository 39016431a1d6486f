"""How a caller sets a reader's option, for the messages that ask for it.

The readers of this package never guess a unit or a limit: when a file does not say, or is
larger than allowed, the message names the setting that would say it.  A Python caller writes
``units='mm'``, the ``pcmm`` command line ``--units mm``.  So the readers take
``spell_setting``, a function ``(parameter, value) -> text`` that spells a reader parameter
(and a value of it) the caller's way; :func:`python_setting` is the default.

Examples
--------
>>> python_setting("units", "mm"), python_setting("max_bytes")
("units='mm'", 'max_bytes')
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

__all__ = ["DEFAULT_MAX_TEXT_BYTES", "SpellSetting", "check_size", "python_setting"]

#: default largest DMIS output or CALYPSO table read (bytes): each statement becomes Python
#: objects of some 60 times its size, so a text file is bounded lower than a QIF point cloud
DEFAULT_MAX_TEXT_BYTES = 32 << 20

#: ``spell(parameter, value=None) -> text``: how the caller sets the reader parameter ``parameter``
SpellSetting = Callable[..., str]


def python_setting(parameter: str, value: str | None = None) -> str:
    """The Python keyword spelling: ``units='mm'``, or ``units`` without a value."""
    return parameter if value is None else f"{parameter}={value!r}"


def check_size(path: str | Path, max_bytes: int, spell_setting: SpellSetting = python_setting) -> None:
    """Refuse a file larger than ``max_bytes`` before reading it (a missing file is left to the reader).

    Raises
    ------
    FileFormatError
        The file exceeds the limit; the message names the setting that raises it.
    """
    from pcmm_geo.errors import FileFormatError

    try:
        size = os.stat(path).st_size
    except OSError:
        return
    if size > max_bytes:
        raise FileFormatError(str(path), f"file of {size} bytes exceeds the limit of {max_bytes} bytes "
                              f"(raise {spell_setting('max_bytes')} for larger files)")
