"""``pcmm uncertainty TASK``: task-specific uncertainty by the virtual micro-CMM (ISO 15530-4 style)."""

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

TASKS = ("gauge-block", "sphere", "distance")


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "uncertainty",
        help="task-specific uncertainty by simulation: gauge block, sphere diameter, point-to-point distance",
        description=(
            "Simulates the measurement task many times with the calibrated model perturbed within its "
            "covariance, laser/encoder noise, probing scatter and thermal state (JCGM 101 Monte Carlo, "
            "adaptive unless --trials), reports the expanded uncertainty (95 % coverage), the budget (one "
            "input group at a time) and the GUM linear result for comparison. Without --calibration the "
            "demo's simulated calibration is used."
        ),
    )
    parser.add_argument("task", choices=TASKS, help="measurement task")
    parser.add_argument("--calibration", metavar="CAL.json",
                        help="calibration file with a covariance (pcmm calibrate --probing-u-mm ... --out)")
    parser.add_argument("--length-mm", dest="length", type=float, default=100.0,
                        help="gauge block / distance length in mm (100)")
    parser.add_argument("--diameter-mm", dest="diameter", type=float, default=25.0, help="sphere diameter in mm (25)")
    parser.add_argument("--points", type=int, default=None,
                        help="probings per gauge-block face (5) or on the sphere (25)")
    parser.add_argument("--centre-mm", "--center-mm", dest="center", type=float, nargs=3, metavar=("X", "Y", "Z"),
                        help="artefact centre in the machine frame, mm (default: middle of the working volume)")
    parser.add_argument("--laser-u-mm", dest="laser_u", type=float, default=0.0005,
                        help="laser reading u in mm (0.0005)")
    parser.add_argument("--encoder-u-mm", dest="encoder_u", type=float, default=0.0002,
                        help="encoder reading u in mm (0.0002)")
    parser.add_argument("--probing-u-mm", dest="probing_u", type=float, default=0.0,
                        help="probing scatter u along the normal, mm (0)")
    parser.add_argument("--arm-temperature-u", type=float, default=0.0, help="u of each arm temperature, K (0)")
    parser.add_argument("--column-temperature-u", type=float, default=0.0, help="u of each column temperature, K")
    parser.add_argument("--machine-temperature", type=float, default=20.0, help="mean machine temperature, degC")
    parser.add_argument("--alpha-machine-u", type=float, default=0.0, help="u of the machine's alpha, 1/K (0)")
    parser.add_argument("--workpiece-temperature", type=float, default=20.0, help="artefact temperature, degC")
    parser.add_argument("--workpiece-temperature-u", type=float, default=0.0, help="its u in K (0)")
    parser.add_argument("--alpha-workpiece-u", type=float, default=0.0, help="u of the artefact's alpha, 1/K (0)")
    parser.add_argument("--trials", type=int, default=None, help="fixed number of trials (default: adaptive)")
    parser.add_argument("--digits", type=int, default=1,
                        help="significant digits of u that the adaptive Monte Carlo stabilises (1)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (0)")
    add_plot_flag(parser, "a histogram of the simulated values with the coverage interval and the budget")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    add_json_flag(parser)
    refuse_renamed_options(parser, {
        "--length": "--length-mm",
        "--diameter": "--diameter-mm",
        "--laser-u": "--laser-u-mm",
        "--encoder-u": "--encoder-u-mm",
        "--probing-u": "--probing-u-mm",
        "--center": "--centre-mm",
    })
    parser.set_defaults(handler=_handle)


def _machine(args: argparse.Namespace) -> tuple[Any, float, Any, Any, str]:
    import numpy as np

    if args.calibration is None:
        from pcmm_geo.demo import demo_calibrated_machine

        machine, radius, covariance, center = demo_calibrated_machine()
        return machine, radius, covariance.model_covariance()[1], center, "demo's simulated calibration"
    from pcmm_geo.errors import FileFormatError, InvalidInputError
    from pcmm_geo.machine.calibration.calfile import load_calibration, load_covariance
    from pcmm_geo.machine.kinematics.model import RigidBodyMachine
    from pcmm_geo.uncertainty.calibration import CalibrationCovariance

    cal = load_calibration(args.calibration)
    if not np.isfinite(cal.tip.radius):
        raise FileFormatError(str(args.calibration), "expected a calibrated tip radius (raw tip probings), got none")
    entry = load_covariance(args.calibration)
    if entry is None:
        raise FileFormatError(str(args.calibration), "expected a 'covariance' entry (pcmm calibrate --probing-u-mm "
                              "U --laser-u-mm U --out FILE), got none")
    from pcmm_geo.machine.calibration.calfile import load_stored_machine

    machine = load_stored_machine(args.calibration)  # a damaged machine entry is an error, not a fallback
    source = f"{args.calibration}"
    if machine is None:
        nominal = RigidBodyMachine.from_dpkm()
        machine = RigidBodyMachine(cal.tetrahedron, nominal.columns, nominal.reference_lasers,
                                   nominal.reference_heights)
        source = f"{args.calibration} (tetrahedron) on the seed's nominal columns"
    center = machine.forward(heights=machine.reference_heights, lasers_hint=machine.reference_lasers).tip
    try:
        covariance = CalibrationCovariance.from_dict(entry).model_covariance()[1]
    except InvalidInputError as exc:
        raise FileFormatError(str(args.calibration), str(exc)) from None
    return machine, float(cal.tip.radius), covariance, np.asarray(center), source


