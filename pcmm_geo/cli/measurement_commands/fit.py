"""``pcmm fit ELEMENT FILE``: Gaussian, minimum-zone, MCC or MIC fit of a point file."""

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
from pcmm_geo.cli._record import CovarianceBlock

_CRITERION_TITLES = {
    "gaussian": "Gaussian least squares",
    "chebyshev": "minimum zone",
    "mcc": "minimum circumscribed",
    "mic": "maximum inscribed",
}
ELEMENTS = ("line", "plane", "circle", "sphere", "cylinder", "cone", "torus")  # = pcmm_geo.fit.ELEMENTS (tested)
_DIRECTIONS = ("direction", "normal", "axis")
_UNITS = {"radius": "mm", "r_in": "mm", "r_out": "mm", "major_radius": "mm", "minor_radius": "mm", "half_angle": "rad"}


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "fit",
        help="fit a geometric element to a point file (Gaussian, minimum zone, MCC, MIC)",
        description=(
            "Fit ELEMENT to the points in FILE (CSV/TXT/XYZ with or without header, NIST .ds, PLY, PCD). "
            "Reports the element, standard uncertainties, rms, form error and convergence."
        ),
    )
    parser.add_argument("element", choices=ELEMENTS)
    parser.add_argument("file", type=Path)
    parser.add_argument(
        "--method",
        choices=("gaussian", "projected"),
        default="gaussian",
        help="3-D circle: distance to the curve (gaussian) or plane-then-circle (projected, NIST)",
    )
    parser.add_argument(
        "--criterion",
        choices=("gaussian", "chebyshev", "mcc", "mic"),
        default="gaussian",
        help="least squares (default), minimum zone, minimum circumscribed or maximum inscribed",
    )
    parser.add_argument("--radius-mm", dest="radius", type=float, help="fixed radius in mm (circle, sphere, cylinder)")
    parser.add_argument("--two-d", action="store_true", help="line/circle: use only the x and y columns")
    parser.add_argument("--axis-hint", type=float, nargs=3, metavar=("X", "Y", "Z"),
                        help="cylinder, cone, torus: the nominal axis direction, tried first (sparse data)")
    parser.add_argument("--residuals", action="store_true", help="include every residual in the JSON output")
    add_plot_flag(parser, "a residual plot")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    add_decimal_flag(parser)
    add_json_flag(parser)
    refuse_renamed_options(parser, {"--radius": "--radius-mm"})
    parser.set_defaults(handler=handle)


def handle(args: argparse.Namespace) -> Report:
    import numpy as np

    from pcmm_geo import fit
    from pcmm_geo.errors import InvalidInputError
    from pcmm_geo.io.points import read_points

    points = read_points(args.file, decimal=args.decimal)
    if args.two_d:
        if args.element not in ("line", "circle"):
            raise InvalidInputError("--two-d", "element line or circle", args.element)
        points = points[:, :2]
    kwargs: dict[str, Any] = {}
    if args.radius is not None:
        if args.element not in ("circle", "sphere", "cylinder"):
            raise InvalidInputError("--radius-mm", "element circle, sphere or cylinder", args.element)
        kwargs["radius"] = args.radius
    if args.axis_hint is not None:
        if args.element not in ("cylinder", "cone", "torus"):
            raise InvalidInputError("--axis-hint", "element cylinder, cone or torus", args.element)
        kwargs["axis_hint"] = np.asarray(args.axis_hint, dtype=float)
    if args.element == "circle" and args.criterion == "gaussian":
        kwargs["method"] = args.method
    if args.criterion != "gaussian":
        kwargs["criterion"] = args.criterion
    result = getattr(fit, f"fit_{args.element}")(points, **kwargs)

    data = result.to_dict()
    if not args.residuals:
        data.pop("residuals", None)
        data.get("extra", {}).pop("residual_components", None)
        data.pop("residual_components", None)
    data["file"] = str(args.file)
    geometry = _geometry_rows(result)
    uncertainty = dict(zip(result.parameter_names, np.asarray(result.std_errors).tolist(), strict=True))
    rows = [
        [name, value, uncertainty.get(name, float("nan")), "1" if name.split("_")[0] in _DIRECTIONS else "mm"]
        for name, value in geometry
    ]
    for name in ("radius", "r_in", "r_out", "major_radius", "minor_radius", "half_angle"):
        if hasattr(result, name):
            value = float(getattr(result, name))
            if name in ("r_in", "r_out") and value != value:  # NaN: Gaussian fits have no zone radii
                continue
            unit = _UNITS[name]
            rows.append([name, value, uncertainty.get(name, float("nan")), unit])
    if hasattr(result, "half_angle"):
        rows.append(["apex_angle_deg", float(np.degrees(2 * result.half_angle)), float("nan"), "deg"])
    tables = [
        Table(
            f"{args.element} fit of {args.file} ({_CRITERION_TITLES[args.criterion]})",
            ["parameter", "value", "u (k = 1)", "unit"],
            rows,
        ),
        Table(
            "statistics",
            ["n", "dof", "rms / mm", "form / mm", "iterations", "converged"],
            [[result.n, result.dof, result.rms, result.form, result.iterations, result.converged]],
        ),
    ]
    lines = [result.message]
    if result.certificate is not None:
        lines.append(
            f"contacts {result.contacts.tolist()}, KKT residual {result.certificate.kkt_residual:.3g}, "
            f"certified {result.certificate.certified}"
        )
    plots = []
    if args.plot is not None:
        from pcmm_geo.plots.fit_residuals import plot_fit_residuals

        written = plot_fit_residuals(result, args.plot, points=points, element=args.element,
                                     overwrite=args.overwrite)
        data["plot"] = str(written)
        plots.append(str(written))
        lines.append(f"plot: {written}")
    covariance = np.asarray(result.covariance, dtype=float)
    blocks = [CovarianceBlock(f"{args.element} fit parameters", tuple(result.parameter_names), covariance)] \
        if covariance.size and np.all(np.isfinite(covariance)) and np.any(np.diag(covariance) > 0) else []
    return Report(data=data, tables=tables, lines=lines, plots=plots, covariances=blocks)


def _geometry_rows(result: Any) -> list[tuple[str, float]]:
    import numpy as np

    rows: list[tuple[str, float]] = []
    for name in ("center", "point", "apex", "direction", "normal", "axis"):
        value = getattr(result, name, None)
        if value is None:
            continue
        vector = np.asarray(value, dtype=float)
        rows.extend((f"{name}_{axis}", float(v)) for axis, v in zip("xyz", vector, strict=False))
    return rows

