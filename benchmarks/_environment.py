"""What a benchmark figure depends on besides the code: cores, load, thread settings.

Every figure of ``benchmarks/run.py`` carries a :func:`snapshot` taken just before and one
taken just after its case: the core counts, the load average (``os.getloadavg``: runnable
processes averaged over 1, 5 and 15 minutes), the thread variables of the BLAS and OpenMP
libraries and, when ``threadpoolctl`` is installed (the ``bench`` extra), the thread pools
actually loaded in the process.  A figure counts as a quiet-machine figure only when the
1-minute load stayed below :data:`QUIET_LOAD` per core during its case.
"""

from __future__ import annotations

import os
import platform
from typing import Any

#: environment variables that set the thread count of BLAS / OpenMP / MKL (read at library load)
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
#: 1-minute load average per core below which a machine counts as quiet
QUIET_LOAD = 0.25
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


def snapshot() -> dict[str, Any]:
    """Cores, load average and thread settings now."""
    return {
        "logical_cores": os.cpu_count(),
        "usable_cores": usable_cores(),
        "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
        "thread_variables": {name: os.environ.get(name) for name in THREAD_VARIABLES},
        "thread_pools": thread_pools(),
    }


def is_quiet(before: dict[str, Any], after: dict[str, Any]) -> bool | None:
    """True when the 1-minute load stayed below ``QUIET_LOAD`` per core (None when the OS gives no load)."""
    if before.get("load_average") is None or after.get("load_average") is None:
        return None
    cores = max(1, int(before.get("usable_cores") or 1))
    return max(before["load_average"][0], after["load_average"][0]) < QUIET_LOAD * cores


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
    """``0.12 -> 0.35`` (1-minute load average before and after)."""
    if before.get("load_average") is None or after.get("load_average") is None:
        return "unknown"
    return f"{before['load_average'][0]:.2f} -> {after['load_average'][0]:.2f}"


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