def human_progress(update: Any) -> Any:
    """``update`` with the input groups' internal names in a step text replaced by their words.

    Examples
    --------
    >>> seen = []
    >>> human_progress(lambda done, total=None, text=None: seen.append(text))(1, 6, "budget 2/6: laser_noise")
    >>> seen
    ['budget 2/6: laser readings']
    """
    from pcmm_geo.uncertainty.virtual_cmm import GROUP_LABELS

    def translated(done: int, total: int | None = None, text: str | None = None) -> None:
        if text:
            head, sep, name = text.rpartition(": ")
            text = f"{head}{sep}{GROUP_LABELS.get(name, name)}" if sep else GROUP_LABELS.get(text, text)
        update(done, total, text)

    return translated


def _handle(args: argparse.Namespace) -> Report:
    import numpy as np

    from pcmm_geo.cli._progress import progress_bar, progress_wanted
    from pcmm_geo.uncertainty.tasks import distance_task, gauge_block_task, sphere_task
    from pcmm_geo.uncertainty.virtual_cmm import ThermalInputs, VirtualCMM

    machine, radius, covariance, center, source = _machine(args)
    if args.center is not None:
        center = np.asarray(args.center, dtype=float)
    if args.task == "gauge-block":
        task = gauge_block_task(args.length, center, points_per_face=args.points or 5)
    elif args.task == "sphere":
        task = sphere_task(args.diameter, center, points=args.points or 25)
    else:
        task = distance_task(args.length, center)
    thermal = ThermalInputs(
        arm_temperature_u=args.arm_temperature_u, column_temperature_u=args.column_temperature_u,
        machine_temperature=args.machine_temperature, alpha_machine_u=args.alpha_machine_u,
        workpiece_temperature=args.workpiece_temperature, workpiece_temperature_u=args.workpiece_temperature_u,
        alpha_workpiece_u=args.alpha_workpiece_u,
    )
    vcmm = VirtualCMM(machine, radius, covariance, laser_sigma=args.laser_u, encoder_sigma=args.encoder_u,
                      probing_sigma=args.probing_u, thermal=thermal)
    with progress_bar("virtual CMM", enabled=progress_wanted(args)) as update:
        outcome = vcmm.evaluate(task, seed=args.seed, trials=args.trials, significant_digits=args.digits,
                                keep_values=bool(args.plot), progress=human_progress(update))
    result, gum = outcome.result, outcome.gum
    data: dict[str, Any] = {"calibration": source, **outcome.to_dict()}
    plots: list[str] = []
    lines = [
        f"machine: {source}",
        f"{task.quantity.replace('_', ' ')} {task.nominal:g} mm: U = {1000 * result.expanded_uncertainty:.3f} µm "
        f"(k = {result.coverage_factor:.2f}, {100 * result.coverage_probability:.0f} % "
        f"{result.interval_kind} interval, {result.n_trials} trials; {result.message})",
    ]
    if gum is not None:
        verdict = "validated" if outcome.validation.get("validated") else "not validated: Monte Carlo used"
        lines.append(f"GUM linear: U = {1000 * gum.expanded_uncertainty:.3f} µm (JCGM 101 §8: {verdict})")
    if args.plot:
        from pcmm_geo.plots.uncertainty import plot_monte_carlo

        written = plot_monte_carlo(result, args.plot, nominal=task.nominal, overwrite=args.overwrite, gum=gum,
                                   title=f"{args.task} {task.nominal:g} mm: U = "
                                   f"{1000 * result.expanded_uncertainty:.3f} µm (95 %)")
        data["plot"] = str(written)
        plots.append(str(written))
        lines.append(f"plot written to {written}")
    low, high = result.coverage_interval
    summary = Table(
        f"Task-specific uncertainty: {args.task}",
        ["method", "mean - nominal / µm", "u / µm", "U / µm", "k", "interval low / µm", "interval high / µm"],
        [["Monte Carlo", 1000 * (result.value - task.nominal), 1000 * result.standard_uncertainty,
          1000 * result.expanded_uncertainty, result.coverage_factor, 1000 * (low - task.nominal),
          1000 * (high - task.nominal)]]
        + ([["GUM linear", 1000 * (gum.value - task.nominal), 1000 * gum.standard_uncertainty,
             1000 * gum.expanded_uncertainty, gum.coverage_factor, 1000 * (gum.coverage_interval[0] - task.nominal),
             1000 * (gum.coverage_interval[1] - task.nominal)]] if gum is not None else []),
    )
    gum_parts = {entry.name: entry.contribution for entry in gum.budget} if gum is not None else {}
    from pcmm_geo.uncertainty.virtual_cmm import GROUP_LABELS

    budget = Table(
        "Budget: contribution of each input group to u (one group varied at a time)",
        ["input group", "Monte Carlo / µm", "share of u²", "GUM / µm"],
        [[GROUP_LABELS.get(entry.name, entry.name), 1000 * entry.contribution, entry.share,
          1000 * gum_parts.get(entry.name, float("nan"))] for entry in result.budget],
    )
    from pcmm_geo.cli._record import Condition

    environment = [Condition("machine temperature", args.machine_temperature, "°C"),
                   Condition("u(arm temperature)", args.arm_temperature_u, "K"),
                   Condition("u(column temperature)", args.column_temperature_u, "K"),
                   Condition("workpiece temperature", args.workpiece_temperature, "°C"),
                   Condition("u(workpiece temperature)", args.workpiece_temperature_u, "K")]
    return Report(data=data, tables=[summary, budget], lines=lines, plots=plots, environment=environment)
