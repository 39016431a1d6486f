"""Type stub of :mod:`pcmm_geo.plots`: lazy public names, real types (pcmm_geo._lazy)."""

from ._figure import check_plot_path as check_plot_path
from ._figure import length_unit as length_unit
from .demo import plot_demo_overview as plot_demo_overview
from .demo import plot_tip_errors as plot_tip_errors
from .fit_residuals import plot_fit_residuals as plot_fit_residuals
from .gauge_block import plot_gauge_block as plot_gauge_block
from .machine.calibration import plot_calibration as plot_calibration
from .machine.conditioning import plot_conditioning_maps as plot_conditioning_maps
from .machine.machine_state import plot_numerical_calibration as plot_numerical_calibration
from .machine.machine_state import plot_pose as plot_pose
from .machine.machine_state import plot_trilateration as plot_trilateration
from .machine.process_log import plot_processed_log as plot_processed_log
from .machine.sensitivity import plot_sensitivity as plot_sensitivity
from .thermal import plot_frame_triangle as plot_frame_triangle
from .thermal import plot_length_correction as plot_length_correction
from .thermal import plot_sensor_curve as plot_sensor_curve
from .thermal import plot_thermal_table as plot_thermal_table
from .uncertainty import plot_monte_carlo as plot_monte_carlo
from .verification import plot_length_test as plot_length_test
from .verification import plot_probing_test as plot_probing_test
from .verification import plot_software_test as plot_software_test
from .verification import plot_stage_test as plot_stage_test
