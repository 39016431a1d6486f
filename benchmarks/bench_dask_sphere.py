"""Fit a sphere to a lazily generated dask array of points; print one JSON line (run in its own process).

The points are generated block by block from a seed inside the dask graph (``map_blocks``
over the block index), so the array is never held in memory; the peak resident memory of
this process (``ru_maxrss``) is reported with the fit and its throughput.  With
``--compare`` the same points are also materialised and fitted in memory, and the largest
difference of centre and radius is reported (use a size that fits in memory).

Usage::

    python benchmarks/bench_dask_sphere.py --points 100000000 [--chunk 1000000] [--compare]
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _environment import environment_line

CENTER = np.array([412.0, -233.0, 87.5])
RADIUS = 25.0
FORM = 0.01


def sphere_block(block: np.ndarray, seed: int, block_info: dict | None = None) -> np.ndarray:
    """Points of block ``k`` of the cloud: seeded by ``(seed, k)``, so any block can be made again alone."""
    index = block_info[None]["chunk-location"][0] if block_info else 0
    rng = np.random.default_rng([seed, index])
    rows = len(block)
    direction = rng.standard_normal((rows, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    return CENTER + direction * (RADIUS + FORM * rng.uniform(-0.5, 0.5, (rows, 1)))


def lazy_sphere(points: int, chunk: int, seed: int = 7) -> Any:
    import dask.array as da

    template = da.empty((points, 3), chunks=(chunk, 3), dtype=np.float64)
    return template.map_blocks(sphere_block, seed, dtype=np.float64)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--points", type=int, default=100_000_000)
    parser.add_argument("--chunk", type=int, default=1_000_000)
    parser.add_argument("--compare", action="store_true", help="also fit the materialised array in memory")
    args = parser.parse_args()

    from pcmm_geo.fit import fit_sphere

    cloud = lazy_sphere(args.points, args.chunk)
    start = time.perf_counter()
    fitted = fit_sphere(cloud)
    seconds = time.perf_counter() - start
    peak_lazy = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    record = {
        "points": args.points, "chunk": args.chunk, "seconds": seconds, "points_per_second": args.points / seconds,
        "peak_rss_mb": peak_lazy, "center": fitted.center.tolist(), "radius": fitted.radius, "rms": fitted.rms,
        "form": fitted.form, "iterations": fitted.iterations, "residuals_lazy": type(fitted.residuals).__name__,
        "environment": environment_line(),
    }
    if args.compare:
        in_memory = fit_sphere(np.asarray(cloud.compute()))
        record["in_memory_center_difference_mm"] = float(np.max(np.abs(in_memory.center - fitted.center)))
        record["in_memory_radius_difference_mm"] = abs(in_memory.radius - fitted.radius)
    print(json.dumps(record))


if __name__ == "__main__":
    main()
