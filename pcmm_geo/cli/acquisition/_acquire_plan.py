"""``pcmm acquire``'s start pose and plan: which start, the planned path, its predicted tip u, before any device moves.

The start (``--start``): ``conditioned`` (default) commands, after homing, each motor to its offset
from the seed's start position that :func:`~pcmm_geo.machine.analysis.conditioning.choose_start`
picks from the start map (on the seed geometry
:data:`~pcmm_geo.machine.analysis.conditioning.CONDITIONED_START_OFFSETS`, 70, -70, 0 mm; with
``--calibration`` the map of that machine); ``level`` is the thesis' start (one encoder count for all
motors).  ``--start-offsets-mm`` (simulated machines) shifts the simulator's pivots at the start count
instead, as before, and starts ``level`` unless ``--start`` says otherwise.  With ``--resume`` the start
is the one the log records (``start_positions_usteps``; a log without it began level), and the
prediction is that of a session from the start (the resumed rows continue the log's last pose instead).

The plan: the programme's moves while the probe touches nothing
(:func:`~pcmm_geo.acquisition.programme.plan_random_programme`) from that start, and what the log
processing will state about it (:func:`~pcmm_geo.machine.analysis.session_prediction.predict_session`).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from typing import Any

from pcmm_geo.cli._output import Report, Table

__all__ = ["StartPlan", "add_start_arguments", "check_start_arguments", "enforce_limit", "plan_report", "plan_start"]

START_NAMES = ("conditioned", "level")
#: the prediction covers at most this many moves of the plan (a longer session's u keeps growing along its log,
#: as every new height inherits the errors of those it was measured against; 200 moves take about 2 s)
MAX_PREDICTED_MOVES = 200


@dataclass(frozen=True)
class StartPlan:
    """The start a session will command and the prediction along its planned path."""

    name: str
    offsets_usteps: tuple[int, int, int]
    start_positions: tuple[int, int, int]
    start_heights: Any  # ndarray (3,), mm
    prediction: Any  # SessionPrediction
    limit: float
    limit_given: bool
    moves: int

    def metadata(self) -> dict[str, str]:
        """The log's header lines of the start."""
        return {"start": self.name, "start_positions_usteps": " ".join(str(p) for p in self.start_positions),
                "start_heights_mm": " ".join(f"{h:.6f}" for h in self.start_heights)}

    def summary(self) -> dict[str, Any]:
        """JSON-ready prediction summary."""
        import numpy as np

        prediction = self.prediction
        above = prediction.rows_above(self.limit)
        return {
            "start": self.name,
            "start_offsets_usteps": list(self.offsets_usteps),
            "start_positions_usteps": list(self.start_positions),
            "start_heights_mm": [float(h) for h in self.start_heights],
            "predicted_median_tip_u_mm": _finite(prediction.median_tip_uncertainty),
            "predicted_max_tip_u_mm": _finite(prediction.max_tip_uncertainty),
            "max_tip_u_mm": self.limit,
            "predicted_moves": int(prediction.motor.size),
            "moves": self.moves,
            "rows_above_limit": (above + 1).tolist(),
            "ambiguous_rows": (np.flatnonzero(prediction.ambiguous) + 1).tolist(),
        }


def _finite(value: float) -> float | None:
    import math

    return value if math.isfinite(value) else None


def add_start_arguments(parser: argparse.ArgumentParser) -> None:
    """``--start``, ``--calibration``, ``--max-tip-u-mm``, ``--plan-only``."""
    from pcmm_geo.cli.machine.kinematics import add_machine_argument

    parser.add_argument("--start", choices=START_NAMES, default=None,
                        help="start pose, commanded after homing: 'conditioned' (default) moves the pivots to the "
                             "start the tip-uncertainty map picks (seed geometry: 70, -70, 0 mm from level; "
                             "docs/machine.md), where the lasers see the heights well over the programme's +-20 mm; "
                             "'level' is the thesis' start (one encoder count for all motors), where they hardly see "
                             "them and points carry millimetre uncertainties. Recorded as start_heights_mm and "
                             "start_positions_usteps")
    add_machine_argument(parser)
    parser.add_argument("--max-tip-u-mm", dest="max_tip_u", type=float, default=None, metavar="MM",
                        help="refuse the session (exit 2, before any device moves, nothing written) when the tip "
                             "uncertainty predicted along the planned path exceeds MM; without it a warning is printed "
                             "above 1 mm (process-log's default limit)")
    parser.add_argument("--plan-only", action="store_true",
                        help="print the planned path and its predicted tip uncertainty (table, or --json) without "
                             "touching a device or writing a file (exit 1 when it exceeds --max-tip-u-mm)")


