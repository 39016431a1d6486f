"""``pcmm convert IN OUT``: convert between point formats and mesh formats; never overwrites unless asked."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from pcmm_geo._optional import require
from pcmm_geo.cli._output import Report, Table, add_decimal_flag, add_json_flag, declare_output

_MESH_ONLY = (".stl", ".obj")  # .ply holds either a mesh or a point cloud


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "convert",
        help="convert point files (CSV/TXT/XYZ/.ds/PLY/PCD) and meshes (STL/OBJ/PLY)",
        description=(
            "Convert IN to OUT, formats chosen by suffix.  Points: .csv .txt .xyz .ds .dat .asc (text), "
            ".ply .pcd (point clouds).  Meshes: .stl .obj .ply (a .ply with faces is read as a mesh).  The "
            "thesis' element export (header x,y,z,d,r) is read as its sphere centres.  A mesh written as "
            "points gives its vertices, or --sample N points spread evenly over its surface.  Refuses to "
            "replace OUT unless --overwrite.  Ctrl-C, SIGTERM or SIGHUP leave OUT as it was; what a killed "
            "run left next to OUT is cleaned up by the next run."
        ),
    )
    parser.add_argument("input", type=Path, metavar="IN")
    parser.add_argument("output", type=Path, metavar="OUT")
    parser.add_argument("--sample", type=int, metavar="N",
                        help="mesh -> points: N points spread evenly over the surface instead of the vertices")
    parser.add_argument("--seed", type=int, default=0, help="seed of --sample (default 0)")
    parser.add_argument("--overwrite", action="store_true", help="replace OUT if it exists")
    declare_output(parser, "output", "OUT")  # written all-or-nothing; checked before IN is read
    add_decimal_flag(parser)
    add_json_flag(parser)
    parser.set_defaults(handler=handle)


def handle(args: argparse.Namespace) -> Report:
    import numpy as np

    from pcmm_geo.errors import InvalidInputError, OutputExistsError
    from pcmm_geo.io.meshes import MESH_SUFFIXES, write_mesh
    from pcmm_geo.io.points import write_points

    source, target = args.input, args.output
    if target.exists() and not args.overwrite:  # before reading anything
        raise OutputExistsError(str(target))
    if source.resolve() == target.resolve():
        raise InvalidInputError("OUT", "a file other than IN", str(target))
    mesh, points, read_as = _read_any(source, args.decimal)
    out_suffix = target.suffix.lower()
    data: dict[str, Any] = {"input": str(source), "output": str(target), "read_as": read_as}

    if mesh is not None and out_suffix in MESH_SUFFIXES and args.sample is None:
        written = write_mesh(target, mesh, overwrite=args.overwrite)
        data.update(written_as="mesh", vertices=len(mesh.vertices), faces=len(mesh.faces))
        detail = f"{len(mesh.vertices)} vertices, {len(mesh.faces)} triangles"
    else:
        if out_suffix in _MESH_ONLY:
            raise InvalidInputError("OUT", f"a point format (points have no triangles to write as {out_suffix})",
                                    str(target))
        if mesh is not None:
            if args.sample is not None:
                trimesh = require("trimesh")

                if args.sample < 1:
                    raise InvalidInputError("--sample", "a positive number of points", repr(args.sample))
                samples, _ = trimesh.sample.sample_surface(mesh, int(args.sample), seed=args.seed)
                points = np.asarray(samples, dtype=float)
                data.update(sampled=int(args.sample), seed=args.seed)
                detail = f"{len(points)} points sampled on the surface (seed {args.seed})"
            else:
                points = np.asarray(mesh.vertices, dtype=float)
                detail = f"the {len(points)} vertices of the mesh (triangles dropped)"
        else:
            if args.sample is not None:
                raise InvalidInputError("--sample", "a mesh input", f"points read from {source}")
            detail = f"{len(points)} points"
        written = write_points(target, points, overwrite=args.overwrite)
        data.update(written_as="points", points=len(points))
    data["output"] = str(written)
    table = Table("convert", ["from", "read as", "to", "written"], [[str(source), read_as, str(written), detail]])
    return Report(data=data, tables=[table])


def _read_any(path: Path, decimal: str | None = None) -> tuple[Any, Any, str]:
    """(mesh, None, label) for a mesh file, (None, points, label) for points."""
    from pcmm_geo.errors import FileFormatError
    from pcmm_geo.io.meshes import read_mesh
    from pcmm_geo.io.points import read_points

    suffix = path.suffix.lower()
    if suffix in _MESH_ONLY:
        return read_mesh(path), None, "mesh"
    if suffix == ".ply":
        if _ply_has_faces(path):
            return read_mesh(path), None, "mesh"
        return None, read_points(path), "point cloud"
    if _is_element_export(path):
        from pcmm_geo.machine.calibration.probings import read_probings

        features = read_probings(path)
        import numpy as np

        centres = np.vstack([features.centers().reshape(-1, 3), features.tip.center[None, :]])
        return None, centres, f"element export ({len(features.positions)} positions x 3 joints + tip)"
    try:
        return None, read_points(path, decimal=decimal), "points"
    except UnicodeDecodeError as exc:
        raise FileFormatError(str(path), f"expected a text point file, got undecodable bytes ({exc.reason})") from None


def _ply_has_faces(path: Path) -> bool:
    """Whether a PLY header declares a non-empty face element (reads the header only)."""
    from pcmm_geo.errors import FileFormatError

    with open(path, "rb") as handle:
        header = handle.read(4096)
    if not header.startswith(b"ply"):
        raise FileFormatError(str(path), "expected a PLY file starting with 'ply'", line=1)
    for line in header.split(b"end_header", 1)[0].splitlines():
        fields = line.split()
        if len(fields) == 3 and fields[0] == b"element" and fields[1] == b"face":
            return fields[2] != b"0"
    return False


def _is_element_export(path: Path) -> bool:
    """Whether a text file starts with the thesis' ``x,y,z,d,r`` header (comments and blank lines skipped)."""
    try:
        with open(path, encoding="utf-8-sig") as handle:
            for line in handle:
                text = line.strip()
                if text and not text.startswith("#"):
                    return [f.strip().lower() for f in text.split(",")] == ["x", "y", "z", "d", "r"]
    except UnicodeDecodeError:
        return False
    return False
