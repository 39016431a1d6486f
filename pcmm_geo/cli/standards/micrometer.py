"""``pcmm micrometer FILE``: micrometer-stage test, CMM distances against stage distances (thesis Table 8.1)."""

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
    parser = subparsers.add_parser(
        "micrometer",
        help="micrometer-stage test: distances between probe points, CMM against stage (thesis 8.1-8.2)",
        description="CSV header point,stage_x,stage_y,stage_z,x,y,z (mm): stage readings and CMM tip positions.",
    )
    parser.add_argument("file", help="CSV file point,stage_x,stage_y,stage_z,x,y,z")
    parser.add_argument(
        "--pairs", choices=("thesis", "consecutive", "all"), default="thesis",
        help="pairs to compare: thesis (1-2, 2-3, ..., 1-3, 1-4, ...), consecutive or all (default thesis)",
    )
    add_plot_flag(parser, "the CMM-minus-stage error of each pair against the stage distance")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    add_json_flag(parser)
    parser.set_defaults(handler=_handle)


def _handle(args: argparse.Namespace) -> Report:
    from pcmm_geo.artefacts.micrometer import evaluate_stage_test, read_micrometer_csv

    stage, cmm, labels = read_micrometer_csv(args.file)
    result = evaluate_stage_test(stage, cmm, pairs=args.pairs, labels=labels)
    pairs = [
        {"pair": p.label, "stage_mm": p.stage_distance, "cmm_mm": p.cmm_distance, "error_mm": p.error}
        for p in result.pairs
    ]
    data = {"pairs": pairs, "max_abs_error_mm": result.max_abs_error, "rms_error_mm": result.rms_error}
    table = Table(
        "Micrometer-stage test",
        ["pair", "stage / mm", "CMM / mm", "error / mm"],
        [[p["pair"], p["stage_mm"], p["cmm_mm"], p["error_mm"]] for p in pairs],
    )
    plots = []
    if args.plot:
        from pcmm_geo.plots.verification import plot_stage_test

        plots.append(str(plot_stage_test(result, args.plot, overwrite=args.overwrite)))
        data["plot"] = plots[0]
    return Report(data=data, tables=[table], lines=[f"max |error| = {result.max_abs_error:.4f} mm"], plots=plots)
