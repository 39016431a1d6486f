"""The report of ``pcmm qif verify``: reported and refitted values side by side, and what was checked.

A second opinion is an agreement check between two evaluations of the same measured points
(the CMM's software and pcmm_geo's refit), not a conformity decision on a workpiece: the
report says so instead of an ISO 14253-1 state, and no temperature enters it.  Files that hold
results but no points (a CALYPSO table, most DMIS output) are said to be read but not refitted.
"""

from __future__ import annotations

from typing import Any

from pcmm_geo.cli._output import Table
from pcmm_geo.cli._record import Condition

#: the conformity row of an agreement check (there is no specification of the workpiece to decide on)
AGREEMENT = ("not a conformity decision (ISO 14253-1 does not apply): an agreement check between the CMM's "
             "evaluation and pcmm_geo's refit of the same measured points")
#: the environment row: the same points enter both evaluations
NO_TEMPERATURE = Condition("temperature", "does not enter: both evaluations use the same measured points", "-")

_QUANTITIES = (  # (key in reported/refit, label, key of the difference, factor to the table's unit, unit)
    ("diameter_mm", "diameter / mm", "diameter_mm", 1000.0, "µm"),
    ("location_mm", "location x, y, z / mm", "location_distance_mm", 1000.0, "µm"),
    ("direction", "direction (unit vector)", "direction_angle_rad", 1e6, "µrad"),
    ("half_angle_rad", "half-angle / rad", "half_angle_rad", 1e6, "µrad"),
)


def _value(value: Any) -> str:
    if value is None:
        return "-"
    if isinstance(value, (list, tuple)):
        return ", ".join(f"{float(v):.6f}" for v in value)
    return f"{float(value):.6f}"


def values_table(result: Any) -> Table:
    """Every compared quantity of every refitted feature: reported, refitted, difference, tolerance, agreement.

    Parameters
    ----------
    result : pcmm_geo.cmm.verify.Verification

    Returns
    -------
    Table
        One row per feature and quantity that both the CMM and the refit give; features that
        could not be refitted are in the terminal's table with their reason.
    """
    rows = []
    for check in result.features:
        for key, label, difference_key, factor, unit in _QUANTITIES:
            if key not in check.reported or key not in check.refit:
                continue
            difference = check.difference.get(difference_key)
            compared = difference_key in check.compared
            if difference_key.endswith("_rad"):
                limit = check.angle_tolerance_rad
                tolerance = "-" if limit is None else f"{factor * limit:.4g} {unit}"
            else:
                tolerance = "-" if check.tolerance_mm is None else f"{factor * check.tolerance_mm:.4g} {unit}"
            if not compared:
                verdict = "not compared"
            else:
                limit_mm = check.angle_tolerance_rad if difference_key.endswith("_rad") else check.tolerance_mm
                verdict = "yes" if limit_mm is not None and abs(float(difference)) <= limit_mm else "NO"
            rows.append([check.id, check.name or "-", label, _value(check.reported[key]), _value(check.refit[key]),
                         "-" if difference is None else f"{factor * abs(float(difference)):.4g} {unit}",
                         tolerance, verdict])
    return Table("Reported and refitted values", ["id", "name", "quantity", "reported by the CMM",
                                                  "refitted by pcmm_geo", "difference", "tolerance", "agrees"], rows)


def scope_statement(document: Any, result: Any, characteristics: dict[str, int] | None = None) -> str:
    """What the second opinion checked and what it did not (a file without points: no feature refitted).

    ``characteristics`` is the characteristics' summary (``agrees``, ``disagrees``,
    ``not_computable``) when they were recomputed.
    """
    summary = result.summary()
    refitted = summary["agree"] + summary["disagree"]
    counts = characteristics or {}
    recomputed = counts.get("agrees", 0) + counts.get("disagrees", 0)
    kind = {"qif": "QIF results file", "dmis": "DMIS output", "calypso": "CALYPSO characteristics table"}.get(
        str(document.format), f"{document.format} file")
    features = len(result.features)
    n_characteristics = len(getattr(document, "characteristics", ()) or ())
    read = (f"The {kind} was read: {features} measured feature{'s' if features != 1 else ''} and "
            f"{n_characteristics} characteristic{'s' if n_characteristics != 1 else ''}.")
    checked = []
    if refitted:
        checked.append(f"{refitted} feature{'s' if refitted != 1 else ''} refitted from "
                       f"{'its' if refitted == 1 else 'their'} measured points and compared quantity by quantity "
                       "with the reported values")
    if recomputed:
        checked.append(f"{recomputed} characteristic{'s' if recomputed != 1 else ''} recomputed and compared with "
                       "the reported values")
    if not checked:
        what = "It holds no measured points" if not document.point_sets else "None of its features could be refitted"
        return (f"{read} {what}, and no characteristic could be recomputed: nothing was verified. Checked: that "
                "the file is readable and what it reports (pcmm qif show lists it). Not checked: any reported "
                "size, location, direction or characteristic value.")
    left = summary["not_checked"]
    not_computable = counts.get("not_computable", 0)
    not_checked = [f"{left} feature{'s' if left != 1 else ''} without usable points (reasons listed)"] if left else []
    if not_computable:
        not_checked.append(f"{not_computable} characteristic{'s' if not_computable != 1 else ''} that could not be "
                           "recomputed")
    not_checked.append("the measurement uncertainty of the points")
    return f"{read} Checked: {'; '.join(checked)}. Not checked: {', '.join(not_checked)}."


def plot(result: Any, path: str, overwrite: bool, characteristics: Any = None) -> str:
    """Draw :func:`pcmm_geo.plots.cmm_verify.plot_verification` (``--plot``): features and characteristics."""
    from pcmm_geo.plots.cmm_verify import plot_verification

    return str(plot_verification(result, path, overwrite=overwrite, characteristics=characteristics))
