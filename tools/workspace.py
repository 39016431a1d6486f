"""Measure the seed machine's workspace within its column travel and laser range (issue 16).

Run from the repository root:  python tools/workspace.py [--points 31]

Prints the share of height triples within the travel whose pose keeps every laser within its
measuring range, the bounding box of the reachable tip centres, the largest cube centred on the
reference tip that inverse kinematics accepts, and the reach from the reference tip along each
axis.  The grid sampling makes the box slightly smaller than the true one (by up to one grid step
of the heights, 15 mm at 31 points).
"""

from __future__ import annotations

import argparse

import numpy as np

from pcmm_geo.errors import PcmmGeoError
from pcmm_geo.machine.kinematics.model import RigidBodyMachine


def reachable(machine: RigidBodyMachine, tips: np.ndarray) -> bool:
    try:
        machine.inverse(tips)
    except PcmmGeoError:
        return False
    return True


def bisect(accept, low: float, high: float, steps: int = 30) -> float:
    for _ in range(steps):
        middle = (low + high) / 2
        low, high = (middle, high) if accept(middle) else (low, middle)
    return low


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=31, help="height grid points per column")
    args = parser.parse_args()
    machine = RigidBodyMachine.from_dpkm()
    limits = machine.limits
    travel, lasers = limits.height_travel[0], limits.laser_range[0]
    print(f"column travel {travel.round(4).tolist()} mm, laser range {lasers.tolist()} mm")
    center = machine.forward(heights=machine.reference_heights).tip
    print(f"reference tip {center.round(3).tolist()} mm at heights {machine.reference_heights.tolist()}")
    axis = np.linspace(travel[0], travel[1], args.points)
    heights = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3)
    solution = machine.forward(heights=heights, check_limits=False)
    inside = solution.converged & np.all((solution.lasers >= lasers[0]) & (solution.lasers <= lasers[1]), axis=1)
    tips = solution.tip[inside]
    print(f"height grid {args.points}^3 (step {axis[1] - axis[0]:.2f} mm): {inside.sum()} of {len(heights)} "
          f"({100 * inside.mean():.1f} %) poses keep every laser in range")
    print(f"reachable tip box: min {tips.min(0).round(2).tolist()} max {tips.max(0).round(2).tolist()} mm")
    print(f"largest height difference between columns in a reachable pose: "
          f"{np.ptp(solution.heights[inside], axis=1).max():.1f} mm")
    grid = np.stack(np.meshgrid(*[np.linspace(-1.0, 1.0, 9)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    half = bisect(lambda h: reachable(machine, center + h * grid), 0.0, 300.0)
    print(f"largest cube centred on the reference tip (9^3 test points): edge {2 * half:.1f} mm")
    for direction in np.vstack([np.eye(3), -np.eye(3)]):
        reach = bisect(lambda d, u=direction: reachable(machine, center + d * u), 0.0, 1000.0)
        print(f"reach from the reference tip along {direction.astype(int).tolist()}: {reach:.2f} mm")


if __name__ == "__main__":
    main()
