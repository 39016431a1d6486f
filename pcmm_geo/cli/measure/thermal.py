"""``pcmm thermal ACTION``: RTD and thermistor conversions, 20 °C length correction, frame triangle, µm/K table."""

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
from pcmm_geo.cli._record import Condition, UncertaintyEntry


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "thermal",
        help="thermal tools: rtd, thermistor, correct-length, triangle, table",
        description="Temperature sensors, correction of lengths to 20 °C and the thermal model of the micro-CMM.",
    )
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)

    rtd = actions.add_parser("rtd", help="IEC 60751 platinum RTD: resistance <-> temperature")
    group = rtd.add_mutually_exclusive_group(required=True)
    group.add_argument("--resistance", type=float, help="resistance in ohm -> temperature")
    group.add_argument("--temperature", type=float, help="temperature in °C -> resistance")
    rtd.add_argument("--r0", type=float, default=100.0, help="resistance at 0 °C in ohm (default 100, Pt100)")
    _add_outputs(rtd, "the sensor curve with the converted point")
    add_json_flag(rtd)
    rtd.set_defaults(handler=_handle_rtd)

    ntc = actions.add_parser("thermistor", help="Steinhart-Hart thermistor: conversions, coefficient fit")
    source = ntc.add_mutually_exclusive_group(required=True)
    source.add_argument("--coefficients", type=float, nargs=3, metavar=("A", "B", "C"),
                        help="Steinhart-Hart A B C (1/K)")
    source.add_argument("--calibration", help="CSV temperature,resistance (°C, ohm), >= 3 rows, to fit A B C")
    value = ntc.add_mutually_exclusive_group()
    value.add_argument("--resistance", type=float, help="resistance in ohm -> temperature")
    value.add_argument("--temperature", type=float, help="temperature in °C -> resistance")
    _add_outputs(ntc, "the sensor curve, the converted point and the calibration residuals")
    add_json_flag(ntc)
    ntc.set_defaults(handler=_handle_thermistor)

    corr = actions.add_parser("correct-length", help="correct a measured length to 20 °C (ISO 1) with a budget")
    corr.add_argument("--length-mm", dest="length", type=float, required=True, help="measured length in mm")
    corr.add_argument("--temperature", type=float, required=True, help="workpiece temperature in °C")
    corr.add_argument("--alpha", type=float, required=True, help="workpiece expansion coefficient in 1/K")
    corr.add_argument("--scale-temperature", type=float, default=20.0, help="machine scale temperature in °C")
    corr.add_argument("--scale-alpha", type=float, default=0.0, help="scale expansion coefficient in 1/K (0)")
    corr.add_argument("--u-length-mm", dest="u_length", type=float, default=0.0,
                      help="standard uncertainty of the length in mm")
    corr.add_argument("--u-alpha", type=float, default=0.0, help="standard uncertainty of alpha in 1/K")
    corr.add_argument("--u-temperature", type=float, default=0.0, help="standard uncertainty of T in K")
    corr.add_argument("--u-scale-alpha", type=float, default=0.0, help="standard uncertainty of scale alpha in 1/K")
    corr.add_argument("--u-scale-temperature", type=float, default=0.0, help="standard uncertainty of scale T in K")
    _add_outputs(corr, "the uncertainty budget (|c| u of each input)")
    add_json_flag(corr)
    refuse_renamed_options(corr, {"--length": "--length-mm", "--u-length": "--u-length-mm"})
    corr.set_defaults(handler=_handle_correct)

    tri = actions.add_parser("triangle", help="frame triangle corners for side temperatures (eqs 4.2-4.9)")
    tri.add_argument("--temperatures", type=float, nargs=3, required=True, metavar=("T_AB", "T_AC", "T_BC"),
                     help="side temperatures in °C")
    tri.add_argument("--side-mm", dest="side", type=float, default=650.0,
                     help="nominal side length in mm (default 650)")
    tri.add_argument("--alpha", type=float, default=23.1e-6, help="expansion coefficient in 1/K (aluminium)")
    _add_outputs(tri, "the nominal and the expanded triangle (displacements magnified)")
    add_json_flag(tri)
    refuse_renamed_options(tri, {"--side": "--side-mm"})
    tri.set_defaults(handler=_handle_triangle)

    table = actions.add_parser("table", help="tip displacement in µm per K per member over the working volume")
    table.add_argument("--points-per-axis", type=int, default=3, help="grid points per axis (default 3)")
    table.add_argument("--size-mm", dest="size", type=float, default=100.0,
                       help="edge of the working cube in mm (default 100)")
    _add_outputs(table, "the largest tip displacement per K of each member")
    add_json_flag(table)
    refuse_renamed_options(table, {"--size": "--size-mm"})
    table.set_defaults(handler=_handle_table)


