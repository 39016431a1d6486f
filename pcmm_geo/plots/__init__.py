"""Plots of pcmm_geo results, one module per kind; matplotlib is imported only when a plot is drawn.

This package sits beside :mod:`pcmm_geo.cli` (it may import fit, machine and artefacts;
nothing in those layers imports it).  Every ``plot_*`` function writes one file (``.png``,
``.svg`` or ``.pdf``), refuses to replace an existing one unless ``overwrite=True``
(:class:`~pcmm_geo.errors.OutputExistsError`) and returns its path.  Figures are built
without ``pyplot``, so no global matplotlib backend is switched.

- :func:`plot_calibration` -- tetrahedron calibration in 3-D (thesis fig 7.2) and miss distances.
- :func:`plot_gauge_block` -- per-face plane residuals and the lengths of every method.
- :func:`plot_sensitivity` -- workspace sensitivity map (defined in :mod:`pcmm_geo.machine.analysis.sensitivity`).
- :func:`plot_fit_residuals` -- residuals of a Gaussian fit.
- :func:`plot_processed_log` -- tip path, pivot heights and closure residuals of a log.
- :func:`plot_tip_errors`, :func:`plot_demo_overview` -- the end-to-end demo.
- :func:`plot_monte_carlo` -- a Monte Carlo uncertainty evaluation (histogram, interval, budget).

Examples
--------
>>> import os, tempfile
>>> import numpy as np
>>> from pcmm_geo import plots
>>> from pcmm_geo.fit import fit_plane
>>> plane = fit_plane(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.001]]))
>>> plots.plot_fit_residuals(plane, os.path.join(tempfile.mkdtemp(), "p.png"), element="plane").suffix
'.png'
"""

from __future__ import annotations

import importlib
from typing import Any

# public name -> module defining it, imported on first access (PEP 562)
_LAZY = {
    "plot_calibration": "pcmm_geo.plots.calibration",
    "plot_gauge_block": "pcmm_geo.plots.gauge_block",
    "plot_sensitivity": "pcmm_geo.machine.analysis.sensitivity",
    "plot_fit_residuals": "pcmm_geo.plots.fit_residuals",
    "plot_processed_log": "pcmm_geo.plots.process_log",
    "plot_tip_errors": "pcmm_geo.plots.demo",
    "plot_monte_carlo": "pcmm_geo.plots.uncertainty",
    "plot_demo_overview": "pcmm_geo.plots.demo",
    "check_plot_path": "pcmm_geo.plots._figure",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    module_name = _LAZY.get(name)
    if module_name is None:
        raise AttributeError(f"module 'pcmm_geo.plots' has no attribute {name!r}")
    value = getattr(importlib.import_module(module_name), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
