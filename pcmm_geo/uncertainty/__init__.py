"""Measurement uncertainty: GUM propagation, Monte Carlo and the virtual micro-CMM.

- :mod:`~pcmm_geo.uncertainty.result` -- :class:`UncertaintyResult` and :class:`BudgetEntry`.
- :mod:`~pcmm_geo.uncertainty.gum` -- linear propagation (JCGM 100): sensitivities,
  covariance ``J U J^T``, Welch-Satterthwaite, budgets.
- :mod:`~pcmm_geo.uncertainty.montecarlo` -- adaptive Monte Carlo (JCGM 101 §7.9),
  shortest / symmetric coverage intervals, GUM validation (§8).
- :mod:`~pcmm_geo.uncertainty.calibration` -- covariance of the tetrahedron calibration
  from the external CMM's probing uncertainty and the laser noise.
- :mod:`~pcmm_geo.uncertainty.virtual_cmm` -- task-specific uncertainty by simulation
  (ISO 15530-4 style): gauge block, sphere, point-to-point distance.
- :mod:`~pcmm_geo.uncertainty.conformity` -- ISO 14253-1 decision rules (guard bands).

This package sits above ``machine`` and ``thermal`` and below ``artefacts`` and the CLI.
Names load lazily (PEP 562).

Examples
--------
>>> from pcmm_geo import uncertainty
>>> r = uncertainty.propagate(lambda v: v[0] + v[1], [1.0, 2.0], [0.3, 0.4])
>>> round(r.standard_uncertainty, 6)
0.5
"""

from __future__ import annotations

from pcmm_geo._lazy import attach

_LAZY = {
    "BudgetEntry": "result",
    "UncertaintyResult": "result",
    "jacobian": "gum",
    "propagate": "gum",
    "propagate_covariance": "gum",
    "welch_satterthwaite": "gum",
    "coverage_factor": "gum",
    "adaptive_monte_carlo": "montecarlo",
    "coverage_interval": "montecarlo",
    "monte_carlo_propagate": "montecarlo",
    "numerical_tolerance": "montecarlo",
    "sample_normal": "montecarlo",
    "validate_gum": "montecarlo",
    "CalibrationCovariance": "calibration",
    "calibration_covariance": "calibration",
    "calibration_covariance_monte_carlo": "calibration",
    "forward_batch": "kinematics",
    "VirtualCMM": "virtual_cmm",
    "ThermalInputs": "virtual_cmm",
    "TaskUncertainty": "virtual_cmm",
    "MeasurementTask": "tasks",
    "gauge_block_task": "tasks",
    "sphere_task": "tasks",
    "distance_task": "tasks",
    "ConformityDecision": "conformity",
    "decide_conformity": "conformity",
}

__getattr__, __dir__, __all__ = attach(__name__, _LAZY)
