"""Type stub of :mod:`pcmm_geo.cmm`: lazy public names, real types (pcmm_geo._lazy)."""

from .compensation import Compensation as Compensation
from .compensation import CompensationPlan as CompensationPlan
from .compensation import plan_compensation as plan_compensation
from .export import FileFeature as FileFeature
from .export import feature_report as feature_report
from .export import file_feature as file_feature
from .export import fit_results_document as fit_results_document
from .export import refit_report as refit_report
from .export import verification_document as verification_document
from .files import detect_format as detect_format
from .files import read_cmm_document as read_cmm_document
from .points import FeaturePoints as FeaturePoints
from .points import load_feature_points as load_feature_points
from .refit import Refit as Refit
from .refit import refit_feature as refit_feature
from .verify import DEFAULT_TOLERANCE_MM as DEFAULT_TOLERANCE_MM
from .verify import FeatureCheck as FeatureCheck
from .verify import Verification as Verification
from .verify import verify_document as verify_document
from .verify import verify_qif as verify_qif
