"""What the machine measured and how sensitive it is: log processing, sensitivity, error investigation.

What lives here:

- :mod:`~pcmm_geo.machine.analysis.logproc` -- processing of the seed's measurement log
  (thesis 3.6, Table 3.2; 5.2; Appendix D) into probe-tip positions: a sub-package with the
  rows and their CSV form, the network adjustment of the pivot heights, Baarda's w-test per
  laser reading, the tip uncertainty and external reliability of every row, mirror-pose
  ambiguity, synthetic logs, and the seed's own DPKM processing;
- :mod:`~pcmm_geo.machine.analysis.parameter_laws` -- the seed DPKM's ``d_i`` and ``beta_in`` as
  linear laws of the lasers (thesis 8.2, Table 8.2), fitted from calibration positions;
- :mod:`~pcmm_geo.machine.analysis.sensitivity` -- sensitivity of the tip to laser and encoder
  readings over the working cube;
- :mod:`~pcmm_geo.machine.analysis.repeatability` -- start-position repeatability of the lasers
  (thesis 6.3, Tables 6.6, 6.7);
- :mod:`~pcmm_geo.machine.analysis.laser_ratio` and
  :mod:`~pcmm_geo.machine.analysis.laser_ratio_model` -- height per laser displacement of measured
  data (eqs 6.1-6.3, Table 6.8) and what the rigid-body geometry predicts for it.

May import: :mod:`pcmm_geo.machine.kinematics`, :mod:`pcmm_geo.acquisition` (to read its logs),
:mod:`pcmm_geo.errors` and the lower layers (:mod:`pcmm_geo.fit`, :mod:`pcmm_geo.io`,
:mod:`pcmm_geo.thermal`).  Not :mod:`pcmm_geo.machine.calibration`, nothing above the machine.
"""
