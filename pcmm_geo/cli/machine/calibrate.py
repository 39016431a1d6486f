"""``pcmm calibrate PROBINGS.csv LASERS.csv``: tetrahedron calibration from external-CMM probings (thesis ch. 7)."""

from __future__ import annotations

import argparse
from typing import Any

from pcmm_geo.cli._cmm_input import add_max_mb_option, cli_setting, max_bytes
from pcmm_geo.cli._output import (
    Report,
    Table,
    add_json_flag,
    add_overwrite_flag,
    add_plot_flag,
    add_report_flag,
    declare_output,
    refuse_renamed_options,
)
from pcmm_geo.cli._record import UncertaintyEntry


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "calibrate",
        help="calibrate the tetrahedron from external-CMM probings and laser readings (thesis ch. 7)",
        description=(
            "Fit the probed joint and tip spheres, the slider lines and laser scales, and report the thesis' "
            "dead distances d (eq 7.3), arm angles beta (eq 7.4, corrected) and b (eq 7.5). PROBINGS.csv is "
            "feature,position,x,y,z (feature joint_a|joint_b|joint_c|tip) or the thesis' x,y,z,d,r export; "
            "LASERS.csv is position,laser_a,laser_b,laser_c (mm)."
        ),
    )
    parser.add_argument("probings", help="probings CSV (raw points or element-level export) or a QIF results file "
                                         "of the sphere probings (features joint_a_1 ... joint_c_K and tip)")
    parser.add_argument("lasers", help="laser readings CSV position,laser_a,laser_b,laser_c")
    parser.add_argument("--feature-map", metavar="MAP.json",
                        help="QIF probings: JSON object from QIF feature names to roles, e.g. "
                             "{\"SPH1\": \"joint_a:1\", \"SPH7\": \"tip\"} (default: the names joint_a_1 ... tip)")
    add_max_mb_option(parser, "QIF probings file read")
    parser.add_argument("--out", metavar="CAL.json", help="write the versioned calibration file")
    parser.add_argument("--sweep", metavar="SWEEP.csv", help="laser sweep (position,laser_a,laser_b,laser_c) for b")
    parser.add_argument("--start-of-range-mm", dest="start_of_range", type=float, default=60.0,
                        help="laser start of range in mm (default 60)")
    parser.add_argument("--probing-u-mm", dest="probing_u", type=float, metavar="MM",
                        help="standard uncertainty of one external-CMM probing (mm); with --laser-u-mm gives the "
                             "covariance of the calibrated parameters (table, JSON, --out file)")
    parser.add_argument("--laser-u-mm", dest="laser_u", type=float, metavar="MM",
                        help="standard uncertainty of one laser reading at a calibration position (mm)")
    declare_output(parser, "out")
    add_plot_flag(parser, "a 3-D plot of slider lines, joint centres, tip and probe points (fig 7.2)")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    add_json_flag(parser)
    refuse_renamed_options(parser, {
        "--start-of-range": "--start-of-range-mm",
        "--probing-u": "--probing-u-mm",
        "--laser-u": "--laser-u-mm",
    })
    parser.set_defaults(handler=_handle)


