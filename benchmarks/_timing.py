"""Wall-clock timing helpers for the benchmarks (best of N, as for ``timeit``)."""

from __future__ import annotations

import gc
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Timing:
    """Best and all wall-clock times of repeated calls, seconds, plus the last return value."""

    best: float
    runs: tuple[float, ...]
    value: Any

    @property
    def median(self) -> float:
        """Median of the runs (s)."""
        ordered = sorted(self.runs)
        middle = len(ordered) // 2
        return ordered[middle] if len(ordered) % 2 else (ordered[middle - 1] + ordered[middle]) / 2


def best_of(function: Callable[[], Any], repeat: int) -> Timing:
    """Call ``function`` ``repeat`` times (garbage collector paused) and keep the fastest run.

    The minimum is the least disturbed by other processes on a shared machine.
    """
    runs = []
    value = None
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        for _ in range(max(1, repeat)):
            start = time.perf_counter()
            value = function()
            runs.append(time.perf_counter() - start)
    finally:
        if was_enabled:
            gc.enable()
    return Timing(best=min(runs), runs=tuple(runs), value=value)


def interleaved(functions: Sequence[Callable[[], Any]], repeat: int) -> list[Timing]:
    """Best of ``repeat`` rounds, each round calling every function once in turn (collector paused).

    On a shared machine the contenders then see the same load, so the ratio of their best
    times means something even when the times themselves do not.
    """
    runs: list[list[float]] = [[] for _ in functions]
    values: list[Any] = [None] * len(functions)
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        for _ in range(max(1, repeat)):
            for number, function in enumerate(functions):
                start = time.perf_counter()
                values[number] = function()
                runs[number].append(time.perf_counter() - start)
    finally:
        if was_enabled:
            gc.enable()
    return [Timing(best=min(times), runs=tuple(times), value=value) for times, value in zip(runs, values, strict=True)]
