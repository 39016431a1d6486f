"""``pcmm kinematics forward|inverse|trilaterate``: rigid-body kinematics of the micro-CMM."""

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

ARM_NAMES = ("a", "b", "c")


def add_machine_argument(parser: argparse.ArgumentParser, *, required: bool = False) -> None:
    """``--calibration FILE``: machine model JSON or calibration JSON (default: the thesis geometry)."""
    parser.add_argument(
        "--calibration",
        required=required,
        metavar="CAL.json",
        help="rigid-body model or calibration JSON (default: thesis geometry of thesis Table 3.1 / Appendix D)",
    )


def load_machine_file(path: str | None) -> Any:
    """RigidBodyMachine from a model JSON, a calibration JSON (with or without columns) or the thesis default.

    A calibration without a stored machine supplies the tetrahedron; the columns are
    then the thesis' (Appendix D, vertical).
    """

    from pcmm_geo.machine.kinematics.model import MODEL_SCHEMA, RigidBodyMachine

    if path is None:
        return RigidBodyMachine.from_dpkm()
    from pcmm_geo.io.text import JsonNode, read_json_file
    from pcmm_geo.machine.calibration.calfile import machine_from_json

    document = read_json_file(path)
    if not isinstance(document, dict):
        raise JsonNode(document, path).fail("a JSON object")
    if document.get("schema") == MODEL_SCHEMA:
        return machine_from_json(JsonNode(document, path))
    if isinstance(document.get("machine"), dict) and document["machine"].get("schema") == MODEL_SCHEMA:
        return machine_from_json(JsonNode(document, path)["machine"])
    from pcmm_geo.machine.calibration import load_calibration

    tetrahedron = load_calibration(path).tetrahedron
    seed = RigidBodyMachine.from_dpkm()
    provisional = RigidBodyMachine(tetrahedron, seed.columns, seed.reference_lasers, seed.reference_heights)
    reference = provisional.forward(heights=seed.reference_heights, check_limits=False)  # a starting pose only
    return RigidBodyMachine(tetrahedron, seed.columns, reference.lasers, seed.reference_heights)


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "kinematics",
        help="rigid-body kinematics: forward (readings -> tip), inverse (tip -> readings), trilaterate",
        description="Kinematics of the parallel micro-CMM (rigid-body model; the thesis DPKM is its special case).",
    )
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)

    forward = actions.add_parser("forward", help="laser and/or height readings -> probe-tip centre")
    forward.add_argument("--lasers-mm", dest="lasers", type=float, nargs=3, metavar=("A", "B", "C"),
                         help="laser readings in mm")
    forward.add_argument("--heights-mm", dest="heights", type=float, nargs=3, metavar=("A", "B", "C"),
                         help="height readings in mm")
    forward.add_argument("--heights-hint-mm", dest="heights_hint", type=float, nargs=3, metavar=("A", "B", "C"),
                         help="starting heights when only lasers are given (selects branch and datum)")
    forward.add_argument("--laser-sigma-mm", dest="laser_sigma", type=float, default=1e-3,
                         help="laser standard uncertainty in mm")
    forward.add_argument("--height-sigma-mm", dest="height_sigma", type=float, default=1e-3,
                         help="height standard uncertainty in mm")
    add_machine_argument(forward)
    _add_outputs(forward, "the machine in the solved pose and the loop-closure residuals")
    add_json_flag(forward)
    refuse_renamed_options(forward, {
        "--lasers": "--lasers-mm",
        "--heights": "--heights-mm",
        "--heights-hint": "--heights-hint-mm",
        "--laser-sigma": "--laser-sigma-mm",
        "--height-sigma": "--height-sigma-mm",
    })
    forward.set_defaults(handler=_handle_forward)

    inverse = actions.add_parser("inverse", help="probe-tip centre -> height and laser readings")
    inverse.add_argument("--tip-mm", dest="tip", type=float, nargs=3, required=True, metavar=("X", "Y", "Z"),
                         help="tip in mm")
    add_machine_argument(inverse)
    _add_outputs(inverse, "the machine in the pose for the tip")
    add_json_flag(inverse)
    refuse_renamed_options(inverse, {"--tip": "--tip-mm"})
    inverse.set_defaults(handler=_handle_inverse)

    tri = actions.add_parser("trilaterate", help="probe from three pivots and arm lengths (eqs 2.9-2.21, corrected)")
    tri.add_argument("--pivots-mm", dest="pivots", type=float, nargs=9, required=True, metavar="XYZ",
                     help="pivot centres a, b, c: xa ya za xb yb zb xc yc zc (mm)")
    tri.add_argument("--lengths-mm", dest="lengths", type=float, nargs=3, required=True, metavar=("LA", "LB", "LC"),
                     help="pivot-to-tip lengths in mm")
    _add_outputs(tri, "the pivots, arm lengths and both intersections in 3-D")
    add_json_flag(tri)
    refuse_renamed_options(tri, {"--pivots": "--pivots-mm", "--lengths": "--lengths-mm"})
    tri.set_defaults(handler=_handle_trilaterate)


