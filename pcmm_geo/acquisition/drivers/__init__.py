"""Serial drivers of the micro-CMM's devices (thesis 3.1-3.4).

- :mod:`~pcmm_geo.acquisition.drivers.zaber` -- Zaber T-series binary protocol, three daisy-chained
  T-LSR stages on one port;
- :mod:`~pcmm_geo.acquisition.drivers.lasers` -- Micro-Epsilon optoNCDT ILD1302 / ILD1420 output
  streams (lasers a, b are ILD1302, laser c an ILD1420 in the seed);
- :mod:`~pcmm_geo.acquisition.drivers.probe` -- the Arduino reporting the TP8 probe state.

Every driver accepts a port name / pyserial URL or an already-open pyserial port object;
``serial`` is imported only when a port has to be opened.  Modules are imported by full path
(``pcmm_geo.acquisition.drivers.zaber``) so that nothing heavy loads with :mod:`pcmm_geo.machine`.
"""
