"""``pcmm iso10360-2``, ``pcmm iso10360-5`` and ``pcmm iso10360-6``: ISO 10360 acceptance-test evaluations.

Verdict "fail" exits with code 1; bad files or impossible input with code 2.
"""

from __future__ import annotations

import argparse
import math
from typing import Any

from pcmm_geo.cli._output import (
    EXIT_FAILURE,
    EXIT_OK,
    Report,
    Table,
    add_decimal_flag,
    add_json_flag,
    add_overwrite_flag,
    add_plot_flag,
    add_report_flag,
    refuse_renamed_options,
)
from pcmm_geo.cli._record import Verdict

_INCOMPLETE_HELP = ("evaluate a data set that is not the standard's (verdict INCOMPLETE, never PASS); "
                    "without it such a file is refused")


def register(subparsers: Any) -> None:
    p2 = subparsers.add_parser(
        "iso10360-2",
        help="ISO 10360-2 length test: E0 against MPE = A + L/K, repeatability R0",
        description=(
            "CSV header length_id,position,repetition,calibrated_length,measured_length (mm). "
            "MPE_E0 = min(A + L/K, B) in micrometres with L in mm."
        ),
    )
    p2.add_argument("file", help="CSV of measured test lengths")
    p2.add_argument("--mpe-a-um", dest="mpe_a", type=float, required=True, help="A in micrometres")
    p2.add_argument("--mpe-k", type=float, required=True, help="K (L in mm, L/K in micrometres)")
    p2.add_argument("--mpe-b-um", dest="mpe_b", type=float, default=None, help="optional cap B in micrometres")
    p2.add_argument("--rule", choices=("simple", "guarded", "iso14253"), default=None,
                    help="decision rule: simple acceptance, guarded by --uncertainty-um, or the three-state "
                         "ISO 14253-1 rule (PASS / FAIL / NOT PROVEN; the default when --uncertainty-um is given)")
    p2.add_argument("--uncertainty-um", dest="uncertainty", type=float, default=0.0,
                    help="expanded test uncertainty U in micrometres")
    p2.add_argument("--mpl-r0-um", dest="mpl_r0", type=float, default=None,
                    help="limit of the repeatability range R0 in micrometres")
    p2.add_argument("--allow-incomplete", action="store_true", help=_INCOMPLETE_HELP + " (5 lengths x 7 positions x 3)")
    add_plot_flag(p2, "every E0 against its length with the MPE curve, and R0 per length")
    add_report_flag(p2)
    add_overwrite_flag(p2)
    add_json_flag(p2)
    refuse_renamed_options(p2, {
        "--mpe-a": "--mpe-a-um",
        "--mpe-b": "--mpe-b-um",
        "--uncertainty": "--uncertainty-um",
        "--mpl-r0": "--mpl-r0-um",
    })
    p2.set_defaults(handler=_handle_2)

    p5 = subparsers.add_parser(
        "iso10360-5",
        help="ISO 10360-5 probing test: P_FTU (form) and P_STU (size) on a calibrated sphere",
        description="CSV header x,y,z (mm): the points probed on the test sphere (25 in the standard).",
    )
    p5.add_argument("file", help="CSV of probed points")
    p5.add_argument("--reference-diameter-mm", dest="reference_diameter", type=float, default=None,
                    help="calibrated diameter in mm (default: the file's '# reference_diameter_mm: D' line)")
    p5.add_argument("--mpe-form-um", dest="mpe_form", type=float, default=None, help="MPE of P_FTU in micrometres")
    p5.add_argument("--mpe-size-um", dest="mpe_size", type=float, default=None, help="MPE of P_STU in micrometres")
    p5.add_argument("--allow-incomplete", action="store_true", help=_INCOMPLETE_HELP + " (25 points)")
    add_decimal_flag(p5)
    p5.add_argument("--uncertainty-um", dest="uncertainty", type=float, nargs=2, metavar=("U_FORM", "U_SIZE"),
                    default=None,
                    help="expanded test uncertainties of P_FTU and P_STU in micrometres: ISO 14253-1 decision "
                         "(PASS / FAIL / NOT PROVEN)")
    add_plot_flag(p5, "the residuals on the sphere (azimuth x elevation) and sorted")
    add_report_flag(p5)
    add_overwrite_flag(p5)
    add_json_flag(p5)
    refuse_renamed_options(p5, {
        "--reference-diameter": "--reference-diameter-mm",
        "--mpe-form": "--mpe-form-um",
        "--mpe-size": "--mpe-size-um",
        "--uncertainty": "--uncertainty-um",
    })
    p5.set_defaults(handler=_handle_5)

    p6 = subparsers.add_parser(
        "iso10360-6",
        help="ISO 10360-6 software test: compare fit results with reference data sets",
        description=(
            "REFERENCE is a folder of NIST pairs (<Element>/<name>.ds + .fit) or a CSV/JSON of reference "
            "parameters; RESULTS a CSV/JSON of the tested software's parameters (name,element,x,y,z,i,j,k,"
            "size,size2,half_angle). Without RESULTS, pcmm_geo's own fits are tested."
        ),
    )
    p6.add_argument("reference", help="reference folder or file")
    p6.add_argument("results", nargs="?", default=None, help="results CSV/JSON (default: fit with pcmm_geo)")
    p6.add_argument("--mpe-position-mm", dest="mpe_position", type=float, default=1e-9, help="mm (default 1e-9)")
    p6.add_argument("--mpe-orientation-rad", dest="mpe_orientation", type=float, default=1e-9,
                    help="rad (default 1e-9)")
    p6.add_argument("--mpe-size-mm", dest="mpe_size", type=float, default=1e-9, help="mm (default 1e-9)")
    p6.add_argument("--mpe-angle-rad", dest="mpe_angle", type=float, default=1e-9, help="rad (default 1e-9)")
    p6.add_argument("--markdown", action="store_true",
                    help="deprecated (removed in the next release): use --report FILE.md")
    add_plot_flag(p6, "each case's deviations as fractions of their MPE")
    add_report_flag(p6)
    add_overwrite_flag(p6)
    add_json_flag(p6)
    refuse_renamed_options(p6, {
        "--mpe-position": "--mpe-position-mm",
        "--mpe-orientation": "--mpe-orientation-rad",
        "--mpe-size": "--mpe-size-mm",
        "--mpe-angle": "--mpe-angle-rad",
    })
    p6.set_defaults(handler=_handle_6)