def _add_outputs(parser: argparse.ArgumentParser, what: str) -> None:
    add_plot_flag(parser, what)
    add_report_flag(parser)
    add_overwrite_flag(parser)


def _plot(args: argparse.Namespace, function: str, *inputs: Any, **options: Any) -> list[str]:
    """Draw ``pcmm_geo.plots.thermal.<function>(*inputs, args.plot, **options)`` when --plot was given."""
    if not args.plot:
        return []
    from pcmm_geo.plots import thermal

    return [str(getattr(thermal, function)(*inputs, args.plot, overwrite=args.overwrite, **options))]


def _handle_rtd(args: argparse.Namespace) -> Report:
    from pcmm_geo.thermal.sensors import rtd_resistance, rtd_temperature

    if args.resistance is not None:
        temperature = float(rtd_temperature(args.resistance, r0=args.r0))
        resistance = float(args.resistance)
        line = f"{args.resistance} ohm -> {temperature:.6f} °C (IEC 60751, R0 = {args.r0})"
    else:
        temperature = float(args.temperature)
        resistance = float(rtd_resistance(args.temperature, r0=args.r0))
        line = f"{args.temperature} °C -> {resistance:.6f} ohm (IEC 60751, R0 = {args.r0})"
    data = {"resistance_ohm": resistance, "temperature_degC": temperature, "r0_ohm": args.r0}
    plots = _plot(args, "plot_sensor_curve", lambda r: rtd_temperature(r, r0=args.r0), (resistance, temperature),
                  title=f"Platinum RTD (IEC 60751), R0 = {args.r0:g} ohm")
    return Report(data=data, lines=[line], plots=plots)


def _read_calibration(path: str) -> tuple[list[float], list[float]]:
    from pcmm_geo.artefacts.table import cell_float, read_rows

    rows = read_rows(path, ("temperature", "resistance"))
    return ([cell_float(path, line, row, "temperature") for line, row in rows],
            [cell_float(path, line, row, "resistance") for line, row in rows])


def _handle_thermistor(args: argparse.Namespace) -> Report:
    from pcmm_geo.thermal.sensors import SteinhartHart, fit_steinhart_hart

    calibration = None
    if args.calibration is not None:
        temps, resistances = _read_calibration(args.calibration)
        model = fit_steinhart_hart(temps, resistances)
        calibration = (temps, resistances)
    else:
        model = SteinhartHart(*args.coefficients)
    data: dict[str, Any] = {"a": model.a, "b": model.b, "c": model.c, "rms_residual_K": model.rms_residual}
    lines = [f"Steinhart-Hart A = {model.a:.10e}, B = {model.b:.10e}, C = {model.c:.10e} (1/K)"]
    if args.calibration is not None:
        lines.append(f"fit RMS residual {model.rms_residual * 1000:.4f} mK")
    if args.resistance is not None:
        data["resistance_ohm"] = args.resistance
        data["temperature_degC"] = float(model.temperature(args.resistance))
        lines.append(f"{args.resistance} ohm -> {data['temperature_degC']:.6f} °C")
    if args.temperature is not None:
        data["temperature_degC"] = args.temperature
        data["resistance_ohm"] = float(model.resistance(args.temperature))
        lines.append(f"{args.temperature} °C -> {data['resistance_ohm']:.6f} ohm")
    point = (data["resistance_ohm"], data["temperature_degC"]) if "resistance_ohm" in data else None
    plots = _plot(args, "plot_sensor_curve", model.temperature, point, calibration=calibration,
                  title="Steinhart-Hart thermistor")
    return Report(data=data, lines=lines, plots=plots)


