"""What a benchmark figure depends on besides the code: cores, load, thread settings.

Every figure of ``benchmarks/run.py`` carries a :func:`snapshot` taken just before and one
taken just after its case: the core counts, the load average (``os.getloadavg``: runnable
processes averaged over 1, 5 and 15 minutes), the machine's busy CPU time and this process's
own (with its waited-for children), the thread variables of the BLAS and OpenMP libraries and,
when ``threadpoolctl`` is installed (the ``bench`` extra), the thread pools actually loaded in
the process.

The load average counts the benchmark itself (a one-thread case alone makes the 1-minute load
about 1), so it cannot tell a quiet machine from a busy one during a case.  A figure counts as a
quiet-machine figure when the CPU time that *other* processes used during its case (the
machine's busy time from ``/proc/stat`` less this process's and its children's) stays below
:data:`QUIET_SHARE` of the case's wall time times the usable cores, and the 1-minute load before
the case, less what this run's own previous work explains, is recorded beside it.
"""

from __future__ import annotations

import os
import platform
import time
from typing import Any

#: environment variables that set the thread count of BLAS / OpenMP / MKL (read at library load)
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
#: 1-minute load average per core below which a machine counts as quiet before a run starts
QUIET_LOAD = 0.25
#: share of the case's CPU capacity (wall time x usable cores) other processes may use on a quiet machine
QUIET_SHARE = 0.05
#: the thread modes of a run: each contender on one thread, or as each library chooses
MODES = ("single", "default")


def single_thread_environment(base: dict[str, str] | None = None) -> dict[str, str]:
    """``base`` (default ``os.environ``) with every thread variable set to 1."""
    environment = dict(os.environ if base is None else base)
    environment.update({name: "1" for name in THREAD_VARIABLES})
    return environment


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity where the OS tells it)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def thread_pools() -> list[dict[str, Any]] | None:
    """threadpoolctl's view of the loaded BLAS / OpenMP pools (API, library, version, threads); None without it."""
    try:
        from threadpoolctl import threadpool_info
    except ImportError:
        return None
    keys = ("user_api", "internal_api", "version", "num_threads", "threading_layer")
    return [{key: pool.get(key) for key in keys} for pool in threadpool_info()]


def machine_busy_seconds() -> float | None:
    """CPU seconds all processes have spent busy since boot (``/proc/stat``; None off Linux)."""
    try:
        with open("/proc/stat") as handle:
            fields = handle.readline().split()
    except OSError:
        return None
    ticks = [int(v) for v in fields[1:]]
    idle = ticks[3] + (ticks[4] if len(ticks) > 4 else 0)  # idle + iowait
    guest = sum(ticks[8:10]) if len(ticks) > 9 else 0  # already counted in user / nice
    return (sum(ticks) - idle - guest) / os.sysconf("SC_CLK_TCK")


def own_busy_seconds() -> float:
    """CPU seconds of this process and its waited-for children (user + system)."""
    times = os.times()
    return times.user + times.system + times.children_user + times.children_system


def snapshot() -> dict[str, Any]:
    """Cores, load average, busy CPU time (machine and own) and thread settings now."""
    return {
        "logical_cores": os.cpu_count(),
        "usable_cores": usable_cores(),
        "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
        "wall_s": time.monotonic(),
        "machine_busy_s": machine_busy_seconds(),
        "own_busy_s": own_busy_seconds(),
        "thread_variables": {name: os.environ.get(name) for name in THREAD_VARIABLES},
        "thread_pools": thread_pools(),
    }


def others_share(before: dict[str, Any], after: dict[str, Any]) -> float | None:
    """Share of the case's CPU capacity used by other processes (None when the OS does not tell)."""
    if before.get("machine_busy_s") is None or after.get("machine_busy_s") is None:
        return None
    wall = after["wall_s"] - before["wall_s"]
    cores = max(1, int(before.get("usable_cores") or 1))
    others = (after["machine_busy_s"] - before["machine_busy_s"]) - (after["own_busy_s"] - before["own_busy_s"])
    return max(0.0, others) / (wall * cores) if wall > 0 else None


def is_quiet(before: dict[str, Any], after: dict[str, Any]) -> bool | None:
    """True when other processes used less than ``QUIET_SHARE`` of the CPU during the case."""
    share = others_share(before, after)
    return None if share is None else share < QUIET_SHARE


def describe_threads(state: dict[str, Any]) -> str:
    """``OPENBLAS_NUM_THREADS=1, ...; openblas 0.3.31 2 threads`` (unset variables omitted)."""
    variables = ", ".join(f"{name}={value}" for name, value in state["thread_variables"].items() if value is not None)
    pools = state.get("thread_pools")
    if pools is None:
        pool_text = "threadpoolctl not installed"
    else:
        pool_text = ", ".join(f"{pool['internal_api']} {pool['version']} {pool['num_threads']} threads"
                              for pool in pools) or "no BLAS/OpenMP pool loaded"
    return f"{variables or 'no thread variable set'}; {pool_text}"


def describe_load(before: dict[str, Any], after: dict[str, Any]) -> str:
    """``0.12 -> 0.35; others 0.4 %`` (1-minute load before and after; other processes' CPU share)."""
    if before.get("load_average") is None or after.get("load_average") is None:
        return "unknown"
    share = others_share(before, after)
    others = "" if share is None else f"; others {100.0 * share:.1f} %"
    return f"{before['load_average'][0]:.2f} -> {after['load_average'][0]:.2f}{others}"


def machine_description() -> str:
    """One line: CPU, core counts, OS, Python and numpy versions."""
    import numpy as np

    cpu = platform.processor() or "unknown CPU"
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as handle:
            for line in handle:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return (f"{cpu}, {os.cpu_count()} logical cores ({usable_cores()} usable), {platform.system()} "
            f"{platform.release()}, Python {platform.python_version()}, numpy {np.__version__}")


def environment_line() -> str:
    """One line for a script's output: cores, 1-minute load average now, thread settings."""
    state = snapshot()
    load = "unknown" if state["load_average"] is None else f"{state['load_average'][0]:.2f}"
    return (f"environment: {state['logical_cores']} logical cores ({state['usable_cores']} usable), "
            f"1-min load {load}; {describe_threads(state)}")
