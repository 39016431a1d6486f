"""Travel, measuring range and consistency limits of the micro-CMM (the machine's reachable readings).

The kinematic equations have solutions far outside what the machine can do: a pivot 5 m up
its column, a laser reading of -1300 mm, a tip 2 m away.  :class:`MachineLimits` holds what
the hardware allows, and :class:`~pcmm_geo.machine.kinematics.model.RigidBodyMachine` checks
every reading it is given or computes against it:

* **column travel** -- each pivot rides a Zaber T-LSR lead-screw stage with a *travel of
  450 mm* (thesis 3.1).  The stages home at the bottom (Appendix A step 14) and park at
  *247 500 microsteps* (Appendix A step 20), which is ``247500 * 6.35 mm / 12800`` =
  122.78 mm above home (T-LSR450B: 6.35 mm lead, 12 800 microsteps per turn,
  docs/protocols.md section 1).  In the seed's height frame (height reading = pivot ``z``)
  the pivots stand near 400 mm at the start position (Appendix E's absolute heights
  381-401 mm; :func:`~pcmm_geo.machine.kinematics.model.seed_machine` and the acquisition
  simulator put the park position at 400 mm), hence the default travel
  ``[400 - 122.78, 400 + 327.22]`` = 277.22-727.22 mm for every column.  A machine whose
  height readings use another datum needs its own :class:`MachineLimits`;
* **laser measuring range** -- the optoNCDT sensors (ILD1302 on arms a and b, ILD1420 on arm
  c, thesis Appendix A) have a *200 mm measuring range* (thesis 3.1) that starts *60 mm*
  from the sensor (start of measuring range, thesis 5.3 and Appendix D line 37).  The reading
  is the distance from that start, so the range of a reading is ``[0, 200]`` mm.  (The
  sensors' digital output has 1 % reserve bands beyond both ends, -2..202 mm, which are
  outside the specified range and are refused here);
* **closure tolerance** -- laser and height readings together over-determine the pose (six
  readings, three motors).  After the weighted least-squares solve, the largest loop-closure
  residual ``|T(joint_i) - pivot_i|`` evaluated with the *measured* readings is compared with
  ``closure_tolerance``; the default 0.25 mm is five times the lasers' accuracy of 0.05 mm
  (thesis 3.1).  With one kind of reading only, the residual is the change the solve had to
  make to the readings to find a pose at all (zero when the readings are realisable).

Boundary values are inside (closed intervals); computed readings may exceed a limit by
:data:`BOUNDARY_SLACK` (round-off) and still count as inside.

Examples
--------
>>> limits = MachineLimits.seed()
>>> limits.laser_range[0].tolist(), limits.height_travel[0].round(4).tolist()
([0.0, 200.0], [277.2168, 727.2168])
>>> try:
...     limits.check_lasers([[10.0, 20.0, 30.0], [10.0, 250.0, 30.0]])
... except OutOfRangeError as exc:
...     print(exc.quantity, exc.high, exc.index)
lasers[1, 1] (laser b measuring range) 200.0 (1, 1)
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import InconsistentMeasurementError, InvalidInputError, NoRealSolutionError, OutOfRangeError

__all__ = [
    "BOUNDARY_SLACK",
    "CLOSURE_TOLERANCE",
    "COLUMN_TRAVEL",
    "LASER_MEASURING_RANGE",
    "PARK_ABOVE_HOME",
    "MachineLimits",
    "arm_spans",
    "check_inverse",
    "check_reach",
    "check_readings",
    "closure_norms",
    "index_label",
]

FloatArray = NDArray[np.float64]

#: travel of each column's lead-screw stage (mm), thesis 3.1 (Zaber T-LSR, "a travel of 450 mm")
COLUMN_TRAVEL = 450.0
#: park position above home (mm): 247 500 microsteps (Appendix A step 20) x 6.35 mm / 12 800 (T-LSR450B)
PARK_ABOVE_HOME = 247_500 * 6.35 / 12_800
#: measuring range of the lasers (mm), thesis 3.1; readings count from the 60 mm start of range
LASER_MEASURING_RANGE = 200.0
#: default closure tolerance (mm): five times the lasers' 0.05 mm accuracy (thesis 3.1)
CLOSURE_TOLERANCE = 0.25
#: computed readings may overshoot a limit by this much (mm, round-off) and still count as inside
BOUNDARY_SLACK = 1e-9

_ARMS = ("a", "b", "c")


def index_label(index: tuple[int, ...]) -> str:
    """``"[4, 1]"`` for an element index of a ``(..., 3)`` array.

    Examples
    --------
    >>> index_label((4, 1)), index_label((2,))
    ('[4, 1]', '[2]')
    """
    return "[" + ", ".join(str(int(k)) for k in index) + "]"


def _interval_rows(value: ArrayLike, name: str) -> FloatArray:
    """``[low, high]`` per arm, shape (3, 2), from one interval (2,) or one per arm (3, 2)."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInputError(name, "[low, high] or one [low, high] per arm (mm)", repr(value)) from None
    if arr.shape == (2,):
        arr = np.tile(arr, (3, 1))
    if arr.shape != (3, 2) or not np.all(np.isfinite(arr)) or np.any(arr[:, 0] > arr[:, 1]):
        raise InvalidInputError(
            name, "finite [low, high] with low <= high, shape (2,) or (3, 2)", f"{arr.tolist()} (shape {arr.shape})"
        )
    arr.setflags(write=False)
    return arr


