"""``pcmm numcal DATA.csv``: numerical calibration of d, beta, b from height-gauge data (thesis ch. 6)."""

from __future__ import annotations

import argparse
from typing import Any

from pcmm_geo.cli._output import (
    EXIT_FAILURE,
    EXIT_OK,
    CovarianceBlock,
    Report,
    Table,
    add_json_flag,
    add_overwrite_flag,
    add_plot_flag,
    add_report_flag,
    refuse_renamed_options,
)


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "numcal",
        help="numerical calibration of d, beta, b from laser readings and height-gauge heights (thesis ch. 6)",
        description=(
            "Identify the nine DPKM parameters from a CSV moved,laser_a,laser_b,laser_c,height (mm; moved is the "
            "arm whose pivot was raised, height its height-gauge reading relative to the level start), with "
            "least squares after a global search run to a Gauss-Newton convergence test, and report standard "
            "uncertainties, identifiability (singular values, condition number, undetermined parameter combinations) "
            "and whether the calibration converged and is determined. --single-arm ARM fits the four parameters of "
            "one arm's pair (thesis 6.2.1, Table 6.2)."
        ),
    )
    parser.add_argument("data", help="CSV moved,laser_a,laser_b,laser_c,height")
    parser.add_argument("--method", choices=("simultaneous", "sequential"), default="simultaneous")
    parser.add_argument("--pairs", choices=("moved", "all"), default="moved",
                        help="equations per sample: the moved arm's pair (the seed's) or all three pairs")
    parser.add_argument("--single-arm", choices=("a", "b", "c"), default=None, metavar="ARM",
                        help="fit only d_i, d_in, beta_in, b_in of the pair of moved arm ARM (thesis 6.2.1)")
    parser.add_argument("--search", choices=("differential_evolution", "multistart", "none"),
                        default="differential_evolution", help="global search before least squares")
    parser.add_argument("--seed", type=int, default=0, help="seed of the global search (default 0)")
    parser.add_argument("--laser-u-mm", dest="laser_u", type=float, default=None, metavar="MM",
                        help="standard uncertainty of the laser readings (mm): weighted fit and its covariance")
    parser.add_argument("--height-u-mm", dest="height_u", type=float, default=None, metavar="MM",
                        help="standard uncertainty of the pivot heights (mm): weighted fit and its covariance")
    add_plot_flag(parser, "the distance residual of every sample and the singular values")
    add_report_flag(parser)
    add_overwrite_flag(parser)
    add_json_flag(parser)
    refuse_renamed_options(parser, {"--laser-u": "--laser-u-mm", "--height-u": "--height-u-mm"})
    parser.set_defaults(handler=_handle)


def _handle(args: argparse.Namespace) -> Report:
    import numpy as np

    from pcmm_geo.cli._progress import progress_bar, progress_wanted
    from pcmm_geo.machine.calibration.numerical.numcal import calibrate_numerically, read_numcal_csv

    data = read_numcal_csv(args.data)
    search = None if args.search == "none" else args.search
    if args.single_arm is not None:
        from pcmm_geo.machine.calibration.numerical.numcal_single_arm import calibrate_single_arm

        with progress_bar(f"single-arm calibration (arm {args.single_arm}, {args.search})",
                          enabled=progress_wanted(args)):
            result = calibrate_single_arm(data, args.single_arm, global_search=search, seed=args.seed,
                                          laser_sigma=args.laser_u, height_sigma=args.height_u)
    else:
        # calibrate_numerically calls progress(done, total) from the global search (generations, starts)
        with progress_bar(f"numerical calibration ({args.method}, {args.search})",
                          enabled=progress_wanted(args)) as update:
            result = calibrate_numerically(data, method=args.method, pairs=args.pairs, global_search=search,
                                           seed=args.seed, laser_sigma=args.laser_u, height_sigma=args.height_u,
                                           progress=update)
    params = result.parameters
    uncertainty = result.standard_uncertainties

    def u_of(name: str, degrees: bool = False) -> str:
        if name not in uncertainty:
            return "fixed"
        value = uncertainty[name]
        return f"{np.degrees(value) if degrees else value:.3g}"

    rows = [
        [arm, params.d[arm], u_of(f"d_{arm}"), pair, params.beta_deg[pair], u_of(f"beta_{pair}", True),
         params.b[pair], u_of(f"b_{pair}")]
        for arm, pair in zip("abc", ("ab", "bc", "ca"), strict=True)
    ]
    table = Table("Numerical calibration", ["arm", "d / mm", "u(d) / mm", "pair", "beta / deg", "u(beta) / deg",
                                            "b / mm", "u(b) / mm"], rows)
    ident = result.identifiability
    lines = [
        f"converged: {'yes' if result.converged else 'NO'} -- {result.message}",
        f"rms distance residual: {result.rms:.6g} mm, {result.residuals.size} equations, dof {result.dof} "
        f"({result.evaluations} evaluations)",
        f"condition number (column-scaled Jacobian): {result.condition_number:.4g}, rank {result.rank} of "
        f"{len(result.names)}",
    ]
    lines += [f"weak combination (s/s_max = {w.relative:.3g}): {w.text}" for w in ident.weak_combinations]
    plots = []
    if args.plot:
        from pcmm_geo.plots.machine.machine_state import plot_numerical_calibration

        used = data if args.single_arm is None else data.subset((args.single_arm,))
        plots.append(str(plot_numerical_calibration(result, used, args.plot, overwrite=args.overwrite)))
    out = result.to_dict()
    if plots:
        out["plot"] = plots[0]
    covariance = np.asarray(result.covariance, dtype=float)
    blocks = [CovarianceBlock("numerical calibration parameters (mm, rad)", tuple(result.names), covariance)] \
        if result.converged and np.all(np.isfinite(covariance)) else []
    # a calibration that did not converge or is not determined is a failed verdict (exit 1), still reported
    return Report(data=out, tables=[table], lines=lines, plots=plots, covariances=blocks,
                  exit_code=EXIT_OK if result.converged else EXIT_FAILURE)
