"""The full results tables of the ISO 10360-2 and ISO 10360-5 reports (every value, its limit, U and verdict).

ISO 10360-2:2009 clause 7 and ISO/IEC 17025 7.8 ask for every test result, not a summary: the
terminal prints the values that do not conform, a ``--report`` prints all of them.  Values are
written as text with a fixed number of decimals (µm to 3 decimals, mm to 6) so that the tables
read like a certificate's, not like floating-point dumps.
"""

from __future__ import annotations

from typing import Any

from pcmm_geo.cli._output import Table


def _um(value_mm: float) -> str:
    """A length in mm as micrometres with 3 decimals (``0.00118`` -> ``"1.180"``)."""
    return f"{1000.0 * value_mm:.3f}"


def e0_verdict(value: Any) -> str:
    """The verdict of one E0 value: its ISO 14253-1 state, else PASS / FAIL of the acceptance rule."""
    return value.verdict or ("PASS" if value.conforms else "FAIL")


def length_test_tables(result: Any, rule: str) -> list[Table]:
    """Every E0 value and every R0 value of an ISO 10360-2 evaluation, each with its limit, U and verdict.

    Parameters
    ----------
    result : pcmm_geo.artefacts.iso10360_2.LengthTestResult
    rule : {"simple", "guarded", "iso14253"}
        The decision rule applied (whether U entered the verdicts).

    Returns
    -------
    list of Table
        ``[E0 table (one row per length, position, repetition), R0 table (one row per length and position)]``.

    Examples
    --------
    >>> from pcmm_geo.artefacts.iso10360_2 import LengthMeasurement, LengthMpe, evaluate_length_test
    >>> data = [LengthMeasurement("L1", "x", r, 100.0, 100.0 + e) for r, e in enumerate([1e-3, 2e-3, -1e-3], 1)]
    >>> e0, r0 = length_test_tables(evaluate_length_test(data, LengthMpe(2.0, 100.0), allow_incomplete=True),
    ...                             "simple")
    >>> e0.rows[1]
    ['L1', 'x', 2, '100.000000', '2.000', '3.000', 'not used', '0.67', 'PASS']
    >>> r0.rows
    [['L1', 'x', 3, '3.000', 'none stated', '-']]
    """
    u_text = _um(result.test_uncertainty) if rule != "simple" else "not used"
    e0_rows = [[e.length_id, e.position, e.repetition, f"{e.calibrated_length:.6f}", _um(e.error), _um(e.mpe),
                u_text, f"{abs(e.error) / e.mpe:.2f}" if e.mpe > 0 else "-", e0_verdict(e)]
               for e in result.errors]
    e0 = Table(f"Results: all {len(e0_rows)} length measurement errors E0",
               ["length", "position", "repetition", "L / mm", "E0 / µm", "MPE_E0 / µm", "U / µm (k = 2)",
                "|E0| / MPE", "verdict"], e0_rows)
    limit = result.mpl_r0
    r0_rows = []
    for r in result.repeatability:
        if limit is None:
            verdict = "-"
        elif r.conforms:
            verdict = "PASS"
        else:  # the library's state: under the ISO 14253-1 rule an R0 above its guarded limit is not proven
            verdict = "NOT PROVEN" if rule == "iso14253" else "FAIL"
        r0_rows.append([r.length_id, r.position, r.repetitions, _um(r.range),
                        "none stated" if limit is None else _um(limit), verdict])
    r0 = Table(f"Results: all {len(r0_rows)} repeatability ranges R0", ["length", "position", "repetitions",
               "R0 / µm", "limit R0 / µm", "verdict"], r0_rows)
    return [e0, r0]


def probing_test_tables(result: Any, points: Any) -> list[Table]:
    """P_FTU and P_STU with their MPE, U and verdict, and every probed point's residual (ISO 10360-5).

    Parameters
    ----------
    result : pcmm_geo.artefacts.iso10360_5.ProbingResult
    points : array_like, shape (N, 3)
        The probed points (mm), in the order of ``result.residuals``.

    Returns
    -------
    list of Table
        ``[test values, residuals of the N points from the Gaussian sphere]``.
    """
    u_form, u_size = result.test_uncertainty if result.test_uncertainty is not None else (None, None)

    def verdict(limit: float | None, conforms: bool | None, state: str) -> str:
        if limit is None:
            return "no MPE stated"
        return state or ("PASS" if conforms else "FAIL")

    values = Table("Results: probing form error P_FTU and size error P_STU",
                   ["quantity", "value / µm", "MPE / µm", "U / µm (k = 2)", "verdict"], [
                       ["P_FTU (form: range of the radial residuals)", _um(result.form_error),
                        "-" if result.mpe_form is None else _um(result.mpe_form),
                        "not used" if u_form is None else _um(u_form),
                        verdict(result.mpe_form, result.form_conforms, result.form_verdict)],
                       ["P_STU (size: fitted minus calibrated diameter)", _um(result.size_error),
                        "-" if result.mpe_size is None else _um(result.mpe_size),
                        "not used" if u_size is None else _um(u_size),
                        verdict(result.mpe_size, result.size_conforms, result.size_verdict)],
                   ])
    rows = [[i + 1, f"{p[0]:.6f}", f"{p[1]:.6f}", f"{p[2]:.6f}", _um(r)]
            for i, (p, r) in enumerate(zip(points, result.residuals, strict=True))]
    residuals = Table(f"Results: residuals of the {len(rows)} probed points from the Gaussian sphere",
                      ["point", "x / mm", "y / mm", "z / mm", "residual / µm"], rows)
    return [values, residuals]
