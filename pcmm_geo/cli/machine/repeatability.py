"""``pcmm repeatability LOG...``: spread of the start readings over repeated tests (thesis 6.3, Tables 6.6/6.7)."""

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
    parser = subparsers.add_parser(
        "repeatability",
        help="start-position repeatability of the lasers over repeated tests (thesis Tables 6.6/6.7)",
        description=(
            "Per laser: mean, median, range, sample (ddof 1) and population (ddof 0) standard deviation of the "
            "start reading over tests, and the readings further than 2 x the laser accuracy from their laser's "
            "median (laser error alone cannot explain them). Inputs: one log per test (pcmm acquire logs or "
            "Table 3.2 logs; the first row, right after homing and the pre-sequence, is the start reading) or "
            "--readings with a table test,laser_a,laser_b,laser_c (mm)."
        ),
    )
    parser.add_argument("logs", nargs="*", metavar="LOG", help="one log per test (at least two)")
    parser.add_argument("--readings", metavar="FILE", help="table test,laser_a,laser_b,laser_c of start readings, mm")
    parser.add_argument("--laser-accuracy-mm", dest="laser_accuracy", type=float, default=0.05,
                        help="accuracy of one laser reading, +- mm (default 0.05, thesis 3.1)")
    add_plot_flag(parser, "each laser's start reading relative to its median, with the laser-error band")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    add_json_flag(parser)
    refuse_renamed_options(parser, {"--laser-accuracy": "--laser-accuracy-mm"})
    parser.set_defaults(handler=_handle)


def _handle(args: argparse.Namespace) -> Report:
    from pcmm_geo.errors import InvalidInputError
    from pcmm_geo.machine.analysis.repeatability import (
        read_start_readings_csv,
        start_readings_from_logs,
        start_repeatability,
    )

    if bool(args.readings) == bool(args.logs):
        raise InvalidInputError("input", "either LOG files or --readings FILE", "both" if args.logs else "neither")
    found = read_start_readings_csv(args.readings) if args.readings else start_readings_from_logs(args.logs)
    result = start_repeatability(found.lasers, found.labels, laser_accuracy=args.laser_accuracy)
    data = result.as_dict()
    data["presequence"] = list(found.presequence)
    rows = [[a.arm, a.count, a.mean, a.median, a.range, a.sigma_sample, a.sigma_population, a.largest_deviation,
             len(a.flagged)] for a in result.arms]
    table = Table("Start readings per laser (mm)", ["laser", "tests", "mean", "median", "range", "s (ddof 1)",
                                                      "sigma (ddof 0)", "max |x - median|", "flagged"], rows)
    lines = [f"{len(result.labels)} tests; outlier limit {result.outlier_limit:g} mm "
             f"(2 x laser accuracy {result.laser_accuracy:g} mm)"]
    lines += [f"flagged: {f.test} laser {f.arm} = {f.value:.4f} mm, {f.deviation:.3f} mm from the median "
              f"{f.median:.4f}" for f in result.flagged]
    plots = []
    if args.plot:
        from pcmm_geo.plots.machine.repeatability import plot_start_repeatability

        plots.append(str(plot_start_repeatability(result, args.plot, overwrite=args.overwrite)))
        data["plot"] = plots[0]
        lines.append(f"plot written to {plots[0]}")
    return Report(data=data, tables=[table], lines=lines, plots=plots)
