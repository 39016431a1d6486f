"""``pcmm process-log FILE``: probe points from a thesis Table 3.2 log, each with u, reliability and flags."""

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
        "process-log",
        help="Table 3.2 log (start_stop,probe,motor,direction,laser_a,laser_b,laser_c) -> probe points",
        description=(
            "Process a measurement log with the rigid-body model: every pivot height from every laser reading "
            "(network adjustment; row logic of thesis Appendix D), Baarda's w-test on every reading, and for "
            "every point its standard uncertainty u, its external reliability R (the largest tip shift an "
            "undetected laser fault of minimal detectable size causes) and its stated bound U (k = 2) + R. "
            "Flags: refused (a reading failed the test), ambiguous (a mirror pose fits as well), unbounded "
            "(a reading no test can check moves the point), uncertain (u above --max-tip-u-mm), over bound."
        ),
    )
    parser.add_argument("file", metavar="FILE", help="log CSV, with header or headerless as the seed wrote it")
    add_machine_argument(parser)
    parser.add_argument("--initial-heights-mm", dest="initial_heights", type=float, nargs=3, metavar=("A", "B", "C"),
                        help="pivot heights of the first row: the start position, held as the datum (default: the "
                             "log's start_heights_mm, written by pcmm acquire at the start it commanded, else the "
                             "machine's reference heights, the level pose)")
    parser.add_argument("--all-rows", action="store_true", help="list every row, not only the probe points")
    parser.add_argument("--allow-unterminated", action="store_true",
                        help="accept a last row without a line end (refused by default: it may be torn mid-number)")
    parser.add_argument("--laser-sigma-mm", dest="laser_sigma", type=float, metavar="MM",
                        help="standard uncertainty of a laser reading for noise and accuracy (default 0.0289 mm: "
                             "the thesis' 50 um accuracy as rectangular bounds); each sensor's reading step "
                             "(from the log's laser_models, else the seed's ILD1302/ILD1302/ILD1420) adds q/sqrt(12)")
    parser.add_argument("--alpha", type=float, default=None, metavar="P",
                        help="significance of the w-test per reading (default 0.001); the minimal detectable bias "
                             "is the fault found with probability --power (default 0.8)")
    parser.add_argument("--power", type=float, default=None, metavar="P", help="power of the w-test (default 0.8)")
    parser.add_argument("--max-closure-mm", dest="max_closure", type=float, metavar="MM",
                        help="largest accepted closure residual of a row in mm, instead of the w-test (for a machine "
                             "model known to misfit by more than the lasers' noise)")
    parser.add_argument("--keep-inconsistent", action="store_true",
                        help="leave readings that fail the test out (their rows are marked 'refused' and give no "
                             "point) instead of refusing the log (exit 2)")
    parser.add_argument("--max-tip-u-mm", dest="max_tip_u", type=float, metavar="MM", default=None,
                        help="largest tip standard uncertainty of a point in mm (default 1.0; 'inf' for none). Rows "
                             "above it are flagged 'uncertain' and counted in one warning line; the exit code stays 0 "
                             "unless --refuse-uncertain")
    parser.add_argument("--refuse-uncertain", action="store_true",
                        help="refuse the log (exit 2, one stderr line, no output) when a probe point's tip "
                             "uncertainty exceeds --max-tip-u-mm")
    parser.add_argument("--max-bound-mm", dest="max_bound", type=float, metavar="MM", default=None,
                        help="leave out probe points whose stated bound U (k = 2) + R (+ ambiguity) exceeds MM "
                             "(flag 'over bound'; an unbounded point always exceeds it)")
    add_plot_flag(parser, "the tip path with probe points, pivot heights, closure residuals, and u and R per row")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    add_json_flag(parser)
    refuse_renamed_options(parser, {
        "--initial-heights": "--initial-heights-mm",
        "--laser-sigma": "--laser-sigma-mm",
        "--max-closure": "--max-closure-mm",
        "--max-tip-u": "--max-tip-u-mm",
        "--max-bound": "--max-bound-mm",
    })
    parser.set_defaults(handler=_handle)