_P6_OPTIONS = {"mpe_position": "--mpe-position-mm", "mpe_orientation": "--mpe-orientation-rad",
               "mpe_size": "--mpe-size-mm", "mpe_angle": "--mpe-angle-rad"}


def _positive(name: str, value: float | None, *, allow_zero: bool = False) -> None:
    from pcmm_geo.errors import InvalidInputError

    if value is None:
        return
    if not math.isfinite(value) or value < 0 or (value == 0 and not allow_zero):
        raise InvalidInputError(name, "a positive number" if not allow_zero else "a non-negative number", repr(value))


def _handle_2(args: argparse.Namespace) -> Report:
    from pcmm_geo.artefacts.iso10360_2 import LengthMpe, evaluate_length_test, read_length_test_csv

    _positive("--uncertainty-um", args.uncertainty, allow_zero=True)
    _positive("--mpl-r0-um", args.mpl_r0)
    mpe = LengthMpe(args.mpe_a, args.mpe_k, args.mpe_b)
    result = evaluate_length_test(
        read_length_test_csv(args.file),
        mpe,
        decision_rule=args.rule or ("iso14253" if args.uncertainty > 0 else "simple"),
        test_uncertainty=args.uncertainty / 1000.0,
        mpl_r0=None if args.mpl_r0 is None else args.mpl_r0 / 1000.0,
        allow_incomplete=args.allow_incomplete,
    )
    bad = [e for e in result.errors if not e.conforms]
    data = {
        "passed": result.passed,
        "verdict": result.verdict,
        "test_uncertainty_um": result.test_uncertainty * 1000,
        "complete": result.complete,
        "decision_rule": result.decision_rule,
        "mpe": {"a_um": mpe.a_um, "k": mpe.k, "b_um": mpe.b_um},
        "max_abs_error_um": result.max_abs_error * 1000,
        "max_error_ratio": result.max_error_ratio,
        "max_r0_um": result.max_range * 1000,
        "n_values": len(result.errors),
        "n_nonconforming": result.n_nonconforming,
        "errors": [
            {"length_id": e.length_id, "position": e.position, "repetition": e.repetition,
             "calibrated_length_mm": e.calibrated_length, "error_um": e.error * 1000, "mpe_um": e.mpe * 1000,
             "conforms": e.conforms, "verdict": e.verdict or ("PASS" if e.conforms else "FAIL")}
            for e in result.errors
        ],
        "r0": [
            {"length_id": r.length_id, "position": r.position, "range_um": r.range * 1000, "conforms": r.conforms}
            for r in result.repeatability
        ],
    }
    rows = [[f"{e.length_id}/{e.position}/{e.repetition}", e.calibrated_length, e.error * 1000, e.mpe * 1000]
            for e in bad]
    title = "E0 values not proven to conform" if result.errors[0].verdict else "Nonconforming E0 values"
    tables = [Table(title, ["length/position/rep", "L / mm", "E0 / µm", "MPE / µm"], rows)] if rows else []
    statement = f"ISO 10360-2: {result.verdict} ({len(result.errors)} values, " + (
        ", ".join(f"{sum(e.verdict == v for e in result.errors)} {v}" for v in ("PASS", "NOT PROVEN", "FAIL"))
        if result.errors[0].verdict else f"{result.n_nonconforming} nonconforming") + ")"
    lines = [f"max |E0| = {result.max_abs_error * 1000:.3f} µm ({result.max_error_ratio:.2f} of MPE), "
             f"max R0 = {result.max_range * 1000:.3f} µm"]
    rule_name = args.rule or ("iso14253" if args.uncertainty > 0 else "simple")
    limits = f"MPE_E0 = {_mpe_text(mpe)}" + (f", R0 <= {args.mpl_r0:g} µm" if args.mpl_r0 is not None else "")
    u_um = 1000 * result.test_uncertainty  # stated once, with the verdict
    plots = _plot(args, "plot_length_test", result)
    verdict = Verdict(_passed(result.verdict), statement, _rule_text(rule_name, limits, "|E0|"),
                      uncertainty=f"U = {u_um:g} µm (k = 2), test uncertainty as stated" if u_um > 0 else "",
                      basis="the E0 values alone (no test uncertainty stated: --uncertainty-um)",
                      conformity_text=_guarded_conformity(rule_name, _passed(result.verdict), u_um > 0))
    from pcmm_geo.cli.documents.iso10360 import length_test_tables

    return Report(data=data, tables=tables, lines=lines, exit_code=EXIT_FAILURE if result.passed is False else EXIT_OK,
                  plots=plots, verdict=verdict, report_tables=length_test_tables(result, rule_name))