def check_start_arguments(args: argparse.Namespace) -> None:
    """Bad values of the start options (``InvalidInputError`` naming the flag)."""
    import math

    from pcmm_geo.errors import InvalidInputError

    if args.max_tip_u is not None and not (args.max_tip_u > 0 and not math.isnan(args.max_tip_u)):
        raise InvalidInputError("--max-tip-u-mm", "a positive length in mm ('inf' for none)", str(args.max_tip_u))
    if args.out is None and not args.plan_only:
        raise InvalidInputError("--out", "a log file to create (LOG.csv), unless --plan-only", "nothing")


def _resumed_start(args: argparse.Namespace, start_position: int) -> tuple[tuple[int, int, int], Any] | None:
    """The start offsets and heights (None: not stated) an existing log records when it is resumed (None: new log)."""
    from pathlib import Path

    if not (args.resume and args.out and Path(args.out).exists()):
        return None
    import numpy as np

    from pcmm_geo.acquisition.acqlog import read_log
    from pcmm_geo.errors import FileFormatError

    metadata = read_log(args.out, allow_partial=True).metadata
    recorded, heights = metadata.get("start_positions_usteps"), metadata.get("start_heights_mm")
    try:
        stated = None if heights is None else np.array([float(value) for value in heights.split()])
        if recorded is None:
            return (0, 0, 0), stated  # logs written before commanded starts began level
        a, b, c = (int(value) - start_position for value in recorded.split())
    except ValueError:
        raise FileFormatError(args.out, f"start_positions_usteps / start_heights_mm: expected three numbers, got "
                              f"{recorded!r} / {heights!r}") from None
    return (a, b, c), stated


def plan_start(args: argparse.Namespace, start_position: int, span: int) -> StartPlan:
    """The start of the session ``args`` describe and the prediction along its planned path."""
    import numpy as np

    from pcmm_geo.acquisition.drivers.zaber import T_LSR450B_MICROSTEP_MM
    from pcmm_geo.acquisition.programme import plan_random_programme, start_offsets_usteps
    from pcmm_geo.cli.machine.kinematics import load_machine_file
    from pcmm_geo.errors import InvalidInputError
    from pcmm_geo.machine.analysis.conditioning_maps import CONDITIONED_START_OFFSETS, choose_start, start_map
    from pcmm_geo.machine.analysis.logproc import DEFAULT_MAX_TIP_UNCERTAINTY
    from pcmm_geo.machine.analysis.session_prediction import predict_session

    machine = load_machine_file(args.calibration)
    microstep = T_LSR450B_MICROSTEP_MM
    name = args.start or ("level" if args.start_offsets is not None else "conditioned")
    offsets: tuple[int, int, int] = (0, 0, 0)
    if name == "conditioned":
        chosen = CONDITIONED_START_OFFSETS if args.calibration is None else choose_start(start_map(machine))
        offsets = start_offsets_usteps(chosen, microstep)
    simulated_shift = np.zeros(3) if args.start_offsets is None else np.asarray(args.start_offsets, dtype=float)
    resumed = _resumed_start(args, start_position)
    stated = None
    if resumed is not None:  # the log's datum is where it began
        if args.start is not None and resumed[0] != offsets:
            raise InvalidInputError("--start", f"the start the log began at (offsets {list(resumed[0])} microsteps) "
                                    "when resuming", args.start)
        name = name if resumed[0] == offsets else ("level" if resumed[0] == (0, 0, 0) else "recorded")
        offsets, stated = resumed
    start_heights = (machine.reference_heights + simulated_shift + np.asarray(offsets, dtype=float) * microstep
                     if stated is None or stated.shape != (3,) else stated)
    starts = tuple(start_position + offset for offset in offsets)
    step = max(2, round(args.step_mm / microstep))
    moves = plan_random_programme(min(args.moves, MAX_PREDICTED_MOVES), step_usteps=step, seed=args.seed,
                                  start_positions=starts, span=span)  # type: ignore[arg-type]
    prediction = predict_session(machine, start_heights, [(motor, steps * microstep) for motor, steps in moves])
    limit = DEFAULT_MAX_TIP_UNCERTAINTY if args.max_tip_u is None else float(args.max_tip_u)
    return StartPlan(name, offsets, starts, start_heights, prediction, limit,  # type: ignore[arg-type]
                     args.max_tip_u is not None, args.moves)


