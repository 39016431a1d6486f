"""Machine layer: kinematics of the parallel-mechanism micro-CMM, calibration, acquisition.

Public names are loaded lazily on first access (PEP 562) so that ``import
pcmm_geo.machine`` stays fast and free of scipy until something is computed.

- rigid-body model (:mod:`~pcmm_geo.machine.model`): :class:`RigidBodyMachine`,
  :class:`Tetrahedron`, :class:`SliderLine`, :class:`ColumnLine`, ``ARMS``;
- the seed's DPKM with errata 1-4 fixed (:mod:`~pcmm_geo.machine.dpkm`) and robust
  trilateration (:mod:`~pcmm_geo.machine.trilateration`);
- seed Table 3.2 log processing (:mod:`~pcmm_geo.machine.logproc`);
- reading-to-tip sensitivity (:mod:`~pcmm_geo.machine.sensitivity`);
- tetrahedron calibration (:mod:`~pcmm_geo.machine.calibration`).

Examples
--------
>>> from pcmm_geo import machine
>>> m = machine.RigidBodyMachine.from_dpkm()
>>> machine.ARMS
('a', 'b', 'c')
"""

from __future__ import annotations

import importlib
from typing import Any

_LAZY = {
    # model
    "ARMS": "model",
    "MODEL_SCHEMA": "model",
    "SliderLine": "model",
    "Tetrahedron": "model",
    "ColumnLine": "model",
    "RigidBodyMachine": "model",
    "ForwardSolution": "model",
    "InverseSolution": "model",
    # seed DPKM
    "START_OF_RANGE": "dpkm",
    "DpkmProbe": "dpkm",
    "arm_lengths": "dpkm",
    "pivot_distance": "dpkm",
    "height_difference": "dpkm",
    "relative_pivot_heights": "dpkm",
    "column_pivots": "dpkm",
    "sphere_constants": "dpkm",
    "dpkm_probe": "dpkm",
    "seed_probe_roots_as_printed": "seed_forms",
    "seed_machine": "dpkm",
    "tetrahedron_directions": "dpkm",
    # trilateration
    "Trilateration": "trilateration",
    "trilaterate": "trilateration",
    # log processing
    "LOG_COLUMNS": "logproc",
    "MeasurementLog": "logproc",
    "ProcessedLog": "logproc",
    "read_log": "logproc",
    "write_log": "logproc",
    "process_log": "logproc",
    "process_log_dpkm": "logproc",
    "synthesise_log": "logproc",
    # sensitivity
    "Sensitivity": "sensitivity",
    "tip_jacobian": "sensitivity",
    "sensitivity_over_cube": "sensitivity",
    # calibration (written by the calibration engineer)
    "calibrate_tetrahedron": "calibration",
    "TetrahedronCalibration": "calibration",
    "load_calibration": "calibration",
    "save_calibration": "calibration",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    module_name = _LAZY.get(name)
    if module_name is None:
        raise AttributeError(f"module 'pcmm_geo.machine' has no attribute {name!r}")
    module = importlib.import_module(f"pcmm_geo.machine.{module_name}")
    value = getattr(module, name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
