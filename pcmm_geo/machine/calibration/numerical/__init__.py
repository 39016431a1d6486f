"""Numerical calibration of the micro-CMM from height-gauge experiments (thesis ch. 6).

- :mod:`~pcmm_geo.machine.calibration.numerical.numcal_data` -- the experiment's data, the nine
  parameters, the CSV reader, physical synthetic data from the rigid-body model;
- :mod:`~pcmm_geo.machine.calibration.numerical.numcal` -- the model (eqs 2.5, 2.7), the
  simultaneous and sequential calibrations (6.2.2), the seed's random search, design
  identifiability and sample selection;
- :mod:`~pcmm_geo.machine.calibration.numerical.numcal_single_arm` -- the single-arm
  four-parameter calibration (6.2.1, Table 6.2);
- :mod:`~pcmm_geo.machine.calibration.numerical.numcal_solver` -- least squares to a real
  convergence test, parameter covariance, the result type;
- :mod:`~pcmm_geo.machine.calibration.numerical.identifiability` -- singular-value analysis of
  identification Jacobians and pose selection (thesis 2.2.2.1).
"""
