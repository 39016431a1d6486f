"""``pcmm segment POINTS``: split a scan into planes and cylinders, each fitted by Gaussian least squares."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from pcmm_geo.cli._output import (
    Report,
    Table,
    add_decimal_flag,
    add_json_flag,
    add_overwrite_flag,
    add_plot_flag,
    add_report_flag,
    refuse_renamed_options,
)


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "segment",
        help="segment a scan into planes and cylinders (RANSAC proposals, Gaussian fits)",
        description=(
            "Find the planes and cylinders in POINTS (CSV/TXT/XYZ, NIST .ds, PLY, PCD; mm): RANSAC on the "
            "remaining points (open3d plane segmentation; cylinders from pairs of points and their normals), "
            "then a Gaussian least-squares fit of every segment.  Points near two surfaces (edges) or none "
            "stay unassigned."
        ),
    )
    parser.add_argument("points", type=Path)
    parser.add_argument("--distance-threshold-mm", dest="distance_threshold", type=float, default=0.02, metavar="MM",
                        help="largest distance of a point from its surface (default 0.02 mm)")
    parser.add_argument("--max-normal-angle-deg", type=float, default=20.0, metavar="DEG",
                        help="largest angle between a point's normal and the surface's while searching (default 20)")
    parser.add_argument("--min-points", type=int, help="smallest segment (default 1%% of the points, at least 20)")
    parser.add_argument("--kinds", default="plane,cylinder", help="shapes to look for (default plane,cylinder)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random draws (default 0)")
    parser.add_argument("--indices", action="store_true", help="include each segment's point indices in the JSON")
    add_plot_flag(parser, "a 3-D scatter coloured by segment")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    add_decimal_flag(parser)
    add_json_flag(parser)
    refuse_renamed_options(parser, {"--distance-threshold": "--distance-threshold-mm"})
    parser.set_defaults(handler=handle)


def handle(args: argparse.Namespace) -> Report:
    import math

    from pcmm_geo.artefacts.cad_segment import segment_scan
    from pcmm_geo.io.points import read_points

    points = read_points(args.points, decimal=args.decimal)
    kinds = tuple(k.strip() for k in args.kinds.split(",") if k.strip())
    result = segment_scan(points, distance_threshold=args.distance_threshold,
                          max_normal_angle=math.radians(args.max_normal_angle_deg), min_points=args.min_points,
                          kinds=kinds, seed=args.seed)
    segments: list[dict[str, Any]] = []
    rows: list[list[Any]] = []
    for number, segment in enumerate(result.segments, start=1):
        fit = segment.fit
        entry: dict[str, Any] = {"kind": segment.kind, "count": len(segment.indices), "rms_mm": fit.rms,
                                 "form_mm": fit.form, "point": fit.point}
        if segment.kind == "plane":
            entry["normal"] = fit.normal  # type: ignore[union-attr]
            direction, radius = fit.normal, "-"  # type: ignore[union-attr]
        else:
            entry["axis"] = fit.axis  # type: ignore[union-attr]
            entry["radius_mm"] = fit.radius  # type: ignore[union-attr]
            direction, radius = fit.axis, fit.radius  # type: ignore[union-attr]
        if args.indices:
            entry["indices"] = segment.indices
        segments.append(entry)
        rows.append([number, segment.kind, len(segment.indices), *(float(v) for v in fit.point),
                     *(float(v) for v in direction), radius, fit.rms, fit.form])
    data: dict[str, Any] = {
        "file": str(args.points),
        "point_count": result.point_count,
        "unassigned": len(result.unassigned),
        "distance_threshold_mm": result.distance_threshold,
        "seed": result.seed,
        "segments": segments,
    }
    table = Table(
        f"segments of {args.points} (normal / axis unit vector; point: centroid or axis point nearest it)",
        ["#", "kind", "n", "x / mm", "y / mm", "z / mm", "dx", "dy", "dz", "radius / mm", "rms / mm", "form / mm"],
        rows,
    )
    lines = [f"{len(result.planes)} planes, {len(result.cylinders)} cylinders; "
             f"{len(result.unassigned)} of {result.point_count} points unassigned"]
    plots = []
    if args.plot:
        from pcmm_geo.plots.cad import plot_segments

        written = plot_segments(points, result, args.plot, overwrite=args.overwrite)
        data["plot"] = str(written)
        plots.append(str(written))
        lines.append(f"plot written to {written}")
    return Report(data=data, tables=[table], lines=lines, plots=plots)
