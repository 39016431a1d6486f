"""Draw docs/machine_conditioning.png: the predicted tip u over the workspace and over the start poses.

Usage (about 10 s of CPU)::

    OPENBLAS_NUM_THREADS=1 python tools/conditioning_maps.py [--out docs/machine_conditioning.png]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from pcmm_geo.machine.analysis.conditioning_maps import choose_start, start_map, workspace_map  # noqa: E402
from pcmm_geo.machine.kinematics.model import RigidBodyMachine  # noqa: E402
from pcmm_geo.plots.machine.conditioning import plot_conditioning_maps  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(REPO / "docs" / "machine_conditioning.png"))
    args = parser.parse_args()
    machine = RigidBodyMachine.from_dpkm()
    found = start_map(machine)
    chosen = choose_start(found)
    written = plot_conditioning_maps(workspace_map(machine, size=400.0, points=81), found, chosen, args.out,
                                     overwrite=True)
    print(f"chosen start {chosen.tolist()} mm from level; wrote {written}")


if __name__ == "__main__":
    main()
