"""``pcmm acquire``: run an acquisition session (simulated rig or real devices) into a durable log."""

from __future__ import annotations

import argparse
from typing import Any

from pcmm_geo.cli._output import (
    Report,
    Table,
    add_json_flag,
    add_overwrite_flag,
    declare_output,
    refuse_renamed_options,
)
from pcmm_geo.cli.acquisition._acquire_plan import (
    add_start_arguments,
    check_start_arguments,
    enforce_limit,
    plan_report,
    plan_start,
)

_ARMS = ("a", "b", "c")


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "acquire",
        help="acquisition session: home, pre-sequence, moves with start/stop rows (thesis Table 3.2) to a CSV log",
        description=(
            "Drive the three Zaber stages, read lasers a, b, c and the probe after each move and append thesis "
            "Table 3.2 rows (plus raw values) to an fsync'ed CSV log. --simulate runs the simulated micro-CMM on "
            "pseudo-terminals, optionally with injected faults. After homing the stages go to a well-conditioned "
            "start (--start conditioned, the default; --start level: the thesis'), and before any device moves the "
            "tip uncertainty process-log will state along the planned path is predicted: a warning above 1 mm, a "
            "refusal above --max-tip-u-mm, the whole plan with --plan-only. Every output (--out, --table-3-2) is "
            "checked before any device is touched; if the command fails, the files it wrote are removed and the ones "
            "it replaced restored, except a log holding measured rows, which is kept (continue it with --resume)."
        ),
    )
    parser.add_argument("--simulate", action="store_true", help="use the simulated machine (pseudo-terminals)")
    parser.add_argument("--moves", type=int, default=20, help="number of logged moves (default 20)")
    parser.add_argument("--settle", type=float, default=2.6, help="settling wait after each move, s (thesis 2.6)")
    parser.add_argument("--fault-rate", type=float, default=0.0, help="simulated fault probability per reply/window")
    parser.add_argument("--seed", type=int, default=0,
                        help="seed of the move programme and the simulation (same seed: same faults, counters, rows)")
    parser.add_argument("--transport", choices=("virtual", "pty"), default="virtual",
                        help="with --simulate: in-process devices on a simulated clock (virtual, repeatable, "
                             "default) or real pseudo-terminals served in real time (pty)")
    parser.add_argument("--out", metavar="LOG.csv",
                        help="durable CSV log to create (required unless --plan-only; an existing one is refused "
                             "unless --overwrite-out, --overwrite or --resume)")
    parser.add_argument("--table-3-2", dest="table_3_2", metavar="FILE",
                        help="also write the plain 7-column Table 3.2 view (for pcmm process-log) to FILE "
                             "(an existing one is refused unless --overwrite-table-3-2 or --overwrite)")
    parser.add_argument("--resume", action="store_true",
                        help="append to an existing log instead of creating one: after homing (and the pre-sequence) "
                             "the stages move back to the log's last position, so the log continues its pose; a "
                             "simulated machine keeps the log's start heights. A log another session holds (one "
                             "session per log) is refused at once")
    parser.add_argument("--repair", action="store_true",
                        help="with --resume: cut a partial last row and report it (a log torn in its header is "
                             "refused, except a column line torn after the whole comment header, which is completed)")
    declare_output(parser, "out", append_when="resume", unused_when="plan_only")
    declare_output(parser, "table_3_2", "--table-3-2", unused_when="plan_only")
    add_overwrite_flag(parser)
    parser.add_argument("--step-mm", type=float, default=4.0, help="largest motor step of the programme, mm")
    parser.add_argument("--no-presequence", action="store_true", help="skip the settling pre-sequence")
    parser.add_argument("--start-offsets-mm", dest="start_offsets", type=float, nargs=3, metavar=("A", "B", "C"),
                        default=None,
                        help="with --simulate: a simulated machine whose pivots stand this far from the level "
                             "(reference) pose at the start count, mm (no commanded move: the start is then 'level' "
                             "unless --start says otherwise); e.g. 0 60 -60 keeps the pivots >= 20 mm apart in height "
                             "over the programme's +-20 mm span. Recorded as start_heights_mm, which process-log "
                             "takes as its datum")
    parser.add_argument("--defects", action="store_true", help="simulate the thesis' dead spot and settling scatter")
    parser.add_argument("--probe-mode", choices=("pin", "text"), default="pin", help="Arduino firmware mode")
    parser.add_argument(
        "--timeout", type=float, default=None, help="device reply timeout, s (default 0.5; simulated 0.1)"
    )
    parser.add_argument(
        "--move-timeout", type=float, default=None, help="timeout of a motion reply, s (default 60; simulated 1)"
    )
    parser.add_argument("--port-zaber", help="port of the Zaber chain (real hardware; thesis COM11)")
    for arm in _ARMS:
        parser.add_argument(f"--port-laser-{arm}", help=f"port of laser {arm}")
    parser.add_argument("--port-probe", help="port of the probe Arduino")
    add_start_arguments(parser)
    add_json_flag(parser)
    refuse_renamed_options(parser, {"--start-offsets": "--start-offsets-mm"})
    parser.set_defaults(handler=_handle)


