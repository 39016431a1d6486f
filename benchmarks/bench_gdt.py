"""Time a 50-feature inspection plan: 3 certified datum planes, 10 faces, 37 holes; print one JSON line per run.

The part is the constructed block of ``pcmm_geo/data/examples/gdt/make_gdt_example.py`` with 10
extra faces (parallelism to A) and 37 holes (position to A|B|C), 10^4 points per feature, written
as CSV files with a TOML plan to a temporary directory.  Each run times :func:`pcmm_geo.gdt.inspect_plan`
on the plan (reading the 50 files included) once with the holes at RFS (least-squares axes) and
once at MMC (each hole's exact MIC for the bonus; the size check's upper limit by a bound, its MCC
only where the bound does not decide), and checks every hole's RFS position against the
construction's exact value.

Usage::

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_gdt.py [--points 10000] [--modes RFS MMC]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _environment import environment_line

ROOT = Path(__file__).resolve().parents[1]


def _maker():
    name = "make_gdt_example"
    spec = importlib.util.spec_from_file_location(name, ROOT / "pcmm_geo" / "data" / "examples" / "gdt" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def write_plan(directory: Path, part, modifier: str) -> Path:
    out = ['units = "mm"', "[part]", 'frame = "A|B|C"']
    for name, normal in (("A", "[0, 0, -1]"), ("B", "[-1, 0, 0]"), ("C", "[0, -1, 0]")):
        out += [f"[features.{name}]", 'element = "plane"', f'points = "{name}.csv"', f"normal = {normal}"]
    faces = sorted(k for k in part.points if k.startswith("F"))
    for name in faces:
        out += [f"[features.{name}]", 'element = "plane"', f'points = "{name}.csv"', "normal = [0, 0, 1]",
                "point = [0, 0, 30]"]
    for hole in part.holes:
        out += [f"[features.{hole.name}]", 'element = "cylinder"', f'points = "{hole.name}.csv"', 'side = "internal"',
                f"point = [{hole.centre[0]!r}, {hole.centre[1]!r}, 0]", "axis = [0, 0, 1]", "diameter = 10",
                "size_tolerance = [0, 0.1]"]
    out += ["[datums]", 'A = "A"', 'B = "B"', 'C = "C"']
    for name in faces:
        out += ["[[characteristics]]", f'name = "par {name}"', f'feature = "{name}"', 'frame = "parallelism 0.05 | A"']
    for hole in part.holes:
        frame = f"position dia 0.1 {modifier} | A | B | C".replace(" RFS", "")
        out += ["[[characteristics]]", f'name = "pos {hole.name}"', f'feature = "{hole.name}"', f'frame = "{frame}"']
    plan = directory / f"plan_{modifier}.toml"
    plan.write_text("\n".join(out) + "\n", encoding="utf-8")
    return plan


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=10_000)
    parser.add_argument("--modes", nargs="+", default=["RFS", "MMC"], choices=["RFS", "MMC"])
    args = parser.parse_args()
    from pcmm_geo.gdt import inspect_plan

    maker = _maker()
    part = maker.make_part(7, n_points=args.points, n_holes=37, n_faces=10)
    with tempfile.TemporaryDirectory() as tmp:
        directory = Path(tmp)
        for name in part.points:
            np.savetxt(directory / f"{name}.csv", part.measured(name), fmt="%.12f", delimiter=",")
        for mode in args.modes:
            plan = write_plan(directory, part, mode)
            start = time.perf_counter()
            result = inspect_plan(plan)
            seconds = time.perf_counter() - start
            by_name = {c.name: c for c in result.characteristics}
            worst = max(abs(by_name[f"pos {h.name}"].value_mm - h.position_rfs()) for h in part.holes)
            print(json.dumps({"mode": mode, "features": len(part.points), "points_per_feature": args.points,
                              "characteristics": len(result.characteristics), "seconds": round(seconds, 3),
                              "largest_position_error_mm": worst,
                              "datum_scopes": [d.certificate.scope for d in result.datums.values()]}))
    print(environment_line())


if __name__ == "__main__":
    main()
