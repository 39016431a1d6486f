"""``pcmm gauge-block FILE``: gauge block calibration from points labelled by face (ISO 3650 certificate)."""

from __future__ import annotations

import argparse
import math
from typing import Any

from pcmm_geo.cli._output import (
    Report,
    add_json_flag,
    add_overwrite_flag,
    add_plot_flag,
    add_report_flag,
)
from pcmm_geo.cli._record import Condition
from pcmm_geo.cli.documents.gauge_block import GRADES

#: expansion coefficient of steel gauge blocks, 1/K (ISO 3650; pcmm_geo.thermal.expansion.ALPHA_GAUGE_BLOCK_STEEL)
ALPHA_GAUGE_BLOCK_STEEL = 11.5e-6


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "gauge-block",
        help="gauge block calibration (ISO 3650 central length, deviation, variation) from probed faces",
        description=(
            "Evaluate a gauge block from a CSV with header face,x,y,z (mm); face is face_1, face_2 "
            "(measuring faces, >= 3 points each), top or side (reference faces, >= 3 points each, optional). "
            "With --report the result is written as a calibration certificate."
        ),
    )
    parser.add_argument("file", help="CSV file face,x,y,z")
    parser.add_argument("--nominal-mm", dest="nominal", type=float, metavar="L",
                        help="nominal length l_n in mm: the deviation e = l_c - l_n is reported")
    parser.add_argument("--grade", choices=GRADES, default=None,
                        help="ISO 3650 grade: its limit deviation t_e and tolerance t_v for the nominal length "
                             "decide conformity (needs --nominal-mm; not with --tolerance-um)")
    parser.add_argument("--tolerance-um", dest="tolerance", type=float, metavar="T",
                        help="limit deviation ±T of the central length from the nominal, in µm: a conformity "
                             "verdict, exit 1 unless PASS")
    parser.add_argument("--uncertainty-um", dest="uncertainty", type=float, metavar="U",
                        help="expanded uncertainty U (k = 2) of the central length in µm, from the laboratory's "
                             "budget: the ISO 14253-1 rule decides (PASS / FAIL / NOT PROVEN)")
    thermal = parser.add_argument_group("temperature (the central length is corrected to 20 °C, ISO 1)")
    thermal.add_argument("--block-temperature-c", dest="block_temperature", type=float, metavar="T",
                         help="temperature of the gauge block during the measurement, °C: the lengths are "
                              "corrected to 20 °C with its expansion coefficient (the CMM's scale taken as "
                              "compensated); without it no correction is applied")
    thermal.add_argument("--u-block-temperature-k", dest="u_block_temperature", type=float, default=0.0,
                         metavar="U", help="standard uncertainty of the block temperature, K (default 0)")
    thermal.add_argument("--alpha-per-k", dest="alpha", type=float, default=ALPHA_GAUGE_BLOCK_STEEL, metavar="A",
                         help="expansion coefficient of the block, 1/K (default 11.5e-6, steel, ISO 3650)")
    thermal.add_argument("--u-alpha-per-k", dest="u_alpha", type=float, default=1.0e-6 / math.sqrt(3.0),
                         metavar="U", help="standard uncertainty of the expansion coefficient, 1/K (default "
                                           "0.58e-6: ±1e-6 /K, rectangular)")
    thermal.add_argument("--air-temperature-c", dest="air_temperature", type=float, metavar="T",
                         help="air temperature during the measurement, °C (recorded in the report)")
    add_plot_flag(parser, "per-face plane residuals and the lengths of every method")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    add_json_flag(parser)
    parser.set_defaults(handler=_handle)


def _thermal(args: argparse.Namespace, length: float) -> tuple[Any, list[Condition]]:
    """The correction of ``length`` to 20 °C (None without --block-temperature-c) and the conditions to report."""
    from pcmm_geo.errors import InvalidInputError
    from pcmm_geo.thermal.correction import correct_length

    conditions = []
    if args.air_temperature is not None:
        if not math.isfinite(args.air_temperature):
            raise InvalidInputError("--air-temperature-c", "a temperature in °C", repr(args.air_temperature))
        conditions.append(Condition("air temperature", f"{args.air_temperature:.2f}", "°C"))
    if args.block_temperature is None:
        return None, conditions
    for option, value in (("--u-block-temperature-k", args.u_block_temperature), ("--u-alpha-per-k", args.u_alpha)):
        if not (math.isfinite(value) and value >= 0):
            raise InvalidInputError(option, "a non-negative standard uncertainty", repr(value))
    if not (math.isfinite(args.block_temperature) and 0.0 <= args.block_temperature <= 40.0):
        raise InvalidInputError("--block-temperature-c", "a block temperature from 0 °C to 40 °C",
                                repr(args.block_temperature))
    correction = correct_length(length, args.block_temperature, args.alpha, u_alpha_workpiece=args.u_alpha,
                                u_temperature_workpiece=args.u_block_temperature)
    conditions += [
        Condition("gauge block temperature", f"{args.block_temperature:.3f} (u = {args.u_block_temperature:g} K)",
                  "°C"),
        Condition("expansion coefficient of the block", f"{args.alpha:.3g} (u = {args.u_alpha:.2g} /K)", "1/K"),
        Condition("correction to 20 °C applied to every length", f"{1000 * correction.correction:+.3f} "
                  f"(u = {1000 * correction.standard_uncertainty:.3f} µm)", "µm"),
    ]
    return correction, conditions


