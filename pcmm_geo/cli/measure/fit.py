"""``pcmm fit ELEMENT FILE``: Gaussian, minimum-zone, MCC or MIC fit of a point file."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from pcmm_geo.cli._cmm_input import (
    add_cmm_input_flags,
    cli_setting,
    naming_the_file,
    read_fit_input,
    write_qif_result,
)
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
from pcmm_geo.elements import AXIAL, CRITERIA, ELEMENTS, SPECS, Criterion, Element

_CRITERION_TITLES = {
    "gaussian": "Gaussian least squares",
    "chebyshev": "minimum zone",
    "mcc": "minimum circumscribed",
    "mic": "maximum inscribed",
}
#: fits taking a fixed ``radius=`` (the size parameter is the radius itself)
_FIXED_RADIUS = tuple(name for name in ELEMENTS if SPECS[name].size == "radius")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "fit",
        help="fit a geometric element to a point file (Gaussian, minimum zone, MCC, MIC)",
        description=(
            "Fit ELEMENT to the points in FILE (CSV/TXT/XYZ with or without header, NIST .ds, PLY, PCD, the "
            "point set of a feature of a QIF results file, a PC-DMIS XYZIJK export). Reports the element, standard "
            "uncertainties, rms, form error and convergence; probe centres are compensated onto the surface."
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
        choices=CRITERIA,
        default="gaussian",
        help="least squares (default), minimum zone, minimum circumscribed or maximum inscribed",
    )
    parser.add_argument("--radius-mm", dest="radius", type=float,
                        help="fixed radius in mm (circle, sphere, cylinder; of the surface)")
    parser.add_argument("--two-d", action="store_true", help="line/circle: use only the x and y columns")
    parser.add_argument("--axis-hint", type=float, nargs=3, metavar=("X", "Y", "Z"),
                        help="cylinder, cone, torus: the nominal axis direction, tried first (sparse data)")
    parser.add_argument("--residuals", action="store_true", help="include every residual in the JSON output")
    add_cmm_input_flags(parser)
    add_axis_region_options(parser)
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

    source = read_fit_input(args, args.element)
    points = source.points
    kwargs: dict[str, Any] = {}
    if args.radius is not None:
        if args.element not in _FIXED_RADIUS:
            raise InvalidInputError("--radius-mm", f"element {', '.join(_FIXED_RADIUS[:-1])} or {_FIXED_RADIUS[-1]}",
                                    args.element)
        kwargs["radius"] = args.radius
    if args.axis_hint is not None:
        if args.element not in AXIAL:
            raise InvalidInputError("--axis-hint", f"element {', '.join(AXIAL[:-1])} or {AXIAL[-1]}", args.element)
        kwargs["axis_hint"] = np.asarray(args.axis_hint, dtype=float)
    if args.element == "circle" and args.criterion == "gaussian":
        kwargs["method"] = args.method
    if args.criterion != "gaussian":
        kwargs["criterion"] = args.criterion
    kwargs.update(axis_search_options(args, args.element, args.criterion, points.shape[1]))
    fit_element = getattr(fit, f"fit_{args.element}")
    with naming_the_file(args.file):
        result, compensation, lines, summary = _fit(args, source, fit_element, kwargs)

    data = result.to_dict()
    if compensation is not None:
        data["probe_compensation"] = summary
    if source.data.feature is not None:
        data["feature"] = {"id": source.data.feature.id, "name": source.data.feature.name,
                           "type": source.data.feature.type}
    if not args.residuals:
        data.pop("residuals", None)
        data.get("extra", {}).pop("residual_components", None)
        data.pop("residual_components", None)
    data["file"] = str(args.file)
    summary = result.summary()  # the rows every display of a fit shares (FitResult.summary)
    rows = [[row.name, row.value, row.u, row.unit] for row in summary]
    diameter_line = _diameter(summary, data)
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
    lines.insert(0, result.message)
    if diameter_line:
        lines.insert(0, diameter_line)
    if result.certificate is not None:
        certificate = result.certificate
        scope = f"scope {certificate.scope}"
        if certificate.scope != "global":
            scope += (f", proven bound {certificate.bound_mm:.6g} mm" if np.isfinite(certificate.bound_mm)
                      else ", no proven global bound")
        lines.append(
            f"{scope}; contacts {result.contacts.tolist()}, KKT residual {certificate.kkt_residual:.3g}, "
            f"certified {certificate.certified}"
        )
    plots = []
    if args.plot is not None:
        from pcmm_geo.plots.fit_residuals import plot_fit_residuals

        shown = points if compensation is None else compensation.surface_points(points)
        written = plot_fit_residuals(result, args.plot, points=shown, element=args.element,
                                     overwrite=args.overwrite)
        data["plot"] = str(written)
        plots.append(str(written))
        lines.append(f"plot: {written}")
    if args.qif:
        written_qif, kept_lines = write_qif_result(args, result, args.element, source.data,
                                                   radius=source.probe_radius, compensation=compensation)
        data["qif"] = written_qif
        lines.append(f"QIF results written to {written_qif}")
        lines += kept_lines
    covariance = np.asarray(result.covariance, dtype=float)
    blocks = [CovarianceBlock(f"{args.element} fit parameters", tuple(result.parameter_names), covariance)] \
        if covariance.size and np.all(np.isfinite(covariance)) and np.any(np.diag(covariance) > 0) else []
    return Report(data=data, tables=tables, lines=lines, plots=plots, covariances=blocks)


def add_axis_region_options(parser: argparse.ArgumentParser) -> None:
    """The axis region and search budget of the global axial minimax search (cylinder; 3-D line budget)."""
    group = parser.add_argument_group(
        "axis region (minimum zone / MCC / MIC cylinder; default: within 45 deg of the least-squares axis, "
        "crossing within 2R of it)"
    )
    group.add_argument("--axis-cone-deg", type=float, metavar="DEG",
                       help="largest angle between the axis and the reference axis, in degrees (0 < DEG < 90)")
    group.add_argument("--axis-offset-mm", type=float, metavar="MM",
                       help="largest distance at which the axis may cross the reference plane from the reference "
                            "axis, in mm (default 2R)")
    group.add_argument("--axis-nominal", type=float, nargs=3, metavar=("X", "Y", "Z"),
                       help="nominal axis direction: the reference axis instead of the least-squares one")
    group.add_argument("--axis-nominal-point-mm", type=float, nargs=3, metavar=("X", "Y", "Z"),
                       help="a point of the nominal axis in mm (default: the least-squares axis point)")
    group.add_argument("--search-seconds", type=float, metavar="S",
                       help="time budget of the global search (default 5 s); the answer is local when it runs out")
    group.add_argument("--search-cells", type=int, metavar="N",
                       help="cell budget of the global search (default 2000000; repeatable where seconds are not)")


def axis_search_options(args: argparse.Namespace, element: Element, criterion: Criterion, dim: int) -> dict[str, Any]:
    """``axis_region`` / ``search_budget`` keyword arguments from the axis options (errors for other elements)."""
    from pcmm_geo.errors import InvalidInputError
    from pcmm_geo.fit import AxisRegion, SearchBudget

    region_given = {
        "--axis-cone-deg": args.axis_cone_deg,
        "--axis-offset-mm": args.axis_offset_mm,
        "--axis-nominal": args.axis_nominal,
        "--axis-nominal-point-mm": args.axis_nominal_point_mm,
    }
    budget_given = {"--search-seconds": args.search_seconds, "--search-cells": args.search_cells}
    out: dict[str, Any] = {}
    searched = criterion != "gaussian" and (element == "cylinder" or (element == "line" and dim == 3))
    for option, value in {**region_given, **budget_given}.items():
        if value is None:
            continue
        if not searched:
            raise InvalidInputError(option, "a minimum-zone / MCC / MIC cylinder or a 3-D line zone",
                                    f"{element} ({criterion})")
        if option in region_given and element != "cylinder":
            raise InvalidInputError(option, "element cylinder (a 3-D line is searched over all directions)", element)
    if element == "cylinder" and any(value is not None for value in region_given.values()):
        region: dict[str, Any] = {"axis": args.axis_nominal, "point": args.axis_nominal_point_mm,
                                  "offset_mm": args.axis_offset_mm}
        if args.axis_cone_deg is not None:
            region["cone_deg"] = args.axis_cone_deg
        out["axis_region"] = AxisRegion(**region)
    if any(value is not None for value in budget_given.values()):
        budget: dict[str, Any] = {}
        if args.search_seconds is not None:
            budget["max_seconds"] = args.search_seconds
        if args.search_cells is not None:
            budget["max_cells"] = args.search_cells
        out["search_budget"] = SearchBudget(**budget)
    return out


def _diameter(summary: Any, data: dict[str, Any]) -> str:
    """The line the terminal prints for a diameter row of the summary (circle, sphere, cylinder; "" otherwise).

    Adds ``diameter_mm`` / ``u_diameter_mm`` to ``data`` (``u(d) = 2 u(r)``, type A, k = 1).
    """
    import math

    found = [row for row in summary if row.name == "diameter"]
    if not found:
        return ""
    diameter, u_diameter = found[0].value, found[0].u
    data["diameter_mm"] = diameter
    data["u_diameter_mm"] = None if math.isnan(u_diameter) else u_diameter
    if math.isnan(u_diameter) or u_diameter <= 0:
        return f"diameter d = {diameter:.6f} mm (no standard uncertainty from this fit)"
    return (f"diameter d = {diameter:.6f} mm, standard uncertainty u(d) = {1000 * u_diameter:.3f} µm "
            "(type A, from the fit residuals; k = 1, not an expanded uncertainty)")


def _fit(args: argparse.Namespace, source: Any, fit_element: Any,
         kwargs: dict[str, Any]) -> tuple[Any, Any, list[str], dict[str, Any]]:
    """Fit the points; probe centres are fitted, then the element is offset onto the surface."""
    from pcmm_geo.errors import InvalidInputError

    points = source.points
    lines: list[str] = []
    summary: dict[str, Any] = {}
    compensation = None
    if source.probe_radius:
        from pcmm_geo.cmm.points import compensate_fit, side_before_fit

        if args.radius is not None:  # the surface radius: the centres lie probe_radius inside or outside it
            free = {key: value for key, value in kwargs.items() if key != "radius"}
            side = side_before_fit(source.data, args.element, source.probe_radius, args.material_side,
                                   lambda p: fit_element(p, **free), spell_setting=cli_setting)
            kwargs["radius"] = args.radius + (-source.probe_radius if side == "internal" else source.probe_radius)
            if kwargs["radius"] <= 0:
                raise InvalidInputError("--radius-mm", f"a surface radius larger than the probe radius "
                                        f"{source.probe_radius:g} mm for an internal feature", repr(args.radius))
        centre_fit = fit_element(points, **kwargs)
        compensation, record = compensate_fit(centre_fit, args.element, source.data, source.probe_radius,
                                              material_side=args.material_side, radius_source=source.radius_source,
                                              spell_setting=cli_setting)
        result = compensation.surface
        summary = record.to_dict()
        lines.append(record.describe())
    else:
        result = fit_element(points, **kwargs)
    return result, compensation, lines, summary