def _handle(args: argparse.Namespace) -> Report:
    from pcmm_geo.machine.calibration import PAIRS, calibrate_tetrahedron, save_calibration
    from pcmm_geo.machine.calibration.probings import LaserTable

    sweep = None if args.sweep is None else LaserTable.from_csv(args.sweep).readings
    probings, qif_lines, qif_data = _probings(args)  # each file read once, then typed
    lasers = LaserTable.from_csv(args.lasers)
    cal = calibrate_tetrahedron(probings, lasers, laser_start_of_range=args.start_of_range, laser_sweep=sweep)
    data: dict[str, Any] = cal.summary()
    lines: list[str] = list(qif_lines)
    if qif_data:
        data["qif_probings"] = qif_data
    covariance = None
    if (args.probing_u is None) != (args.laser_u is None):
        from pcmm_geo.errors import InvalidInputError

        raise InvalidInputError("--probing-u-mm/--laser-u-mm", "both or neither", "only one of them")
    if args.probing_u is not None:
        from pcmm_geo.uncertainty.calibration import calibration_covariance

        covariance = calibration_covariance(probings, lasers, probing_sigma=args.probing_u,
                                            laser_sigma=args.laser_u, laser_start_of_range=args.start_of_range)
        data["uncertainty"] = covariance.to_dict()
        data["uncertainty"]["standard_uncertainties"] = covariance.standard_uncertainties
    else:
        lines.append("no uncertainty: give --probing-u-mm and --laser-u-mm for the parameters' covariance")
    if args.out:
        written = save_calibration(cal, args.out, overwrite=args.overwrite, covariance=covariance)
        data["written"] = str(written)
        lines.append(f"calibration written to {written}")
    plots = []
    if args.plot:
        from pcmm_geo.plots.machine.calibration import plot_calibration

        written_plot = plot_calibration(cal, args.plot, overwrite=args.overwrite)
        data["plot"] = str(written_plot)
        plots.append(str(written_plot))
        lines.append(f"plot written to {written_plot}")
    rows = []
    for arm, pair in zip("abc", PAIRS, strict=True):
        line = cal.slider_lines[arm]
        rows.append([arm, cal.dead_distance[arm], pair, cal.beta_deg[pair], cal.b_in[pair], line.laser_scale,
                     line.laser_offset, line.straightness, line.tip_offset])
    arms = Table(
        "Tetrahedron calibration (Table 7.1 layout)",
        ["arm", "d / mm", "pair", "beta / deg", "b / mm", "laser scale", "laser offset / mm", "straightness / mm",
         "tip offset / mm"],
        rows,
    )
    geometry = Table(
        "Geometry",
        ["quantity", "x / mm", "y / mm", "z / mm"],
        [["tip centre", *cal.tip_center.tolist()], ["probe point eq 7.2 (least squares)", *cal.probe_point.tolist()],
         ["probe point (thesis pairwise)", *cal.probe_point_pairwise.tolist()]],
    )
    lines.insert(0, "skew distances / mm: " + ", ".join(f"{k} {v:.4f}" for k, v in cal.skew_distances.items()))
    uncertainties = []
    if covariance is not None:
        method = (f"{covariance.method}; probing u = {1000 * args.probing_u:g} µm, "
                  f"laser u = {1000 * args.laser_u:g} µm")
        uncertainties = [UncertaintyEntry(row["name"], row["value"], row["standard_uncertainty"], row["unit"],
                                          method=method) for row in covariance.table()]
    return Report(data=data, tables=[arms, geometry], lines=lines, plots=plots, uncertainties=uncertainties)


def _probings(args: argparse.Namespace) -> tuple[Any, list[str], dict[str, Any]]:
    """The probed balls (ProbedFeatures) of the CSV or QIF file, read once; with the QIF route's lines and data."""
    from pathlib import Path

    from pcmm_geo.errors import InvalidInputError
    from pcmm_geo.machine.calibration.probings import ProbedFeatures

    path = Path(args.probings)
    limit = max_bytes(args)
    if path.suffix.lower() != ".qif":
        for option, value in (("--feature-map", args.feature_map), ("--max-mb", limit)):
            if value is not None:
                raise InvalidInputError(option, "a QIF probings file (.qif)", str(path))
        return ProbedFeatures.from_csv(path), [], {}
    from pcmm_geo.machine.calibration.qif_probings import read_qif_probings

    read = read_qif_probings(path, feature_map=args.feature_map, max_bytes=limit, spell_setting=cli_setting)
    parts = [f"{len(read.refitted)} sphere centres refitted from their points"] if read.refitted else []
    if read.reported:
        parts.append(f"{len(read.reported)} centres as the CMM reported them (the file holds no points for them): "
                     + ", ".join(read.reported))
    lines = ["QIF probings: " + "; ".join(parts)]
    lines += list(read.notes)
    if read.ignored:
        lines.append(f"sphere features without a role, ignored: {', '.join(read.ignored)}")
    info = {"refitted": list(read.refitted), "reported": list(read.reported), "ignored": list(read.ignored),
            "roles": {name: [role, position] for name, (role, position) in read.roles.items()}}
    return read.features, lines, info
