"""``pcmm form FILE --element E --tolerance-mm T``: ISO form deviation by minimum zone with a verdict."""

from __future__ import annotations

import argparse
from pathlib import Path

from pcmm_geo.cli._cmm_input import (
    add_cmm_input_flags,
    cli_setting,
    naming_the_file,
    read_fit_input,
    write_qif_result,
)
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
from pcmm_geo.cli.measure.fit import add_axis_region_options
from pcmm_geo.elements import ELEMENTS as FIT_ELEMENTS
from pcmm_geo.elements import SPECS

#: the elements with a minimum-zone form characteristic (pcmm_geo.elements)
ELEMENTS = tuple(name for name in FIT_ELEMENTS if SPECS[name].form is not None)


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "form",
        help="straightness/flatness/roundness/sphericity/cylindricity by minimum zone, with pass/fail",
        description=(
            "Evaluate the form deviation of the points in FILE as the width of the minimum zone "
            "(Chebyshev fit with an optimality certificate stating its scope: global over all elements, "
            "or local with a proven lower bound). With --tolerance-mm the verdict is PASS (the zone is within "
            "the tolerance), FAIL (the proven lower bound exceeds it) or NOT PROVEN; exit status 0 on PASS, "
            "1 on FAIL or NOT PROVEN, 2 on bad input."
        ),
    )
    parser.add_argument("file", type=Path)
    parser.add_argument("--element", choices=ELEMENTS, required=True)
    parser.add_argument("--tolerance-mm", dest="tolerance", type=float, metavar="MM", help="form tolerance in mm")
    parser.add_argument("--two-d", action="store_true", help="line/circle: use only the x and y columns")
    add_cmm_input_flags(parser)
    add_axis_region_options(parser)
    add_plot_flag(parser, "the zone with the deviations and contact points")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    add_decimal_flag(parser)
    add_json_flag(parser)
    refuse_renamed_options(parser, {"--tolerance": "--tolerance-mm"})
    parser.set_defaults(handler=handle)


def handle(args: argparse.Namespace) -> Report:
    import dataclasses

    from pcmm_geo.cli.measure.fit import axis_search_options
    from pcmm_geo.fit.zone.form import evaluate_form

    source = read_fit_input(args, args.element)
    compensation = None
    search = axis_search_options(args, args.element, "chebyshev", source.points.shape[1])
    with naming_the_file(args.file):
        evaluation = evaluate_form(source.points, args.element, tolerance=args.tolerance, **search)
        if source.probe_radius:  # the zone width stays; the zone's element moves onto the surface
            from pcmm_geo.cmm.points import compensate_fit

            compensation, record = compensate_fit(evaluation.fit, args.element, source.data, source.probe_radius,
                                                  material_side=args.material_side,
                                                  radius_source=source.radius_source, spell_setting=cli_setting)
            evaluation = dataclasses.replace(evaluation, fit=compensation.surface,
                                             points=compensation.surface_points(source.points))
    fit = evaluation.fit
    data = evaluation.to_dict()
    data["file"] = str(args.file)
    if compensation is not None:
        data["probe_compensation"], compensation_line = record.to_dict(), record.describe()
    rows = [
        [evaluation.characteristic, 1000.0 * evaluation.deviation, "µm"],
        ["tolerance", "-" if evaluation.tolerance is None else 1000.0 * evaluation.tolerance, "µm"],
        ["scope", f"{evaluation.scope} ({evaluation.domain})" if evaluation.domain else evaluation.scope, ""],
    ]
    if evaluation.scope != "global":
        bound = evaluation.bound
        rows.append(["proven lower bound", "none" if bound != bound else 1000.0 * bound, "µm"])
    rows += [
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
    lines = [fit.message] + ([] if compensation is None else [compensation_line])
    plots = []
    if args.plot is not None:
        from pcmm_geo.plots.form_zone import plot_form_zone

        written = plot_form_zone(evaluation, args.plot, overwrite=args.overwrite)
        data["plot"] = str(written)
        plots.append(str(written))
        lines.append(f"plot: {written}")
    if args.qif:
        data["qif"], kept_lines = write_qif_result(args, fit, args.element, source.data, radius=source.probe_radius,
                                                   compensation=compensation, evaluation=evaluation)
        lines.append(f"QIF results written to {data['qif']}")
        lines += kept_lines
    exit_code = EXIT_FAILURE if evaluation.tolerance is not None and evaluation.passed is not True else 0
    verdict = None
    if evaluation.tolerance is not None:
        from pcmm_geo.cli._record import Verdict
        from pcmm_geo.fit.zone.form import FORM_DECISION_RULE

        statement = f"{evaluation.characteristic}: {evaluation.verdict}"
        bound = "" if evaluation.scope == "global" or evaluation.bound != evaluation.bound else \
            f", proven lower bound {1000.0 * evaluation.bound:.3f} µm"
        verdict = Verdict(evaluation.passed, statement,
                          f"{FORM_DECISION_RULE}; tolerance {1000.0 * evaluation.tolerance:g} µm",
                          basis=f"the minimum-zone width {1000.0 * evaluation.deviation:.3f} µm ({evaluation.scope} "
                                f"optimum{bound}) of the points as measured; their measurement uncertainty is not "
                                "taken into account")
    return Report(data=data, tables=tables, lines=lines, plots=plots, exit_code=exit_code, verdict=verdict)
