"""Progress bars on stderr for long sub-commands (rich, extra ``[progress]``, imported only when a bar is shown).

Library functions take a plain callback (``progress(done, total)``, some also a step text);
the CLI supplies :func:`progress_bar`'s callback.  A bar is shown only when stderr is a
terminal and ``--json`` is not given, so piped output and tests stay clean.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Callable, Iterator

from pcmm_geo._optional import available, require

#: ``update(done, total=None, text=None)``: total and text are optional (None = unchanged)
ProgressUpdate = Callable[..., None]


def progress_wanted(args: argparse.Namespace) -> bool:
    """True when a bar may be drawn: stderr is a terminal, ``--json`` is not given and rich is installed.

    The bar is decoration (extra ``[progress]``): without rich the command runs the same, silently.
    """
    return not getattr(args, "json", False) and sys.stderr.isatty() and available("rich")


def _ignore(done: int, total: int | None = None, text: str | None = None) -> None:
    """The callback used when no bar is shown."""


@contextlib.contextmanager
def progress_bar(
    description: str, *, enabled: bool, total: int | None = None, counted: bool = True
) -> Iterator[ProgressUpdate]:
    """A transient rich bar on stderr; yields ``update(done, total=None, text=None)``.

    ``total`` may also be given (or changed) by the first update.  With ``counted=False``
    the bar shows no "done/total" count and, never updated, pulses with the elapsed time
    (work whose length the library does not report).  When ``enabled`` is False nothing is
    imported or drawn and the callback does nothing.

    Examples
    --------
    >>> with progress_bar("work", enabled=False, total=3) as update:
    ...     for done in range(1, 4):
    ...         update(done, 3)
    """
    if not enabled:
        yield _ignore
        return
    console = require("rich.console", purpose="progress bars")
    rich = require("rich.progress", purpose="progress bars")
    columns = [rich.SpinnerColumn(), rich.TextColumn("{task.description}"), rich.BarColumn(), rich.TimeElapsedColumn()]
    if counted:
        columns.insert(3, rich.MofNCompleteColumn())
    with rich.Progress(*columns, console=console.Console(stderr=True), transient=True) as bar:
        task = bar.add_task(description, total=total)

        def update(done: int, total: int | None = None, text: str | None = None) -> None:
            bar.update(task, completed=done, total=total, description=text or description)

        yield update
