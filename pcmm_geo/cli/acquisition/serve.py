"""``pcmm serve``: an I++ DME 1.4.3 server in front of the simulated micro-CMM; ``--replay`` reads a transcript."""

from __future__ import annotations

import argparse
from typing import Any

from pcmm_geo.cli._output import Report, Table, add_json_flag, add_overwrite_flag, declare_output

_WORKPIECES = ("sphere", "plane", "gauge-block", "cylinder", "mesh", "none")


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "serve",
        help="I++ DME server (TCP, port 1294) in front of the simulated micro-CMM; --replay extracts points",
        description=(
            "Serve the I++ DME 1.4.3 protocol so that inspection software can drive the simulated micro-CMM: "
            "moves run through the calibrated kinematic model and its workspace limits, probings on a simulated "
            "workpiece return the probe-compensated points of a true machine that differs from the calibrated "
            "one within the calibration's uncertainty, with noisy readings counted in microsteps (seeded). "
            "Listens on 127.0.0.1 unless --host is given; one client at a time; every session is written to "
            "an fsync'ed transcript (--transcript). Stop with Ctrl-C (or --duration-s). "
            "--replay TRANSCRIPT --points-out FILE writes the measured points of a transcript as x,y,z CSV "
            "for pcmm fit / pcmm iso10360-5."
        ),
    )
    parser.add_argument("--simulate", action="store_true",
                        help="serve the simulated micro-CMM (the only machine this version serves)")
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
    if not args.simulate:
        raise InvalidInputError("--simulate", "--simulate (this version serves the simulated micro-CMM only; "
                                "real drivers are not wired to the server yet)", "no --simulate")
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

    from pcmm_geo.demo import demo_calibrated_machine
    from pcmm_geo.ippdme.machine import MachineModel, SimulatedMachine
    from pcmm_geo.ippdme.server import DmeServer
    from pcmm_geo.ippdme.session import ServerState
    from pcmm_geo.ippdme.transcript import Transcript

    machine, radius, covariance, center = demo_calibrated_machine()
    model = MachineModel(machine, radius, covariance.model_covariance()[1], laser_sigma=args.laser_u,
                         encoder_sigma=args.encoder_u)
    where = np.asarray(center if args.center is None else args.center, dtype=float)
    pieces = workpiece(args.workpiece, where, args.diameter, args.length, args.mesh)
    sim = SimulatedMachine(model, pieces, seed=args.seed, max_tip_uncertainty=args.max_tip_u)
    settings = {"machine": "simulated micro-CMM (the demo's calibrated model and calibration covariance)",
                "seed": args.seed, "workpieces": [p.describe() for p in pieces], "laser_u_mm": args.laser_u,
                "encoder_u_mm": args.encoder_u, "time_scale": args.time_scale, "host": args.host}
    transcript = Transcript(args.transcript, settings, overwrite=args.overwrite)
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
    data = {"host": args.host, "port": port if "port" in locals() else args.port, "transcript": args.transcript,
            "seed": args.seed, "workpieces": settings["workpieces"], "home_mm": sim.home_position.tolist(),
            "homed": sim.homed, "position_mm": sim.position.tolist()}
    return Report(data=data, lines=[f"served on {args.host}:{data['port']}"])
