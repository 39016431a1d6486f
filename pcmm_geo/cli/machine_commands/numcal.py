"""``pcmm numcal DATA.csv``: numerical calibration of d, beta, b from height-gauge data (thesis ch. 6)."""

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
)


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "numcal",
        help="numerical calibration of d, beta, b from laser readings and height-gauge heights (thesis ch. 6)",
        description=(
            "Identify the nine DPKM parameters from a CSV moved,laser_a,laser_b,laser_c,height (mm; moved is the "
            "arm whose pivot was raised, height its height-gauge reading relative to the level start), with "
            "least squares after a global search, and report identifiability (singular values, condition number, "
            "undetermined parameter combinations)."
        ),
    )
    parser.add_argument("data", help="CSV moved,laser_a,laser_b,laser_c,height")
    parser.add_argument("--method", choices=("simultaneous", "sequential"), default="simultaneous")
    parser.add_argument("--search", choices=("differential_evolution", "multistart", "none"),
                        default="differential_evolution", help="global search before least squares")
    parser.add_argument("--seed", type=int, default=0, help="seed of the global search (default 0)")
    add_plot_flag(parser, "the distance residual of every sample and the singular values")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    add_json_flag(parser)
    parser.set_defaults(handler=_handle)


def _handle(args: argparse.Namespace) -> Report:
    from pcmm_geo.cli._progress import progress_bar, progress_wanted
    from pcmm_geo.machine.calibration.numcal import calibrate_numerically, read_numcal_csv

    data = read_numcal_csv(args.data)
    # calibrate_numerically calls progress(done, total) from the global search (generations, starts)
    with progress_bar(f"numerical calibration ({args.method}, {args.search})",
                      enabled=progress_wanted(args)) as update:
        result = calibrate_numerically(
            data, method=args.method, global_search=None if args.search == "none" else args.search, seed=args.seed,
            progress=update,
        )
    params = result.parameters
    rows = [
        [arm, params.d[arm], pair, params.beta_deg[pair], params.b[pair]]
        for arm, pair in zip("abc", ("ab", "bc", "ca"), strict=True)
    ]
    table = Table("Numerical calibration", ["arm", "d / mm", "pair", "beta / deg", "b / mm"], rows)
    ident = result.identifiability
    lines = [
        f"rms distance residual: {result.rms:.6g} mm over {len(data.moved)} samples ({result.evaluations} evaluations)",
        f"condition number (column-scaled Jacobian): {ident.condition_number:.4g}, rank {ident.rank} of 9",
    ]
    lines += [f"weak combination (s/s_max = {w.relative:.3g}): {w.text}" for w in ident.weak_combinations]
    plots = []
    if args.plot:
        from pcmm_geo.plots.machine.machine_state import plot_numerical_calibration

        plots.append(str(plot_numerical_calibration(result, data, args.plot, overwrite=args.overwrite)))
    out = result.to_dict()
    if plots:
        out["plot"] = plots[0]
    return Report(data=out, tables=[table], lines=lines, plots=plots)
