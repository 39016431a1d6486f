"""Coverage of the stated U (k = 2) over many seeded true machines (the run quoted in docs/guide/ippdme.rst).

A 20 mm sphere probed at 25 points and a 50 mm gauge block at 2 x 5 points, with the server's
probing physics (:meth:`pcmm_geo.ippdme.machine.SimulatedMachine.probe_many`), one true machine
per seed; U from the virtual micro-CMM's GUM evaluation of the same contacts::

    PYTHONPATH=. python tests/ippdme/coverage_run.py 1000
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np


def main(runs: int) -> dict:  # pragma: no cover - the documented command
    sys.path.insert(0, str(Path(__file__).parents[1]))
    sys.path.insert(0, str(Path(__file__).parent))
    from scipy import stats
    from test_ippdme_measure import DIAMETER, LENGTH, OFFSETS, spiral

    from pcmm_geo.demo import demo_calibrated_machine
    from pcmm_geo.fit import fit_sphere
    from pcmm_geo.ippdme.machine import MachineModel, SimulatedMachine
    from pcmm_geo.ippdme.workpieces import BoxWorkpiece, SphereWorkpiece
    from pcmm_geo.uncertainty.tasks import MeasurementTask, gauge_block_central_lengths, sphere_task
    from pcmm_geo.uncertainty.virtual_cmm import VirtualCMM
    machine, radius, covariance, c = demo_calibrated_machine()
    model = MachineModel(machine, radius, covariance.model_covariance()[1])
    vcmm = VirtualCMM(machine, radius, model.calibration_covariance, laser_sigma=model.laser_sigma,
                      encoder_sigma=model.height_sigma)
    normals = spiral(25)
    contacts = c + DIAMETER / 2 * normals
    u_sphere = vcmm.gum(MeasurementTask("s", "d", 0, contacts, normals,
                                        sphere_task(DIAMETER, c).evaluate)).expanded_uncertainty
    nominal = np.vstack([c + np.column_stack([np.full(5, s * LENGTH / 2), OFFSETS]) for s in (-1.0, 1.0)])
    faces = np.repeat([[-1.0, 0, 0], [1.0, 0, 0]], 5, axis=0)

    def length(q: np.ndarray) -> np.ndarray:
        return gauge_block_central_lengths(q[:, :5], q[:, 5:])

    u_block = vcmm.gum(MeasurementTask("g", "l", 0, nominal, faces, length)).expanded_uncertainty
    sphere_errors, block_errors = [], []
    t = time.time()
    for seed in range(runs):
        sim = SimulatedMachine(model, [SphereWorkpiece(c, DIAMETER)], seed=100000 + seed)
        points = np.array([x.result.point for x in sim.probe_many(contacts, normals, 2.0, 4.0, diagnostics=False)])
        sphere_errors.append(2 * fit_sphere(points).radius - DIAMETER)
        sim = SimulatedMachine(model, [BoxWorkpiece(c, (LENGTH, 35.0, 9.0))], seed=200000 + seed)
        points = np.array([x.result.point for x in sim.probe_many(nominal, faces, 2.0, 4.0, diagnostics=False)])
        block_errors.append(float(length(points[None])[0]) - LENGTH)

    def summary(errors: list[float], u: float) -> dict:
        e = np.asarray(errors)
        k = int(np.sum(np.abs(e) <= u))
        low, high = stats.binomtest(k, len(e)).proportion_ci(0.95)
        return {"runs": len(e), "U_k2_um": round(u * 1e3, 4), "inside": k, "coverage": round(k / len(e), 4),
                "coverage_95ci": [round(low, 4), round(high, 4)], "mean_error_um": round(float(e.mean()) * 1e3, 4),
                "std_error_um": round(float(e.std(ddof=1)) * 1e3, 4)}

    return {"sphere_diameter_20mm_25pts": summary(sphere_errors, u_sphere),
            "gauge_block_50mm_2x5pts": summary(block_errors, u_block), "seconds": round(time.time() - t, 1)}


if __name__ == "__main__":  # pragma: no cover
    print(json.dumps(main(int(sys.argv[1]) if len(sys.argv) > 1 else 1000), indent=1))
