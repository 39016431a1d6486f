"""Minimax fits against annealing and trimesh, side by side in one run (on demand, not a test).

Cases, each on data with a known solution (``pcmm_geo.fit.zone.reference``):

* minimum-zone circle, 10,000 points: ``fit_circle(criterion="chebyshev")`` vs
  ``scipy.optimize.dual_annealing`` on the same objective (zone width over the centre),
  the NIST-style simulated-annealing reference approach, started around the least-squares centre;
* minimum-zone cylinder, 5,000 points: ``fit_cylinder(criterion="chebyshev")`` vs
  ``dual_annealing`` on the zone width over the four axis parameters;
* minimum circumscribed sphere, 10,000 points: ``fit_sphere(criterion="mcc")`` vs
  ``trimesh.nsphere.minimum_nsphere``.

Reported: best wall-clock time of N runs, the deviation of each contender from the known
solution (centre / axis position in mm, axis in rad, zone width or radius in mm) and the
time ratio.  Goal: exact (1e-9) where the peers are not, and >= 10x faster than annealing.

Usage::

    .venv/bin/python benchmarks/bench_zone.py [--repeat N] [--anneal-iterations M]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _environment
from _timing import best_of

from pcmm_geo.fit import fit_circle, fit_cylinder, fit_sphere
from pcmm_geo.fit._kernels._core import rotation_to_z
from pcmm_geo.fit.zone.reference import make_minimax_reference


def _row(name: str, seconds: float, deviations: dict[str, float], note: str = "") -> dict:
    return {"contender": name, "seconds": seconds, **deviations, "note": note}


def circle_case(repeat: int, anneal_iterations: int) -> list[dict]:
    from scipy.optimize import dual_annealing

    data = make_minimax_reference("circle", "chebyshev", n_points=10_000, size=25.0, form=0.01, offset=500.0, rng=301)
    truth = data.parameters
    ours = best_of(lambda: fit_circle(data.points, criterion="chebyshev"), repeat)
    start = fit_circle(data.points).center

    def width(center: np.ndarray) -> float:
        distances = np.linalg.norm(data.points - center, axis=1)
        return float(distances.max() - distances.min())

    box = 0.05  # mm around the least-squares centre
    anneal = best_of(
        lambda: dual_annealing(
            width, bounds=list(zip(start - box, start + box, strict=True)), maxiter=anneal_iterations, seed=1
        ),
        1,
    )
    found = anneal.value.x
    return [
        _row(
            "pcmm_geo fit_circle(criterion='chebyshev')",
            ours.best,
            {
                "center_mm": float(np.linalg.norm(ours.value.center - truth["center"])),
                "form_mm": abs(ours.value.form - truth["form"]),
            },
            f"certified={ours.value.converged}",
        ),
        _row(
            f"scipy dual_annealing (maxiter {anneal_iterations})",
            anneal.best,
            {"center_mm": float(np.linalg.norm(found - truth["center"])), "form_mm": abs(width(found) - truth["form"])},
            f"{anneal.value.nfev} evaluations",
        ),
    ]


def cylinder_case(repeat: int, anneal_iterations: int) -> list[dict]:
    from scipy.optimize import dual_annealing

    data = make_minimax_reference("cylinder", "chebyshev", n_points=5_000, size=20.0, form=0.01, offset=500.0, rng=302)
    truth = data.parameters
    ours = best_of(lambda: fit_cylinder(data.points, criterion="chebyshev"), repeat)
    gauss = fit_cylinder(data.points)
    frame = rotation_to_z(gauss.axis)
    local = (data.points - gauss.point) @ frame.T

    def axis_of(params: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x0, y0, a, b = params
        direction = np.array([a, b, 1.0]) / np.sqrt(1 + a * a + b * b)
        return np.array([x0, y0, 0.0]), direction

    def width(params: np.ndarray) -> float:
        point, direction = axis_of(params)
        rho = np.linalg.norm(np.cross(local - point, direction), axis=1)
        return float(rho.max() - rho.min())

    bounds = [(-0.05, 0.05), (-0.05, 0.05), (-0.005, 0.005), (-0.005, 0.005)]
    anneal = best_of(lambda: dual_annealing(width, bounds=bounds, maxiter=anneal_iterations, seed=1), 1)
    point_local, direction_local = axis_of(anneal.value.x)
    anneal_axis = direction_local @ frame
    anneal_point = gauss.point + point_local @ frame

    def axis_errors(point: np.ndarray, axis: np.ndarray) -> dict[str, float]:
        shift = point - truth["point"]
        off_axis = shift - (shift @ truth["axis"]) * truth["axis"]
        angle = float(np.arctan2(np.linalg.norm(np.cross(axis, truth["axis"])), abs(axis @ truth["axis"])))
        return {"axis_position_mm": float(np.linalg.norm(off_axis)), "axis_rad": angle}

    return [
        _row(
            "pcmm_geo fit_cylinder(criterion='chebyshev')",
            ours.best,
            {**axis_errors(ours.value.point, ours.value.axis), "form_mm": abs(ours.value.form - truth["form"])},
            f"certified={ours.value.converged}",
        ),
        _row(
            f"scipy dual_annealing (maxiter {anneal_iterations})",
            anneal.best,
            {**axis_errors(anneal_point, anneal_axis), "form_mm": abs(width(anneal.value.x) - truth["form"])},
            f"{anneal.value.nfev} evaluations",
        ),
    ]


def mcc_case(repeat: int) -> list[dict]:
    import trimesh.nsphere

    data = make_minimax_reference("sphere", "mcc", n_points=10_000, size=25.0, form=0.01, offset=500.0, rng=303)
    truth = data.parameters
    ours = best_of(lambda: fit_sphere(data.points, criterion="mcc"), repeat)
    theirs = best_of(lambda: trimesh.nsphere.minimum_nsphere(data.points), repeat)
    center, radius = theirs.value
    return [
        _row(
            "pcmm_geo fit_sphere(criterion='mcc')",
            ours.best,
            {
                "center_mm": float(np.linalg.norm(ours.value.center - truth["center"])),
                "radius_mm": abs(ours.value.radius - truth["radius"]),
            },
            f"certified={ours.value.converged}",
        ),
        _row(
            "trimesh.nsphere.minimum_nsphere",
            theirs.best,
            {"center_mm": float(np.linalg.norm(center - truth["center"])), "radius_mm": abs(radius - truth["radius"])},
        ),
    ]


def _print(title: str, rows: list[dict]) -> None:
    keys = [k for k in rows[0] if k not in ("contender", "seconds", "note")]
    print(f"\n### {title}\n")
    print("| contender | time / s | " + " | ".join(k.replace("_", " ") for k in keys) + " | note |")
    print("|---|---|" + "---|" * len(keys) + "---|")
    for row in rows:
        cells = " | ".join(f"{row[k]:.2e}" for k in keys)
        print(f"| {row['contender']} | {row['seconds']:.4f} | {cells} | {row['note']} |")
    print(f"\ntime ratio (peer / pcmm_geo): {rows[1]['seconds'] / rows[0]['seconds']:.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs of each pcmm_geo / trimesh call (best kept)")
    parser.add_argument(
        "--anneal-iterations", type=int, default=1000, help="dual_annealing maxiter (scipy default 1000)"
    )
    args = parser.parse_args()
    print(_environment.environment_line())
    _print("minimum-zone circle, 10,000 points", circle_case(args.repeat, args.anneal_iterations))
    _print("minimum-zone cylinder, 5,000 points", cylinder_case(args.repeat, args.anneal_iterations))
    _print("minimum circumscribed sphere, 10,000 points", mcc_case(args.repeat))
    print(_environment.environment_line())


if __name__ == "__main__":
    main()