def _handle(args: argparse.Namespace) -> Report:
    from pcmm_geo.artefacts.gauge_block import measure_gauge_block, read_gauge_block_csv
    from pcmm_geo.cli.documents import gauge_block as certificate

    points_by_face = read_gauge_block_csv(args.file)
    result = measure_gauge_block(points_by_face)
    correction, environment = _thermal(args, result.central_length)
    ratio = 1.0 if correction is None else correction.value / correction.measured_length
    central = result.central_length * ratio
    seed = result.seed
    variation_um = None if math.isnan(result.variation_in_length) else 1000 * result.variation_in_length
    data: dict[str, Any] = {
        "central_length_mm": central,
        "central_length_as_measured_mm": result.central_length,
        "length_face1_to_plane2_mm": result.length_face1_to_plane2 * ratio,
        "length_face2_to_plane1_mm": result.length_face2_to_plane1 * ratio,
        "variation_in_length_mm": None if variation_um is None else variation_um / 1000,
        "parallelism_rad": result.parallelism,
        "face_form_mm": list(result.face_form),
        "axis": result.axis,
        "projected_length_mm": None if math.isnan(result.projected_length) else result.projected_length * ratio,
        "seed": None
        if seed is None
        else {
            "length_mm": seed.length * ratio,
            "phi_deg": math.degrees(seed.phi),
            "theta_top_deg": math.degrees(seed.theta_top),
            "theta_side_deg": math.degrees(seed.theta_side),
            "two_point_distance_mm": seed.vector_length * ratio,
        },
        "n_points": result.n_points,
    }
    if correction is not None:
        data["thermal_correction_um"] = 1000 * correction.correction
        data["thermal_correction_u_um"] = 1000 * correction.standard_uncertainty
        data["block_temperature_c"] = args.block_temperature
    console = []
    plots = []
    if args.plot:
        from pcmm_geo.plots.gauge_block import plot_gauge_block

        written = plot_gauge_block(points_by_face, result, args.plot, overwrite=args.overwrite)
        data["plot"] = str(written)
        plots.append(str(written))
        console.append(f"plot written to {written}")
    lines: list[str] = []
    verdict, uncertainties, exit_code = _decide(args, central, variation_um, data, lines)
    values = {"central_length_mm": central, "corrected": correction is not None, "variation_um": variation_um,
              "nominal_mm": data.get("nominal_mm"), "deviation_um": data.get("deviation_um"),
              "expanded_uncertainty_um": args.uncertainty, "grade": args.grade,
              "t_e_um": data.get("t_e_um"), "t_v_um": data.get("t_v_um")}
    if correction is None:
        lines.append("no block temperature entered (--block-temperature-c): the lengths are not corrected to 20 °C")
    else:  # the report states it in its environmental conditions
        console.append(f"corrected to 20 °C: block at {args.block_temperature:g} °C, alpha {args.alpha:.3g} /K, "
                       f"correction {1000 * correction.correction:+.3f} µm (u = "
                       f"{1000 * correction.standard_uncertainty:.3f} µm)")
    statements = [("Method", certificate.method_statement(result.n_points)),
                  ("Measurement uncertainty", certificate.uncertainty_statement(args.uncertainty)),
                  ("Traceability", certificate.traceability_statement(len(_references(args))))]
    return Report(data=data, tables=[certificate.certified_table(values)], lines=lines, plots=plots,
                  verdict=verdict, uncertainties=uncertainties, exit_code=exit_code, console=console,
                  environment=environment, statements=statements,
                  annex=certificate.annex_tables(result, ratio),
                  title="Calibration certificate: gauge block (ISO 3650)")


def _references(args: argparse.Namespace) -> list[str]:
    """The reference standards stated for the report (options or pcmm.toml), for the traceability statement."""
    if getattr(args, "reference_standards", None):
        return list(args.reference_standards)
    if not getattr(args, "report", None):
        return []
    from pcmm_geo.cli._identity import config_path, load_config

    path = config_path(args)
    return [] if path is None else list(load_config(path).get("reference", ()))


