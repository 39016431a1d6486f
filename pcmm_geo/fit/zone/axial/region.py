"""The axis region searched by the axial minimax fits, and the budget of that search.

A cylinder's minimum zone, minimum circumscribed and maximum inscribed cylinders are
searched over the axes of a stated *region* around a reference axis (the least-squares
axis unless a nominal axis is given):

* the axis direction lies within ``cone_deg`` of the reference direction (default 45 deg);
* the axis crosses the *reference plane* -- normal to the reference axis through the foot
  of the data centroid on it -- within ``offset_mm`` of that foot (default twice the
  least-squares radius).

The region is compact, so every criterion has an optimum in it; an optimum on the
region's edge is flagged (``certificate.on_region_boundary``): a better element may
exist outside.  A 3-D line (smallest enclosing cylinder) is searched over all
directions and needs no region.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.elements import Criterion
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.fit._kernels._axial import as_axis_hint
from pcmm_geo.fit._kernels._core import rotation_to_z

__all__ = ["AxisRegion", "SearchBudget"]

FloatArray = NDArray[np.float64]

#: default largest angle (deg) between the axis and the reference axis
DEFAULT_CONE_DEG = 45.0
#: default largest crossing offset in radii of the least-squares cylinder
DEFAULT_OFFSET_RADII = 2.0


@record
class AxisRegion:
    """Axes searched by a minimum-zone, MCC or MIC cylinder fit.

    Parameters
    ----------
    cone_deg : float
        Largest angle (degrees, in (0, 90)) between the axis and the reference axis.
    offset_mm : float, optional
        Largest distance (mm) from the reference axis at which the axis may cross the
        reference plane (normal to the reference axis through the foot of the data
        centroid).  Default: twice the radius of the least-squares cylinder.
    axis : array_like, shape (3,), optional
        Nominal axis direction (either sign).  Default: the least-squares axis.
    point : array_like, shape (3,), optional
        A point of the nominal axis (mm); only with ``axis``.  Default: the point of the
        least-squares axis nearest the data centroid.

    Raises
    ------
    InvalidInputError
        An angle outside (0, 90) deg, a non-positive offset, a bad axis or point, or a
        point without an axis.

    Examples
    --------
    >>> AxisRegion(cone_deg=10.0, offset_mm=0.5)
    AxisRegion(cone_deg=10.0, offset_mm=0.5)
    """

    cone_deg: float = DEFAULT_CONE_DEG
    offset_mm: float | None = None
    axis: FloatArray | None = None
    point: FloatArray | None = None

    def __post_init__(self) -> None:
        cone = _real(self.cone_deg, "axis_region.cone_deg")
        if not 0.0 < cone < 90.0:
            raise InvalidInputError("axis_region.cone_deg", "an angle in (0, 90) degrees", repr(self.cone_deg))
        object.__setattr__(self, "cone_deg", cone)
        if self.offset_mm is not None:
            offset = _real(self.offset_mm, "axis_region.offset_mm")
            if not (np.isfinite(offset) and offset > 0.0):
                raise InvalidInputError("axis_region.offset_mm", "a positive finite length in mm", repr(self.offset_mm))
            object.__setattr__(self, "offset_mm", offset)
        if self.axis is not None:
            object.__setattr__(self, "axis", as_axis_hint(self.axis))
        if self.point is not None:
            if self.axis is None:
                raise InvalidInputError("axis_region.point", "None unless axis is given", repr(self.point))
            point = np.asarray(self.point, dtype=float) if _numeric(self.point) else None
            if point is None or point.shape != (3,) or not np.all(np.isfinite(point)):
                raise InvalidInputError("axis_region.point", "3 finite coordinates in mm", repr(self.point))
            object.__setattr__(self, "point", point)


@dataclass(frozen=True)
class SearchBudget:
    """Budget of the branch-and-bound search of an axial minimax fit.

    When the budget runs out before the proof closes, the best axis found is returned
    with ``certificate.scope == "local"`` and the bound proven so far.

    Parameters
    ----------
    max_cells : int
        Largest number of axis cells evaluated (deterministic; default 2 000 000).
    max_seconds : float, optional
        Wall-clock limit of the search (default 5 s; None: no limit).  A time limit
        makes the outcome depend on the machine: give ``max_cells`` alone for repeatable runs.

    Examples
    --------
    >>> SearchBudget(max_cells=100_000, max_seconds=None)
    SearchBudget(max_cells=100000, max_seconds=None)
    """

    max_cells: int = 2_000_000
    max_seconds: float | None = 5.0

    def __post_init__(self) -> None:
        if isinstance(self.max_cells, bool) or not isinstance(self.max_cells, (int, np.integer)) or self.max_cells < 1:
            raise InvalidInputError("search_budget.max_cells", "a positive integer", repr(self.max_cells))
        object.__setattr__(self, "max_cells", int(self.max_cells))
        if self.max_seconds is not None:
            seconds = _real(self.max_seconds, "search_budget.max_seconds")
            if not (np.isfinite(seconds) and seconds > 0.0):
                raise InvalidInputError("search_budget.max_seconds", "a positive number of seconds or None",
                                        repr(self.max_seconds))
            object.__setattr__(self, "max_seconds", seconds)


@record
class ResolvedRegion:
    """An :class:`AxisRegion` made concrete for one data set (internal).

    Attributes
    ----------
    frame : ndarray, shape (3, 3)
        Rows: two unit vectors of the reference plane, then the reference axis.
    origin : ndarray, shape (3,)
        Foot of the data centroid on the reference axis (mm).
    tan_max : float
        ``tan(cone_deg)``: the region's tilt ``(a, b)`` of the axis ``(a, b, 1)`` lies in this disc.
    offset : float
        Largest crossing offset (mm).
    domain : str
        Plain-language statement of the region.
    """

    frame: FloatArray
    origin: FloatArray
    tan_max: float
    offset: float
    domain: str


def resolve_region(
    region: AxisRegion | None, centroid: FloatArray, ls_axis: FloatArray, ls_point: FloatArray, ls_radius: float
) -> ResolvedRegion:
    """Concrete frame, origin and limits of ``region`` (None: the default) for data of this centroid.

    ``ls_axis``, ``ls_point``, ``ls_radius``: the least-squares cylinder (the default reference).
    """
    region = AxisRegion() if region is None else region
    if not isinstance(region, AxisRegion):
        raise InvalidInputError("axis_region", "an AxisRegion or None", type(region).__name__)
    if region.axis is None:
        axis, through, reference = np.asarray(ls_axis, float), np.asarray(ls_point, float), "the least-squares axis"
    else:
        axis = region.axis
        through = ls_point if region.point is None else region.point
        reference = "the nominal axis"
    axis = axis / np.linalg.norm(axis)
    origin = through + float((centroid - through) @ axis) * axis
    if region.offset_mm is None:
        offset = DEFAULT_OFFSET_RADII * float(ls_radius)
        offset_text = f"2R = {offset:.4g} mm"
    else:
        offset = float(region.offset_mm)
        offset_text = f"{offset:.4g} mm"
    domain = (
        f"axes within {region.cone_deg:g} deg of {reference}, crossing its normal plane at the data centroid "
        f"within {offset_text} of it"
    )
    return ResolvedRegion(
        frame=rotation_to_z(axis),
        origin=origin,
        tan_max=float(np.tan(np.radians(region.cone_deg))),
        offset=offset,
        domain=domain,
    )


def as_budget(budget: SearchBudget | None) -> SearchBudget:
    """The given budget or the default one."""
    if budget is None:
        return SearchBudget()
    if not isinstance(budget, SearchBudget):
        raise InvalidInputError("search_budget", "a SearchBudget or None", type(budget).__name__)
    return budget


def check_minimax_only(criterion: Criterion, **options: object) -> None:
    """Raise :class:`InvalidInputError` for a minimax-only option (region, budget) given to a Gaussian fit."""
    if criterion == "gaussian":
        for name, value in options.items():
            if value is not None:
                raise InvalidInputError(name, "None with criterion='gaussian' (minimax criteria only)", repr(value))


def _numeric(value: ArrayLike) -> bool:
    try:
        np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return False
    return True


def _real(value: object, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InvalidInputError(name, "a real number", repr(value))
    return float(value)
