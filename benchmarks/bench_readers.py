"""Benchmark of the shared readers (issue 16): the Table 3.2 log reader against plain parsers, and bad input.

Reads a synthetic Table 3.2 log of ``--rows`` rows with :func:`pcmm_geo.machine.analysis.logproc.read_log`
(every check: ASCII decimals, field bounds, flags, finiteness, torn last row) and with peers that
check nothing or little: the stdlib ``csv`` module with ``float``, ``numpy.loadtxt`` and, when
installed, ``pandas.read_csv``.  Then times the refusal of a file holding one 100 MB damaged line
and of a 100 MB JSON string, and reports the length of the error message (the issue: 419 MB of
stderr before).

Run: ``.venv/bin/python benchmarks/bench_readers.py [--rows 200000] [--repeat 3] [--bad-mb 100]``.
"""

from __future__ import annotations

import argparse
import csv
import tempfile
from pathlib import Path

import numpy as np

from benchmarks._timing import best_of
from pcmm_geo.errors import FileFormatError
from pcmm_geo.machine.analysis.logproc import LOG_COLUMNS, read_log


def write_table_3_2(path: Path, rows: int, seed: int = 0) -> Path:
    rng = np.random.default_rng(seed)
    lasers = 50.0 + rng.random((rows, 3)) * 10.0
    k = np.arange(rows)
    with open(path, "w", encoding="utf-8") as handle:
        handle.write(",".join(LOG_COLUMNS) + "\n")
        handle.writelines(
            f"{1 - i % 2},{i % 2},{1 + i % 3},1,{a:.6f},{b:.6f},{c:.6f}\n"
            for i, (a, b, c) in zip(k, lasers, strict=True)
        )
    return path


def stdlib_csv(path: Path) -> np.ndarray:
    with open(path, newline="", encoding="utf-8") as handle:
        reader = csv.reader(handle)
        next(reader)
        return np.array([[float(cell) for cell in row] for row in reader])


def refusal(path: Path) -> tuple[float, int]:
    def attempt() -> int:
        try:
            read_log(path)
        except FileFormatError as exc:
            return len(str(exc))
        raise AssertionError("the damaged file was read")

    timing = best_of(attempt, 1)
    return timing.best, timing.value


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=200_000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--bad-mb", type=int, default=100, help="size of the damaged line, MB")
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="bench-readers-"))
    log = write_table_3_2(folder / "log.csv", args.rows)
    reference = stdlib_csv(log)
    print(f"Table 3.2 log: {args.rows} rows, {log.stat().st_size / 1e6:.1f} MB; best of {args.repeat}")
    print(f"{'reader':44s} {'time s':>8s} {'rows/s':>10s}  agrees")
    runs = [
        ("pcmm_geo read_log (all checks)", lambda: read_log(log)),
        ("csv.reader + float (no checks)", lambda: stdlib_csv(log)),
        ("numpy.loadtxt (numbers only)", lambda: np.loadtxt(log, delimiter=",", skiprows=1)),
    ]
    try:
        import pandas as pd

        runs.append(("pandas.read_csv (C engine)", lambda: pd.read_csv(log).to_numpy(dtype=float)))
    except ImportError:
        print("(pandas not installed: no pandas row)")
    for name, function in runs:
        timing = best_of(function, args.repeat)
        value = timing.value
        table = np.column_stack([value.start_stop, value.probe, value.motor, value.direction, value.lasers]) \
            if hasattr(value, "lasers") else value
        agrees = bool(np.array_equal(table, reference))
        print(f"{name:44s} {timing.best:8.2f} {args.rows / timing.best:10.0f}  {agrees}")

    bad = folder / "bad.csv"
    with open(bad, "wb") as handle:
        handle.write((",".join(LOG_COLUMNS) + "\n1,0,1,1,50,51,52\n").encode())
        block = b"7" * (1 << 20)
        for _ in range(args.bad_mb):
            handle.write(block)
        handle.write(b"\n")
    seconds, length = refusal(bad)
    print(f"{args.bad_mb} MB damaged line: refused in {seconds:.2f} s, message {length} characters")
    from pcmm_geo.io._text import read_json_file

    bad_json = folder / "bad.json"
    bad_json.write_bytes(b'{"schema": "' + b"x" * (args.bad_mb << 20) + b'", "a": 1e400}')
    timing = best_of(lambda: _json_refusal(read_json_file, bad_json), 1)
    print(f"{args.bad_mb} MB JSON string then 1e400: refused in {timing.best:.2f} s, message {timing.value} characters")


def _json_refusal(reader: object, path: Path) -> int:
    try:
        reader(path)  # type: ignore[operator]
    except FileFormatError as exc:
        return len(str(exc))
    raise AssertionError("the damaged JSON was read")


if __name__ == "__main__":
    main()
