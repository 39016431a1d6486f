"""Benchmark case: a scanner-size point file fitted by ``pcmm fit sphere`` under a 3 GB address-space cap.

Writes ``N`` points of a sphere (R 25 mm about (300, 200, 400) mm, 0.01 mm form) with six
decimals, 33 bytes a row (330 MB for 10 million points), as ``scan.csv`` (commas) and
``scan.xyz`` (spaces; what open3d reads), then runs, each in its own process, side by side:

* ``pcmm fit sphere scan.csv --json`` with ``RLIMIT_AS`` = 3 GB (as ``ulimit -v``): wall time
  of the whole command (interpreter start, reading, fit, output) and its peak resident memory;
* the peer: open3d reading ``scan.xyz`` plus the in-memory ``fit_sphere`` of those points, timed
  the same way (wall time of the whole process, interpreter start and imports included; the
  read and fit timed inside it are reported beside), and its peak memory;
* ``pcmm process-log scan.csv``: the refusal of the point file's first line as a log header
  (it must not read the file).

Targets (issue 35): pcmm peak RSS <= 1 GB, pcmm time <= 1 x the peer's, the two fits equal to
1e-9 mm.  The two commands alternate, run by run.  Peak memory does not depend on the machine's load; times do, so the
ratio of two runs made one after the other is what counts on a shared machine.  Run alone::

    .venv/bin/python benchmarks/cases_readers.py [--points 10000000] [--repeat 3]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cases import CaseResult, Contender

ROOT = Path(__file__).resolve().parents[1]
ADDRESS_SPACE_CAP = 3 << 30
CENTRE = np.array([300.0, 200.0, 400.0])
_PEER = r"""
import json, resource, sys, time
import numpy as np
import open3d as o3d
from pcmm_geo.fit import fit_sphere
start = time.perf_counter()
points = np.asarray(o3d.io.read_point_cloud(sys.argv[1], format="xyz").points)
read = time.perf_counter() - start
result = fit_sphere(points)
total = time.perf_counter() - start
print(json.dumps({"read_s": read, "total_s": total, "n": len(points), "center": result.center.tolist(),
                  "radius": float(result.radius)}))
"""


def write_scan(folder: Path, n_points: int, seed: int = 7, block: int = 1_000_000) -> tuple[Path, Path]:
    """``scan.csv`` and ``scan.xyz`` (same points, six decimals, 33 bytes a row), written block by block."""
    rng = np.random.default_rng(seed)
    csv, xyz = folder / "scan.csv", folder / "scan.xyz"
    powers = 10 ** np.arange(8, -1, -1)
    with open(csv, "wb") as comma, open(xyz, "wb") as space:
        for start in range(0, n_points, block):
            m = min(block, n_points - start)
            direction = rng.standard_normal((m, 3))
            direction /= np.linalg.norm(direction, axis=1)[:, None]
            points = CENTRE + direction * (25.0 + 0.01 * rng.standard_normal((m, 1)))
            micrometres = np.rint(points * 1e6).astype(np.int64)  # nine digits: 175000000 .. 425000000
            digits = (micrometres[:, :, None] // powers) % 10
            cells = np.empty((m, 3, 11), np.uint8)
            cells[:, :, :3] = digits[:, :, :3] + 48
            cells[:, :, 3] = ord(".")
            cells[:, :, 4:10] = digits[:, :, 3:] + 48
            cells[:, :2, 10] = ord(",")
            cells[:, 2, 10] = ord("\n")
            comma.write(cells.tobytes())
            cells[:, :2, 10] = ord(" ")
            space.write(cells.tobytes())
    return csv, xyz


def _run(command: list[str], cap: int | None = None) -> tuple[float, float, str, int]:
    """Wall seconds, peak RSS (MB), stdout and exit code of ``command`` in its own process."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))

    def limit() -> None:
        if cap is not None:
            resource.setrlimit(resource.RLIMIT_AS, (cap, cap))

    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        start = time.perf_counter()
        child = subprocess.Popen(command, stdout=out, stderr=err, env=env, preexec_fn=limit)
        _, status, usage = os.wait4(child.pid, 0)  # this child's own peak memory
        seconds = time.perf_counter() - start
        child.returncode = code = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        text = out.read().decode() or err.read().decode()
    return seconds, usage.ru_maxrss / 1024.0, text, code


