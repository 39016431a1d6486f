"""``pcmm sensitivity``: tip sensitivity to laser and encoder readings over the working cube."""

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
        "sensitivity",
        help="laser/encoder-to-tip amplification over the 100 mm working cube",
        description="Jacobians of the probe tip w.r.t. the readings; the thesis' probe-to-laser ratio (20:1).",
    )
    add_machine_argument(parser)
    parser.add_argument("--size-mm", dest="size", type=float, default=100.0,
                        help="edge of the working cube in mm (default 100)")
    parser.add_argument("--points-per-axis", type=int, default=5, help="grid points per axis (default 5)")
    parser.add_argument("--centre-mm", "--center-mm", dest="center", type=float, nargs=3, metavar=("X", "Y", "Z"),
                        help="cube centre in mm (default: tip at the reference heights)")
    parser.add_argument("--laser-accuracy-mm", dest="laser_accuracy", type=float, default=0.05,
                        help="laser accuracy in mm (default 0.05)")
    add_plot_flag(parser, "the sensitivity map (laser gain over the grid, probe/laser ratio per motor)")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    add_json_flag(parser)
    refuse_renamed_options(parser, {
        "--size": "--size-mm",
        "--laser-accuracy": "--laser-accuracy-mm",
        "--center": "--centre-mm",
        "--centre": "--centre-mm",
    })
    parser.set_defaults(handler=_handle)


def _handle(args: argparse.Namespace) -> Report:
    from pcmm_geo.cli.machine.kinematics import load_machine_file
    from pcmm_geo.machine.analysis.sensitivity import sensitivity_over_cube
    from pcmm_geo.plots import plot_sensitivity

    machine = load_machine_file(args.calibration)
    sens = sensitivity_over_cube(
        machine, center=args.center, size=args.size, points_per_axis=args.points_per_axis,
        laser_accuracy=args.laser_accuracy,
    )
    data = sens.summary()
    lines = []
    plots = []
    if args.plot:
        data["plot"] = str(plot_sensitivity(sens, args.plot, overwrite=args.overwrite))
        plots.append(data["plot"])
        lines.append(f"plot written to {data['plot']}")
    rows = []
    for name, label in (("laser_gain", "laser gain / (mm/mm)"), ("tip_error_mm", "tip error / mm"),
                        ("height_gain", "height gain / (mm/mm)")):
        stats = data[name]
        rows.append([label, stats["median"], stats["max_finite"], stats["infinite"]])
    for arm in "abc":
        stats = data["motor_ratio"][arm]
        rows.append([f"probe/laser ratio, motor {arm}", stats["median"], stats["max_finite"], stats["infinite"]])
    paths = ", ".join(f"{axis}: {value:.2f}" for axis, value in data["path_ratio"].items())
    lines.insert(0, f"probe/laser ratio on {args.size:g} mm paths through the centre -> {paths} (thesis: 20:1)")
    table = Table(f"Sensitivity over {data['points']} grid points", ["quantity", "median", "max (finite)", "infinite"],
                  rows)
    return Report(data=data, tables=[table], lines=lines, plots=plots)
