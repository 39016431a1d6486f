"""Writing output files whole or not at all, never replacing a file unless asked.

The content goes to a temporary file in the target's folder, is flushed and fsync'ed, and
only then takes the target's name: with ``overwrite`` by ``os.replace`` (atomic on POSIX and
Windows), without it by ``os.link`` (atomic, fails if the name exists).  A failure at any
point leaves the target as it was and no temporary file behind.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO

from pcmm_geo.errors import OutputExistsError

__all__ = ["atomic_output", "write_atomic"]


@contextlib.contextmanager
def atomic_output(path: str | Path, *, overwrite: bool = False) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success it becomes ``path`` (see the module notes).

    Raises
    ------
    OutputExistsError
        ``path`` exists (before or after the content is written) and ``overwrite`` is False.

    Examples
    --------
    >>> import os, tempfile
    >>> target = os.path.join(tempfile.mkdtemp(), "out.txt")
    >>> with atomic_output(target) as temporary:
    ...     _ = temporary.write_text("whole\\n")
    >>> open(target).read()
    'whole\\n'
    >>> try:
    ...     with atomic_output(target) as temporary:
    ...         _ = temporary.write_text("other\\n")
    ... except OutputExistsError:
    ...     print(open(target).read().strip())
    whole
    """
    target = Path(path)
    if target.exists() and not overwrite:
        raise OutputExistsError(str(target))
    folder = target.parent if str(target.parent) else Path(".")
    folder.mkdir(parents=True, exist_ok=True)
    handle, name = tempfile.mkstemp(prefix=f".{target.stem}-", suffix=f".tmp{target.suffix}", dir=folder)
    os.close(handle)
    temporary = Path(name)
    os.chmod(temporary, 0o666 & ~_umask())  # mkstemp makes 0600; give the file the usual permissions
    try:
        yield temporary
        with open(temporary, "rb+") as stream:
            os.fsync(stream.fileno())
        if overwrite:
            os.replace(temporary, target)
        else:
            try:
                os.link(temporary, target)
            except FileExistsError:
                raise OutputExistsError(str(target)) from None
            except OSError:  # no hard links on this file system: check, then rename
                if target.exists():
                    raise OutputExistsError(str(target)) from None
                os.replace(temporary, target)
    finally:
        with contextlib.suppress(FileNotFoundError):
            temporary.unlink()


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def write_atomic(path: str | Path, content: bytes | str | Callable[[IO[bytes]], None], *,
                 overwrite: bool = False) -> Path:
    """Write ``content`` (bytes, UTF-8 text, or a callable writing to a binary stream) to ``path`` whole.

    Raises
    ------
    OutputExistsError
        ``path`` exists and ``overwrite`` is False.
    """
    target = Path(path)
    with atomic_output(target, overwrite=overwrite) as temporary, open(temporary, "wb") as stream:
        if callable(content):
            content(stream)
        else:
            stream.write(content.encode("utf-8") if isinstance(content, str) else content)
    return target
