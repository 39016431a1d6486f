"""Machine layer: kinematics, calibration and analysis of the parallel-mechanism micro-CMM.

Sub-packages (each ``__init__`` says what lives there and what it may import):

- :mod:`~pcmm_geo.machine.kinematics` -- rigid-body model, the seed's DPKM with errata 1-4
  fixed, trilateration, pose solver; imports nothing else of the machine;
- :mod:`~pcmm_geo.machine.calibration` -- tetrahedron and column calibration from
  external-CMM probings (ch. 7), numerical calibration from height-gauge data (ch. 6),
  identifiability, calibration files;
- :mod:`~pcmm_geo.machine.analysis` -- seed Table 3.2 log processing and reading-to-tip
  sensitivity.

Talking to the hardware (drivers, simulators, sessions, durable logs) is
:mod:`pcmm_geo.acquisition`, below the calibration and analysis and above the kinematics.

The machine may import :mod:`pcmm_geo.acquisition`, :mod:`pcmm_geo.fit`, :mod:`pcmm_geo.io`,
:mod:`pcmm_geo.thermal` and :mod:`pcmm_geo.errors`; never :mod:`pcmm_geo.artefacts`,
:mod:`pcmm_geo.plots` or :mod:`pcmm_geo.cli`.

The most used names are re-exported here, loaded lazily on first access (PEP 562) so that
``import pcmm_geo.machine`` stays fast and free of scipy until something is computed:
:class:`RigidBodyMachine`, :class:`Tetrahedron`, :class:`SliderLine`, :class:`ColumnLine`,
``ARMS``, the DPKM functions, :func:`trilaterate`, the log processing (with its closure test and
tip uncertainty constants), the variable DPKM parameters, the start-position repeatability, the
laser/height ratio, the sensitivity and :func:`calibrate_tetrahedron` with its calibration files.

The modules' former flat paths (``pcmm_geo.machine.dpkm``, ``pcmm_geo.machine.drivers.zaber``,
...) still import for one release with a :class:`DeprecationWarning`
(:mod:`pcmm_geo.machine._moved`).

Examples
--------
>>> from pcmm_geo import machine
>>> m = machine.RigidBodyMachine.from_dpkm()
>>> machine.ARMS
('a', 'b', 'c')
"""

from __future__ import annotations

from pcmm_geo._lazy import attach
from pcmm_geo.machine import _moved

_moved.install()

_LAZY = {
    # model
    "ARMS": "kinematics.model",
    "MODEL_SCHEMA": "kinematics.model",
    "SliderLine": "kinematics.model",
    "Tetrahedron": "kinematics.model",
    "ColumnLine": "kinematics.model",
    "RigidBodyMachine": "kinematics.model",
    "ForwardSolution": "kinematics.model",
    "InverseSolution": "kinematics.model",
    "MachineLimits": "kinematics.limits",
    # seed DPKM
    "START_OF_RANGE": "kinematics.dpkm",
    "DpkmProbe": "kinematics.dpkm",
    "arm_lengths": "kinematics.dpkm",
    "pivot_distance": "kinematics.dpkm",
    "height_difference": "kinematics.dpkm",
    "relative_pivot_heights": "kinematics.dpkm",
    "column_pivots": "kinematics.dpkm",
    "sphere_constants": "kinematics.dpkm",
    "dpkm_probe": "kinematics.dpkm",
    "seed_probe_roots_as_printed": "kinematics.seed_forms",
    "seed_machine": "kinematics.model",
    "tetrahedron_directions": "kinematics.dpkm",
    # trilateration
    "Trilateration": "kinematics.trilateration",
    "trilaterate": "kinematics.trilateration",
    # log processing
    "LOG_COLUMNS": "analysis.logproc",
    "MeasurementLog": "analysis.logproc",
    "ProcessedLog": "analysis.logproc",
    "read_log": "analysis.logproc",
    "write_log": "analysis.logproc",
    "process_log": "analysis.logproc",
    "process_log_dpkm": "analysis.logproc",
    "synthesise_log": "analysis.logproc",
    # variable DPKM parameters (thesis 8.2)
    "DpkmParameterLaws": "analysis.parameter_laws",
    "LinearLaw": "analysis.parameter_laws",
    "fit_parameter_laws": "analysis.parameter_laws",
    "synthesise_log_dpkm": "analysis.parameter_laws",
    "ParameterLawFit": "analysis.parameter_laws",
    "table_8_errors": "analysis.parameter_laws",
    # log processing: closure test and tip uncertainty
    "SEED_LASER_SIGMA": "analysis.logproc",
    "SEED_LASER_STEPS": "analysis.logproc",
    "DEFAULT_MAX_TIP_UNCERTAINTY": "analysis.logproc",
    # start-position repeatability (thesis 6.3, Tables 6.6/6.7)
    "StartReadings": "analysis.repeatability",
    "StartRepeatability": "analysis.repeatability",
    "start_repeatability": "analysis.repeatability",
    "start_readings_from_logs": "analysis.repeatability",
    "read_start_readings_csv": "analysis.repeatability",
    # laser/height ratio of measured data (eqs 6.1-6.3, Table 6.8)
    "HeightGaugeRecord": "analysis.laser_ratio",
    "LaserHeightRatio": "analysis.laser_ratio",
    "laser_height_ratio": "analysis.laser_ratio",
    "predicted_height_per_laser": "analysis.laser_ratio_model",
    "ratio_table_summary": "analysis.laser_ratio_model",
    "read_ratio_table_csv": "analysis.laser_ratio_model",
    # sensitivity
    "Sensitivity": "analysis.sensitivity",
    "tip_jacobian": "analysis.sensitivity",
    "sensitivity_over_cube": "analysis.sensitivity",
    # calibration (written by the calibration engineer)
    "calibrate_tetrahedron": "calibration.tetrahedron",
    "TetrahedronCalibration": "calibration.result",
    "load_calibration": "calibration.calfile",
    "save_calibration": "calibration.calfile",
}

__getattr__, __dir__, __all__ = attach(__name__, _LAZY)
