"""``pcmm process-log FILE``: pivot heights and probe points from a thesis Table 3.2 log."""

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
)


def register(subparsers: Any) -> None:
    from pcmm_geo.cli.machine_commands.kinematics import add_machine_argument

    parser = subparsers.add_parser(
        "process-log",
        help="Table 3.2 log (start_stop,probe,motor,direction,laser_a,laser_b,laser_c) -> probe points",
        description="Process a measurement log with the rigid-body model (row logic of thesis Appendix D).",
    )
    parser.add_argument("file", metavar="FILE", help="log CSV, with header or headerless as the seed wrote it")
    add_machine_argument(parser)
    parser.add_argument("--initial-heights", type=float, nargs=3, metavar=("A", "B", "C"),
                        help="pivot heights of the first row (datum; default: the machine's reference heights)")
    parser.add_argument("--all-rows", action="store_true", help="list every row, not only the probe points")
    parser.add_argument("--allow-unterminated", action="store_true",
                        help="accept a last row without a line end (refused by default: it may be torn mid-number)")
    add_plot_flag(parser, "the tip path with probe points, pivot heights and closure residual per row")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    add_json_flag(parser)
    parser.set_defaults(handler=_handle)


def _handle(args: argparse.Namespace) -> Report:
    from pcmm_geo.cli._progress import progress_bar, progress_wanted
    from pcmm_geo.cli.machine_commands.kinematics import load_machine_file
    from pcmm_geo.machine.analysis.logproc import process_log, read_log

    machine = load_machine_file(args.calibration)
    log = read_log(args.file, allow_unterminated=args.allow_unterminated)
    with progress_bar("processing log rows", enabled=progress_wanted(args), total=len(log)) as update:
        out = process_log(machine, log, initial_heights=args.initial_heights, progress=update)
    rows_index = range(len(log)) if args.all_rows else out.probe_rows.tolist()
    rows = [
        [int(k) + 2, int(log.probe[k]), *out.tips[k].tolist(), *out.heights[k].tolist()] for k in rows_index
    ]
    data = {
        "file": args.file,
        "rows": len(log),
        "probe_rows": (out.probe_rows + 2).tolist(),
        "probe_points": out.probe_points.tolist(),
        "heights": out.heights.tolist(),
        "tips": out.tips.tolist(),
        "direction_consistent": out.direction_consistent.tolist(),
        "converged": out.converged.tolist(),
        "max_residual_mm": float(abs(out.residuals).max()),
    }
    lines = [f"{len(log)} rows, {out.probe_rows.size} probe points; max closure residual "
             f"{data['max_residual_mm']:.3g} mm"]
    bad = [int(k) + 2 for k in range(len(log)) if not out.direction_consistent[k]]
    if bad:
        lines.append(f"warning: direction flag contradicts the solved height change on lines {bad}")
    table = Table(
        "Probe points" if not args.all_rows else "Rows",
        ["line", "probe", "x / mm", "y / mm", "z / mm", "h_a / mm", "h_b / mm", "h_c / mm"],
        rows,
    )
    plots = []
    if args.plot:
        from pcmm_geo.plots.machine.process_log import plot_processed_log

        written = plot_processed_log(out, args.plot, overwrite=args.overwrite)
        data["plot"] = str(written)
        plots.append(str(written))
        lines.append(f"plot written to {written}")
    return Report(data=data, tables=[table], lines=lines, plots=plots)