def _decide(args: argparse.Namespace, length: float, variation_um: float | None, data: dict[str, Any],
            lines: list[str]) -> tuple[Any, list[Any], int]:
    """The deviation from the nominal, U and the conformity verdict (ISO 14253-1 with U, else simple acceptance)."""
    from pcmm_geo.cli._output import EXIT_FAILURE, EXIT_OK
    from pcmm_geo.cli._record import UncertaintyEntry, Verdict
    from pcmm_geo.cli.documents.gauge_block import limit_deviations
    from pcmm_geo.errors import InvalidInputError
    from pcmm_geo.uncertainty.conformity import decide_conformity

    for option, value in (("--nominal-mm", args.nominal), ("--tolerance-um", args.tolerance),
                          ("--uncertainty-um", args.uncertainty)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise InvalidInputError(option, "a positive number", repr(value))
    for option, value in (("--tolerance-um", args.tolerance), ("--grade", args.grade)):
        if value is not None and args.nominal is None:
            raise InvalidInputError(option, "--nominal-mm as well (the limits are about the nominal)",
                                    "no --nominal-mm")
    if args.tolerance is not None and args.grade is not None:
        raise InvalidInputError("--tolerance-um", "either --tolerance-um or --grade (the grade sets t_e)",
                                "both")
    tolerance, t_v = args.tolerance, None
    if args.grade is not None:
        try:
            tolerance, t_v = limit_deviations(args.nominal, args.grade)
        except InvalidInputError as exc:
            raise InvalidInputError("--nominal-mm", "a nominal length from 0.5 mm to 500 mm for --grade "
                                    "(state --tolerance-um otherwise)", repr(args.nominal)) from exc
        data["grade"], data["t_e_um"], data["t_v_um"] = args.grade, tolerance, t_v
    uncertainties = []  # U is stated with the verdict; alone (no tolerance) it is the result's uncertainty
    if args.uncertainty is not None:
        data["expanded_uncertainty_um"] = args.uncertainty
        if tolerance is None:
            uncertainties.append(UncertaintyEntry("central length l_c", length, args.uncertainty / 2000, "mm", 2.0,
                                                  "laboratory budget as stated"))
    if args.nominal is None:
        return None, uncertainties, EXIT_OK
    deviation_um = 1000 * (length - args.nominal)
    data["nominal_mm"], data["deviation_um"] = args.nominal, deviation_um
    if tolerance is None:
        lines.append(f"deviation from nominal {args.nominal:g} mm: {deviation_um:+.3f} µm (no tolerance stated)")
        return None, uncertainties, EXIT_OK
    u_um = args.uncertainty or 0.0
    decision = decide_conformity(deviation_um, u_um, upper_limit=tolerance, lower_limit=-tolerance)
    state = decision.verdict
    limits = f"deviation e within ±{tolerance:g} µm of the nominal {args.nominal:g} mm"
    conformity = ""
    if t_v is not None:
        limits = f"grade {args.grade} (ISO 3650): {limits} (t_e)"
        if variation_um is not None:
            limits += f" and variation in length v <= t_v = {t_v:g} µm (simple acceptance, U not applied to v)"
            if variation_um > t_v:
                # the deviation's ISO 14253-1 state stands; v fails by simple acceptance, which proves nothing
                conformity = (f"variation in length v = {variation_um:.3f} µm exceeds t_v = {t_v:g} µm (simple "
                              "acceptance: U is not applied to v, so its nonconformity is not proven in ISO 14253-1 "
                              f"terms); deviation e: {decision.verdict}")
                state = "FAIL"
    data["verdict"], data["passed"] = state, {"PASS": True, "FAIL": False}.get(state)
    if args.uncertainty is not None:
        rule = ("ISO 14253-1 default rule: conformity is proven inside the tolerance zone reduced by U, "
                f"nonconformity outside it enlarged by U, otherwise neither is proven; {limits}")
    else:
        rule = (f"simple acceptance (zero guard band, shared risk): accepted when the {limits}; U is not used, so "
                "neither conformity nor nonconformity is proven in ISO 14253-1 terms")
    statement = f"gauge block: {state} (deviation {deviation_um:+.3f} µm" + (
        f", variation {variation_um:.3f} µm)" if t_v is not None and variation_um is not None else ")")
    verdict = Verdict(data["passed"], statement, rule,
                      uncertainty=f"U = {u_um:g} µm (k = 2), as stated" if args.uncertainty is not None else "",
                      basis="the measured central length alone (no U stated: --uncertainty-um)",
                      conformity_text=conformity)
    return verdict, uncertainties, EXIT_OK if state == "PASS" else EXIT_FAILURE