def _handle(args: argparse.Namespace) -> Report:
    import numpy as np

    from pcmm_geo.cli._progress import progress_bar, progress_wanted
    from pcmm_geo.cli.machine.kinematics import load_machine_file
    from pcmm_geo.errors import ConvergenceError, InconsistentMeasurementError, OutOfRangeError
    from pcmm_geo.machine.analysis.logproc import (
        DEFAULT_ALPHA,
        DEFAULT_MAX_TIP_UNCERTAINTY,
        DEFAULT_POWER,
        SEED_LASER_SIGMA,
        process_log,
        read_log,
    )

    machine = load_machine_file(args.calibration)
    covariance = _calibration_covariance(args.calibration, machine)
    limit = DEFAULT_MAX_TIP_UNCERTAINTY if args.max_tip_u is None else args.max_tip_u
    log = read_log(args.file, allow_unterminated=args.allow_unterminated)
    metadata = _acquisition_metadata(args.file, args.allow_unterminated)
    initial_heights = args.initial_heights
    if initial_heights is None and metadata.get("start_heights_mm") is not None:
        initial_heights = [float(v) for v in metadata["start_heights_mm"].split()]
    steps = _laser_steps(metadata.get("laser_models"))
    sigma = SEED_LASER_SIGMA if args.laser_sigma is None else args.laser_sigma
    alpha = DEFAULT_ALPHA if args.alpha is None else args.alpha
    power = DEFAULT_POWER if args.power is None else args.power
    try:
        with progress_bar("processing log rows", enabled=progress_wanted(args), total=len(log)) as update:
            out = process_log(machine, log, initial_heights=initial_heights, laser_sigma=sigma, laser_steps=steps,
                              closure_tolerance=args.max_closure, progress=update, max_tip_uncertainty=limit,
                              on_inconsistent="flag" if args.keep_inconsistent else "raise", alpha=alpha,
                              power=power, max_bound=np.inf if args.max_bound is None else args.max_bound,
                              model_covariance=covariance)
    except InconsistentMeasurementError as exc:
        raise InconsistentMeasurementError(
            f"{args.file}: {exc.what}", exc.residual, exc.tolerance, exc.unit,
            f"{exc.detail}; --keep-inconsistent leaves such readings out, --max-closure-mm sets a tolerance in mm",
        ) from None
    except ConvergenceError as exc:
        raise ConvergenceError(f"{args.file}: {exc.element}", exc.iterations,
                               f"{exc.reason}; --keep-inconsistent leaves such rows out") from None
    uncertain_probes = [int(k) for k in out.probe_rows if out.uncertain[k]]
    if args.refuse_uncertain and uncertain_probes:
        first = uncertain_probes[0]
        raise OutOfRangeError(f"{args.file}: tip uncertainty of log row {first + 1} ({len(uncertain_probes)} probe "
                              "points above the limit; --max-tip-u-mm sets it)",
                              float(f"{out.tip_uncertainty[first]:.4g}"), None, float(limit), "mm")
    data = _json(args, log, out, initial_heights, limit, covariance is not None)
    rows_index = range(len(log)) if args.all_rows else out.probe_rows.tolist()
    table = Table(
        "Probe points" if not args.all_rows else "Rows",
        ["line", "probe", "x / mm", "y / mm", "z / mm", "h_a / mm", "h_b / mm", "h_c / mm", "closure / mm",
         "u / mm", "R / mm", "U+R / mm", "flags"],
        [[int(k) + 2, int(log.probe[k]), *out.tips[k].tolist(), *out.heights[k].tolist(),
          float(out.closure_residual[k]), _number(out.tip_uncertainty[k]), _number(out.tip_reliability[k]),
          _number(out.bound[k]), ",".join(_flags(out, int(k))) or "-"] for k in rows_index],
    )
    lines = _summary_lines(args, log, out, data, initial_heights, sigma, limit, len(uncertain_probes))
    plots = []
    if args.plot:
        from pcmm_geo.plots.machine.process_log import plot_processed_log

        written = plot_processed_log(out, args.plot, overwrite=args.overwrite)
        data["plot"] = str(written)
        plots.append(str(written))
        lines.append(f"plot written to {written}")
    return Report(data=data, tables=[table], lines=lines, plots=plots)


def _number(value: float) -> float | str:
    import math

    return value if math.isfinite(value) else "inf"


def _flags(out: Any, row: int) -> list[str]:
    flags = []
    for name, label in (("inconsistent", "refused"), ("ambiguous", "ambiguous"), ("unbounded", "unbounded"),
                        ("uncertain", "uncertain"), ("over_bound", "over bound")):
        if getattr(out, name)[row]:
            flags.append(label)
    if not out.direction_consistent[row]:
        flags.append("direction")
    return flags