@record
class MachineLimits:
    """What the machine can physically read: column travel, laser range, closure tolerance.

    Attributes
    ----------
    height_travel : ndarray, shape (3, 2)
        ``[low, high]`` of the height (encoder) reading of columns a, b, c, in the machine's
        height-reading units (mm for the seed).  A ``(2,)`` value applies to all columns.
    laser_range : ndarray, shape (3, 2)
        ``[low, high]`` of the laser readings a, b, c (mm from the start of measuring range).
    closure_tolerance : float
        Largest accepted loop-closure residual (mm) of the measured readings after the solve.

    Examples
    --------
    >>> limits = MachineLimits(height_travel=[0.0, 450.0], laser_range=[0.0, 200.0])
    >>> limits.height_travel.shape, limits.closure_tolerance
    ((3, 2), 0.25)
    """

    height_travel: FloatArray
    laser_range: FloatArray = field(default_factory=lambda: np.array([0.0, LASER_MEASURING_RANGE]))
    closure_tolerance: float = CLOSURE_TOLERANCE

    def __post_init__(self) -> None:
        object.__setattr__(self, "height_travel", _interval_rows(self.height_travel, "height_travel"))
        object.__setattr__(self, "laser_range", _interval_rows(self.laser_range, "laser_range"))
        tolerance = self.closure_tolerance
        if not (isinstance(tolerance, (int, float)) and np.isfinite(tolerance) and tolerance > 0):
            raise InvalidInputError("closure_tolerance", "a positive finite length in mm", repr(tolerance))
        object.__setattr__(self, "closure_tolerance", float(tolerance))

    # ------------------------------------------------------------------ construction
    @classmethod
    def seed(cls, park_heights: ArrayLike = (400.0, 400.0, 400.0)) -> MachineLimits:
        """The seed machine's limits, with the park position at ``park_heights``.

        Travel ``[h - 122.78, h + 327.22]`` per column (450 mm, park 247 500 microsteps above
        home), lasers ``[0, 200]`` mm, closure tolerance 0.25 mm (module notes).  The default
        park heights (400 mm) are the seed's height frame; this is the default of every
        :class:`~pcmm_geo.machine.kinematics.model.RigidBodyMachine` and of machine files
        written before limits existed.

        Examples
        --------
        >>> MachineLimits.seed([0.0, 0.0, 10.0]).height_travel[2].round(4).tolist()
        [-112.7832, 337.2168]
        """
        heights = np.asarray(park_heights, dtype=float)
        if heights.shape != (3,) or not np.all(np.isfinite(heights)):
            raise InvalidInputError("park_heights", "3 finite heights (mm)", repr(park_heights))
        low = heights - PARK_ABOVE_HOME
        return cls(np.column_stack([low, low + COLUMN_TRAVEL]))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (mm); read back by :meth:`from_dict`."""
        return {
            "height_travel": {arm: self.height_travel[k].tolist() for k, arm in enumerate(_ARMS)},
            "laser_range": {arm: self.laser_range[k].tolist() for k, arm in enumerate(_ARMS)},
            "closure_tolerance": self.closure_tolerance,
            "units": "mm",
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> MachineLimits:
        """Rebuild limits written by :meth:`to_dict`.

        Raises
        ------
        InvalidInputError
            Missing keys, wrong shapes, low above high, non-positive tolerance.

        Examples
        --------
        >>> limits = MachineLimits.seed()
        >>> MachineLimits.from_dict(limits.to_dict()) == limits
        True
        """
        if not isinstance(data, Mapping):
            raise InvalidInputError("limits", "a mapping", type(data).__name__)
        try:
            travel = data["height_travel"]
            lasers = data["laser_range"]
            if isinstance(travel, Mapping):
                travel = [travel[arm] for arm in _ARMS]
            if isinstance(lasers, Mapping):
                lasers = [lasers[arm] for arm in _ARMS]
            return cls(travel, lasers, data.get("closure_tolerance", CLOSURE_TOLERANCE))
        except (KeyError, TypeError) as exc:
            raise InvalidInputError("limits", "height_travel and laser_range per arm a, b, c", repr(exc)) from None

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, MachineLimits):
            return NotImplemented
        return (
            np.array_equal(self.height_travel, other.height_travel)
            and np.array_equal(self.laser_range, other.laser_range)
            and self.closure_tolerance == other.closure_tolerance
        )

    # ------------------------------------------------------------------ checks
    def check_heights(self, heights: ArrayLike, *, name: str = "heights", context: str = "") -> None:
        """Raise :class:`OutOfRangeError` for the first height reading outside the column travel.

        ``heights`` has shape ``(..., 3)``; the error's ``quantity`` names the index, e.g.
        ``"heights[4, 1] (column b travel)"``, and carries ``index`` (a tuple) and ``count`` (how
        many readings are outside).
        """
        check_readings(heights, self.height_travel, name, "column", context)

    def check_lasers(self, lasers: ArrayLike, *, name: str = "lasers", context: str = "") -> None:
        """Raise :class:`OutOfRangeError` for the first laser reading outside the measuring range."""
        check_readings(lasers, self.laser_range, name, "laser", context)

    def check_readings(self, lasers: ArrayLike | None, heights: ArrayLike | None) -> None:
        """Check measured laser and height readings ``(..., 3)`` (either may be None)."""
        if lasers is not None:
            self.check_lasers(lasers)
        if heights is not None:
            self.check_heights(heights)

    def check_solution(self, residuals: ArrayLike, lasers: ArrayLike | None, heights: ArrayLike | None) -> None:
        """Check a forward solution: closure of the measured readings, then the implied ones.

        ``lasers`` / ``heights`` are the *solved* readings of the kind that was **not**
        measured, ``None`` for the kind that was (at least one is None).
        """
        measured = " and ".join(name for name, implied in (("lasers", lasers), ("heights", heights)) if implied is None)
        self.check_closure(residuals, what=measured)
        if lasers is not None:
            self.check_lasers(lasers, context="implied by the heights")
        if heights is not None:
            self.check_heights(heights, context="implied by the lasers and the heights hint")

    def check_closure(self, residuals: ArrayLike, *, what: str, detail: str = "") -> None:
        """Raise :class:`InconsistentMeasurementError` where a closure residual exceeds the tolerance.

        Parameters
        ----------
        residuals : array_like, shape (..., 9)
            Loop-closure residuals (x, y, z of arms a, b, c), mm.
        what : str
            Names the readings, e.g. ``"lasers and heights"``.
        """
        norms = closure_norms(residuals)
        bad = norms > self.closure_tolerance
        if not np.any(bad):
            return
        first = tuple(int(k) for k in np.argwhere(bad)[0])
        where = f"{what}{index_label(first)}" if first else what
        per_arm = np.linalg.norm(np.asarray(residuals, dtype=float)[first].reshape(3, 3), axis=1)
        arm = _ARMS[int(np.argmax(per_arm))]
        text = f"largest at arm {arm}; no pose of the machine matches these readings"
        if int(bad.sum()) > 1:
            text += f"; {int(bad.sum())} of {bad.size} samples inconsistent"
        error = InconsistentMeasurementError(
            f"loop closure of {where}", round(float(norms[first]), 6), self.closure_tolerance, "mm",
            text + (f"; {detail}" if detail else ""),
        )
        _attach(error, index=first, count=int(bad.sum()))
        raise error


def closure_norms(residuals: ArrayLike) -> FloatArray:
    """Largest per-arm closure distance ``max_i |r_i|`` (mm) of residuals ``(..., 9)`` -> ``(...)``."""
    arr = np.asarray(residuals, dtype=float)
    return np.linalg.norm(arr.reshape(*arr.shape[:-1], 3, 3), axis=-1).max(axis=-1)


def _attach(error: Exception, **fields: Any) -> None:
    error.fields.update(fields)  # type: ignore[attr-defined]
    for key, value in fields.items():
        setattr(error, key, value)


def check_readings(values: ArrayLike, interval: ArrayLike, name: str, part: str, context: str = "") -> None:
    """Raise :class:`OutOfRangeError` for the first reading ``(..., 3)`` outside ``[low, high]`` of its arm.

    ``interval`` is ``(2,)`` or one row per arm ``(3, 2)``; ``part`` is ``"laser"`` or
    ``"column"`` (used in the message).  Fields ``index`` (tuple) and ``count`` are attached.

    Examples
    --------
    >>> try:
    ...     check_readings([10.0, 20.0, -3.0], [0.0, 200.0], "lasers", "laser")
    ... except OutOfRangeError as exc:
    ...     print(exc)
    lasers[2] (laser c measuring range): expected a value in [0.0, 200.0] mm, got -3.0 mm
    """
    values = np.asarray(values, dtype=float)
    interval = np.broadcast_to(np.asarray(interval, dtype=float), (3, 2))
    low, high = interval[:, 0], interval[:, 1]
    bad = (values < low - BOUNDARY_SLACK) | (values > high + BOUNDARY_SLACK)
    if not np.any(bad):
        return
    first = tuple(int(k) for k in np.argwhere(bad)[0])
    arm = first[-1]
    kind = {"column": " travel", "laser": " measuring range"}.get(part, "")
    quantity = f"{name}{index_label(first)} ({part} {_ARMS[arm]}{kind}{', ' + context if context else ''})"
    if int(bad.sum()) > 1:
        quantity += f" [{int(bad.sum())} readings outside]"
    error = OutOfRangeError(
        quantity, round(float(values[first]), 6), float(low[arm]), float(high[arm]), "mm"
    )
    _attach(error, index=first, count=int(bad.sum()))
    raise error


def arm_spans(geometry: Any, limits: MachineLimits) -> FloatArray:
    """Shortest and longest tip-to-joint distance of each arm within the laser range, ``(3, 2)`` mm.

    ``geometry`` is the machine's stacked geometry
    (:attr:`~pcmm_geo.machine.kinematics.model.RigidBodyMachine.geometry`).  For the seed
    the arm length is ``laser + 60 + d_i``, so arm a spans 354.02-554.02 mm.
    """
    spans = np.empty((3, 2))
    for arm in range(3):
        slide = geometry.laser_scale[arm] * limits.laser_range[arm] + geometry.laser_offset[arm]
        s_low, s_high = np.sort(slide)
        start = geometry.slider_points[arm] - geometry.tip_center
        along = geometry.slider_directions[arm]
        nearest = float(np.clip(-(start @ along), s_low, s_high))
        ends = [float(np.linalg.norm(start + s_val * along)) for s_val in (s_low, s_high)]
        spans[arm] = (float(np.linalg.norm(start + nearest * along)), max(ends))
    return spans


def check_reach(geometry: Any, limits: MachineLimits, tips: ArrayLike) -> None:
    """Raise :class:`OutOfRangeError` for the first tip no arm-and-column pair can reach.

    A necessary condition for reaching tip ``X``: for each arm, some pivot position within the
    column travel lies at a distance from ``X`` that the arm spans within the laser range
    (:func:`arm_spans`).  Tips failing it are outside the workspace whatever the pose; the
    error's ``quantity`` is ``"distance of tip[i] from column a"`` with the arm's span as
    ``low``/``high``.

    Examples
    --------
    >>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
    >>> m = RigidBodyMachine.from_dpkm()
    >>> try:
    ...     check_reach(m.geometry, m.limits, [2000.0, 0.0, 90.0])
    ... except OutOfRangeError as exc:
    ...     print(exc.quantity, round(exc.value, 1), round(exc.high, 2))
    distance of tip from column a 2275.9 554.02
    """
    points = np.asarray(tips, dtype=float)
    lead = points.shape[:-1]
    spans = arm_spans(geometry, limits)
    for arm in range(3):
        along = geometry.encoder_scale[arm] * limits.height_travel[arm]
        z_low, z_high = np.sort(along)
        direction = geometry.column_directions[arm]
        offset = points - geometry.column_points[arm]
        nearest = np.clip(offset @ direction, z_low, z_high)
        closest = np.linalg.norm(offset - nearest[..., None] * direction, axis=-1)
        farthest = np.maximum(
            np.linalg.norm(offset - z_low * direction, axis=-1), np.linalg.norm(offset - z_high * direction, axis=-1)
        )
        too_far = closest > spans[arm, 1] + BOUNDARY_SLACK
        too_near = farthest < spans[arm, 0] - BOUNDARY_SLACK
        bad = too_far | too_near
        if not np.any(bad):
            continue
        first = tuple(int(k) for k in np.argwhere(bad)[0]) if lead else ()
        value = closest[first] if too_far[first] else farthest[first]
        quantity = f"distance of tip{index_label(first) if first else ''} from column {_ARMS[arm]}"
        if int(bad.sum()) > 1:
            quantity += f" [{int(bad.sum())} tips outside]"
        error = OutOfRangeError(quantity, round(float(value), 6), round(float(spans[arm, 0]), 6),
                                round(float(spans[arm, 1]), 6), "mm")
        _attach(error, index=first, count=int(bad.sum()), arm=_ARMS[arm])
        raise error


def check_inverse(
    limits: MachineLimits,
    target: FloatArray,
    converged: NDArray[np.bool_],
    error: FloatArray,
    state: Any,
    lead: tuple[int, ...],
) -> None:
    """Raise for inverse solutions that failed or need readings outside the limits.

    ``converged`` and ``error`` (largest open equation, mm) have the leading shape ``lead``
    of the targets ``(..., 3)``; ``state`` holds the solved ``heights`` and ``lasers`` ``(K, 3)``.

    Raises
    ------
    NoRealSolutionError
        A target whose equations were not closed (field ``index``).
    OutOfRangeError
        A needed height or laser reading outside the limits.
    """
    if not np.all(converged):
        first = tuple(int(k) for k in np.argwhere(~converged)[0]) if lead else ()
        point = ", ".join(f"{v:.6g}" for v in target[first])
        failed = int((~converged).sum())
        exc = NoRealSolutionError(
            f"inverse kinematics of tip{index_label(first) if first else ''} = ({point}) mm",
            detail="the Newton iteration found no pose that puts the tip there "
            f"(equations left open by {float(error[first]):.3g} mm)"
            + (f"; {failed} of {converged.size} targets" if failed > 1 else ""),
        )
        exc.fields.update(index=first, count=failed)
        exc.index, exc.count = first, failed  # type: ignore[attr-defined]
        raise exc
    limits.check_heights(state.heights.reshape(*lead, 3), context="needed for the tip")
    limits.check_lasers(state.lasers.reshape(*lead, 3), context="needed for the tip")
