"""``pcmm laser-ratio FILE``: height per laser displacement, delta_h / delta_l (thesis eqs 6.1-6.3, Table 6.8)."""

from __future__ import annotations

import argparse
from typing import Any

from pcmm_geo.cli._output import (
    Report,
    Table,
    add_json_flag,
    add_overwrite_flag,
    add_plot_flag,
    add_report_flag,
    refuse_renamed_options,
)


def register(subparsers: Any) -> None:
    from pcmm_geo.cli.machine.kinematics import add_machine_argument

    parser = subparsers.add_parser(
        "laser-ratio",
        help="height per laser displacement delta_h/delta_l per run and arm vs the rigid-body model (Table 6.8)",
        description=(
            "Eqs 6.1-6.3: delta_l = l_s - l_f (laser of the moved arm), delta_h = h_s - h_f (height gauge), "
            "height_per_laser = delta_h / delta_l per run; mean, sample and population sigma per arm; the "
            "uncertainty of each ratio from the reading resolutions and accuracies; and the rigid-body model's "
            "ratio for the same arm moved alone over the same heights. FILE is the height-gauge CSV "
            "moved,laser_a,laser_b,laser_c,height of pcmm numcal (a run ends where the height reverses or the "
            "arm changes); --ratios takes a printed table test,ratio_a,ratio_b,ratio_c instead."
        ),
    )
    parser.add_argument("file", nargs="?", metavar="FILE", help="height-gauge CSV moved,laser_a,laser_b,laser_c,height")
    parser.add_argument("--ratios", metavar="FILE", help="table test,ratio_a,ratio_b,ratio_c of printed ratios")
    parser.add_argument("--travel-mm", dest="travel", type=float, default=None,
                        help="with --ratios: rise of each run from level pivots, mm (default 100, Table 6.8)")
    add_machine_argument(parser)
    add_plot_flag(parser, "the ratio per run against the model, and the model's ratio against the rise")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    add_json_flag(parser)
    refuse_renamed_options(parser, {"--travel": "--travel-mm"})
    parser.set_defaults(handler=_handle)


def _handle(args: argparse.Namespace) -> Report:
    from pcmm_geo.cli.machine.kinematics import load_machine_file
    from pcmm_geo.errors import InvalidInputError

    if bool(args.file) == bool(args.ratios):
        raise InvalidInputError("input", "either FILE or --ratios FILE", "both" if args.file else "neither")
    if args.file and args.travel is not None:
        raise InvalidInputError("--travel-mm", "only with --ratios (a height-gauge record has its own heights)",
                                f"{args.travel:g} with FILE")
    machine = load_machine_file(args.calibration)
    model = args.calibration or "thesis geometry (Table 3.1 / Appendix D)"
    lines: list[str] = []
    tables: list[Table] = []
    if args.ratios:
        from pcmm_geo.machine.analysis.laser_ratio_model import ratio_table_summary, read_ratio_table_csv

        labels, ratios = read_ratio_table_csv(args.ratios)
        travel = 100.0 if args.travel is None else args.travel
        result: Any = ratio_table_summary(ratios, labels, travel=travel, machine=machine, model_name=model)
        lines.append(f"printed ratios of {len(labels)} tests; model prediction for a {travel:g} mm rise "
                     "from level pivots")
    else:
        from pcmm_geo.machine.analysis.laser_ratio import laser_height_ratio
        from pcmm_geo.machine.calibration.numerical.numcal_data import read_numcal_csv

        result = laser_height_ratio(read_numcal_csv(args.file), machine=machine, model_name=model)
        tables.append(Table("Runs (eqs 6.1-6.3)", [
            "arm", "test", "rows", "delta_h / mm", "delta_l / mm", "delta_h/delta_l", "u (resolution)",
            "u (accuracy)", "model", "measured - model"],
            [[r.arm, r.test, f"{r.rows[0] + 1}-{r.rows[1] + 1}", r.height_change, r.laser_change, r.height_per_laser,
              r.u_resolution, r.u_accuracy, r.predicted, r.deviation] for r in result.runs]))
        lines.append(f"{len(result.runs)} runs; spread of the model's ratio over the arms: "
                     f"{result.predicted_spread:.3f}")
    predicted = {p.arm: p for p in result.predictions}
    rows = [[a.arm, a.count, a.mean, a.sigma_sample, a.sigma_population, a.range,
             predicted[a.arm].height_per_laser, a.mean - predicted[a.arm].height_per_laser,
             predicted[a.arm].per_mm_travel, predicted[a.arm].per_mm_start_height,
             predicted[a.arm].per_mm_start_laser] for a in result.arms]
    tables.insert(0, Table("height_per_laser = delta_h / delta_l per arm (mm/mm)", [
        "arm", "runs", "mean", "s (ddof 1)", "sigma (ddof 0)", "range", "model", "mean - model",
        "model per mm travel", "per mm start height", "per mm start-laser offset"], rows))
    lines.append("Table 6.8 prints these ratios under the inverted header l/h; eq 6.3 is delta_h / delta_l")
    data = result.as_dict()
    plots = []
    if args.plot:
        from pcmm_geo.plots.machine.repeatability import plot_laser_ratio

        plots.append(str(plot_laser_ratio(result, args.plot, machine=machine, overwrite=args.overwrite)))
        data["plot"] = plots[0]
        lines.append(f"plot written to {plots[0]}")
    return Report(data=data, tables=tables, lines=lines, plots=plots)
