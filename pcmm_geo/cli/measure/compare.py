"""``pcmm compare POINTS MESH``: register a scan to its nominal CAD mesh and report the surface deviations."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from pcmm_geo.cli._output import (
    EXIT_FAILURE,
    EXIT_OK,
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
        "compare",
        help="compare a scan with its nominal CAD mesh (ICP registration, signed deviations)",
        description=(
            "Register the points in POINTS (CSV/TXT/XYZ, NIST .ds, PLY, PCD; mm) to the nominal surface "
            "MESH (STL/OBJ/PLY) or a --nominal primitive: open3d point-to-plane ICP, then a least-squares "
            "best fit to the exact triangles.  MESH must be closed (watertight, outward normals).  Reports the "
            "transform (measured -> nominal), the fitness and the signed deviations of every point (positive "
            "outside the material).  With --tolerance-mm "
            "the exit code is 1 when a point deviates by more than it."
        ),
    )
    parser.add_argument("points", type=Path, help="measured points (mm)")
    parser.add_argument("mesh", type=Path, nargs="?", help="nominal mesh .stl/.obj/.ply (mm)")
    parser.add_argument("--nominal", metavar="SPEC",
                        help="nominal primitive instead of MESH, centred at the origin: box:LxWxH (length along x), "
                             "cylinder:RxH (axis z), sphere:R, sizes in mm, e.g. box:100x35x9")
    parser.add_argument("--init-transform", metavar="FILE|centroid",
                        help="starting transform measured -> nominal: a text file with 16 numbers (4x4, row by "
                             "row), or 'centroid' to move the scan's centroid onto the surface's")
    parser.add_argument("--tolerance-mm", dest="tolerance", type=float, metavar="MM",
                        help="symmetric deviation tolerance (mm)")
    parser.add_argument("--max-distance-mm", dest="max_distance", type=float, metavar="MM",
                        help="points farther than this from the surface are left out of the registration "
                             "(default 5%% of the mesh's bounding-box diagonal)")
    parser.add_argument("--samples", type=int, default=50_000,
                        help="points sampled on the nominal surface for ICP (default 50000)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the surface sampling (default 0)")
    parser.add_argument("--deviations", action="store_true",
                        help="include every signed deviation and registered point in the JSON output")
    add_plot_flag(parser, "a 3-D scatter of the registered points coloured by deviation")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    add_decimal_flag(parser)
    add_json_flag(parser)
    refuse_renamed_options(parser, {"--tolerance": "--tolerance-mm", "--max-distance": "--max-distance-mm"})
    parser.set_defaults(handler=handle)


def handle(args: argparse.Namespace) -> Report:
    import numpy as np

    from pcmm_geo.artefacts.cad_compare import compare_to_mesh
    from pcmm_geo.artefacts.cad_distance import check_closed_mesh
    from pcmm_geo.artefacts.cad_register import centroid_alignment
    from pcmm_geo.errors import InvalidInputError
    from pcmm_geo.io.meshes import nominal_mesh, read_mesh
    from pcmm_geo.io.points import read_points

    if (args.mesh is None) == (args.nominal is None):
        given = "both" if args.mesh is not None else "neither"
        raise InvalidInputError("MESH / --nominal", "exactly one nominal surface", given)
    if args.tolerance is not None and not args.tolerance >= 0:
        raise InvalidInputError("--tolerance-mm", "a non-negative distance in mm", repr(args.tolerance))
    mesh = read_mesh(args.mesh) if args.mesh is not None else nominal_mesh(args.nominal)
    nominal_name = str(args.mesh) if args.mesh is not None else args.nominal
    check_closed_mesh(mesh, what=nominal_name)  # signed deviations need a closed surface
    points = read_points(args.points, decimal=args.decimal)
    initial = None
    if args.init_transform == "centroid":
        initial = centroid_alignment(points, mesh)
    elif args.init_transform is not None:
        initial = read_transform(Path(args.init_transform))

    comparison = compare_to_mesh(points, mesh, initial_transform=initial, tolerance=args.tolerance,
                                 max_distance=args.max_distance, sample_count=args.samples, seed=args.seed)
    registration, deviations = comparison.registration, comparison.deviations
    summary = deviations.summary
    angle = registration.rotation_angle
    data: dict[str, Any] = {
        "points_file": str(args.points),
        "nominal": nominal_name,
        "registration": {
            "transform": registration.transform,
            "rotation_angle_rad": angle,
            "translation_mm": registration.translation,
            "fitness": registration.fitness,
            "inlier_rms_mm": registration.inlier_rms,
            "inlier_count": registration.inlier_count,
            "max_distance_mm": registration.max_distance,
            "icp_fitness": registration.icp_fitness,
            "icp_inlier_rms_mm": registration.icp_inlier_rms,
            "iterations": registration.iterations,
            "condition_number": registration.condition_number,
        },
        "deviations_mm": summary.to_dict(),
    }
    if args.deviations:
        data["signed_distance_mm"] = deviations.signed_distance
        data["registered_points_mm"] = deviations.points
    translation = registration.translation
    tables = [
        Table(
            f"registration of {args.points} to {nominal_name} (measured -> nominal)",
            ["quantity", "value", "unit"],
            [
                ["rotation angle", angle, "rad"],
                ["rotation angle", float(np.degrees(angle)), "deg"],
                ["translation x", float(translation[0]), "mm"],
                ["translation y", float(translation[1]), "mm"],
                ["translation z", float(translation[2]), "mm"],
                ["fitness (points within max distance)", registration.fitness, "1"],
                ["inlier rms distance", registration.inlier_rms, "mm"],
                ["max distance", registration.max_distance, "mm"],
                ["ICP fitness (sampled surface)", registration.icp_fitness, "1"],
                ["ICP inlier rms (sampled surface)", registration.icp_inlier_rms, "mm"],
                ["best-fit iterations", registration.iterations, ""],
            ],
        ),
        Table("transform (4x4)", ["row", "c1", "c2", "c3", "c4"],
              [[f"r{k + 1}", *(float(v) for v in row)] for k, row in enumerate(registration.transform)]),
        Table(
            "deviations from nominal (+ outside material)",
            ["n", "min / mm", "max / mm", "mean / mm", "rms / mm", "tolerance / mm", "beyond"],
            [[summary.count, summary.minimum, summary.maximum, summary.mean, summary.rms,
              "none" if summary.tolerance is None else summary.tolerance, summary.count_beyond]],
        ),
    ]
    lines = []
    exit_code = EXIT_OK
    verdict = None
    if summary.tolerance is not None:
        from pcmm_geo.cli._record import Verdict

        passed = summary.count_beyond == 0
        data["passed"] = passed
        exit_code = EXIT_OK if passed else EXIT_FAILURE
        verdict = Verdict(passed, f"{'PASS' if passed else 'FAIL'} ({summary.count_beyond} of {summary.count} points "
                                  f"beyond ±{summary.tolerance:g} mm)",
                          f"simple acceptance: every signed deviation within ±{summary.tolerance:g} mm",
                          basis="the signed distances of the registered points from the nominal surface; the "
                                "uncertainty of the points and of the registration is not taken into account")
    plots = []
    if args.plot:
        from pcmm_geo.plots.cad import plot_deviations

        written = plot_deviations(deviations, args.plot, title=f"{args.points.name} vs {Path(nominal_name).name}",
                                  overwrite=args.overwrite)
        data["plot"] = str(written)
        plots.append(str(written))
        lines.append(f"plot written to {written}")
    return Report(data=data, tables=tables, lines=lines, exit_code=exit_code, plots=plots, verdict=verdict)


def read_transform(path: Path) -> Any:
    """Read a 4x4 rigid transform: 16 numbers separated by spaces, commas or new lines (``#`` comments).

    Raises
    ------
    FileFormatError
        Not 16 numbers, or not a rigid transform.
    OSError
        The file cannot be read.
    """
    import numpy as np

    from pcmm_geo.artefacts.cad_register import as_rigid_transform
    from pcmm_geo.errors import FileFormatError, InvalidInputError

    numbers: list[float] = []
    from pcmm_geo.io.text import excerpt, parse_decimal, read_text_lines

    for line_number, line in read_text_lines(path):
        text = line.split("#", 1)[0].replace(",", " ").split()
        try:
            numbers.extend(parse_decimal(field) for field in text)
        except ValueError:
            raise FileFormatError(str(path), f"expected numbers, got {excerpt(line.strip())}", line_number) from None
    if len(numbers) != 16:
        raise FileFormatError(str(path), f"expected 16 numbers (a 4x4 transform), got {len(numbers)}")
    try:
        return as_rigid_transform(np.array(numbers).reshape(4, 4), name="transform")
    except InvalidInputError as exc:
        raise FileFormatError(str(path), str(exc)) from None
