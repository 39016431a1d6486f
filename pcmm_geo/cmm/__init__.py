"""Files from external CMMs, above the fits and the readers: second opinion, fits as QIF, point sets to fit.

The readers and the writer (:mod:`pcmm_geo.io.cmm`) know plain dataclasses and no fits; the fits
(:mod:`pcmm_geo.fit`, with probe compensation in :mod:`pcmm_geo.fit.probe`) know no files.  This
package joins them:

================================  =================================================================
name                              what it does
================================  =================================================================
:func:`verify_document`           refit every measured feature of a results file from its points
                                  (compensated, common frame, the file's criterion) and compare
                                  with the CMM's actuals (``pcmm qif verify``); :func:`verify_qif`
                                  reads the file first
:func:`refit_feature`             the refit of one feature
:func:`fit_results_document`      a fit (with form evaluation, verdict, uncertainty) as the QIF
                                  writer's records (``pcmm fit|form --qif``); one feature:
                                  :func:`feature_report`
:func:`load_feature_points`       the points of one feature of a CMM file, with what the file
                                  says about their compensation (``pcmm fit FILE.qif``)
:func:`read_cmm_document`         a QIF document, DMIS output or CALYPSO table, format detected
:func:`plan_compensation`         probe compensation decided once (file flags and the caller's
                                  statement -> radius, side, sources; :class:`Compensation`)
================================  =================================================================
"""

from __future__ import annotations

import importlib
from typing import Any

_LAZY = {
    "DEFAULT_TOLERANCE_MM": "verify",
    "FeatureCheck": "verify",
    "Verification": "verify",
    "verify_document": "verify",
    "verify_qif": "verify",
    "Compensation": "compensation",
    "CompensationPlan": "compensation",
    "plan_compensation": "compensation",
    "Refit": "refit",
    "refit_feature": "refit",
    "feature_report": "export",
    "fit_results_document": "export",
    "FeaturePoints": "points",
    "detect_format": "files",
    "read_cmm_document": "files",
    "load_feature_points": "points",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    module_name = _LAZY.get(name)
    if module_name is None:
        raise AttributeError(f"module 'pcmm_geo.cmm' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"pcmm_geo.cmm.{module_name}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
