"""Type stub of :mod:`pcmm_geo.machine.calibration`: lazy public names, real types (pcmm_geo._lazy)."""

from .calfile import load_calibration as load_calibration
from .calfile import save_calibration as save_calibration
from .geometry import seed_printed_angle_deg as seed_printed_angle_deg
from .result import PAIRS as PAIRS
from .result import SliderLineCalibration as SliderLineCalibration
from .result import TetrahedronCalibration as TetrahedronCalibration
from .tetrahedron import b_in_from_lasers as b_in_from_lasers
from .tetrahedron import calibrate_tetrahedron as calibrate_tetrahedron