def _add_outputs(parser: argparse.ArgumentParser, what: str) -> None:
    add_plot_flag(parser, what)
    add_report_flag(parser)
    add_overwrite_flag(parser)


def _handle_forward(args: argparse.Namespace) -> Report:
    from pcmm_geo.errors import InvalidInputError

    if args.lasers is None and args.heights is None:
        raise InvalidInputError("forward", "--lasers-mm and/or --heights-mm", "neither")
    machine = load_machine_file(args.calibration)
    sol = machine.forward(
        lasers=args.lasers, heights=args.heights, laser_sigma=args.laser_sigma, height_sigma=args.height_sigma,
        heights_hint=args.heights_hint,
    )
    data = {
        "tip": sol.tip.tolist(),
        "lasers": sol.lasers.tolist(),
        "heights": sol.heights.tolist(),
        "rotation": sol.rotation.tolist(),
        "translation": sol.translation.tolist(),
        "residuals": sol.residuals.tolist(),
        "converged": bool(sol.converged),
        "measured": [name for name, value in (("lasers", args.lasers), ("heights", args.heights)) if value],
    }
    rows = [[arm, float(sol.lasers[k]), float(sol.heights[k])] for k, arm in enumerate(ARM_NAMES)]
    plots = []
    if args.plot:
        from pcmm_geo.plots.machine.machine_state import plot_pose

        plots.append(str(plot_pose(machine, sol.heights, sol.tip, args.plot, residuals=sol.residuals,
                                   title="Forward kinematics: pose for the readings", overwrite=args.overwrite)))
        data["plot"] = plots[0]
    return Report(
        data=data,
        plots=plots,
        tables=[Table("Readings (as solved)", ["arm", "laser / mm", "height / mm"], rows)],
        lines=[f"tip centre: x = {sol.tip[0]:.6f}  y = {sol.tip[1]:.6f}  z = {sol.tip[2]:.6f} mm"
               f" (max closure residual {abs(sol.residuals).max():.3g} mm)"],
    )


def _handle_inverse(args: argparse.Namespace) -> Report:
    machine = load_machine_file(args.calibration)
    sol = machine.inverse(args.tip)
    data = {
        "tip": list(args.tip),
        "lasers": sol.lasers.tolist(),
        "heights": sol.heights.tolist(),
        "rotation": sol.rotation.tolist(),
        "translation": sol.translation.tolist(),
        "converged": bool(sol.converged),
    }
    rows = [[arm, float(sol.lasers[k]), float(sol.heights[k])] for k, arm in enumerate(ARM_NAMES)]
    plots = []
    if args.plot:
        from pcmm_geo.plots.machine.machine_state import plot_pose

        plots.append(str(plot_pose(machine, sol.heights, args.tip, args.plot,
                                   title="Inverse kinematics: pose for the tip", overwrite=args.overwrite)))
        data["plot"] = plots[0]
    return Report(data=data, plots=plots,
                  tables=[Table("Readings for the tip", ["arm", "laser / mm", "height / mm"], rows)])


def _handle_trilaterate(args: argparse.Namespace) -> Report:
    import numpy as np

    from pcmm_geo.machine.kinematics.trilateration import trilaterate

    pivots = np.asarray(args.pivots, dtype=float).reshape(3, 3)
    result = trilaterate(pivots, args.lengths)
    data = {
        "point": result.point.tolist(),
        "lower": result.lower.tolist(),
        "upper": result.upper.tolist(),
        "height_squared": float(result.height_squared),
    }
    rows = [["lower (probe hangs below)", *result.lower.tolist()], ["upper", *result.upper.tolist()]]
    plots = []
    if args.plot:
        from pcmm_geo.plots.machine.machine_state import plot_trilateration

        plots.append(str(plot_trilateration(pivots, args.lengths, result.lower, result.upper, args.plot,
                                            overwrite=args.overwrite)))
        data["plot"] = plots[0]
    return Report(data=data, plots=plots,
                  tables=[Table("Sphere intersections", ["root", "x / mm", "y / mm", "z / mm"], rows)])
