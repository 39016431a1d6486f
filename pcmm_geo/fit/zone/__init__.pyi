"""Type stub of :mod:`pcmm_geo.fit.zone`: lazy public names, real types (pcmm_geo._lazy)."""

from . import reference as reference
from ._check import CheckOutcome as CheckOutcome
from ._check import check_answer as check_answer
from ._common import CRITERIA as CRITERIA
from ._distinct import merge_duplicates as merge_duplicates
from .batch import RoundnessBatch as RoundnessBatch
from .batch import roundness_profiles as roundness_profiles
from .form import FormEvaluation as FormEvaluation
from .form import decide_form as decide_form
from .form import evaluate_form as evaluate_form