def _rule_text(rule: str, limits: str, value: str) -> str:
    """The decision rule in ISO 14253-1 terms, once, with the limits it was applied to."""
    if rule == "iso14253":
        return (f"ISO 14253-1 default rule: conformity is proven when {value} + U <= MPE, nonconformity when "
                f"{value} - U > MPE, otherwise neither is proven; {limits}")
    if rule == "guarded":
        return (f"guarded acceptance: a value is accepted only when {value} + U <= MPE (conformity proven), "
                f"otherwise rejected (which does not prove nonconformity); {limits}")
    return (f"simple acceptance (zero guard band, shared risk): a value is accepted when {value} <= MPE; U is not "
            f"used, so neither conformity nor nonconformity is proven in ISO 14253-1 terms; {limits}")


def _guarded_conformity(rule: str, passed: bool | None, has_u: bool = True) -> str:
    """The ISO 14253-1 state where it does not follow from the verdict and U.

    Guarded acceptance proves conformity, but its FAIL proves nothing (the value may lie within
    U of the limit); simple acceptance with a stated U proves neither, as it does not use U.
    """
    if rule == "guarded" and passed is False:
        return "nonconformity not proven: guarded acceptance fails a value within U of the limit too"
    if rule == "simple" and has_u and passed is not None:
        return "neither conformity nor nonconformity proven: simple acceptance does not use the stated U"
    return ""