def _finite_list(values: Any) -> list[Any]:
    import numpy as np

    array = np.asarray(values, dtype=float)
    if array.ndim > 1:
        return [_finite_list(part) for part in array]
    return [float(v) if np.isfinite(v) else None for v in array]


def _json(args: argparse.Namespace, log: Any, out: Any, initial_heights: Any, limit: float,
          calibration: bool) -> dict[str, Any]:
    import numpy as np

    def data_rows(mask: Any) -> list[int]:
        return (np.flatnonzero(mask) + 1).tolist()  # 1-based data rows

    return {
        "file": args.file,
        "rows": len(log),
        "probe_rows": (out.probe_rows + 2).tolist(),  # file lines (header = line 1)
        "probe_points": out.probe_points.tolist(),
        "heights": out.heights.tolist(),
        "tips": out.tips.tolist(),
        "direction_consistent": out.direction_consistent.tolist(),
        "converged": out.converged.tolist(),
        "max_residual_mm": float(np.nanmax(np.abs(out.residuals))),
        "residuals_mm": out.residuals.tolist(),
        "closure_residual_mm": out.closure_residual.tolist(),
        "closure_tolerance_mm": out.closure_tolerance,
        "alpha": out.alpha,
        "power": out.power,
        "critical_value": out.critical_value,
        "laser_sigmas_mm": out.laser_sigmas.tolist(),
        "w_test": _finite_list(out.w_test),
        "redundancy": _finite_list(out.redundancy),
        "mdb_mm": _finite_list(out.mdb),
        "faulty_readings": out.faulty_readings.tolist(),
        "inconsistent_data_rows": data_rows(out.inconsistent),
        "rejected_probe_data_rows": (out.rejected_probe_rows + 1).tolist(),
        "initial_heights": None if initial_heights is None else [float(h) for h in initial_heights],
        "calibration_covariance": calibration,
        "max_tip_uncertainty_mm": float(limit) if np.isfinite(limit) else None,
        "tip_uncertainty_mm": _finite_list(out.tip_uncertainty),
        "tip_u_mm": _finite_list(out.tip_u),
        "probe_tip_uncertainty_mm": _finite_list(out.tip_uncertainty[out.probe_rows]),
        "uncertain_data_rows": data_rows(out.uncertain),
        "tip_reliability_mm": _finite_list(out.tip_reliability),
        "bound_mm": _finite_list(out.bound),
        "probe_bound_mm": _finite_list(out.bound[out.probe_rows]),
        "max_bound_mm": out.max_bound if np.isfinite(out.max_bound) else None,
        "ambiguous_data_rows": data_rows(out.ambiguous),
        "ambiguity_mm": out.ambiguity.tolist(),
        "unbounded_data_rows": data_rows(out.unbounded),
        "over_bound_data_rows": data_rows(out.over_bound),
    }


def _summary_lines(args: argparse.Namespace, log: Any, out: Any, data: dict[str, Any], initial_heights: Any,
                   sigma: float, limit: float, uncertain: int) -> list[str]:
    import numpy as np

    lines = [f"{len(log)} rows, {out.probe_rows.size} probe points; largest closure residual "
             f"{float(np.nanmax(out.closure_residual)):.3g} mm"]
    if args.initial_heights is None and initial_heights is not None:
        lines.append("initial heights (datum) from the log's start_heights_mm: "
                     + " ".join(f"{h:g}" for h in initial_heights) + " mm")
    probe_u = out.tip_uncertainty[out.probe_rows]
    if probe_u.size:
        source = "laser sigma " + f"{sigma:g} mm" + (" and the calibration's covariance" if data[
            "calibration_covariance"] else "; no calibration covariance")
        lines.append(f"u (standard uncertainty of the 3-D point, {source}): median {float(np.median(probe_u)):.3g} "
                     f"mm, largest {float(np.max(probe_u)):.3g} mm; {uncertain} above the limit {limit:g} mm")
        reliability, bound = out.tip_reliability[out.probe_rows], out.bound[out.probe_rows]
        lines.append(f"R (largest tip shift of an undetected laser fault of minimal detectable size, w-test at "
                     f"alpha0 {out.alpha:g}, power {out.power:g}): median {float(np.median(reliability)):.3g} mm, "
                     f"largest {float(np.max(reliability)):.3g} mm; stated bound U (k = 2) + R: largest "
                     f"{float(np.max(bound)):.3g} mm")
    if out.inconsistent.any():
        test = (f"the closure tolerance {out.closure_tolerance:g} mm" if out.closure_tolerance is not None
                else f"the w-test (critical value {out.critical_value:.3g})")
        lines.append(f"warning: {int(out.faulty_readings.sum())} readings fail {test} and were left out (data rows "
                     f"{data['inconsistent_data_rows']}); {out.rejected_probe_rows.size - int(out.over_bound.sum())} "
                     "probe points refused")
    for key, text in (("ambiguous_data_rows", "ambiguous rows (a mirror pose fits as well; bound includes it)"),
                      ("unbounded_data_rows", "unbounded rows (a reading no test can check moves them)"),
                      ("over_bound_data_rows", f"probe points left out: bound above {args.max_bound} mm")):
        if data[key]:
            lines.append(f"warning: {len(data[key])} {text}: data rows {data[key]}")
    bad = [int(k) + 2 for k in range(len(log)) if not out.direction_consistent[k]]
    if bad:
        lines.append(f"warning: direction flag contradicts the solved height change on lines {bad}")
    return lines


