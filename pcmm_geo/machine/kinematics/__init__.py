"""Kinematics of the parallel-mechanism micro-CMM: from readings to the probe tip and back.

What lives here:

- :mod:`~pcmm_geo.machine.kinematics.model` -- the rigid-body model
  (:class:`~pcmm_geo.machine.kinematics.model.RigidBodyMachine`, forward and inverse
  solutions) and :func:`~pcmm_geo.machine.kinematics.model.seed_machine`;
- :mod:`~pcmm_geo.machine.kinematics.model_parts` -- its building blocks (slider lines,
  tetrahedron, column lines, input checks);
- :mod:`~pcmm_geo.machine.kinematics.limits` -- what the machine can read and reach
  (:class:`~pcmm_geo.machine.kinematics.limits.MachineLimits`: 450 mm column travel, 0-200 mm
  laser range, loop-closure tolerance) and the checks behind the typed range errors;
- :mod:`~pcmm_geo.machine.kinematics.dpkm` -- the seed's direct parallel kinematic model with
  errata 1-4 fixed and the thesis' Table 3.1 / Appendix D / E values;
- :mod:`~pcmm_geo.machine.kinematics.trilateration` -- robust trilateration of the tip;
- :mod:`~pcmm_geo.machine.kinematics._pose_solver` -- the batched Gauss-Newton closure solver
  (internal);
- :mod:`~pcmm_geo.machine.kinematics.seed_forms` -- the seed's equations *as printed*, for
  tests and documentation of the errata.

May import: :mod:`pcmm_geo.errors`, :mod:`pcmm_geo.fit`, :mod:`pcmm_geo.thermal`,
:mod:`pcmm_geo.io`.  Nothing else of :mod:`pcmm_geo.machine`: calibration, analysis and
:mod:`pcmm_geo.acquisition` build on the kinematics, never the other way round.
"""