def _passed(verdict: str) -> bool | None:
    """PASS -> True, FAIL -> False, NOT PROVEN (or no decision) -> None."""
    return {"PASS": True, "FAIL": False}.get(verdict)


def _mpe_text(mpe: object) -> str:
    text = f"{mpe.a_um:g} µm + L / {mpe.k:g}"  # type: ignore[attr-defined]
    cap = mpe.b_um  # type: ignore[attr-defined]
    return text if cap is None else f"min({text}, {cap:g} µm)"


def _plot(args: argparse.Namespace, function: str, *inputs: object) -> list[str]:
    """Draw ``pcmm_geo.plots.verification.<function>(*inputs, args.plot)`` when --plot was given."""
    if not args.plot:
        return []
    from pcmm_geo.plots import verification

    return [str(getattr(verification, function)(*inputs, args.plot, overwrite=args.overwrite))]


def _handle_5(args: argparse.Namespace) -> Report:
    from pcmm_geo.artefacts.iso10360_5 import evaluate_probing, read_reference_diameter
    from pcmm_geo.errors import InvalidInputError
    from pcmm_geo.io.points import read_points

    _positive("--mpe-form-um", args.mpe_form)
    _positive("--mpe-size-um", args.mpe_size)
    points = read_points(args.file, decimal=args.decimal)
    stated = read_reference_diameter(args.file)
    diameter = args.reference_diameter if args.reference_diameter is not None else stated
    if diameter is None:
        raise InvalidInputError("--reference-diameter-mm", "the sphere's calibrated diameter in mm "
                                f"(or a '# reference_diameter_mm: D' line in {args.file})", "neither")
    if stated is not None and args.reference_diameter is not None and stated != args.reference_diameter:
        raise InvalidInputError("--reference-diameter-mm", f"the {stated} mm that {args.file} states",
                                f"{args.reference_diameter} mm")
    for value in args.uncertainty or ():
        _positive("--uncertainty-um", value, allow_zero=True)
    result = evaluate_probing(
        points,
        diameter,
        mpe_form=None if args.mpe_form is None else args.mpe_form / 1000,
        mpe_size=None if args.mpe_size is None else args.mpe_size / 1000,
        allow_incomplete=args.allow_incomplete,
        test_uncertainty=None if args.uncertainty is None else (args.uncertainty[0] / 1000,
                                                                 args.uncertainty[1] / 1000),
    )
    data = {
        "p_ftu_um": result.form_error * 1000,
        "p_stu_um": result.size_error * 1000,
        "fitted_diameter_mm": result.fitted_diameter,
        "reference_diameter_mm": result.reference_diameter,
        "centre_mm": result.center,
        "n_points": result.n,
        "form_conforms": result.form_conforms,
        "size_conforms": result.size_conforms,
        "passed": result.passed,
        "complete": result.complete,
        "verdict": result.verdict,
        "form_verdict": result.form_verdict or None,
        "size_verdict": result.size_verdict or None,
        "decision_rule": result.decision_rule,
    }
    table = Table(
        "ISO 10360-5 probing test",
        ["quantity", "value", "unit"],
        [["P_FTU", result.form_error * 1000, "µm"], ["P_STU", result.size_error * 1000, "µm"],
         ["fitted diameter", result.fitted_diameter, "mm"], ["reference diameter", result.reference_diameter, "mm"],
         ["points", result.n, ""]],
    )
    plots = _plot(args, "plot_probing_test", result, points)
    exit_code = EXIT_FAILURE if result.passed is False else EXIT_OK
    from pcmm_geo.cli.documents.iso10360 import probing_test_tables

    full = probing_test_tables(result, points)
    if args.mpe_form is None and args.mpe_size is None:
        return Report(data=data, tables=[table], plots=plots, exit_code=exit_code, report_tables=full,
                      lines=["no verdict: no MPE stated (--mpe-form-um, --mpe-size-um)"])
    verdict = result.verdict
    if result.test_uncertainty is not None and (result.form_verdict or result.size_verdict):
        verdict += f" (P_FTU {result.form_verdict or '-'}, P_STU {result.size_verdict or '-'})"
    limits = "P is " + " and ".join(text for text in (
        f"P_FTU against MPE_PFTU = {args.mpe_form:g} µm" if args.mpe_form is not None else "",
        f"|P_STU| against MPE_PSTU = {args.mpe_size:g} µm" if args.mpe_size is not None else "") if text)
    u_form, u_size = args.uncertainty if args.uncertainty is not None else (0.0, 0.0)
    return Report(data=data, tables=[table], plots=plots, exit_code=exit_code, report_tables=full,
                  verdict=Verdict(
                      _passed(verdict.split(" ")[0]), f"ISO 10360-5: {verdict}",
                      _rule_text("iso14253" if args.uncertainty is not None else "simple", limits, "P"),
                      uncertainty=(f"U(P_FTU) = {u_form:g} µm, U(P_STU) = {u_size:g} µm (k = 2), test uncertainties "
                                   "as stated") if args.uncertainty is not None else "",
                      basis="the P_FTU and P_STU values alone (no test uncertainty stated: --uncertainty-um)"))


