"""Type stub of :mod:`pcmm_geo.fit.zone`: lazy public names, real types (pcmm_geo._lazy)."""

from . import reference as reference
from ._common import CRITERIA as CRITERIA
from .batch import RoundnessBatch as RoundnessBatch
from .batch import roundness_profiles as roundness_profiles
from .form import FormEvaluation as FormEvaluation
from .form import decide_form as decide_form
from .form import evaluate_form as evaluate_form
