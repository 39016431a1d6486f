"""Thermal behaviour of the micro-CMM and its workpieces.

- :mod:`~pcmm_geo.thermal.expansion` -- member expansion ``Δl = α l0 ΔT`` (eq 4.1) and the
  seed's faulty ``α·10·ΔT`` (erratum 5).
- :mod:`~pcmm_geo.thermal.triangle` -- frame triangle under temperature (eqs 4.2-4.9, Table 4.1).
- :mod:`~pcmm_geo.thermal.probe_error` -- the seed's probe model (eqs 4.10-4.17).
- :mod:`~pcmm_geo.thermal.physical` -- physical model (expanded members, exact three-sphere
  solution) and µm/K tables; :mod:`~pcmm_geo.thermal.machine_expansion` -- the same
  expansion applied to a ``RigidBodyMachine`` and its kinematics re-solved.
- :mod:`~pcmm_geo.thermal.sensors` -- IEC 60751 RTDs and Steinhart-Hart thermistors.
- :mod:`~pcmm_geo.thermal.correction` -- correction of lengths to 20 °C with a GUM budget.

Names load lazily (PEP 562) so ``import pcmm_geo.thermal`` is cheap.

Examples
--------
>>> from pcmm_geo import thermal
>>> round(thermal.rtd_resistance(100.0), 4)
138.5055
"""

from __future__ import annotations

from pcmm_geo._lazy import attach

_LAZY = {
    "REFERENCE_TEMPERATURE": "expansion",
    "ALPHA_ALUMINIUM": "expansion",
    "ALPHA_STEEL": "expansion",
    "ALPHA_GAUGE_BLOCK_STEEL": "expansion",
    "delta_l": "expansion",
    "expanded_length": "expansion",
    "seed_delta_l": "expansion",
    "FrameTriangle": "triangle",
    "NOMINAL_SIDE": "triangle",
    "frame_corners": "triangle",
    "expand_frame": "triangle",
    "seed_frame_corners": "triangle",
    "CallendarVanDusen": "sensors",
    "IEC60751": "sensors",
    "rtd_resistance": "sensors",
    "rtd_temperature": "sensors",
    "SteinhartHart": "sensors",
    "fit_steinhart_hart": "sensors",
    "KELVIN_OFFSET": "sensors",
    "BudgetEntry": "correction",
    "LengthCorrection": "correction",
    "correct_length": "correction",
    "SeedProbeError": "probe_error",
    "seed_probe_error": "probe_error",
    "ThermalMachineGeometry": "physical",
    "trilaterate": "probe_error",
    "physical_tip": "physical",
    "physical_tip_displacement": "physical",
    "MEMBERS": "physical",
    "expand_rigid_body_machine": "machine_expansion",
    "rigid_body_tip_displacement": "machine_expansion",
    "deform_triangle": "triangle",
    "ThermalSensitivityTable": "physical",
    "thermal_sensitivity_table": "physical",
}

__getattr__, __dir__, __all__ = attach(__name__, _LAZY)
