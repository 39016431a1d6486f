"""``pcmm serve``: an I++ DME 1.4.3 server in front of the simulated micro-CMM or the real one on its ports.

``--replay`` reads a transcript back.
"""

from __future__ import annotations

import argparse
from typing import Any

from pcmm_geo.cli._output import Report, Table, add_json_flag, add_overwrite_flag, declare_output

_WORKPIECES = ("sphere", "plane", "gauge-block", "cylinder", "mesh", "none")
_PORTS = ("port_zaber", "port_laser_a", "port_laser_b", "port_laser_c", "port_probe")


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "serve",
        help="I++ DME server (TCP, port 1294) in front of the simulated or the real micro-CMM; --replay reads points",
        description=(
            "Serve the I++ DME 1.4.3 protocol so that inspection software can drive the simulated micro-CMM: "
            "moves run through the calibrated kinematic model and its workspace limits, probings on a simulated "
            "workpiece return the probe-compensated points of a true machine that differs from the calibrated "
            "one within the calibration's uncertainty, with noisy readings counted in microsteps (seeded). "
            "Listens on 127.0.0.1 unless --host is given; one client at a time; every session is written to "
            "an fsync'ed transcript (--transcript). Stop with Ctrl-C (or --duration-s). "
            "With the five ports (--port-zaber, --port-laser-a/-b/-c, --port-probe, as pcmm acquire) instead of "
            "--simulate it serves the real machine on its drivers: homing, coordinated stepped moves through the "
            "calibrated inverse kinematics, a stepped search on the probe trigger for PtMeas. --calibration FILE "
            "(pcmm calibrate --out) replaces the demo's calibrated machine for both. "
            "--replay TRANSCRIPT --points-out FILE writes the measured points of a transcript as x,y,z CSV "
            "for pcmm fit / pcmm iso10360-5."
        ),
    )
    parser.add_argument("--simulate", action="store_true",
                        help="serve the simulated micro-CMM (else give the five device ports; --seed, --time-scale, "
                             "--workpiece and its shape options apply to the simulation only)")
    parser.add_argument("--port-zaber", help="port of the Zaber chain (the real machine; thesis COM11)")
    for arm in "abc":
        parser.add_argument(f"--port-laser-{arm}", help=f"port of laser {arm}")
    parser.add_argument("--port-probe", help="port of the probe Arduino")
    parser.add_argument("--probe-mode", choices=("pin", "text"), default="pin", help="Arduino firmware mode (ports)")
    parser.add_argument("--timeout", type=float, default=0.5, help="device reply timeout, s (ports; default 0.5)")
    parser.add_argument("--move-timeout", type=float, default=60.0,
                        help="timeout of a stage's motion reply, s (ports; default 60)")
    parser.add_argument("--move-step-mm", dest="move_step", type=float, default=1.0,
                        help="largest tip step of a coordinated free move (ports; default 1)")
    parser.add_argument("--search-step-mm", dest="search_step", type=float, default=0.25,
                        help="tip step of the first probing search (ports; default 0.25)")
    parser.add_argument("--fine-step-mm", dest="fine_step", type=float, default=0.01,
                        help="tip step of the re-approach after backing off (ports; default 0.01)")
    parser.add_argument("--back-off-mm", dest="back_off", type=float, default=0.3,
                        help="retreat after the first trigger (ports; default 0.3, more than the search step)")
    parser.add_argument("--calibration", metavar="FILE",
                        help="calibration file (pcmm calibrate --out) of the served machine (default: the demo's)")
    parser.add_argument("--port", type=int, default=1294, help="TCP port (default 1294, the I++ DME port; 0: any)")
    parser.add_argument("--host", default="127.0.0.1",
                        help="address to listen on (default 127.0.0.1: this computer only)")
    parser.add_argument("--transcript", metavar="FILE", help="JSON-lines transcript of every session to create")
    declare_output(parser, "transcript")
    parser.add_argument("--seed", type=int, default=0,
                        help="seed of the true machine's draw and of every reading's noise (default 0)")
    parser.add_argument("--workpiece", choices=_WORKPIECES, default="sphere",
                        help="simulated workpiece on the table (default sphere)")
    parser.add_argument("--center-mm", dest="center", type=float, nargs=3, metavar=("X", "Y", "Z"),
                        help="workpiece centre, machine frame (default: the middle of the working volume)")
    parser.add_argument("--diameter-mm", dest="diameter", type=float, default=20.0,
                        help="sphere / cylinder diameter (default 20)")
    parser.add_argument("--length-mm", dest="length", type=float, default=50.0,
                        help="gauge-block length along X, cylinder length along Z (default 50)")
    parser.add_argument("--mesh", metavar="FILE", help="closed mesh (STL/PLY/OBJ, mm) with --workpiece mesh")
    parser.add_argument("--laser-u-mm", dest="laser_u", type=float, default=0.0005,
                        help="standard uncertainty of a laser reading (default 0.0005)")
    parser.add_argument("--encoder-u-mm", dest="encoder_u", type=float, default=0.0002,
                        help="standard uncertainty of a height (encoder) reading (default 0.0002)")
    parser.add_argument("--max-tip-uncertainty-mm", dest="max_tip_u", type=float, default=1.0,
                        help="flag a probing as poorly resolved above this (lasers' view of the heights, default 1)")
    parser.add_argument("--time-scale", type=float, default=1.0,
                        help="wall seconds per second of machine motion (default 1; 0: moves are instant)")
    parser.add_argument("--duration-s", dest="duration", type=float, default=None,
                        help="stop serving after this many seconds (default: until Ctrl-C)")
    parser.add_argument("--replay", metavar="TRANSCRIPT", help="read a transcript instead of serving")
    parser.add_argument("--points-out", dest="points_out", metavar="FILE",
                        help="with --replay: write the measured points as x,y,z CSV (mm, as reported)")
    declare_output(parser, "points_out", "--points-out")
    parser.add_argument("--allow-partial", action="store_true",
                        help="with --replay: ignore a torn last line (a crash while writing it)")
    add_overwrite_flag(parser)
    add_json_flag(parser)
    parser.set_defaults(handler=_handle)


