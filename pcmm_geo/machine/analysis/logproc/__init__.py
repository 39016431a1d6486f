"""Processing of the seed's measurement log (thesis 3.6, Table 3.2; 5.2; Appendix D) into probe points.

A log of ``N`` rows ``start_stop,probe,motor,direction,laser_a,laser_b,laser_c`` becomes ``N``
tips, each with its covariance, its external reliability and its flags
(:func:`process_log`, :class:`ProcessedLog`).  The modules, in the order the data flow:

- :mod:`~pcmm_geo.machine.analysis.logproc.rows` -- the rows: array type, CSV reader and writer;
- :mod:`~pcmm_geo.machine.analysis.logproc.segments` -- the seed's row logic (which motor moved,
  which heights stand still) as unknowns, and their starting values on the branches the motor
  directions pick;
- :mod:`~pcmm_geo.machine.analysis.logproc.geometry` -- what three lasers say about three
  heights: the pivot distances, and the derivatives of lasers and tip by heights and geometry;
- :mod:`~pcmm_geo.machine.analysis.logproc.adjustment` -- the network adjustment: every height
  from every reading by least squares;
- :mod:`~pcmm_geo.machine.analysis.logproc.gate` -- the lasers' uncertainty and Baarda's w-test
  per reading, minimal detectable biases;
- :mod:`~pcmm_geo.machine.analysis.logproc.reliability` -- redundancy numbers, tip covariance
  (readings and calibration) and external reliability of every row;
- :mod:`~pcmm_geo.machine.analysis.logproc.ambiguity` -- mirror poses the data cannot exclude;
- :mod:`~pcmm_geo.machine.analysis.logproc.uncertainty` -- what ``tip_uncertainty`` means for a
  3-D point, and its limit;
- :mod:`~pcmm_geo.machine.analysis.logproc.process` -- :func:`process_log` and how the flags combine;
- :mod:`~pcmm_geo.machine.analysis.logproc.synthesis` -- noise-free logs of known heights;
- :mod:`~pcmm_geo.machine.analysis.logproc.dpkm` -- the seed's own processing, for comparison.

How the seed used the rows (Appendix D, lines 98-257), and what is kept
-----------------------------------------------------------------------
* Row 1 sets the datum.  Here it is the start position (``initial_heights``): the thesis starts
  every log at one encoder count for all motors (6.3), so all three start heights are known and
  the first row's lasers check them.
* On a *stop* row only the motor moved can have changed height; on a *start* row whose lasers
  differ from the previous row (the machine had not settled, thesis 3.5) the previous row's
  motor is still moving; a start row with the same lasers is the same reading.  Kept
  (:mod:`~pcmm_geo.machine.analysis.logproc.segments`).
* The seed re-derived the moved pivot's height from the laser pair with one neighbour and took
  ``direction`` as the sign of the height difference.  Replaced: every height comes from all
  three lasers of every row that sees it, and ``direction`` (which says whether the pivot moved
  up or down, not on which side of its neighbour it ends) only picks between mirror branches.
* Probe points are the rows with ``probe = 1``.

Examples
--------
>>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
>>> machine = RigidBodyMachine.from_dpkm()
>>> start = machine.reference_heights + [0.0, 60.0, -50.0]
>>> log = synthesise_log(machine, start, [(1, 5.0, True), (2, -4.0, True)])
>>> processed = process_log(machine, log, initial_heights=start)
>>> processed.probe_points.shape
(2, 3)
"""

from pcmm_geo.machine.analysis.logproc.dpkm import SEED_NEIGHBOUR, process_log_dpkm
from pcmm_geo.machine.analysis.logproc.gate import (
    DEFAULT_ALPHA,
    DEFAULT_POWER,
    SEED_LASER_ACCURACY,
    SEED_LASER_SIGMA,
    SEED_LASER_STEPS,
)
from pcmm_geo.machine.analysis.logproc.geometry import GEOMETRY_PARAMETERS
from pcmm_geo.machine.analysis.logproc.process import ProcessedLog, process_log
from pcmm_geo.machine.analysis.logproc.rows import LOG_COLUMNS, MeasurementLog, read_log, write_log
from pcmm_geo.machine.analysis.logproc.synthesis import synthesise_log
from pcmm_geo.machine.analysis.logproc.uncertainty import DEFAULT_MAX_TIP_UNCERTAINTY, flag_uncertain_tips

__all__ = [
    "DEFAULT_ALPHA",
    "DEFAULT_MAX_TIP_UNCERTAINTY",
    "DEFAULT_POWER",
    "GEOMETRY_PARAMETERS",
    "LOG_COLUMNS",
    "SEED_LASER_ACCURACY",
    "SEED_LASER_SIGMA",
    "SEED_LASER_STEPS",
    "SEED_NEIGHBOUR",
    "MeasurementLog",
    "ProcessedLog",
    "flag_uncertain_tips",
    "process_log",
    "process_log_dpkm",
    "read_log",
    "synthesise_log",
    "write_log",
]
