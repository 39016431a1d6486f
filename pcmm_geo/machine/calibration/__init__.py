"""Calibration of the micro-CMM: tetrahedron and columns (thesis ch. 7) and numerical calibration (ch. 6).

What lives here:

- :mod:`~pcmm_geo.machine.calibration.tetrahedron` -- :func:`calibrate_tetrahedron` from
  external-CMM probings (eqs 7.1-7.5, Table 7.1);
- :mod:`~pcmm_geo.machine.calibration.result` -- its result types
  (:class:`TetrahedronCalibration`, :class:`SliderLineCalibration`);
- :mod:`~pcmm_geo.machine.calibration.geometry` -- sphere fits of probed joints, slider lines,
  arm angles (line geometry itself is :mod:`pcmm_geo.fit.skew` / :func:`pcmm_geo.fit.fit_line`);
- :mod:`~pcmm_geo.machine.calibration.probings` -- reading and writing the external-CMM
  probing, element-export and laser CSV files;
- :mod:`~pcmm_geo.machine.calibration.calfile` -- versioned calibration files (JSON);
- :mod:`~pcmm_geo.machine.calibration.columns` -- column lines from pivot probings
  (eqs 2.19-2.20);
- :mod:`~pcmm_geo.machine.calibration.datum` -- the tetrahedron's datum frame (plane and hole);
- :mod:`~pcmm_geo.machine.calibration.seed` -- the seed's calibration data rebuilt from
  Appendices C and D;
- :mod:`~pcmm_geo.machine.calibration.noise` -- seeded study of how calibration errors grow
  with probing noise;
- :mod:`~pcmm_geo.machine.calibration.numerical` -- numerical calibration of d, beta, b from
  height-gauge experiments (ch. 6), single-arm calibration (Table 6.2), identifiability of
  calibration parameters and pose selection (the old paths ``calibration.numcal``,
  ``calibration.numcal_data``, ``calibration.identifiability`` still import, with a
  DeprecationWarning).

May import: :mod:`pcmm_geo.machine.kinematics`, :mod:`pcmm_geo.acquisition`,
:mod:`pcmm_geo.errors` and the lower layers (:mod:`pcmm_geo.fit`, :mod:`pcmm_geo.io`,
:mod:`pcmm_geo.thermal`).  Not :mod:`pcmm_geo.machine.analysis`, nothing above the machine.

The names of the former module ``pcmm_geo.machine.calibration`` are available here, loaded on
first access (PEP 562):

>>> from pcmm_geo.machine.calibration import calibrate_tetrahedron, load_calibration
>>> calibrate_tetrahedron.__module__
'pcmm_geo.machine.calibration.tetrahedron'
"""

from __future__ import annotations

from pcmm_geo._lazy import attach

_LAZY = {
    "PAIRS": "result",
    "SliderLineCalibration": "result",
    "TetrahedronCalibration": "result",
    "b_in_from_lasers": "tetrahedron",
    "calibrate_tetrahedron": "tetrahedron",
    "seed_printed_angle_deg": "geometry",
    "load_calibration": "calfile",
    "save_calibration": "calfile",
}

__getattr__, __dir__, __all__ = attach(__name__, _LAZY)