def _acquisition_metadata(path: str, allow_partial: bool) -> dict[str, str]:
    """The ``# key: value`` metadata of an acquisition log (``pcmm acquire``), else an empty dict."""
    from pcmm_geo.acquisition.acqlog import read_log as read_acquisition_log

    with open(path, "rb") as handle:
        if not handle.read(64).startswith(b"# pcmm_geo acquisition log"):
            return {}
    return dict(read_acquisition_log(path, allow_partial=allow_partial).metadata)


def _laser_steps(models: str | None) -> Any:
    """Reading steps (mm) of lasers a, b, c from ``laser_models`` metadata (``a=ILD1302 b=ILD1302 c=ILD1420``)."""
    from pcmm_geo.errors import InvalidInputError
    from pcmm_geo.machine.analysis.logproc.gate import LASER_STEPS_BY_MODEL, SEED_LASER_STEPS

    if models is None:
        return SEED_LASER_STEPS
    named = dict(part.split("=", 1) for part in models.split() if "=" in part)
    try:
        return tuple(LASER_STEPS_BY_MODEL[named[arm]] for arm in "abc")
    except KeyError:
        raise InvalidInputError("laser_models", "a=MODEL b=MODEL c=MODEL of " + ", ".join(LASER_STEPS_BY_MODEL),
                                models) from None


def _calibration_covariance(path: str | None, machine: Any) -> Any:
    """The tetrahedron parameters' covariance of a calibration file (for ``process_log``), or None.

    Refused when the file's parameter values are not the machine's tetrahedron (another frame).
    """
    if path is None:
        return None
    import numpy as np

    from pcmm_geo.errors import FileFormatError
    from pcmm_geo.io.text import read_json_file
    from pcmm_geo.machine.analysis.logproc import GEOMETRY_PARAMETERS
    from pcmm_geo.machine.calibration.calfile import load_covariance

    document = read_json_file(path)
    if not isinstance(document, dict) or "covariance" not in document:
        return None
    stored = load_covariance(path)
    assert stored is not None
    names = list(stored["names"])
    try:
        index = [names.index(name) for name in GEOMETRY_PARAMETERS]
    except ValueError:
        raise FileFormatError(path, "covariance.names: expected the tetrahedron parameters "
                              f"{', '.join(GEOMETRY_PARAMETERS[:2])}, ...") from None
    values = np.array([np.nan if v is None else v for v in stored["values"]], dtype=float)[index]
    matrix = np.array([[np.nan if v is None else v for v in row] for row in stored["matrix"]], dtype=float)
    g = machine.geometry
    model = np.concatenate([np.concatenate([g.slider_points[k], g.slider_directions[k], [g.laser_scale[k]],
                                            [g.laser_offset[k]]]) for k in range(3)] + [g.tip_center])
    if not np.allclose(values[:27], model, rtol=0.0, atol=1e-6):
        raise FileFormatError(path, "covariance.values: expected the parameters of the machine's tetrahedron (the "
                              "stored machine uses another frame than the calibration); the covariance cannot be "
                              "applied")
    return np.nan_to_num(matrix[np.ix_(index, index)], nan=0.0)