def _problem(plan: StartPlan) -> str | None:
    """What the prediction says is wrong with the plan (None: nothing)."""
    prediction = plan.prediction
    above = prediction.rows_above(plan.limit)
    if not above.size:
        return None
    return (f"the planned path ({plan.name} start{_covered(plan)}) enters poses where the predicted tip uncertainty "
            f"exceeds {plan.limit:g} mm: {above.size} of {prediction.tip_uncertainty.size} log rows, largest "
            f"{prediction.max_tip_uncertainty:.3g} mm, first at log row {int(above[0]) + 1}")


def _covered(plan: StartPlan) -> str:
    """``", first 200 of 1000 moves"`` when the prediction covers only part of the session."""
    predicted = int(plan.prediction.motor.size)
    return "" if predicted >= plan.moves else f", first {predicted} of {plan.moves} moves"


def enforce_limit(plan: StartPlan) -> None:
    """Before any device moves: refuse (``--max-tip-u-mm``) or warn on stderr when the plan exceeds the limit."""
    import numpy as np

    from pcmm_geo.errors import OutOfRangeError

    problem = _problem(plan)
    if problem is not None and plan.limit_given:
        prediction = plan.prediction
        raise OutOfRangeError(f"{problem}; nothing was moved (--start conditioned, or a larger --max-tip-u-mm); "
                              "predicted tip uncertainty", float(f"{prediction.max_tip_uncertainty:.4g}"), None,
                              plan.limit, "mm")
    notes = [] if problem is None else [problem + " (--max-tip-u-mm refuses such a session; --start conditioned "
                                        "avoids it)"]
    ambiguous = np.flatnonzero(plan.prediction.ambiguous)
    if ambiguous.size:
        notes.append(f"the planned path ({plan.name} start) has {ambiguous.size} log rows where a mirror pose fits "
                     "the lasers as well (ambiguous)")
    for note in notes:
        print(f"pcmm acquire: warning: IllConditionedWarning: {note}", file=sys.stderr)


def plan_report(plan: StartPlan) -> Report:
    """``--plan-only``: the first row and every stop row of the plan with its prediction."""
    import numpy as np

    prediction = plan.prediction
    rows = [0, *range(1, len(prediction.tip_uncertainty), 2)]

    def number(value: float) -> float | str:
        return float(value) if np.isfinite(value) else "inf"

    table_rows = []
    for row in rows:
        move = (row + 1) // 2
        motor = "-" if row == 0 else int(prediction.motor[move - 1])
        change = "-" if row == 0 else float(prediction.change[move - 1])
        flags = [flag for flag, on in (("above limit", not prediction.tip_uncertainty[row] <= plan.limit),
                                       ("ambiguous", prediction.ambiguous[row])) if on]
        table_rows.append([row + 1, move, motor, change, *prediction.heights[row].tolist(),
                           number(prediction.tip_uncertainty[row]), number(prediction.move_tip_u[row]),
                           number(prediction.ambiguity_ratio[row]), ",".join(flags) or "-"])
    table = Table(f"Planned path ({plan.name} start; stop rows, no probe contact)",
                  ["log row", "move", "motor", "change / mm", "h_a / mm", "h_b / mm", "h_c / mm", "u / mm",
                   "one-move u / mm", "mirror / critical", "flags"], table_rows)
    summary = plan.summary()
    data = {**summary, "rows": [
        {"log_row": r[0], "move": r[1], "motor": None if r[2] == "-" else r[2], "change_mm": None if r[3] == "-"
         else r[3], "heights_mm": r[4:7], "tip_u_mm": _finite(float(r[7])), "one_move_tip_u_mm": _finite(float(r[8])),
         "mirror_ratio": _finite(float(r[9]))} for r in table_rows]}
    lines = [f"start {plan.name}: pivot heights " + " ".join(f"{h:.3f}" for h in plan.start_heights)
             + " mm, motor positions " + " ".join(str(p) for p in plan.start_positions) + " microsteps",
             f"predicted tip u (the u process-log will state for this path{_covered(plan)}, laser sigma 0.0289 mm and "
             f"the sensors' steps): median {prediction.median_tip_uncertainty:.3g} mm, largest "
             f"{prediction.max_tip_uncertainty:.3g} mm; {len(summary['rows_above_limit'])} rows above "
             f"{plan.limit:g} mm, {len(summary['ambiguous_rows'])} ambiguous"]
    problem = _problem(plan)
    exit_code = 1 if problem is not None and plan.limit_given else 0
    if problem is not None:
        lines.append(("refused: " if exit_code else "warning: ") + problem)
    return Report(data=data, tables=[table], lines=lines, exit_code=exit_code)