def stream_sphere_case(n_points: int, repeat: int) -> CaseResult:
    """``pcmm fit sphere`` of an n-point six-decimal CSV under a 3 GB cap vs open3d .xyz read + fit_sphere."""
    folder = Path(tempfile.mkdtemp(prefix="bench-stream-"))
    try:
        csv, xyz = write_scan(folder, n_points)
        load_before = os.getloadavg()
        pcmm_runs, peer_runs = [], []
        for _ in range(max(1, repeat)):  # alternate, so that both see the same load
            pcmm_runs.append(_run([sys.executable, "-m", "pcmm_geo", "fit", "sphere", str(csv), "--json"],
                                  cap=ADDRESS_SPACE_CAP))
            peer_runs.append(_run([sys.executable, "-c", _PEER, str(xyz)]))
        refusal = _run([sys.executable, "-m", "pcmm_geo", "process-log", str(csv)], cap=ADDRESS_SPACE_CAP)
        load_after = os.getloadavg()
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    failed = [run for run in pcmm_runs + peer_runs if run[3] != 0]
    if failed:
        raise RuntimeError(f"a run failed (exit {failed[0][3]}): {failed[0][2][-500:]}")
    ours = min(pcmm_runs, key=lambda run: run[0])
    peer = [json.loads(run[2].strip().splitlines()[-1]) for run in peer_runs]
    best_peer = min(peer, key=lambda p: p["total_s"])
    fitted = json.loads(ours[2])
    center_diff = float(np.max(np.abs(np.asarray(fitted["center"]) - best_peer["center"])))
    radius_diff = abs(float(fitted["radius"]) - best_peer["radius"])
    peak = max(run[1] for run in pcmm_runs)
    peer_wall = min(run[0] for run in peer_runs)
    ratio = ours[0] / peer_wall
    threads = os.environ.get("OPENBLAS_NUM_THREADS", "default")
    contenders = [
        Contender("pcmm fit sphere (3 GB address-space cap)", ours[0],
                  {"centre vs peer fit": center_diff, "radius vs peer fit": radius_diff},
                  f"peak RSS {peak:.0f} MB (array {n_points * 24 / 1e6:.0f} MB); whole command, interpreter "
                  f"start included; runs {', '.join(f'{r[0]:.3g}' for r in pcmm_runs)} s"),
        Contender("open3d read .xyz + fit_sphere (in memory)", peer_wall, {},
                  f"whole process, interpreter start included; runs {', '.join(f'{r[0]:.3g}' for r in peer_runs)} s; "
                  f"inside it read {best_peer['read_s']:.3g} s, read + fit {best_peer['total_s']:.3g} s; peak RSS "
                  f"{max(r[1] for r in peer_runs):.0f} MB"),
        Contender("pcmm process-log (refuses line 1)", refusal[0], {},
                  f"exit {refusal[3]}; peak RSS {refusal[1]:.0f} MB"),
    ]
    met = peak <= 1000.0 and ratio <= 1.0 and max(center_diff, radius_diff) <= 1e-9 and refusal[3] == 2
    return CaseResult(
        "stream sphere",
        f"{n_points:,} points, six decimals, {33 * n_points / 1e6:.0f} MB CSV; load average "
        f"{load_before[0]:.2f} -> {load_after[0]:.2f} on {os.cpu_count()} cores; OPENBLAS_NUM_THREADS={threads}",
        contenders,
        "peak RSS <= 1 GB under a 3 GB cap, <= 1 x (open3d read + fit; whole processes), = in-memory fit to 1e-9 mm",
        ratio,
        met,
        {"peak_rss_mb": peak},
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=10_000_000)
    parser.add_argument("--repeat", type=int, default=1)
    args = parser.parse_args()
    result = stream_sphere_case(args.points, args.repeat)
    print(result.data)
    for contender in result.contenders:
        print(f"{contender.name:45s} {contender.seconds:8.3f} s  {contender.deviations}  {contender.note}")
    print(f"ratio {result.ratio:.3f} (target {result.target}); met: {result.target_met}")


if __name__ == "__main__":
    main()
