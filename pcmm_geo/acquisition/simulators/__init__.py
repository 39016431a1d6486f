"""Device simulators behind real pseudo-terminals, for tests and ``pcmm acquire --simulate``.

- :mod:`~pcmm_geo.acquisition.simulators.pty` -- :class:`PtyServer`: one thread serving any number
  of simulated devices, each on its own ``os.openpty`` pair in raw mode;
- :mod:`~pcmm_geo.acquisition.simulators.devices` -- Zaber T-series chain, ILD1302 / ILD1420
  streams, Arduino probe;
- :mod:`~pcmm_geo.acquisition.simulators.faults` -- seeded fault injection (garbled bytes, dropped
  bytes, timeouts, device error replies, disconnect);
- :mod:`~pcmm_geo.acquisition.simulators.cmm` -- the simulated micro-CMM on the rigid-body model
  with a gauge block, and :class:`~pcmm_geo.acquisition.simulators.cmm.SimulatedRig` which starts
  all five devices.

POSIX only (pseudo-terminals).
"""
