"""I++ DME 1.4.3 server in front of the simulated micro-CMM or the real one on its drivers (issue 34).

Inspection software speaks I++ DME to a CMM: this package lets it drive pcmm_geo's micro-CMM.
:mod:`~pcmm_geo.ippdme.protocol` parses command lines and formats responses;
:mod:`~pcmm_geo.ippdme.session` and :mod:`~pcmm_geo.ippdme.commands` are the session's state
machine and method handlers, driving a :class:`~pcmm_geo.ippdme.machine.MachineBackend`:
:mod:`~pcmm_geo.ippdme.machine` holds the interface and the simulated machine (the
calibrated kinematic model, a true machine within the calibration's uncertainty, noisy
readings counted in microsteps), :mod:`~pcmm_geo.ippdme.drivers` the real machine on the
acquisition drivers; :mod:`~pcmm_geo.ippdme.calfile` reads the calibrated machine of a
calibration file; :mod:`~pcmm_geo.ippdme.workpieces` the simulated parts;
:mod:`~pcmm_geo.ippdme.server` the asyncio TCP server; :mod:`~pcmm_geo.ippdme.transcript`
the durable session transcript and the points read back from it.  ``pcmm serve`` runs it.
"""

from __future__ import annotations

__all__ = ["DEFAULT_PORT"]

DEFAULT_PORT = 1294
