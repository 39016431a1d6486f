"""``pcmm form FILE --element E --tolerance-mm T``: ISO form deviation by minimum zone with a verdict."""

from __future__ import annotations

import argparse
from pathlib import Path

from pcmm_geo.cli._output import (
    EXIT_FAILURE,
    Report,
    Table,
    add_decimal_flag,
    add_json_flag,
    add_overwrite_flag,
    add_plot_flag,
    add_report_flag,
    refuse_renamed_options,
)

ELEMENTS = ("line", "plane", "circle", "sphere", "cylinder", "cone")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "form",
        help="straightness/flatness/roundness/sphericity/cylindricity by minimum zone, with pass/fail",
        description=(
            "Evaluate the form deviation of the points in FILE as the width of the minimum zone "
            "(Chebyshev fit with an optimality certificate). With --tolerance-mm, exit status 1 on fail "
            "(and when an uncertified zone exceeds the tolerance: no verdict)."
        ),
    )
    parser.add_argument("file", type=Path)
    parser.add_argument("--element", choices=ELEMENTS, required=True)
    parser.add_argument("--tolerance-mm", dest="tolerance", type=float, metavar="MM", help="form tolerance in mm")
    parser.add_argument("--two-d", action="store_true", help="line/circle: use only the x and y columns")
    add_plot_flag(parser, "the zone with the deviations and contact points")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    add_decimal_flag(parser)
    add_json_flag(parser)
    refuse_renamed_options(parser, {"--tolerance": "--tolerance-mm"})
    parser.set_defaults(handler=handle)


def handle(args: argparse.Namespace) -> Report:
    from pcmm_geo.errors import InvalidInputError
    from pcmm_geo.fit.zone.form import evaluate_form
    from pcmm_geo.io.points import read_points

    points = read_points(args.file, decimal=args.decimal)
    if args.two_d:
        if args.element not in ("line", "circle"):
            raise InvalidInputError("--two-d", "element line or circle", args.element)
        points = points[:, :2]
    evaluation = evaluate_form(points, args.element, tolerance=args.tolerance)
    fit = evaluation.fit
    data = evaluation.to_dict()
    data["file"] = str(args.file)
    rows = [
        [evaluation.characteristic, 1000.0 * evaluation.deviation, "µm"],
        ["tolerance", "-" if evaluation.tolerance is None else 1000.0 * evaluation.tolerance, "µm"],
        ["certified", evaluation.certified, ""],
        ["points", fit.n, ""],
        ["contacts", " ".join(str(i) for i in fit.contacts.tolist()), "index"],
    ]
    if fit.certificate is not None:
        rows.append(["KKT residual", fit.certificate.kkt_residual, ""])
    for name in ("r_in", "r_out", "radius"):
        value = getattr(fit, name, None)
        if value is not None:
            rows.append([name + (" (mid-zone)" if name == "radius" else ""), float(value), "mm"])
    tables = [Table(f"{evaluation.characteristic} of {args.file} (minimum zone)", ["quantity", "value", "unit"], rows)]
    lines = [fit.message]
    plots = []
    if args.plot is not None:
        from pcmm_geo.plots.form_zone import plot_form_zone

        written = plot_form_zone(evaluation, args.plot, overwrite=args.overwrite)
        data["plot"] = str(written)
        plots.append(str(written))
        lines.append(f"plot: {written}")
    exit_code = EXIT_FAILURE if evaluation.tolerance is not None and evaluation.passed is not True else 0
    verdict = None
    if evaluation.tolerance is not None:
        from pcmm_geo.cli._record import Verdict

        verdict = Verdict(evaluation.passed, f"{evaluation.characteristic}: {evaluation.verdict}",
                          f"simple acceptance: the minimum-zone width is compared with the tolerance "
                          f"{1000.0 * evaluation.tolerance:g} µm; a zone within the tolerance passes even "
                          "uncertified, a fail needs a certified zone",
                          basis=f"the minimum-zone width {1000.0 * evaluation.deviation:.3f} µm "
                                f"({'certified' if evaluation.certified else 'not certified'} optimum) of the points "
                                "as measured; their measurement uncertainty is not taken into account")
    return Report(data=data, tables=tables, lines=lines, plots=plots, exit_code=exit_code, verdict=verdict)
