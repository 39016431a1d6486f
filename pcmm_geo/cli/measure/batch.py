"""``pcmm batch TASK FILE...``: evaluate many files over a Dask cluster, one JSON line per file.

Each file is evaluated by the sub-command that evaluates one file (``pcmm fit ELEMENT``,
``pcmm gauge-block``, ``pcmm compare``), run on a worker of a ``dask.distributed`` cluster:
the one at ``--scheduler ADDRESS``, or a local cluster of ``--workers`` processes (one
thread each) started for the batch and closed after it.  As files finish, one JSON object
per line is printed on stdout (in completion order; file names as given, which with
``--scheduler`` must name the files on the workers)::

    {"file": "a.csv", "task": "fit-sphere", "ok": true, "seconds": 0.12, "result": {...}}
    {"file": "b.csv", "task": "fit-sphere", "ok": false, "error": {"type": "DegenerateGeometryError", ...}}

The ``result`` is what ``pcmm <sub-command> --json`` prints for that file.  A file that
fails is reported with its error and the batch goes on.  Exit code: 0 when every file was
evaluated, 1 when at least one failed, 2 for bad arguments (no file evaluated).  A progress
bar is drawn on stderr when it is a terminal.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import logging
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from pcmm_geo._optional import require
from pcmm_geo.cli._output import EXIT_FAILURE, EXIT_OK, Report, refuse_renamed_options, to_jsonable
from pcmm_geo.elements import ELEMENTS

FIT_ELEMENTS = ELEMENTS
TASKS = (*(f"fit-{element}" for element in FIT_ELEMENTS), "gauge-block", "compare")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "batch",
        help="evaluate many files (fits, gauge blocks, CAD comparison) over a Dask cluster, JSON lines out",
        description=(
            "Evaluate every FILE with the TASK's sub-command (fit-ELEMENT: pcmm fit ELEMENT; gauge-block; "
            "compare: pcmm compare FILE with --mesh MESH or --nominal SPEC) on a dask.distributed cluster, "
            "and print one JSON line per file as it finishes: {file, task, ok, seconds, result} or "
            "{file, task, ok: false, error}.  A failed file does not stop the batch.  Exit code 0 when all "
            "files were evaluated, 1 when any failed."
        ),
    )
    parser.add_argument("task", choices=TASKS, help="what to evaluate in each file")
    parser.add_argument("files", nargs="+", type=Path, metavar="FILE", help="input files (one evaluation each)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="address of a running dask scheduler, e.g. tcp://10.0.0.5:8786 (default: start a "
                             "local cluster for the batch)")
    parser.add_argument("--workers", type=int, default=2,
                        help="worker processes of the local cluster (default 2, one thread each)")
    parser.add_argument("--radius-mm", dest="radius", type=float, help="fit-circle/sphere/cylinder: fixed radius (mm)")
    parser.add_argument("--mesh", type=Path, help="compare: nominal mesh .stl/.obj/.ply (mm)")
    parser.add_argument("--nominal", metavar="SPEC", help="compare: nominal primitive (see pcmm compare)")
    parser.add_argument("--tolerance-mm", dest="tolerance", type=float, metavar="MM",
                        help="compare: symmetric deviation tolerance")
    refuse_renamed_options(parser, {"--radius": "--radius-mm", "--tolerance": "--tolerance-mm"})
    parser.set_defaults(handler=handle)


def command_line(task: str, file: str, options: dict[str, Any]) -> list[str]:
    """The ``pcmm`` arguments that evaluate one file (the sub-command's own parser checks them).

    Examples
    --------
    >>> command_line("fit-sphere", "ball.csv", {"radius": 12.5})
    ['fit', 'sphere', 'ball.csv', '--radius-mm', '12.5']
    >>> command_line("compare", "scan.ply", {"nominal": "box:100x35x9"})
    ['compare', 'scan.ply', '--nominal', 'box:100x35x9']
    """
    if task.startswith("fit-"):
        argv = ["fit", task.removeprefix("fit-"), file]
        if options.get("radius") is not None:
            argv += ["--radius-mm", repr(float(options["radius"]))]
        return argv
    if task == "gauge-block":
        return ["gauge-block", file]
    argv = ["compare", file]
    if options.get("mesh") is not None:
        argv.append(str(options["mesh"]))
    if options.get("nominal") is not None:
        argv += ["--nominal", str(options["nominal"])]
    if options.get("tolerance") is not None:
        argv += ["--tolerance-mm", repr(float(options["tolerance"]))]
    return argv


def evaluate_file(task: str, file: str, options: dict[str, Any]) -> dict[str, Any]:
    """Evaluate one file as its sub-command would (on a worker); never raises: errors become the record."""
    from pcmm_geo.cli import build_parser

    started = time.perf_counter()
    record: dict[str, Any] = {"file": file, "task": task}
    try:
        args = build_parser().parse_args(command_line(task, file, options))
        args.json, args.plot, args.report, args.overwrite = True, None, None, False
        report = args.handler(args)
        record.update(ok=True, seconds=time.perf_counter() - started, result=to_jsonable(report.data))
    except SystemExit as exc:  # argparse refused the arguments
        record.update(ok=False, error={"type": "UsageError", "message": f"invalid arguments (exit {exc.code})"})
    except Exception as exc:  # any failure of one file is reported, never fatal for the batch
        record.update(ok=False, seconds=time.perf_counter() - started,
                      error={"type": type(exc).__name__, "message": str(exc)})
    return record


def handle(args: argparse.Namespace) -> Report:
    from pcmm_geo.cli._progress import progress_bar, progress_wanted
    from pcmm_geo.errors import InvalidInputError

    if args.task == "compare" and (args.mesh is None) == (args.nominal is None):
        raise InvalidInputError("--mesh / --nominal", "exactly one nominal surface for compare",
                                "both" if args.mesh is not None else "neither")
    if args.workers < 1:
        raise InvalidInputError("--workers", "at least one worker process", repr(args.workers))
    distributed = require("distributed", purpose="pcmm batch")  # MissingDependencyError names the [dask] extra
    Client, LocalCluster, as_completed = distributed.Client, distributed.LocalCluster, distributed.as_completed

    # paths go to the workers as given: a local cluster's workers share this working directory;
    # with --scheduler the files must be reachable under these names on the workers
    options = {"radius": args.radius, "mesh": None if args.mesh is None else str(args.mesh),
               "nominal": args.nominal, "tolerance": args.tolerance}
    files = [str(path) for path in args.files]
    failed = 0
    with contextlib.ExitStack() as stack:  # closed in reverse: client, cluster, then its scratch folder
        cluster = None
        if args.scheduler is None:
            # the workers' scratch space (dask-scratch-space/, lock files) in a folder of our own, removed at the
            # end: by default dask leaves it in $TMPDIR
            scratch = stack.enter_context(tempfile.TemporaryDirectory(prefix="pcmm-batch-",
                                                                      ignore_cleanup_errors=True))
            stack.enter_context(require("dask.config").set({"temporary-directory": scratch}))
            cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                                   local_directory=scratch, dashboard_address=None, silence_logs=logging.ERROR)
            stack.callback(cluster.close)
        client = Client(args.scheduler if cluster is None else cluster)
        stack.callback(client.close)
        futures = client.map(evaluate_file, [args.task] * len(files), files, [options] * len(files), pure=False)
        owner = {future.key: name for future, name in zip(futures, files, strict=True)}
        with progress_bar(f"batch {args.task}", enabled=progress_wanted(args), total=len(files)) as update:
            for done, future in enumerate(as_completed(futures), start=1):
                try:
                    record = future.result()
                except Exception as exc:  # the worker itself died: still one line for the file
                    record = {"file": owner[future.key], "task": args.task, "ok": False,
                              "error": {"type": type(exc).__name__, "message": str(exc)}}
                record["file"] = owner[future.key]  # as given on the command line
                failed += not record["ok"]
                print(json.dumps(record, allow_nan=False, default=str), flush=True)
                update(done, len(files))
    print(f"pcmm batch: {len(files) - failed} of {len(files)} files evaluated, {failed} failed", file=sys.stderr)
    return Report(data={}, exit_code=EXIT_FAILURE if failed else EXIT_OK)
