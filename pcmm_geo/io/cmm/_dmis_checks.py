"""Checks of a DMIS output's numbers against each other: a verdict its numbers contradict is refused."""

from __future__ import annotations

from dataclasses import dataclass

from pcmm_geo.errors import FileFormatError
from pcmm_geo.io.cmm.model import Tolerance

__all__ = ["StatedTolerance", "check_verdict"]


@dataclass(frozen=True)
class StatedTolerance:
    """What ``T(label)`` states: type, quantity, tolerance, nominal size (design values: exact) and
    whether a material modifier (MMC, LMC) makes the zone depend on the actual size (then its
    verdict is not checked)."""

    kind: str
    quantity: str
    tolerance: Tolerance | None
    nominal: float | None
    modified: bool = False


def check_verdict(path: str, line: int, what: str, status: str, stated: StatedTolerance, value: float | None,
                  deviation: float | None, margin: float, *, modified: bool) -> None:
    """Refuse an INTOL/OUTOL that the numbers contradict (beyond the rounding ``margin`` of the numbers written).

    A geometric zone: the result must lie within ``[0, zone]`` for INTOL and above it for OUTOL
    (not checked with MMC/LMC: the bonus tolerance depends on the actual size).  A size: the
    deviation (read with ``size_values``) must lie within the lower and upper tolerance for INTOL.
    """
    tolerance = stated.tolerance
    if tolerance is None:
        return
    if tolerance.value is not None:
        if modified or value is None:
            return
        if value < -margin:
            raise FileFormatError(path, f"{what}: a negative form or location result ({value:g} mm)", line)
        outside, inside = value > tolerance.value + margin, value < tolerance.value - margin
        limits = f"the tolerance zone {tolerance.value:g}"
        shown = value
    else:
        if deviation is None and value is not None and stated.nominal is not None:
            deviation = value - stated.nominal
        if deviation is None or tolerance.min_value is None or tolerance.max_value is None:
            return
        outside = not (tolerance.min_value - margin <= deviation <= tolerance.max_value + margin)
        inside = tolerance.min_value + margin < deviation < tolerance.max_value - margin
        limits = f"the tolerances [{tolerance.min_value:g}, {tolerance.max_value:g}]"
        shown = deviation
    if (status == "PASS" and outside) or (status == "FAIL" and inside):
        verdict = "INTOL" if status == "PASS" else "OUTOL"
        raise FileFormatError(path, f"{what}: {verdict} contradicts the result {shown:g} and {limits} (mm or rad, "
                          f"rounding {margin:.2g} allowed)", line)
