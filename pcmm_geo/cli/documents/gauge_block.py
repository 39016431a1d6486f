"""The gauge-block calibration certificate (ISO 3650): certified values, method, thermal correction, annex.

The certified values are those of ISO 3650:1998: the central length ``l_c`` (the length at the
centre of the free measuring face, clause 3) at the reference temperature 20 °C (ISO 1), its
deviation ``e = l_c − l_n`` from the nominal length and the variation in length ``v`` (largest
minus smallest length over the measuring face), with -- for a stated grade -- the limit
deviation ``t_e`` of length at any point and the tolerance ``t_v`` of the variation in length
(:data:`ISO_3650_LIMITS`).  Every other length the evaluation computes is supplementary
information and goes to the technical annex with its meaning.
"""

from __future__ import annotations

import math
from typing import Any

from pcmm_geo.cli._output import Table

#: ISO 3650:1998 limit deviations ``t_e`` of length at any point from nominal length and tolerances
#: ``t_v`` for the variation in length (both µm) by nominal length range: rows of
#: ``(upper end of the range in mm, {grade: (t_e, t_v)})``; a range includes its upper end.
ISO_3650_LIMITS: tuple[tuple[float, dict[str, tuple[float, float]]], ...] = (
    (10.0, {"K": (0.20, 0.05), "0": (0.12, 0.10), "1": (0.20, 0.16), "2": (0.45, 0.30)}),
    (25.0, {"K": (0.30, 0.05), "0": (0.14, 0.10), "1": (0.30, 0.16), "2": (0.60, 0.30)}),
    (50.0, {"K": (0.40, 0.06), "0": (0.20, 0.10), "1": (0.40, 0.18), "2": (0.80, 0.30)}),
    (75.0, {"K": (0.50, 0.06), "0": (0.25, 0.12), "1": (0.50, 0.18), "2": (1.00, 0.35)}),
    (100.0, {"K": (0.60, 0.07), "0": (0.30, 0.12), "1": (0.60, 0.20), "2": (1.20, 0.35)}),
    (150.0, {"K": (0.80, 0.08), "0": (0.40, 0.14), "1": (0.80, 0.20), "2": (1.60, 0.40)}),
    (200.0, {"K": (1.00, 0.09), "0": (0.50, 0.16), "1": (1.00, 0.25), "2": (2.00, 0.40)}),
    (250.0, {"K": (1.20, 0.10), "0": (0.60, 0.16), "1": (1.20, 0.25), "2": (2.40, 0.45)}),
    (300.0, {"K": (1.40, 0.10), "0": (0.70, 0.18), "1": (1.40, 0.25), "2": (2.80, 0.50)}),
    (400.0, {"K": (1.80, 0.12), "0": (0.90, 0.20), "1": (1.80, 0.30), "2": (3.60, 0.50)}),
    (500.0, {"K": (2.20, 0.14), "0": (1.10, 0.25), "1": (2.20, 0.35), "2": (4.40, 0.60)}),
)
GRADES = ("K", "0", "1", "2")
COVERAGE = "a coverage probability of approximately 95 %"


def limit_deviations(nominal_mm: float, grade: str) -> tuple[float, float]:
    """``(t_e, t_v)`` in µm of ISO 3650 for a block of nominal length ``nominal_mm`` and ``grade``.

    Raises
    ------
    InvalidInputError
        A grade other than K, 0, 1, 2, or a nominal length outside 0.5 mm to 500 mm (the
        range this table holds).

    Examples
    --------
    >>> limit_deviations(100.0, "K"), limit_deviations(100.01, "0"), limit_deviations(10.0, "2")
    ((0.6, 0.07), (0.4, 0.14), (0.45, 0.3))
    """
    from pcmm_geo.errors import InvalidInputError

    if grade not in GRADES:
        raise InvalidInputError("grade", f"one of {', '.join(GRADES)}", repr(grade))
    if not (math.isfinite(nominal_mm) and 0.5 <= nominal_mm <= ISO_3650_LIMITS[-1][0]):
        raise InvalidInputError("nominal_mm", "a nominal length from 0.5 mm to 500 mm for the ISO 3650 grade "
                                "limits (state --tolerance-um otherwise)", repr(nominal_mm))
    return next(limits[grade] for upper, limits in ISO_3650_LIMITS if nominal_mm <= upper)


