"""Plots of pcmm_geo results, one module per kind; matplotlib is imported only when a plot is drawn.

This package sits beside :mod:`pcmm_geo.cli` (it may import fit, machine and artefacts;
nothing in those layers imports it).  Every ``plot_*`` function writes one file (``.png``,
``.svg`` or ``.pdf``), refuses to replace an existing one unless ``overwrite=True``
(:class:`~pcmm_geo.errors.OutputExistsError`) and returns its path.  Figures are built
without ``pyplot``, so no global matplotlib backend is switched.

- :func:`plot_calibration` -- tetrahedron calibration in 3-D (thesis fig 7.2) and miss distances.
- :func:`plot_gauge_block` -- per-face plane residuals and the lengths of every method.
- :func:`plot_sensitivity` -- workspace sensitivity map, one panel per z level, singular points counted.
- :func:`plot_conditioning_maps` -- predicted tip uncertainty over the workspace and over session start poses.
- :func:`plot_fit_residuals` -- residuals of a fit where the points lie (angle, height, in-plane maps).
- :func:`plot_processed_log` -- tip path, pivot heights and closure residuals of a log.
- :func:`plot_tip_errors`, :func:`plot_demo_overview` -- the end-to-end demo.
- :func:`plot_length_test`, :func:`plot_probing_test`, :func:`plot_software_test`,
  :func:`plot_stage_test` -- ISO 10360-2, -5, -6 and the micrometer-stage test.
- :func:`plot_numerical_calibration`, :func:`plot_pose`, :func:`plot_trilateration` -- the machine.
- :func:`plot_sensor_curve`, :func:`plot_length_correction`, :func:`plot_frame_triangle`,
  :func:`plot_thermal_table` -- the thermal tools.

Lengths that may be nm, µm or mm are shown in the unit :func:`length_unit` picks from the data.
- :func:`plot_monte_carlo` -- a Monte Carlo uncertainty evaluation (histogram, interval, budget).

Examples
--------
>>> import os, tempfile
>>> import numpy as np
>>> from pcmm_geo import plots
>>> from pcmm_geo.fit import fit_plane
>>> points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.001]])
>>> plots.plot_fit_residuals(fit_plane(points), os.path.join(tempfile.mkdtemp(), "p.png"), points=points).suffix
'.png'
"""

from __future__ import annotations

from pcmm_geo._lazy import attach

# public name -> module defining it, imported on first access (PEP 562)
_LAZY = {
    "plot_calibration": "machine.calibration",
    "plot_gauge_block": "gauge_block",
    "plot_sensitivity": "machine.sensitivity",
    "plot_conditioning_maps": "machine.conditioning",
    "plot_fit_residuals": "fit_residuals",
    "plot_processed_log": "machine.process_log",
    "plot_tip_errors": "demo",
    "plot_monte_carlo": "uncertainty",
    "plot_demo_overview": "demo",
    "check_plot_path": "_figure",
    "length_unit": "_figure",
    "plot_length_test": "verification",
    "plot_probing_test": "verification",
    "plot_software_test": "verification",
    "plot_stage_test": "verification",
    "plot_numerical_calibration": "machine.machine_state",
    "plot_pose": "machine.machine_state",
    "plot_trilateration": "machine.machine_state",
    "plot_sensor_curve": "thermal",
    "plot_length_correction": "thermal",
    "plot_frame_triangle": "thermal",
    "plot_thermal_table": "thermal",
}

__getattr__, __dir__, __all__ = attach(__name__, _LAZY)
