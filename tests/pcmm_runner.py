"""``pcmm`` run inside the test process: the exit code, stdout and stderr a pipe would receive, no child process.

A child process costs an interpreter start with numpy, scipy and pcmm_geo imported again (about 0.5 s
of CPU), and open3d, trimesh or matplotlib imported again where the command needs them (1-2 s); the
command-line tests started some 300 of them.  :func:`run_pcmm` calls :func:`pcmm_geo.cli.main`
instead, as many tests here already do, with

* stdout and stderr captured as text (neither is a terminal, as for a pipe) and an empty stdin;
* the warning filters a fresh interpreter starts with, plus the suite's rule that the library never
  uses its own deprecated names (an error, as pyproject's ``filterwarnings`` says);
* ``cwd`` and ``env`` applied for the call and restored after it;
* ``SystemExit`` (argparse's usage errors) turned into its exit code, and any other exception that
  escapes ``main`` printed as a traceback with exit code 1, as the interpreter would.

Tests that need a real process still start one: signals and kills, terminals, the console script and
``python -m pcmm_geo``, what a fresh interpreter imports, dask's local cluster of worker processes
and the pseudo-terminal transport.
"""

from __future__ import annotations

import contextlib
import io
import os
import subprocess
import sys
import traceback
import warnings
from collections.abc import Iterator, Mapping

from pcmm_geo.cli import main


def _fresh_interpreter_warning_filters() -> None:
    """The filters of ``python`` started without ``-W`` (CPython's defaults), and the suite's deprecation rule."""
    warnings.resetwarnings()
    warnings.filterwarnings("default", category=DeprecationWarning, module="__main__")
    for category in (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning):
        warnings.filterwarnings("ignore", category=category, append=True)
    warnings.filterwarnings("error", message=".*deprecated since pcmm_geo", category=DeprecationWarning)


@contextlib.contextmanager
def _environment(env: Mapping[str, str]) -> Iterator[None]:
    saved = dict(os.environ)
    os.environ.clear()
    os.environ.update(env)
    try:
        yield
    finally:
        os.environ.clear()
        os.environ.update(saved)


def _exit_code(exc: SystemExit, stderr: io.StringIO) -> int:
    if exc.code is None:
        return 0
    if isinstance(exc.code, int):
        return exc.code
    print(exc.code, file=stderr)  # sys.exit("message"): printed, exit status 1
    return 1


def run_pcmm(
    *args: str | os.PathLike[str], cwd: str | os.PathLike[str] | None = None, env: Mapping[str, str] | None = None
) -> subprocess.CompletedProcess[str]:
    """Run ``pcmm ARGS`` in this process; the result reads like that of ``subprocess.run(..., text=True)``.

    Parameters
    ----------
    *args
        The command line after ``pcmm`` (paths are converted with ``os.fspath``).
    cwd : path, optional
        Working directory for the call.
    env : mapping, optional
        The whole environment for the call (as ``subprocess.run``'s ``env``).

    Returns
    -------
    subprocess.CompletedProcess
        ``args`` (``["pcmm", ...]``), ``returncode``, ``stdout`` and ``stderr`` (str).
    """
    argv = [os.fspath(arg) for arg in args]
    stdout, stderr = io.StringIO(), io.StringIO()
    saved_stdin = sys.stdin
    with contextlib.ExitStack() as stack:
        if cwd is not None:
            stack.enter_context(contextlib.chdir(cwd))
        if env is not None:
            stack.enter_context(_environment(env))
        stack.enter_context(warnings.catch_warnings())
        _fresh_interpreter_warning_filters()
        stack.enter_context(contextlib.redirect_stdout(stdout))
        stack.enter_context(contextlib.redirect_stderr(stderr))
        sys.stdin = io.StringIO()
        try:
            code = main(argv)
        except SystemExit as exc:
            code = _exit_code(exc, stderr)
        except Exception:  # what the interpreter prints for an uncaught exception
            traceback.print_exc(file=stderr)
            code = 1
        finally:
            sys.stdin = saved_stdin
    return subprocess.CompletedProcess(["pcmm", *argv], 0 if code is None else int(code), stdout.getvalue(),
                                       stderr.getvalue())