def certified_table(values: dict[str, Any]) -> Table:
    """The certified values: ``l_n``, ``l_c``, ``e``, ``U``, ``v`` and the grade's ``t_e``, ``t_v``.

    ``values`` holds ``central_length_mm``, ``corrected`` (whether it was corrected to 20 °C) and
    optionally ``nominal_mm``, ``deviation_um``, ``expanded_uncertainty_um``, ``variation_um``,
    ``grade``, ``t_e_um``, ``t_v_um``.
    """
    rows: list[list[Any]] = []
    if values.get("nominal_mm") is not None:
        rows.append(["nominal length l_n", f"{values['nominal_mm']:g}", "mm"])
    label = "central length l_c at 20 °C" if values.get("corrected") else "central length l_c (not corrected to 20 °C)"
    rows.append([label, f"{values['central_length_mm']:.6f}", "mm"])
    if values.get("deviation_um") is not None:
        rows.append(["deviation e = l_c − l_n", f"{values['deviation_um']:+.3f}", "µm"])
    if values.get("expanded_uncertainty_um") is not None:
        rows.append(["expanded uncertainty U of l_c and e (k = 2, ≈ 95 %)",
                     f"{values['expanded_uncertainty_um']:.3f}", "µm"])
    variation = values.get("variation_um")
    rows.append(["variation in length v", "-" if variation is None else f"{variation:.3f}", "µm"])
    if values.get("grade"):
        rows.append([f"limit deviation t_e, grade {values['grade']} (ISO 3650)", f"±{values['t_e_um']:.2f}", "µm"])
        rows.append([f"tolerance t_v for v, grade {values['grade']} (ISO 3650)", f"{values['t_v_um']:.2f}", "µm"])
    return Table("Certified values", ["quantity", "value", "unit"], rows)


def method_statement(n_points: dict[str, int]) -> str:
    """How the block was measured: two-face probing on a CMM, not wringing (with the point counts)."""
    counts = ", ".join(f"{label} {count}" for label, count in sorted(n_points.items()))
    return ("The gauge block was measured on a coordinate measuring machine by probing both measuring faces "
            "(two-face probing); it was not wrung to a platen, so no wringing film enters the length. A "
            "least-squares (Gaussian) plane was fitted to the points of each measuring face; the central length "
            "l_c is the distance from the centre point of one measuring face to the plane of the other, taken "
            "both ways and averaged (ISO 3650:1998, clause 3). The variation in length v is the range of the "
            "distances of the probed points of one face from the plane of the other (evaluated over the probed "
            f"points only). Points probed per face: {counts}.")


def traceability_statement(references: int) -> str:
    """The traceability statement: through the listed reference standards, or that none is stated."""
    if not references:
        return ("No reference standard is stated in this report (--reference or [[reference]] in pcmm.toml), so "
                "the report itself does not show the traceability of the result to the SI metre.")
    return ("The result is metrologically traceable to the SI unit of length, the metre, through the reference "
            "standards listed above, whose calibration certificates and uncertainties are stated there, by which "
            "the measuring instrument's length indication was verified.")


def uncertainty_statement(u_um: float | None) -> str:
    """U with its coverage factor and coverage probability (or that none was stated)."""
    if u_um is None:
        return ("No expanded uncertainty was stated for this calibration (--uncertainty-um); the certified "
                "values are stated without U, which a calibration certificate needs (ISO/IEC 17025 7.8.4).")
    return (f"The expanded uncertainty U = {u_um:.3f} µm is the standard uncertainty of the laboratory's budget "
            f"multiplied by the coverage factor k = 2, which for a normal distribution corresponds to {COVERAGE} "
            "(JCGM 100:2008). It applies to the central length and to its deviation e.")


def annex_tables(result: Any, ratio: float) -> list[Table]:
    """The supplementary lengths with their meaning (all corrected to 20 °C by ``ratio`` = l_20 / l_measured)."""
    rows: list[list[Any]] = [
        ["one-way central length, face 1 centre → plane of face 2", f"{result.length_face1_to_plane2 * ratio:.6f}",
         "mm", "the definition of l_c taken from face 1; l_c is the mean of the two one-way lengths"],
        ["one-way central length, face 2 centre → plane of face 1", f"{result.length_face2_to_plane1 * ratio:.6f}",
         "mm", "the same from face 2; the two differ when the faces are not parallel"],
    ]
    if not math.isnan(result.projected_length):
        rows.append(["projection of one point pair on the block axis (top × side faces)",
                     f"{result.projected_length * ratio:.6f}", "mm",
                     "one point on each measuring face, not the face centres: differs from l_c by the faces' "
                     "form and non-parallelism between those points"])
    if result.seed is not None:
        rows.append(["two-angle length of one point pair (three-point top and side planes)",
                     f"{result.seed.length * ratio:.6f}", "mm",
                     "a comparison method: single points and three-point planes, with no averaging"])
        rows.append(["two-point distance of that point pair", f"{result.seed.vector_length * ratio:.6f}", "mm",
                     "includes the lateral offset of the two points: longer than the block"])
    form1, form2 = result.face_form
    rows += [["flatness of measuring face 1 (fitted plane)", f"{1000 * form1:.3f}", "µm",
              "range of the plane residuals"],
             ["flatness of measuring face 2 (fitted plane)", f"{1000 * form2:.3f}", "µm",
              "range of the plane residuals"],
             ["parallelism of the measuring faces", f"{1e6 * result.parallelism:.2f}", "µrad",
              "angle between the two fitted face normals"]]
    if result.seed is not None:
        rows.append(["angle between top and side faces", f"{math.degrees(result.seed.phi):.4f}", "°",
                     "from the three-point planes (90° for a square block)"])
    return [Table("Supplementary information (not certified)", ["quantity", "value", "unit", "meaning"], rows)]