def _open_log(args: argparse.Namespace, metadata: dict[str, Any]) -> Any:
    from pathlib import Path

    from pcmm_geo.acquisition.acqlog import AcquisitionLog

    if args.resume and Path(args.out).exists():
        return AcquisitionLog.resume(args.out, repair=args.repair)
    # the permission is the command's (--overwrite or --overwrite-out), checked before any work
    return AcquisitionLog.create(args.out, metadata, overwrite=args.overwrite)


def _check_args(args: argparse.Namespace) -> None:
    # simulated devices answer at once: a lost reply should cost a fraction of a second, not a minute
    if args.timeout is None:
        args.timeout = 0.1 if args.simulate else 0.5
    if args.move_timeout is None:
        args.move_timeout = 1.0 if args.simulate else 60.0
    from pcmm_geo.errors import InvalidInputError

    if args.moves < 0:
        raise InvalidInputError("--moves", "a non-negative integer", str(args.moves))
    if not args.settle >= 0:
        raise InvalidInputError("--settle", "a non-negative number of seconds", str(args.settle))
    if not 0.0 <= args.fault_rate <= 1.0:
        raise InvalidInputError("--fault-rate", "a probability in [0, 1]", str(args.fault_rate))
    if args.start_offsets is not None and not args.simulate:
        raise InvalidInputError("--start-offsets-mm", "only with --simulate", " ".join(map(str, args.start_offsets)))
    if args.start_offsets is not None and not all(abs(v) <= 150.0 for v in args.start_offsets):
        raise InvalidInputError("--start-offsets-mm", "offsets within +-150 mm", " ".join(map(str, args.start_offsets)))
    if args.fault_rate > 0 and not args.simulate:
        raise InvalidInputError("--fault-rate", "0 unless --simulate", str(args.fault_rate))
    if not args.step_mm > 0:
        raise InvalidInputError("--step-mm", "a positive length", str(args.step_mm))
    check_start_arguments(args)
    if not args.simulate and not args.plan_only:
        for name in ("port_zaber", "port_laser_a", "port_laser_b", "port_laser_c", "port_probe"):
            if not getattr(args, name):
                raise InvalidInputError("--" + name.replace("_", "-"), "a port name (or use --simulate)", "nothing")


def _handle(args: argparse.Namespace) -> Report:
    import contextlib
    from pathlib import Path

    from pcmm_geo.acquisition.session import SessionConfig

    _check_args(args)
    from pcmm_geo.acquisition.loglock import check_unlocked

    if not args.plan_only:
        check_unlocked(args.out)  # a log another session holds is refused at once, before any device is touched
    earlier = None
    if args.resume and args.out and Path(args.out).exists():  # a log resume would refuse is refused before homing
        from pcmm_geo.acquisition.acqlog import AcquisitionLog, read_log

        if AcquisitionLog.check_resumable(args.out, repair=args.repair).header_completed_bytes == 0:
            earlier = read_log(args.out, allow_partial=True)  # whole rows only (a torn one is cut on resume)
    # the start and the tip u predicted along the planned path, before any device is touched
    defaults = SessionConfig()
    start = plan_start(args, defaults.start_position, defaults.presequence_span)
    if args.plan_only:
        return plan_report(start)
    enforce_limit(start)
    with contextlib.ExitStack() as stack:
        rig = None
        if args.simulate:
            from pcmm_geo.acquisition.simulators.cmm import SimulatedMicroCMM, SimulatedRig
            from pcmm_geo.machine.kinematics.model import RigidBodyMachine

            reference = RigidBodyMachine.from_dpkm().reference_heights
            offsets = [0.0, 0.0, 0.0] if args.start_offsets is None else args.start_offsets
            cmm = SimulatedMicroCMM(
                start_heights=_start_heights(args, reference + offsets, earlier, start.offsets_usteps),
                laser_noise=0.002 if args.defects else 0.0, dead_spot=4.0 if args.defects else 0.0,
                settle_scatter=0.45 if args.defects else 0.0, seed=args.seed,
            )
            rig = stack.enter_context(
                SimulatedRig(cmm, fault_rate=args.fault_rate, seed=args.seed, probe_mode=args.probe_mode,
                             silence=max(0.1, 2 * args.timeout), transport=args.transport)
            )
            ports = dict(rig.ports)
        else:
            ports = {"zaber": args.port_zaber, "probe": args.port_probe}
            ports.update({f"laser_{arm}": getattr(args, f"port_laser_{arm}") for arm in _ARMS})
        session = _open_session(args, ports, stack, None if rig is None else rig.clock, start.offsets_usteps)
        metadata = {
            "mode": "simulated" if args.simulate else "hardware",
            "ports": " ".join(f"{k}={v}" for k, v in ports.items()), "transport": args.transport,
            "settle_s": args.settle, "moves_requested": args.moves, "seed": args.seed,
            "fault_rate": args.fault_rate, "probe_mode": args.probe_mode, "presequence": not args.no_presequence,
            "start_position_usteps": session.config.start_position,
            **start.metadata(),
            "microstep_mm": session.motors.microstep_mm, "laser_models": "a=ILD1302 b=ILD1302 c=ILD1420",
            **session.identify(),
        }
        log = stack.enter_context(_open_log(args, metadata))
        session.log = log
        session.prepare(presequence=not args.no_presequence)
        block = None if rig is None else rig.gauge_block_beside_tip(0.5)  # at the start pose, as the log began
        if earlier is not None and earlier.rows:  # the machine continues where the log left it
            _continue_from(session, log, earlier.rows)
        if rig is not None:
            rig.place_gauge_block(block=block)
        _run_programme(session, args)
        summary = session.summary()
    data: dict[str, Any] = {"out": str(args.out), **summary.as_dict(), "plan": start.summary()}
    if args.table_3_2:
        from pcmm_geo.acquisition.acqlog import export_table_3_2

        data["table_3_2"] = str(export_table_3_2(args.out, args.table_3_2, overwrite=args.overwrite))
    data["resumed"] = bool(args.resume and log.recovery.rows)
    data["truncated_bytes"] = log.recovery.dropped_bytes
    if rig is not None:
        data["injected_faults"] = rig.injected_faults
    counters = [[key, value] for key, value in summary.as_dict().items()]
    if rig is not None:
        counters += [[f"injected {kind}", count] for kind, count in rig.injected_faults.items()]
    prediction = start.prediction
    lines = [f"wrote {summary.rows} rows to {args.out}",
             f"start {start.name}: pivot heights " + " ".join(f"{h:.3f}" for h in start.start_heights) + " mm; "
             f"predicted tip u along the planned path: median {prediction.median_tip_uncertainty:.3g} mm, largest "
             f"{prediction.max_tip_uncertainty:.3g} mm"]
    if log.recovery.truncated:
        lines.append(f"cut a partial last row of {log.recovery.dropped_bytes} bytes before resuming")
    return Report(data=data, tables=[Table("Acquisition session", ["counter", "value"], counters)], lines=lines)


