"""Progress bars on stderr for long sub-commands (rich, imported only when a bar is shown).

Library functions take a plain callback (``progress(done, total)``, some also a step text);
the CLI supplies :func:`progress_bar`'s callback.  A bar is shown only when stderr is a
terminal and ``--json`` is not given, so piped output and tests stay clean.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Callable, Iterator

#: ``update(done, total=None, text=None)``: total and text are optional (None = unchanged)
ProgressUpdate = Callable[..., None]


def progress_wanted(args: argparse.Namespace) -> bool:
    """True when a bar may be drawn: stderr is a terminal and ``--json`` is not given."""
    return not getattr(args, "json", False) and sys.stderr.isatty()


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
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        SpinnerColumn,
        TextColumn,
        TimeElapsedColumn,
    )

    columns = [SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), TimeElapsedColumn()]
    if counted:
        columns.insert(3, MofNCompleteColumn())
    with Progress(*columns, console=Console(stderr=True), transient=True) as bar:
        task = bar.add_task(description, total=total)

        def update(done: int, total: int | None = None, text: str | None = None) -> None:
            bar.update(task, completed=done, total=total, description=text or description)

        yield update