def _handle_correct(args: argparse.Namespace) -> Report:
    from pcmm_geo.thermal.correction import correct_length

    res = correct_length(
        args.length, args.temperature, args.alpha,
        temperature_scale=args.scale_temperature, alpha_scale=args.scale_alpha,
        u_measured_length=args.u_length, u_alpha_workpiece=args.u_alpha, u_temperature_workpiece=args.u_temperature,
        u_alpha_scale=args.u_scale_alpha, u_temperature_scale=args.u_scale_temperature,
    )
    budget = [
        {"quantity": e.quantity, "value": e.value, "standard_uncertainty": e.standard_uncertainty,
         "sensitivity": e.sensitivity, "contribution_mm": e.contribution}
        for e in res.budget
    ]
    data = {
        "measured_length_mm": res.measured_length, "length_20C_mm": res.value, "correction_mm": res.correction,
        "standard_uncertainty_mm": res.standard_uncertainty, "expanded_uncertainty_k2_mm": res.expanded_uncertainty(),
        "budget": budget,
    }
    table = Table("Uncertainty budget", ["quantity", "value", "u(x)", "c = dL/dx", "|c| u / mm"],
                  [[b["quantity"], b["value"], b["standard_uncertainty"], b["sensitivity"], b["contribution_mm"]]
                   for b in budget])
    lines = [f"L(20 °C) = {res.value:.6f} mm (correction {res.correction * 1000:+.3f} µm), "
             f"u = {res.standard_uncertainty * 1000:.3f} µm, U(k=2) = {res.expanded_uncertainty() * 1000:.3f} µm"]
    uncertainty = UncertaintyEntry("length at 20 °C", res.value, res.standard_uncertainty, "mm", coverage_factor=2.0,
                                   method="GUM, first-order propagation of the budget above")
    environment = [Condition("workpiece temperature", args.temperature, "°C"),
                   Condition("u(workpiece temperature)", args.u_temperature, "K"),
                   Condition("machine scale temperature", args.scale_temperature, "°C"),
                   Condition("u(scale temperature)", args.u_scale_temperature, "K")]
    return Report(data=data, tables=[table], lines=lines, plots=_plot(args, "plot_length_correction", res),
                  uncertainties=[uncertainty], environment=environment)


def _handle_triangle(args: argparse.Namespace) -> Report:
    import math

    from pcmm_geo.thermal.triangle import expand_frame, frame_corners

    nominal = frame_corners(args.side, args.side, args.side)
    tri = expand_frame(args.temperatures, nominal_sides=[args.side] * 3, alpha=args.alpha)
    rows = []
    data: dict[str, Any] = {"sides_mm": tri.side_lengths(), "beta_deg": math.degrees(tri.beta),
                            "psi_deg": math.degrees(tri.psi), "theta_deg": math.degrees(tri.theta), "corners": {}}
    for name in "abc":
        now, before = getattr(tri, name), getattr(nominal, name)
        data["corners"][name] = {"x_mm": now[0], "y_mm": now[1], "dx_um": (now[0] - before[0]) * 1000,
                                 "dy_um": (now[1] - before[1]) * 1000}
        rows.append([name.upper(), now[0], now[1], (now[0] - before[0]) * 1000, (now[1] - before[1]) * 1000])
    table = Table("Frame corners (A pinned, B sliding in x)", ["corner", "x / mm", "y / mm", "dx / µm", "dy / µm"],
                  rows)
    environment = [Condition(f"frame side {side} temperature", value, "°C")
                   for side, value in zip(("AB", "AC", "BC"), args.temperatures, strict=True)]
    return Report(data=data, tables=[table], plots=_plot(args, "plot_frame_triangle", nominal, tri),
                  environment=environment)


def _handle_table(args: argparse.Namespace) -> Report:
    from pcmm_geo.thermal.physical import thermal_sensitivity_table

    table = thermal_sensitivity_table(points_per_axis=args.points_per_axis, size=args.size)
    summary = table.summary()
    data = {"members": summary, "n_positions": len(table.positions), "positions_mm": table.positions,
            "displacement_um_per_k": table.displacement_um_per_k}
    out = Table(
        f"Tip displacement per K over a {args.size:g} mm cube ({len(table.positions)} positions)",
        ["member", "max / (µm/K)", "mean / (µm/K)", "max |dx| / (µm/K)", "max |dy| / (µm/K)", "max |dz| / (µm/K)"],
        [[r["member"], r["max_um_per_k"], r["mean_um_per_k"], r["max_dx_um_per_k"], r["max_dy_um_per_k"],
          r["max_dz_um_per_k"]] for r in summary],
    )
    return Report(data=data, tables=[out], plots=_plot(args, "plot_thermal_table", table))