def _check(args: argparse.Namespace) -> None:
    from pcmm_geo.errors import InvalidInputError

    if args.replay:
        if args.transcript:
            raise InvalidInputError("--transcript", "not with --replay (use --points-out)", args.transcript)
        return
    if args.points_out:
        raise InvalidInputError("--points-out", "only with --replay TRANSCRIPT", args.points_out)
    given = [name for name in _PORTS if getattr(args, name)]
    if args.simulate and given:
        raise InvalidInputError("--" + given[0].replace("_", "-"), "no device port with --simulate", "a port")
    if not args.simulate:
        missing = [name for name in _PORTS if not getattr(args, name)]
        if len(missing) == len(_PORTS):
            raise InvalidInputError("--simulate", "--simulate or the five device ports (--port-zaber, "
                                    "--port-laser-a, --port-laser-b, --port-laser-c, --port-probe)", "neither")
        if missing:
            raise InvalidInputError("--" + missing[0].replace("_", "-"), "a port name (all five ports are needed)",
                                    "nothing")
        for flag, value in (("--timeout", args.timeout), ("--move-timeout", args.move_timeout)):
            if not value > 0:
                raise InvalidInputError(flag, "a positive number of seconds", str(value))
    if not 0 <= args.port <= 65535:
        raise InvalidInputError("--port", "a TCP port 0..65535", str(args.port))
    for flag, value in (("--diameter-mm", args.diameter), ("--length-mm", args.length),
                        ("--laser-u-mm", args.laser_u), ("--encoder-u-mm", args.encoder_u),
                        ("--max-tip-uncertainty-mm", args.max_tip_u)):
        if not value > 0:
            raise InvalidInputError(flag, "a positive number", str(value))
    if not args.time_scale >= 0:
        raise InvalidInputError("--time-scale", "a number >= 0", str(args.time_scale))
    if args.duration is not None and not args.duration > 0:
        raise InvalidInputError("--duration-s", "a positive number of seconds", str(args.duration))
    if (args.workpiece == "mesh") != bool(args.mesh):
        raise InvalidInputError("--mesh", "a mesh file exactly when --workpiece mesh", str(args.mesh))


def workpiece(kind: str, center: Any, diameter: float, length: float, mesh: str | None) -> list[Any]:
    """The simulated workpieces of ``pcmm serve`` (also used by its tests)."""
    from pcmm_geo.ippdme import workpieces as wp

    if kind == "sphere":
        return [wp.SphereWorkpiece(center, diameter)]
    if kind == "plane":
        return [wp.PlaneWorkpiece(center, (0.0, 0.0, 1.0))]
    if kind == "gauge-block":
        return [wp.BoxWorkpiece(center, (length, 35.0, 9.0))]
    if kind == "cylinder":
        return [wp.CylinderWorkpiece(center, (0.0, 0.0, 1.0), diameter, length)]
    if kind == "mesh":
        return [wp.MeshWorkpiece(str(mesh), center)]
    return []


def _replay(args: argparse.Namespace) -> Report:
    from pcmm_geo.ippdme.transcript import measured_points, read_transcript, write_points_csv

    header, records = read_transcript(args.replay, allow_partial=args.allow_partial)
    points = measured_points(records)
    kinds: dict[str, int] = {}
    for rec in records:
        kinds[str(rec.get("kind"))] = kinds.get(str(rec.get("kind")), 0) + 1
    data: dict[str, Any] = {
        "transcript": str(args.replay), "settings": header.get("settings", {}), "records": kinds,
        "points": len(points.points), "refused_probings": points.refused,
        "poorly_resolved": int(points.poorly_resolved.sum()), "coordinate_systems": sorted(set(points.csy)),
    }
    lines = [f"{len(points.points)} measured points, {points.refused} probings refused, "
             f"{int(points.poorly_resolved.sum())} poorly resolved"]
    if len(set(points.csy)) > 1:
        lines.append(f"warning: the points are in several coordinate systems: {', '.join(sorted(set(points.csy)))}")
    if args.points_out:
        data["points_out"] = str(write_points_csv(args.points_out, points.points, overwrite=args.overwrite))
        lines.append(f"wrote {args.points_out}")
    table = Table("Transcript records", ["kind", "count"], [[k, v] for k, v in sorted(kinds.items())])
    return Report(data=data, tables=[table], lines=lines)


