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
    parser.add_argument("--laser-sigma", type=float, metavar="MM",
                        help="standard uncertainty of a laser reading (default 0.0289 mm: the thesis' 50 um laser "
                             "accuracy as rectangular bounds): scale of the closure test")
    parser.add_argument("--max-closure", type=float, metavar="MM",
                        help="largest accepted closure residual of a row in mm, instead of the default test "
                             "(within 6 standard deviations of the scatter predicted from --laser-sigma)")
    parser.add_argument("--keep-inconsistent", action="store_true",
                        help="keep rows beyond --max-closure, marked and left out of the probe points, instead of "
                             "refusing the log (exit 2)")
    add_plot_flag(parser, "the tip path with probe points, pivot heights and closure residual per row")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    add_json_flag(parser)
    parser.set_defaults(handler=_handle)


def _handle(args: argparse.Namespace) -> Report:
    import numpy as np

    from pcmm_geo.cli._progress import progress_bar, progress_wanted
    from pcmm_geo.cli.machine_commands.kinematics import load_machine_file
    from pcmm_geo.errors import ConvergenceError, InconsistentMeasurementError
    from pcmm_geo.machine.analysis.logproc import CLOSURE_SIGMAS, SEED_LASER_SIGMA, process_log, read_log

    machine = load_machine_file(args.calibration)
    log = read_log(args.file, allow_unterminated=args.allow_unterminated)
    try:
        with progress_bar("processing log rows", enabled=progress_wanted(args), total=len(log)) as update:
            sigma = SEED_LASER_SIGMA if args.laser_sigma is None else args.laser_sigma
            out = process_log(machine, log, initial_heights=args.initial_heights, laser_sigma=sigma,
                              closure_tolerance=args.max_closure, progress=update,
                              on_inconsistent="flag" if args.keep_inconsistent else "raise")
    except InconsistentMeasurementError as exc:
        raise InconsistentMeasurementError(
            f"{args.file}: {exc.what}", exc.residual, exc.tolerance, exc.unit,
            f"{exc.detail}; --keep-inconsistent keeps and marks such rows, --max-closure sets the tolerance",
        ) from None
    except ConvergenceError as exc:
        raise ConvergenceError(f"{args.file}: {exc.element}", exc.iterations,
                               f"{exc.reason}; --keep-inconsistent keeps and marks such rows") from None
    rows_index = range(len(log)) if args.all_rows else out.probe_rows.tolist()
    rows = [
        [int(k) + 2, int(log.probe[k]), *out.tips[k].tolist(), *out.heights[k].tolist(),
         float(out.closure_residual[k]), "no" if out.inconsistent[k] else "yes"]
        for k in rows_index
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
        "closure_residual_mm": out.closure_residual.tolist(),
        "closure_sigmas": [None if not np.isfinite(v) else float(v) for v in out.closure_sigmas],
        "closure_tolerance_mm": [None if not np.isfinite(v) else float(v) for v in out.closure_tolerance],
        "inconsistent_data_rows": (np.flatnonzero(out.inconsistent) + 1).tolist(),  # 1-based data rows
        "rejected_probe_data_rows": (out.rejected_probe_rows + 1).tolist(),
    }
    lines = [f"{len(log)} rows, {out.probe_rows.size} probe points; largest closure residual "
             f"{float(out.closure_residual.max()):.3g} mm (the table's closure column)"]
    if out.inconsistent.any():
        test = (f"{args.max_closure:g} mm" if args.max_closure is not None
                else f"{CLOSURE_SIGMAS:g} standard deviations of the predicted scatter")
        lines.append(f"warning: {int(out.inconsistent.sum())} rows do not close within {test} "
                     f"(data rows {data['inconsistent_data_rows']}); "
                     f"{out.rejected_probe_rows.size} probe points left out")
    bad = [int(k) + 2 for k in range(len(log)) if not out.direction_consistent[k]]
    if bad:
        lines.append(f"warning: direction flag contradicts the solved height change on lines {bad}")
    table = Table(
        "Probe points" if not args.all_rows else "Rows",
        ["line", "probe", "x / mm", "y / mm", "z / mm", "h_a / mm", "h_b / mm", "h_c / mm", "closure / mm",
         "closes"],
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
