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

from collections.abc import Callable

__all__ = ["SpellSetting", "python_setting"]

#: ``spell(parameter, value=None) -> text``: how the caller sets the reader parameter ``parameter``
SpellSetting = Callable[..., str]


def python_setting(parameter: str, value: str | None = None) -> str:
    """The Python keyword spelling: ``units='mm'``, or ``units`` without a value."""
    return parameter if value is None else f"{parameter}={value!r}"