def _start_heights(args: argparse.Namespace, heights: Any, earlier: Any, offsets: tuple[int, int, int]) -> Any:
    """The simulated pivot heights at the start count: from those the resumed log states, else from the options.

    The log states the heights at its own start positions (``start_positions_usteps``, the commanded start):
    its start count's heights are those less the commanded ``offsets`` (microsteps).
    """
    import numpy as np

    from pcmm_geo.acquisition.drivers.zaber import T_LSR450B_MICROSTEP_MM
    from pcmm_geo.errors import InvalidInputError

    stated = None if earlier is None else earlier.metadata.get("start_heights_mm")
    if stated is None:
        return heights
    logged = np.array([float(value) for value in stated.split()]) - np.asarray(offsets) * T_LSR450B_MICROSTEP_MM
    if args.start_offsets is not None and not np.allclose(logged, heights, rtol=0.0, atol=1e-6):
        raise InvalidInputError("--start-offsets-mm", f"the offsets the resumed log {args.out} started with (start "
                                f"heights {stated} mm), or none", " ".join(map(str, args.start_offsets)))
    return logged


def _continue_from(session: Any, log: Any, rows: Any) -> None:
    """Move the stages back to the last logged position and take over its contact state, noted in the log.

    Homing and the pre-sequence leave the pivots at the start position; the log's next rows must
    continue its last pose (``pcmm process-log`` chains the heights from row to row).  After a stop
    row in contact only the retreat of its motor is allowed (thesis 3.6).
    """
    last = rows[-1]
    session.restore(last.pos_usteps)
    stop = next((row for row in reversed(rows) if row.start_stop == 0), None)
    if stop is not None and stop.probe and stop.pos_usteps == last.pos_usteps:
        session.contact_move = (stop.motor, stop.direction)
    log.note({"continued_from_seq": last.seq, "continued_from_usteps": " ".join(map(str, last.pos_usteps))})


def _open_session(args: argparse.Namespace, ports: dict[str, Any], stack: Any, clock: Any = None,
                  start_offsets: tuple[int, int, int] = (0, 0, 0)) -> Any:
    from pcmm_geo.acquisition.programme import open_session
    return open_session(ports, stack, timeout=args.timeout, move_timeout=args.move_timeout,
                        probe_mode=args.probe_mode, settle_time=args.settle, clock=clock, start_offsets=start_offsets)


def _run_programme(session: Any, args: argparse.Namespace) -> None:
    from pcmm_geo.acquisition.programme import run_random_programme
    from pcmm_geo.cli._progress import progress_bar, progress_wanted

    with progress_bar("acquiring", enabled=progress_wanted(args), total=args.moves) as update:
        run_random_programme(session, args.moves, step_mm=args.step_mm, seed=args.seed, on_move=update)