def _handle_6(args: argparse.Namespace) -> Report:
    from pcmm_geo.artefacts.iso10360_6 import HarnessMpe, compare_results, fit_with_pcmm_geo
    from pcmm_geo.artefacts.iso10360_6_io import load_reference_cases, read_element_parameters

    for name in ("mpe_position", "mpe_orientation", "mpe_size", "mpe_angle"):
        _positive(_P6_OPTIONS[name], getattr(args, name))
    cases = load_reference_cases(args.reference)
    results = fit_with_pcmm_geo(cases) if args.results is None else read_element_parameters(args.results)
    mpe = HarnessMpe(args.mpe_position, args.mpe_orientation, args.mpe_size, args.mpe_angle)
    report = compare_results(cases, results, mpe)

    def num(value: float) -> float | None:
        return None if math.isnan(value) else value

    data = {
        "passed": report.passed,
        "n_cases": len(report.cases),
        "n_failed": report.n_failed,
        "mpe": {"position_mm": mpe.position, "orientation_rad": mpe.orientation, "size_mm": mpe.size,
                "angle_rad": mpe.angle},
        "cases": [
            {"name": c.name, "element": c.element, "position_mm": num(c.position),
             "orientation_rad": num(c.orientation), "size_mm": num(c.size), "angle_rad": num(c.angle),
             "passed": c.passed, "note": c.note}
            for c in report.cases
        ],
        "markdown": report.to_markdown(),
    }
    plots = _plot(args, "plot_software_test", report, mpe)
    statement = (f"ISO 10360-6: {'PASS' if report.passed else 'FAIL'} "
                 f"({len(report.cases) - report.n_failed}/{len(report.cases)} cases within MPE)")
    verdict = Verdict(report.passed, statement,
                      f"simple acceptance: every deviation <= its MPE (position {mpe.position:g} mm, orientation "
                      f"{mpe.orientation:g} rad, size {mpe.size:g} mm, angle {mpe.angle:g} rad)",
                      basis="the deviations of the tested results from the reference results, which are exact to "
                            "the digits given; no U is applied")
    if args.markdown:
        import sys

        print("pcmm iso10360-6: warning: --markdown is deprecated and will be removed in the next release; "
              "use --report FILE.md", file=sys.stderr)
        return Report(data=data, lines=[report.to_markdown().rstrip("\n")], plots=plots,
                      exit_code=EXIT_OK if report.passed else EXIT_FAILURE)
    table = Table(
        "ISO 10360-6 software test",
        ["case", "element", "position / mm", "orientation / rad", "size / mm", "angle / rad", "result"],
        [[c.name, c.element, *(("-" if math.isnan(v) else v) for v in (c.position, c.orientation, c.size, c.angle)),
          "pass" if c.passed else f"FAIL {c.note}".strip()]
         for c in report.cases],
    )
    limits = Table("Maximum permissible errors of the test", ["quantity", "MPE", "unit"],
                   [["position", mpe.position, "mm"], ["orientation", mpe.orientation, "rad"],
                    ["size", mpe.size, "mm"], ["angle", mpe.angle, "rad"]])
    return Report(data=data, tables=[table], plots=plots, verdict=verdict, report_tables=[limits],
                  exit_code=EXIT_OK if report.passed else EXIT_FAILURE)
