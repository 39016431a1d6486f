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
    refuse_renamed_options,
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
    parser.add_argument("--initial-heights-mm", dest="initial_heights", type=float, nargs=3, metavar=("A", "B", "C"),
                        help="pivot heights of the first row (datum; default: the log's start_heights_mm, written "
                             "by pcmm acquire --simulate, else the machine's reference heights)")
    parser.add_argument("--all-rows", action="store_true", help="list every row, not only the probe points")
    parser.add_argument("--allow-unterminated", action="store_true",
                        help="accept a last row without a line end (refused by default: it may be torn mid-number)")
    parser.add_argument("--laser-sigma-mm", dest="laser_sigma", type=float, metavar="MM",
                        help="standard uncertainty of a laser reading (default 0.0289 mm: the thesis' 50 um laser "
                             "accuracy as rectangular bounds): scale of the closure test")
    parser.add_argument("--max-closure-mm", dest="max_closure", type=float, metavar="MM",
                        help="largest accepted closure residual of a row in mm, instead of the default test "
                             "(within 6 standard deviations of the scatter predicted from --laser-sigma-mm)")
    parser.add_argument("--keep-inconsistent", action="store_true",
                        help="keep rows beyond --max-closure-mm, marked and left out of the probe points, instead of "
                             "refusing the log (exit 2)")
    parser.add_argument("--max-tip-u-mm", dest="max_tip_u", type=float, metavar="MM", default=None,
                        help="largest tip standard uncertainty of a point in mm (default 1.0; 'inf' for none). Each "
                             "point is listed with its uncertainty (first-order from --laser-sigma-mm and the heights "
                             "carried from earlier rows; near the level pose it reaches millimetres); rows above the "
                             "limit are marked 'no' in the 'u ok' column and counted in one warning line. The exit "
                             "code stays 0: a point with its stated uncertainty is a complete result, only its "
                             "reader can decide whether it is good enough; use --refuse-uncertain where a "
                             "pipeline must not receive such points")
    parser.add_argument("--refuse-uncertain", action="store_true",
                        help="refuse the log (exit 2, one stderr line, no output) when a probe point's tip "
                             "uncertainty exceeds --max-tip-u-mm")
    add_plot_flag(parser, "the tip path with probe points, pivot heights and closure residual per row")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    add_json_flag(parser)
    refuse_renamed_options(parser, {
        "--initial-heights": "--initial-heights-mm",
        "--laser-sigma": "--laser-sigma-mm",
        "--max-closure": "--max-closure-mm",
        "--max-tip-u": "--max-tip-u-mm",
    })
    parser.set_defaults(handler=_handle)


def _handle(args: argparse.Namespace) -> Report:
    import numpy as np

    from pcmm_geo.cli._progress import progress_bar, progress_wanted
    from pcmm_geo.cli.machine_commands.kinematics import load_machine_file
    from pcmm_geo.errors import ConvergenceError, InconsistentMeasurementError, OutOfRangeError
    from pcmm_geo.machine.analysis.logproc import (
        CLOSURE_SIGMAS,
        DEFAULT_MAX_TIP_UNCERTAINTY,
        SEED_LASER_SIGMA,
        process_log,
        read_log,
    )

    machine = load_machine_file(args.calibration)
    limit = DEFAULT_MAX_TIP_UNCERTAINTY if args.max_tip_u is None else args.max_tip_u
    log = read_log(args.file, allow_unterminated=args.allow_unterminated)
    initial_heights = args.initial_heights
    if initial_heights is None:
        initial_heights = _logged_start_heights(args.file, args.allow_unterminated)
    try:
        with progress_bar("processing log rows", enabled=progress_wanted(args), total=len(log)) as update:
            sigma = SEED_LASER_SIGMA if args.laser_sigma is None else args.laser_sigma
            out = process_log(machine, log, initial_heights=initial_heights, laser_sigma=sigma,
                              closure_tolerance=args.max_closure, progress=update, max_tip_uncertainty=limit,
                              on_inconsistent="flag" if args.keep_inconsistent else "raise")
    except InconsistentMeasurementError as exc:
        raise InconsistentMeasurementError(
            f"{args.file}: {exc.what}", exc.residual, exc.tolerance, exc.unit,
            f"{exc.detail}; --keep-inconsistent keeps and marks such rows, --max-closure-mm sets the tolerance",
        ) from None
    except ConvergenceError as exc:
        raise ConvergenceError(f"{args.file}: {exc.element}", exc.iterations,
                               f"{exc.reason}; --keep-inconsistent keeps and marks such rows") from None
    uncertain_probes = [int(k) for k in out.probe_rows if out.uncertain[k]]
    if args.refuse_uncertain and uncertain_probes:
        first = uncertain_probes[0]
        raise OutOfRangeError(f"{args.file}: tip uncertainty of log row {first + 1} ({len(uncertain_probes)} probe "
                              "points above the limit; --max-tip-u-mm sets it)",
                              float(f"{out.tip_uncertainty[first]:.4g}"), None, float(limit), "mm")
    rows_index = range(len(log)) if args.all_rows else out.probe_rows.tolist()
    rows = [
        [int(k) + 2, int(log.probe[k]), *out.tips[k].tolist(), *out.heights[k].tolist(),
         float(out.closure_residual[k]), "no" if out.inconsistent[k] else "yes",
         float(out.tip_uncertainty[k]), "no" if out.uncertain[k] or not np.isfinite(out.tip_uncertainty[k]) else "yes"]
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
        "initial_heights": None if initial_heights is None else [float(h) for h in initial_heights],
        "max_tip_uncertainty_mm": float(limit) if np.isfinite(limit) else None,
        "tip_uncertainty_mm": [None if not np.isfinite(v) else float(v) for v in out.tip_uncertainty],
        "tip_u_mm": [[None if not np.isfinite(v) else float(v) for v in axes] for axes in out.tip_u],
        "probe_tip_uncertainty_mm": [None if not np.isfinite(v) else float(v)
                                     for v in out.tip_uncertainty[out.probe_rows]],
        "uncertain_data_rows": (np.flatnonzero(out.uncertain) + 1).tolist(),
    }
    lines = [f"{len(log)} rows, {out.probe_rows.size} probe points; largest closure residual "
             f"{float(out.closure_residual.max()):.3g} mm (the table's closure column)"]
    if args.initial_heights is None and initial_heights is not None:
        lines.append("initial heights (datum) from the log's start_heights_mm: "
                     + " ".join(f"{h:g}" for h in initial_heights) + " mm")
    probe_u = out.tip_uncertainty[out.probe_rows]
    if probe_u.size and np.isfinite(probe_u).any():
        lines.append(f"tip uncertainty of the probe points (u, first-order, laser sigma {sigma:g} mm): median "
                     f"{float(np.nanmedian(probe_u)):.3g} mm, largest {float(np.nanmax(probe_u)):.3g} mm; "
                     f"{len(uncertain_probes)} above the limit {limit:g} mm")
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
         "closes", "u / mm", "u ok"],
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


def _logged_start_heights(path: str, allow_partial: bool) -> list[float] | None:
    """The ``start_heights_mm`` of an acquisition log's metadata (simulated sessions), else None."""
    from pcmm_geo.acquisition.acqlog import read_log as read_acquisition_log

    with open(path, "rb") as handle:
        if not handle.read(64).startswith(b"# pcmm_geo acquisition log"):
            return None
    value = read_acquisition_log(path, allow_partial=allow_partial).metadata.get("start_heights_mm")
    return None if value is None else [float(v) for v in value.split()]
