"""``pcmm inspect PLAN.toml``: datums, DRFs and GD&T characteristics of an inspection plan, with verdicts."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from pcmm_geo.cli._output import (
    EXIT_FAILURE,
    Report,
    Table,
    add_decimal_flag,
    add_json_flag,
    add_overwrite_flag,
    add_report_flag,
    declare_output,
)

DECISION_RULE = (
    "PASS if the value of a zone containing every point is within the tolerance (plus the bonus proven by the "
    "mating envelope's certificate); FAIL if its proven lower bound exceeds the largest possible allowance or the "
    "size is outside its limits; otherwise NOT PROVEN (measurement uncertainty not included)"
)


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "inspect",
        help="GD&T with datums: evaluate the feature control frames of a TOML inspection plan",
        description=(
            "Read PLAN.toml (features with points files relative to it, datums, feature control frames such as "
            "'position dia 0.1 MMC | A | B | C' or '⊥ ⌀0.02 | A'; composite and stacked position frames as a list of "
            "segments), associate the datums (ISO 5459 or ASME "
            "Y14.5 by the plan's standard), build each datum reference frame and evaluate every characteristic. "
            "Exit status 0 when all PASS, 1 on FAIL or NOT PROVEN, 2 on a plan error (one line naming the plan's "
            "line). See the guide page 'GD&T with datums'."
        ),
    )
    parser.add_argument("plan", type=Path, metavar="PLAN.toml")
    add_report_flag(parser)
    parser.add_argument("--qif", metavar="OUT.qif",
                        help="also write the results as a QIF 3.0 results document: the features (nominals from the "
                             "plan, actuals and points in the part's datum reference frame, else in the frame of the "
                             "most datums), datum definitions, datum "
                             "reference frames and the characteristic measurements (NOT PROVEN as INDETERMINATE); "
                             "characteristics with no QIF record written are listed by name")
    declare_output(parser, "qif")
    add_overwrite_flag(parser)
    add_decimal_flag(parser)
    add_json_flag(parser)
    parser.set_defaults(handler=handle)


def handle(args: argparse.Namespace) -> Report:
    from pcmm_geo.cli._record import Method, Verdict
    from pcmm_geo.gdt.inspection import inspect_plan
    from pcmm_geo.uncertainty.conformity import DECISION_RULE_TEXT

    result = inspect_plan(args.plan)
    data = result.to_dict()
    rows = []
    # U (k = 2), stated or propagated from the points: a column only when some characteristic has one
    expanded = [c.details.get("expanded_uncertainty_mm", c.details.get("expanded_uncertainty_rad"))
                for c in result.characteristics]
    for c, u in zip(result.characteristics, expanded, strict=True):
        if c.details.get("unit") == "rad":  # an angle: degrees at the edge
            scale, unit = math.degrees(1.0), "deg"
        elif "limits_mm" in c.details:  # a dimension: millimetres, the tolerance as its limits' width
            scale, unit = 1.0, "mm"
        else:
            scale, unit = 1000.0, "µm"
        rows.append([c.name, c.characteristic, scale * c.value_mm, scale * c.tolerance_mm,
                     "-" if c.bonus_mm is None else 1000.0 * c.bonus_mm, unit, "|".join(
                         d if m == "RMB" else f"{d}({m[0]})" for d, m in zip(
                             c.datums, c.details.get("datum_modifiers") or ["RMB"] * len(c.datums), strict=True))
                     or "-", c.verdict])
        if any(v is not None for v in expanded):
            rows[-1].insert(4, "-" if u is None else scale * u)
    columns = ["name", "characteristic", "value", "tolerance", "bonus", "unit", "datums", "verdict"]
    if any(v is not None for v in expanded):
        columns.insert(4, "U (k=2)")
    tables = [Table(f"characteristics of {args.plan} ({result.plan.standard})", columns, rows)]
    datum_rows = []
    for label, d in result.datums.items():
        cert = d.certificate
        datum_rows.append([label, d.element, d.criterion, 1000.0 * d.deviation_mm, cert.scope,
                           " ".join(str(i) for i in cert.contacts.tolist()[:8]), ", ".join(d.constrained_by) or "-"])
    if datum_rows:
        tables.append(Table("datums", ["datum", "element", "association", "deviation µm", "scope", "contacts",
                                       "constrained"], datum_rows))
    frame_rows = [[key, " ".join(f"{v:.6f}" for v in f.origin), " ".join(f.free) or "none"]
                  for key, f in result.frames.items()]
    tables.append(Table("datum reference frames", ["frame", "origin (mm, measurement coordinates)", "free"],
                        frame_rows))
    counts = {v: sum(c.verdict == v for c in result.characteristics) for v in ("PASS", "FAIL", "NOT PROVEN")}
    summary = ", ".join(f"{n} {v}" for v, n in counts.items() if n)
    passed = True if result.passed else (False if counts["FAIL"] else None)
    with_u = sum(v is not None for v in expanded)
    verdict = Verdict(passed, f"{len(result.characteristics)} characteristics: {summary or 'none'}", DECISION_RULE
                      if not with_u else DECISION_RULE.replace("(measurement uncertainty not included)",
                                                               f"(with U: {DECISION_RULE_TEXT})"),
                      basis="zones of the points as measured in the DRFs of their datums; " + (
                          "the points' measurement uncertainty is not taken into account" if not with_u else
                          f"{with_u} characteristic(s) decided with their U (stated, or propagated from the points' "
                          "point_u_mm by Monte Carlo re-evaluation)"))
    exit_code = 0 if result.passed else EXIT_FAILURE
    if result.plan.standard == "ASME":
        method = Method("ASME Y14.5-2018, ASME Y14.5.1-2019", "datums (7), tolerances of form, orientation, "
                        "location and runout (8-12)", "characteristics from measured points in their datum frames")
    else:
        method = Method("ISO 1101:2017, ISO 5459:2011", "geometrical tolerances (clause 18), datums and datum "
                        "systems", "characteristics from measured points in their datum reference frames")
    lines = []
    if args.qif:
        from pcmm_geo.gdt.qif.results import inspection_to_qif

        export = inspection_to_qif(result, args.qif, overwrite=bool(args.overwrite or args.overwrite_qif))
        data["qif"] = export.to_dict()
        lines.append(f"QIF: {len(export.written)} characteristic(s), {len(export.features)} feature(s) and "
                     f"{len(export.frames)} datum reference frame(s) written to {export.path}")
        lines += [f"QIF: not written: {name} ({reason})" for name, reason in export.not_written]
    return Report(data=data, tables=tables, lines=lines, exit_code=exit_code, verdict=verdict, method=method)
