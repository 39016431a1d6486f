"""ISO 10360-2 length measurement test: errors E0, repeatability range R0, conformance decision.

Each calibrated test length is measured in several positions of the measuring volume,
several times (the standard: 5 lengths × 7 positions × 3 repetitions = 105 values).  For
each measurement the length measurement error is ``E0 = measured − calibrated`` and the
repeatability range ``R0`` is the range of the repetitions of one length in one position.

The maximum permissible error is stated as ``MPE_E0 = A + L/K`` (µm, with ``L`` in mm),
optionally capped: ``MPE_E0 = min(A + L/K, B)``.

Decision rule (ISO 14253-1 style, stated in every result):

* ``"simple"`` -- simple acceptance, zero guard band: a value conforms when ``|E0| ≤ MPE``.
* ``"guarded"`` -- guarded acceptance: the conformance zone is reduced by the expanded
  uncertainty ``U`` of the test: a value conforms when ``|E0| + U ≤ MPE``.
* ``"iso14253"`` -- the three-state rule of ISO 14253-1
  (:func:`pcmm_geo.uncertainty.conformity.decide_conformity`): ``PASS`` (conformity
  proved, ``|E0| + U ≤ MPE``), ``FAIL`` (nonconformity proved, ``|E0| − U > MPE``) or
  ``NOT PROVEN``; the test's ``verdict`` is ``FAIL`` if any value fails, ``PASS`` if all
  pass.  ``passed`` is True only for ``PASS``.

The machine passes when every value conforms (and every R0 does, when an ``MPL_R0`` is
given).  The retest allowances of ISO 10360-2:2009 are not applied automatically.

CSV input (:func:`read_length_test_csv`), header
``length_id,position,repetition,calibrated_length,measured_length`` (mm); ``#`` comment
lines allowed.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pcmm_geo.artefacts.table import cell_float, cell_int, cell_text, read_rows
from pcmm_geo.errors import FileFormatError, InvalidInputError

__all__ = [
    "DECISION_RULES",
    "E0Value",
    "LengthMeasurement",
    "LengthMpe",
    "LengthTestResult",
    "R0Value",
    "STANDARD_LAYOUT",
    "completeness",
    "evaluate_length_test",
    "read_length_test_csv",
]

#: the standard's data set: (test lengths, positions, repetitions) = 5 x 7 x 3 = 105 values
STANDARD_LAYOUT = (5, 7, 3)

DECISION_RULES = {
    "simple": "simple acceptance (ISO 14253-1, zero guard band): |E0| <= MPE_E0",
    "guarded": "guarded acceptance (ISO 14253-1): |E0| + U <= MPE_E0, U = expanded test uncertainty",
    "iso14253": "ISO 14253-1: PASS if |E0| + U <= MPE_E0 (conformity proved), FAIL if |E0| - U > MPE_E0 "
    "(nonconformity proved), otherwise NOT PROVEN",
}


@dataclass(frozen=True)
class LengthMpe:
    """``MPE_E0 = min(A + L/K, B)`` in µm with L in mm.

    Attributes
    ----------
    a_um : float
        Constant term A (µm), >= 0.
    k : float
        Length divisor K (mm per µm), > 0.
    b_um : float or None
        Optional cap B (µm).

    Examples
    --------
    >>> LengthMpe(1.5, 333.0).mpe_mm(500.0) * 1000
    3.0015015015015014
    """

    a_um: float
    k: float
    b_um: float | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.a_um) and self.a_um >= 0):
            raise InvalidInputError("mpe A", "a non-negative number of micrometres", repr(self.a_um))
        if not (math.isfinite(self.k) and self.k > 0):
            raise InvalidInputError("mpe K", "a positive number", repr(self.k))
        if self.b_um is not None and not (math.isfinite(self.b_um) and self.b_um > 0):
            raise InvalidInputError("mpe B", "a positive number of micrometres or None", repr(self.b_um))

    def mpe_mm(self, length: float) -> float:
        """MPE (mm) for a test length (mm)."""
        value = self.a_um + abs(length) / self.k
        if self.b_um is not None:
            value = min(value, self.b_um)
        return value / 1000.0


@dataclass(frozen=True)
class LengthMeasurement:
    """One measured test length (mm)."""

    length_id: str
    position: str
    repetition: int
    calibrated_length: float
    measured_length: float


@dataclass(frozen=True)
class E0Value:
    """Error of one measurement and its verdict (lengths in mm)."""

    length_id: str
    position: str
    repetition: int
    calibrated_length: float
    error: float
    mpe: float
    acceptance_limit: float
    conforms: bool
    #: ISO 14253-1 verdict (``"PASS"``, ``"FAIL"``, ``"NOT PROVEN"``) under the ``"iso14253"`` rule, else ""
    verdict: str = ""


@dataclass(frozen=True)
class R0Value:
    """Repeatability range of one length in one position (mm)."""

    length_id: str
    position: str
    repetitions: int
    range: float
    conforms: bool


@dataclass(frozen=True)
class LengthTestResult:
    """ISO 10360-2 evaluation.

    Attributes
    ----------
    errors : tuple of E0Value
    repeatability : tuple of R0Value
    max_abs_error : float
        Largest ``|E0|`` (mm).
    max_error_ratio : float
        Largest ``|E0| / MPE_E0``.
    max_range : float
        Largest R0 (mm).
    n_nonconforming : int
        E0 values (and R0 values) outside their acceptance limits.
    passed : bool
    decision_rule : str
        Text of the rule applied.
    test_uncertainty : float
        Expanded uncertainty U used by the guarded rule (mm).
    mpe : LengthMpe
    mpl_r0 : float or None
        Limit of R0 (mm), if given.
    complete : bool
        The data set is the standard's 5 lengths x 7 positions x 3 repetitions.  A partial set
        (evaluated only on request) never passes: ``passed`` is then False when a value does not
        conform and None otherwise.
    completeness : str
        What the data set holds against the standard ("" when complete).
    """

    errors: tuple[E0Value, ...]
    repeatability: tuple[R0Value, ...]
    max_abs_error: float
    max_error_ratio: float
    max_range: float
    n_nonconforming: int
    passed: bool | None
    decision_rule: str
    test_uncertainty: float
    mpe: LengthMpe
    mpl_r0: float | None
    #: ``"PASS"``, ``"FAIL"`` or (``"iso14253"`` rule only) ``"NOT PROVEN"``
    verdict: str = ""
    complete: bool = True
    completeness: str = ""


def completeness(measurements: Iterable[LengthMeasurement]) -> str:
    """What a data set lacks against the standard's 5 lengths x 7 positions x 3 repetitions ("" when complete).

    Raises
    ------
    InvalidInputError
        The same length, position and repetition appear twice.

    Examples
    --------
    >>> completeness([LengthMeasurement("L1", "x", r, 100.0, 100.0) for r in (1, 2, 3)])
    '3 of 105 values: 1 of 5 lengths, 1 of 7 positions'
    """
    lengths_needed, positions_needed, repetitions_needed = STANDARD_LAYOUT
    seen: set[tuple[str, str, int]] = set()
    for item in measurements:
        key = (item.length_id, item.position, item.repetition)
        if key in seen:
            raise InvalidInputError("measurements", "each length/position/repetition once", f"{key} twice")
        seen.add(key)
    lengths = {k[0] for k in seen}
    positions = {k[1] for k in seen}
    per_group: dict[tuple[str, str], int] = {}
    for length_id, position, _ in seen:
        per_group[(length_id, position)] = per_group.get((length_id, position), 0) + 1
    needed = lengths_needed * positions_needed * repetitions_needed
    gaps = []
    if len(lengths) != lengths_needed:
        gaps.append(f"{len(lengths)} of {lengths_needed} lengths")
    if len(positions) != positions_needed:
        gaps.append(f"{len(positions)} of {positions_needed} positions")
    missing_groups = len(lengths) * len(positions) - len(per_group)
    if missing_groups:
        gaps.append(f"{missing_groups} length/position pairs not measured")
    odd = sum(count != repetitions_needed for count in per_group.values())
    if odd:
        gaps.append(f"{odd} length/position pairs without {repetitions_needed} repetitions")
    if not gaps and len(seen) == needed:
        return ""
    return f"{len(seen)} of {needed} values" + (": " + ", ".join(gaps) if gaps else "")


def evaluate_length_test(
    measurements: Iterable[LengthMeasurement],
    mpe: LengthMpe,
    *,
    decision_rule: str = "simple",
    test_uncertainty: float = 0.0,
    mpl_r0: float | None = None,
    allow_incomplete: bool = False,
) -> LengthTestResult:
    r"""Evaluate an ISO 10360-2 length test.

    Parameters
    ----------
    measurements : iterable of LengthMeasurement
        All measured test lengths (mm).
    mpe : LengthMpe
        The stated ``MPE_E0``.
    decision_rule : {"simple", "guarded", "iso14253"}
        See the module documentation.
    test_uncertainty : float
        Expanded uncertainty U of the test (mm), used by ``"guarded"``.
    mpl_r0 : float, optional
        Maximum permissible limit of R0 (mm).
    allow_incomplete : bool
        Evaluate a data set that is not the standard's 105 values (see :func:`completeness`);
        the result is then marked incomplete and never passes.

    Returns
    -------
    LengthTestResult

    Raises
    ------
    InvalidInputError
        No measurements, unknown rule, negative U, or a calibrated length that differs
        between measurements of the same ``length_id``, or a length/position/repetition twice.
    IncompleteTestError
        Not the standard's 5 x 7 x 3 values and ``allow_incomplete`` is False.

    See Also
    --------
    pcmm_geo.uncertainty.conformity : the ISO 14253-1 decision rule
    pcmm_geo.artefacts.iso10360_5.evaluate_probing : the probing test of ISO 10360-5

    Notes
    -----
    ISO 10360-2 [1]_ (and ASME B89.4.10360.2 [2]_): each length measurement error is
    :math:`E_0 = L_\mathrm{measured} - L_\mathrm{calibrated}`, compared with the maximum
    permissible error, commonly stated as :math:`\mathrm{MPE}_{E_0} = \pm (A + L / K)`; the
    repeatability range :math:`R_0` is the range of the three repeated measurements of one
    length in one position.  ``decision_rule="iso14253"`` decides with the guard bands of
    ISO 14253-1 [3]_.

    References
    ----------
    .. [1] ISO 10360-2:2009, *Geometrical product specifications (GPS) -- Acceptance and reverification tests
           for coordinate measuring machines (CMM) -- Part 2: CMMs used for measuring linear dimensions*.
    .. [2] ASME B89.4.10360.2-2008, *Acceptance Test and Reverification Test for Coordinate Measuring Machines
           (CMMs) -- Part 2: CMMs Used for Measuring Linear Dimensions*.
    .. [3] ISO 14253-1:2017, *Geometrical product specifications (GPS) -- Inspection by measurement of
           workpieces and measuring equipment -- Part 1: Decision rules for verifying conformity or
           nonconformity with specifications*.

    Examples
    --------
    >>> data = [LengthMeasurement("L1", "x", r, 100.0, 100.0 + e) for r, e in enumerate([1e-3, 2e-3, -1e-3])]
    >>> res = evaluate_length_test(data, LengthMpe(2.0, 100.0), allow_incomplete=True)
    >>> res.passed, round(res.max_abs_error, 6), round(res.repeatability[0].range, 6)
    (None, 0.002, 0.003)
    >>> res.verdict.split(":")[0]
    'INCOMPLETE (3 of 105 values'
    """
    from pcmm_geo.errors import IncompleteTestError

    if decision_rule not in DECISION_RULES:
        raise InvalidInputError("decision_rule", f"one of {sorted(DECISION_RULES)}", repr(decision_rule))
    if not (math.isfinite(test_uncertainty) and test_uncertainty >= 0):
        raise InvalidInputError("test_uncertainty", "a non-negative length in mm", repr(test_uncertainty))
    if mpl_r0 is not None and not (math.isfinite(mpl_r0) and mpl_r0 > 0):
        raise InvalidInputError("mpl_r0", "a positive length in mm or None", repr(mpl_r0))
    items = list(measurements)
    if not items:
        raise InvalidInputError("measurements", "at least one measured test length", "none")
    calibrated: dict[str, float] = {}
    for item in items:
        known = calibrated.setdefault(item.length_id, item.calibrated_length)
        if known != item.calibrated_length:
            raise InvalidInputError(
                f"calibrated_length of {item.length_id!r}", f"{known} mm in every row", f"{item.calibrated_length} mm"
            )
    missing = completeness(items)
    if missing and not allow_incomplete:
        raise IncompleteTestError("ISO 10360-2", math.prod(STANDARD_LAYOUT), len(items), missing.partition(": ")[2])
    guard = test_uncertainty if decision_rule in ("guarded", "iso14253") else 0.0
    errors = []
    for item in items:
        limit_mpe = mpe.mpe_mm(item.calibrated_length)
        error = item.measured_length - item.calibrated_length
        verdict = ""
        if decision_rule == "iso14253":
            from pcmm_geo.uncertainty.conformity import decide_conformity

            verdict = decide_conformity(abs(error), test_uncertainty, upper_limit=limit_mpe).verdict
        errors.append(
            E0Value(
                length_id=item.length_id,
                position=item.position,
                repetition=item.repetition,
                calibrated_length=item.calibrated_length,
                error=error,
                mpe=limit_mpe,
                acceptance_limit=limit_mpe - guard,
                conforms=abs(error) <= limit_mpe - guard,
                verdict=verdict,
            )
        )
    groups: dict[tuple[str, str], list[float]] = {}
    for item in items:
        groups.setdefault((item.length_id, item.position), []).append(item.measured_length)
    ranges = []
    for (length_id, position), values in groups.items():
        spread = float(np.ptp(values))
        ok = True if mpl_r0 is None else spread <= mpl_r0 - guard
        ranges.append(R0Value(length_id, position, len(values), spread, ok))
    n_bad = sum(not e.conforms for e in errors) + sum(not r.conforms for r in ranges)
    if decision_rule == "iso14253":
        from pcmm_geo.uncertainty.conformity import overall_verdict

        verdict = overall_verdict([e.verdict for e in errors] + ["PASS" if r.conforms else "NOT PROVEN"
                                                                 for r in ranges])
    else:
        verdict = "PASS" if n_bad == 0 else "FAIL"
    if missing:  # a partial data set never passes; a proven nonconformity is still reported
        found = "FAIL" if verdict == "FAIL" else (
            "NOT PROVEN" if verdict == "NOT PROVEN" else "no nonconforming value among these")
        verdict = f"INCOMPLETE ({missing}): {found}" + ("" if verdict == "FAIL" else ", no acceptance verdict")
    return LengthTestResult(
        errors=tuple(errors),
        repeatability=tuple(ranges),
        max_abs_error=max(abs(e.error) for e in errors),
        max_error_ratio=max(abs(e.error) / e.mpe if e.mpe > 0 else math.inf for e in errors),
        max_range=max(r.range for r in ranges),
        n_nonconforming=n_bad,
        passed=False if n_bad else (True if not missing else None),
        decision_rule=DECISION_RULES[decision_rule],
        test_uncertainty=test_uncertainty,
        mpe=mpe,
        mpl_r0=mpl_r0,
        verdict=verdict,
        complete=not missing,
        completeness=missing,
    )


def read_length_test_csv(path: str | Path) -> list[LengthMeasurement]:
    """Read ``length_id,position,repetition,calibrated_length,measured_length`` rows (mm).

    Raises
    ------
    FileFormatError
        Missing columns, non-numeric cells, non-positive calibrated length.
    OSError
        Unreadable file.

    Examples
    --------
    >>> from importlib.resources import files
    >>> rows = read_length_test_csv(files("pcmm_geo") / "data/examples/iso10360_2_lengths.csv")
    >>> len(rows)
    105
    """
    columns = ("length_id", "position", "repetition", "calibrated_length", "measured_length")
    out = []
    for line, row in read_rows(path, columns):
        calibrated = cell_float(path, line, row, "calibrated_length")
        if calibrated <= 0:
            raise FileFormatError(str(path), f"calibrated_length: expected a positive length, got {calibrated}", line)
        out.append(
            LengthMeasurement(
                length_id=cell_text(path, line, row, "length_id"),
                position=cell_text(path, line, row, "position"),
                repetition=cell_int(path, line, row, "repetition"),
                calibrated_length=calibrated,
                measured_length=cell_float(path, line, row, "measured_length"),
            )
        )
    return out
