"""``pcmm gauge-block FILE``: gauge block length from points labelled by face (ISO 3650 and the thesis' method)."""

from __future__ import annotations

import argparse
import math
from typing import Any

from pcmm_geo.cli._output import (
    Report,
    Table,
    add_json_flag,
    add_overwrite_flag,
    add_plot_flag,
    add_report_flag,
)


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "gauge-block",
        help="gauge block central length from probed faces (ISO 3650 method and the thesis' eqs 5.1-5.3)",
        description=(
            "Evaluate a gauge block from a CSV with header face,x,y,z (mm); face is face_1, face_2 "
            "(measuring faces, >= 3 points each), top or side (reference faces, >= 3 points each, optional)."
        ),
    )
    parser.add_argument("file", help="CSV file face,x,y,z")
    parser.add_argument("--nominal-mm", dest="nominal", type=float, metavar="L",
                        help="nominal length in mm: the deviation of the central length from it is reported")
    parser.add_argument("--tolerance-um", dest="tolerance", type=float, metavar="T",
                        help="limit deviation ±T of the central length from the nominal, in µm (e.g. ISO 3650's t_e "
                             "for the block's grade): a conformity verdict, exit 1 unless PASS")
    parser.add_argument("--uncertainty-um", dest="uncertainty", type=float, metavar="U",
                        help="expanded uncertainty U (k = 2) of the central length in µm, from the laboratory's "
                             "budget: the ISO 14253-1 rule decides (PASS / FAIL / NOT PROVEN)")
    add_plot_flag(parser, "per-face plane residuals and the lengths of every method")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    add_json_flag(parser)
    parser.set_defaults(handler=_handle)


def _handle(args: argparse.Namespace) -> Report:
    from pcmm_geo.artefacts.gauge_block import measure_gauge_block, read_gauge_block_csv

    points_by_face = read_gauge_block_csv(args.file)
    result = measure_gauge_block(points_by_face)
    seed = result.seed
    data: dict[str, Any] = {
        "central_length_mm": result.central_length,
        "length_face1_to_plane2_mm": result.length_face1_to_plane2,
        "length_face2_to_plane1_mm": result.length_face2_to_plane1,
        "variation_in_length_mm": None if math.isnan(result.variation_in_length) else result.variation_in_length,
        "parallelism_rad": result.parallelism,
        "face_form_mm": list(result.face_form),
        "axis": result.axis,
        "projected_length_mm": None if math.isnan(result.projected_length) else result.projected_length,
        "seed": None
        if seed is None
        else {
            "length_mm": seed.length,
            "phi_deg": math.degrees(seed.phi),
            "theta_top_deg": math.degrees(seed.theta_top),
            "theta_side_deg": math.degrees(seed.theta_side),
            "two_point_distance_mm": seed.vector_length,
        },
        "n_points": result.n_points,
    }
    rows: list[list[Any]] = [
        ["ISO 3650 central length (mean)", result.central_length],
        ["  face 1 centre -> plane 2", result.length_face1_to_plane2],
        ["  face 2 centre -> plane 1", result.length_face2_to_plane1],
        ["variation in length", result.variation_in_length],
    ]
    if seed is not None:
        rows += [
            ["exact projection (top x side)", result.projected_length],
            ["thesis eqs 5.1-5.3 length", seed.length],
            ["two-point distance", seed.vector_length],
        ]
    lines = []
    if seed is not None:
        lines.append(
            f"thesis angles: phi = {math.degrees(seed.phi):.4f} deg, theta1 = {math.degrees(seed.theta_top):.4f} deg, "
            f"theta2 = {math.degrees(seed.theta_side):.4f} deg"
        )
    plots = []
    if args.plot:
        from pcmm_geo.plots.gauge_block import plot_gauge_block

        written = plot_gauge_block(points_by_face, result, args.plot, overwrite=args.overwrite)
        data["plot"] = str(written)
        plots.append(str(written))
        lines.append(f"plot written to {written}")
    verdict, uncertainties, exit_code = _decide(args, result.central_length, data, lines)
    table = Table("Gauge block", ["quantity", "value / mm"], rows)
    return Report(data=data, tables=[table], lines=lines, plots=plots, verdict=verdict, uncertainties=uncertainties,
                  exit_code=exit_code)


def _decide(args: argparse.Namespace, length: float, data: dict[str, Any],
            lines: list[str]) -> tuple[Any, list[Any], int]:
    """The deviation from the nominal, U and the conformity verdict (ISO 14253-1 with U, else simple acceptance)."""
    from pcmm_geo.cli._output import EXIT_FAILURE, EXIT_OK
    from pcmm_geo.cli._record import UncertaintyEntry, Verdict
    from pcmm_geo.errors import InvalidInputError
    from pcmm_geo.uncertainty.conformity import decide_conformity

    for option, value in (("--nominal-mm", args.nominal), ("--tolerance-um", args.tolerance),
                          ("--uncertainty-um", args.uncertainty)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise InvalidInputError(option, "a positive number", repr(value))
    if args.tolerance is not None and args.nominal is None:
        raise InvalidInputError("--tolerance-um", "--nominal-mm as well (the tolerance is about the nominal)",
                                "no --nominal-mm")
    uncertainties = []  # U is stated with the verdict; alone (no tolerance) it is the result's uncertainty
    if args.uncertainty is not None:
        data["expanded_uncertainty_um"] = args.uncertainty
        if args.tolerance is None:
            uncertainties.append(UncertaintyEntry("central length", length, args.uncertainty / 2000, "mm", 2.0,
                                                  "laboratory budget as stated"))
    if args.nominal is None:
        return None, uncertainties, EXIT_OK
    deviation_um = 1000 * (length - args.nominal)
    data["nominal_mm"], data["deviation_um"] = args.nominal, deviation_um
    if args.tolerance is None:
        lines.append(f"deviation from nominal {args.nominal:g} mm: {deviation_um:+.3f} µm (no tolerance stated)")
        return None, uncertainties, EXIT_OK
    u_um = args.uncertainty or 0.0
    decision = decide_conformity(deviation_um, u_um, upper_limit=args.tolerance, lower_limit=-args.tolerance)
    data["verdict"], data["passed"] = decision.verdict, {"PASS": True, "FAIL": False}.get(decision.verdict)
    limits = f"deviation within ±{args.tolerance:g} µm of the nominal {args.nominal:g} mm"
    if args.uncertainty is not None:
        rule = ("ISO 14253-1 default rule: conformity is proven inside the tolerance zone reduced by U, "
                f"nonconformity outside it enlarged by U, otherwise neither is proven; {limits}")
    else:
        rule = (f"simple acceptance (zero guard band, shared risk): accepted when the {limits}; U is not used, so "
                "neither conformity nor nonconformity is proven in ISO 14253-1 terms")
    verdict = Verdict(data["passed"], f"gauge block: {decision.verdict} (deviation {deviation_um:+.3f} µm)", rule,
                      uncertainty=f"U = {u_um:g} µm (k = 2), as stated" if args.uncertainty is not None else "",
                      basis="the measured central length alone (no U stated: --uncertainty-um)")
    return verdict, uncertainties, EXIT_OK if decision.verdict == "PASS" else EXIT_FAILURE
