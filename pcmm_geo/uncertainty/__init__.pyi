"""Type stub of :mod:`pcmm_geo.uncertainty`: lazy public names, real types (pcmm_geo._lazy)."""

from .calibration import CalibrationCovariance as CalibrationCovariance
from .calibration import calibration_covariance as calibration_covariance
from .calibration import calibration_covariance_monte_carlo as calibration_covariance_monte_carlo
from .conformity import ConformityDecision as ConformityDecision
from .conformity import decide_conformity as decide_conformity
from .gum import coverage_factor as coverage_factor
from .gum import jacobian as jacobian
from .gum import propagate as propagate
from .gum import propagate_covariance as propagate_covariance
from .gum import welch_satterthwaite as welch_satterthwaite
from .kinematics import forward_batch as forward_batch
from .montecarlo import adaptive_monte_carlo as adaptive_monte_carlo
from .montecarlo import coverage_interval as coverage_interval
from .montecarlo import monte_carlo_propagate as monte_carlo_propagate
from .montecarlo import numerical_tolerance as numerical_tolerance
from .montecarlo import sample_normal as sample_normal
from .montecarlo import validate_gum as validate_gum
from .result import BudgetEntry as BudgetEntry
from .result import UncertaintyResult as UncertaintyResult
from .tasks import MeasurementTask as MeasurementTask
from .tasks import distance_task as distance_task
from .tasks import gauge_block_task as gauge_block_task
from .tasks import sphere_task as sphere_task
from .virtual_cmm import TaskUncertainty as TaskUncertainty
from .virtual_cmm import ThermalInputs as ThermalInputs
from .virtual_cmm import VirtualCMM as VirtualCMM
