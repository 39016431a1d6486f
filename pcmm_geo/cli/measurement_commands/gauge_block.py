"""``pcmm gauge-block FILE``: gauge block length from points labelled by face (ISO 3650 and the thesis' method)."""

from __future__ import annotations

import argparse
import math
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
        "gauge-block",
        help="gauge block central length from probed faces (ISO 3650 method and the thesis' eqs 5.1-5.3)",
        description=(
            "Evaluate a gauge block from a CSV with header face,x,y,z (mm); face is face_1, face_2 "
            "(measuring faces, >= 3 points each), top or side (reference faces, >= 3 points each, optional)."
        ),
    )
    parser.add_argument("file", help="CSV file face,x,y,z")
    add_plot_flag(parser, "per-face plane residuals and the lengths of every method")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    add_json_flag(parser)
    parser.set_defaults(handler=_handle)


def _handle(args: argparse.Namespace) -> Report:
    from pcmm_geo.artefacts.gauge_block import measure_gauge_block, read_gauge_block_csv

    points_by_face = read_gauge_block_csv(args.file)
    result = measure_gauge_block(points_by_face)
    seed = result.seed
    data: dict[str, Any] = {
        "central_length_mm": result.central_length,
        "length_face1_to_plane2_mm": result.length_face1_to_plane2,
        "length_face2_to_plane1_mm": result.length_face2_to_plane1,
        "variation_in_length_mm": None if math.isnan(result.variation_in_length) else result.variation_in_length,
        "parallelism_rad": result.parallelism,
        "face_form_mm": list(result.face_form),
        "axis": result.axis,
        "projected_length_mm": None if math.isnan(result.projected_length) else result.projected_length,
        "seed": None
        if seed is None
        else {
            "length_mm": seed.length,
            "phi_deg": math.degrees(seed.phi),
            "theta_top_deg": math.degrees(seed.theta_top),
            "theta_side_deg": math.degrees(seed.theta_side),
            "two_point_distance_mm": seed.vector_length,
        },
        "n_points": result.n_points,
    }
    rows: list[list[Any]] = [
        ["ISO 3650 central length (mean)", result.central_length],
        ["  face 1 centre -> plane 2", result.length_face1_to_plane2],
        ["  face 2 centre -> plane 1", result.length_face2_to_plane1],
        ["variation in length", result.variation_in_length],
    ]
    if seed is not None:
        rows += [
            ["exact projection (top x side)", result.projected_length],
            ["thesis eqs 5.1-5.3 length", seed.length],
            ["two-point distance", seed.vector_length],
        ]
    lines = []
    if seed is not None:
        lines.append(
            f"thesis angles: phi = {math.degrees(seed.phi):.4f} deg, theta1 = {math.degrees(seed.theta_top):.4f} deg, "
            f"theta2 = {math.degrees(seed.theta_side):.4f} deg"
        )
    plots = []
    if args.plot:
        from pcmm_geo.plots.gauge_block import plot_gauge_block

        written = plot_gauge_block(points_by_face, result, args.plot, overwrite=args.overwrite)
        data["plot"] = str(written)
        plots.append(str(written))
        lines.append(f"plot written to {written}")
    table = Table("Gauge block", ["quantity", "value / mm"], rows)
    return Report(data=data, tables=[table], lines=lines, plots=plots)
