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
                                  :func:`feature_report` (several: pass them to
                                  :func:`~pcmm_geo.io.cmm.results_document`)
:func:`file_feature`              what a file states about a feature that its refit keeps in
                                  the QIF written (name, nominal, side, size tolerance)
:func:`verification_document`     every refit of a verification as one QIF results document
                                  (``pcmm qif verify --qif``); one refit: :func:`refit_report`
:func:`load_feature_points`       the points of one feature of a CMM file, with what the file
                                  says about their compensation (``pcmm fit FILE.qif``)
:func:`read_cmm_document`         a QIF document, DMIS output or CALYPSO table, format detected
:func:`plan_compensation`         probe compensation decided once (file flags and the caller's
                                  statement -> radius, side, sources; :class:`Compensation`)
================================  =================================================================
"""

from __future__ import annotations

from pcmm_geo._lazy import attach

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
    "FileFeature": "export",
    "file_feature": "export",
    "refit_report": "export",
    "verification_document": "export",
    "fit_results_document": "export",
    "FeaturePoints": "points",
    "detect_format": "files",
    "read_cmm_document": "files",
    "load_feature_points": "points",
}

__getattr__, __dir__, __all__ = attach(__name__, _LAZY)
