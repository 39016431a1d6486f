"""``pcmm demo``: the end-to-end demonstration on generated data (see :mod:`pcmm_geo.demo`)."""

from __future__ import annotations

import argparse
from datetime import UTC, datetime
from pathlib import Path

from pcmm_geo.cli._output import (
    Report,
    Table,
    add_json_flag,
    add_overwrite_flag,
    add_plot_flag,
    add_report_flag,
    declare_output,
)


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "demo",
        help="end-to-end demo: calibrate a simulated micro-CMM, measure a 100 mm gauge block",
        description=(
            "Simulates a micro-CMM with skewed slider lines, calibrates it from simulated external-CMM "
            "probings (thesis ch. 7), measures a 100 mm gauge block with laser and encoder noise, and "
            "reports the length error of the calibrated and of the nominal model. No network, no files needed."
        ),
    )
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("out") / "demo",
        help="folder for the plots; each run writes a fresh time-stamped sub-folder (default: %(default)s)",
    )
    parser.add_argument("--no-plots", action="store_true", help="skip the plots in the --out folder")
    declare_output(parser, "out", folder=True, unused_when="no_plots")  # checked before the run
    add_plot_flag(parser, "one overview figure: the calibration (fig 7.2) and the tip error per contact")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    parser.add_argument("--seed", type=int, default=2026, help="random seed (default: %(default)s)")
    add_json_flag(parser)
    parser.set_defaults(handler=handle)


def handle(args: argparse.Namespace) -> Report:
    from pcmm_geo.cli._progress import progress_bar, progress_wanted
    from pcmm_geo.demo import DemoSettings, run_demo

    out_dir = None
    if not args.no_plots:
        stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%S%fZ")
        out_dir = args.out / f"run-{stamp}"

    with progress_bar("demo", enabled=progress_wanted(args)) as update:  # run_demo gives the step count
        result = run_demo(DemoSettings(seed=args.seed), out_dir=out_dir, progress=update)
    plots = list(result.plots)
    data = result.to_dict()
    if args.plot:
        from pcmm_geo.plots.demo import plot_demo_overview

        written = plot_demo_overview(result.tetrahedron_calibration, result.tip_errors, args.plot,
                                     overwrite=args.overwrite)
        data["plot"] = str(written)
        plots.append(str(written))
    cal = result.calibration
    tables = [
        Table(
            "Calibration from simulated external-CMM probings (thesis ch. 7)",
            ["arm", "true line misses tip / mm", "line error / mm", "laser scale", "dead distance d / mm"],
            [
                [
                    arm,
                    result.true_slider_miss[arm],
                    cal["slider_line_error_mm"][arm],
                    cal["laser_scale"][arm],
                    cal["dead_distance_mm"][arm],
                ]
                for arm in ("a", "b", "c")
            ],
        ),
        Table(
            f"{result.gauge_length:g} mm gauge block, ISO 3650 central length",
            ["model", "measured / mm", "error / µm", "tip error rms / µm"],
            [
                [
                    "calibrated (rigid body)",
                    result.measured_length_calibrated,
                    1000.0 * result.length_error_calibrated,
                    1000.0 * result.tip_error_rms_calibrated,
                ],
                [
                    "nominal design",
                    result.measured_length_nominal,
                    1000.0 * result.length_error_nominal,
                    1000.0 * result.tip_error_rms_nominal,
                ],
            ],
        ),
    ]
    lines = [f"plot: {path}" for path in plots]
    if result.length_uncertainty is not None:
        from pcmm_geo.uncertainty.result import decimals_for

        u = result.length_uncertainty.result
        places = decimals_for(u.expanded_uncertainty)
        from pcmm_geo.uncertainty.virtual_cmm import GROUP_LABELS

        budget = ", ".join(f"{GROUP_LABELS.get(entry.name, entry.name)} {1000 * entry.contribution:.3f}"
                           for entry in u.budget)
        lines[:0] = [
            f"calibrated length L = {result.measured_length_calibrated:.{places}f} mm "
            f"± {u.expanded_uncertainty:.{places}f} mm (U, k = {u.coverage_factor:.2f}, coverage "
            f"{100 * u.coverage_probability:.0f} %; virtual micro-CMM, {u.method}, {u.n_trials} trials)",
            f"true length error {1000 * result.length_error_calibrated:+.3f} µm, U = "
            f"{1000 * u.expanded_uncertainty:.3f} µm" + (f"; contributions to u / µm: {budget}" if budget else ""),
        ]
    return Report(data=data, tables=tables, lines=lines, plots=plots)
