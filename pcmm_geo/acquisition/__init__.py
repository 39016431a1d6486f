"""Acquisition layer: talking to the micro-CMM's hardware and recording what it said.

What lives here:

- :mod:`~pcmm_geo.acquisition.drivers` -- serial drivers of the devices (Zaber T-series stages,
  Micro-Epsilon ILD1302 / ILD1420 lasers, the Arduino reporting the TP8 probe);
- :mod:`~pcmm_geo.acquisition.simulators` -- simulated devices behind pseudo-terminals and the
  simulated micro-CMM rig (``pcmm acquire --simulate``, tests);
- :mod:`~pcmm_geo.acquisition.session` -- an acquisition session: homing, the settling
  pre-sequence, moves with start/stop rows (thesis 3.5-3.6), retries of transient faults;
- :mod:`~pcmm_geo.acquisition.acqlog` -- the durable (fsync'ed, checksummed) acquisition log and
  its export to the seed's Table 3.2 view;
- :mod:`~pcmm_geo.acquisition.loglock` -- one session at a time on a log (``check_unlocked``:
  ``pcmm acquire`` refuses a busy log before any device moves);
- :mod:`~pcmm_geo.acquisition.programme` -- the library side of ``pcmm acquire``: the five
  devices opened as one session, the seeded move programme.

May import: :mod:`pcmm_geo.errors`, the lower layers (:mod:`pcmm_geo.fit`, :mod:`pcmm_geo.io`,
:mod:`pcmm_geo.thermal`) and the machine model it simulates,
:mod:`pcmm_geo.machine.kinematics` -- nothing else of :mod:`pcmm_geo.machine`, nothing above.
Processing a recorded log is :mod:`pcmm_geo.machine.analysis`'s job.

Modules are imported by full path (``pcmm_geo.acquisition.drivers.zaber``) so that nothing
heavy (pyserial, threads) loads with the package.
"""