def _handle(args: argparse.Namespace) -> Report:
    _check(args)
    if args.replay:
        return _replay(args)
    import asyncio
    import contextlib
    import sys

    import numpy as np

    from pcmm_geo.ippdme.calfile import ServedCalibration, model_from_calibration
    from pcmm_geo.ippdme.machine import SimulatedMachine
    from pcmm_geo.ippdme.server import DmeServer
    from pcmm_geo.ippdme.session import ServerState
    from pcmm_geo.ippdme.transcript import Transcript

    if args.calibration:
        served = model_from_calibration(args.calibration, laser_sigma=args.laser_u, encoder_sigma=args.encoder_u)
    else:
        from pcmm_geo.demo import demo_calibrated_machine
        from pcmm_geo.ippdme.machine import MachineModel

        machine, radius, covariance, center = demo_calibrated_machine()
        model = MachineModel(machine, radius, covariance.model_covariance()[1], laser_sigma=args.laser_u,
                             encoder_sigma=args.encoder_u)
        served = ServedCalibration(model, np.asarray(center, dtype=float),
                                   "the demo's calibrated model and calibration covariance", True)
    stack = contextlib.ExitStack()
    lines = []
    if args.simulate:
        where = np.asarray(served.center if args.center is None else args.center, dtype=float)
        pieces = workpiece(args.workpiece, where, args.diameter, args.length, args.mesh)
        sim: Any = SimulatedMachine(served.model, pieces, seed=args.seed, max_tip_uncertainty=args.max_tip_u)
        settings: dict[str, Any] = {"machine": f"simulated micro-CMM ({served.source})", "seed": args.seed,
                                    "workpieces": [p.describe() for p in pieces]}
        if not served.has_covariance:
            lines.append(f"note: {args.calibration} holds no covariance: the simulated true machine is the "
                         "calibrated one (no calibration error)")
    else:
        from pcmm_geo.ippdme.drivers import StepSettings, open_driver_machine

        steps = _step_settings(args, StepSettings)
        ports = {name[5:]: getattr(args, name) for name in _PORTS}
        sim = open_driver_machine(served.model, ports, stack, timeout=args.timeout, move_timeout=args.move_timeout,
                                  probe_mode=args.probe_mode, settings=steps, max_tip_uncertainty=args.max_tip_u)
        settings = {"machine": f"micro-CMM on its drivers ({served.source})", "ports": ports, "workpieces": []}
    settings.update({"calibration": served.source, "laser_u_mm": sim.model.laser_sigma,
                     "encoder_u_mm": args.encoder_u, "time_scale": args.time_scale, "host": args.host,
                     "backend": sim.describe()})
    try:
        transcript = Transcript(args.transcript, settings, overwrite=args.overwrite)
    except BaseException:
        stack.close()
        raise
    server = DmeServer(ServerState.create(sim), transcript, time_scale=args.time_scale)

    async def main() -> int:
        port = await server.start(args.host, args.port)
        print(f"pcmm serve: I++ DME server on {args.host}:{port} (Ctrl-C stops it)", file=sys.stderr, flush=True)
        try:
            await asyncio.sleep(args.duration if args.duration is not None else 1e12)
        finally:
            await server.close()
        return port

    try:
        with contextlib.suppress(KeyboardInterrupt):
            port = asyncio.run(main())
    finally:
        transcript.close()
        stack.close()
    data = {"host": args.host, "port": port if "port" in locals() else args.port, "transcript": args.transcript,
            "seed": args.seed, "workpieces": settings["workpieces"], "home_mm": sim.home_position.tolist(),
            "homed": sim.homed, "position_mm": sim.position.tolist()}
    data["calibration"] = served.source
    return Report(data=data, lines=[*lines, f"served on {args.host}:{data['port']}"])


def _step_settings(args: argparse.Namespace, settings_type: Any) -> Any:
    """The drivers' step settings from the options (their errors name the flags)."""
    from pcmm_geo.errors import InvalidInputError

    flags = {"move_step_mm": "--move-step-mm", "search_step_mm": "--search-step-mm", "fine_step_mm": "--fine-step-mm",
             "back_off_mm": "--back-off-mm"}
    try:
        return settings_type(move_step_mm=args.move_step, search_step_mm=args.search_step,
                             fine_step_mm=args.fine_step, back_off_mm=args.back_off)
    except InvalidInputError as exc:
        name = str(exc.fields.get("what", ""))
        raise InvalidInputError(flags.get(name, "--fine-step-mm"), str(exc.fields.get("expected", "")),
                                str(exc.fields.get("got", ""))) from None
