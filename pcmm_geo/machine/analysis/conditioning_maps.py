"""Maps of the predicted tip uncertainty: over start poses (and the choice of a session's start) and the workspace.

:func:`start_map` evaluates :func:`~pcmm_geo.machine.analysis.conditioning.pose_conditioning` over the
session box of every start of a grid (each motor within the test programme's span of its start) and
:func:`choose_start` picks the start ``pcmm acquire`` commands; :func:`workspace_map` evaluates it over a
horizontal plane of tip positions.  ``docs/machine.md`` ("The start pose") plots both.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.errors import InvalidInputError
from pcmm_geo.machine.analysis.conditioning import pose_conditioning, reachable_poses
from pcmm_geo.machine.analysis.logproc.gate import SEED_LASER_SIGMA, SEED_LASER_STEPS
from pcmm_geo.machine.kinematics.model import RigidBodyMachine, as_readings

__all__ = [
    "CONDITIONED_START_OFFSETS",
    "DEFAULT_TARGET_TIP_U",
    "MIN_SEPARATION",
    "START_AXIS",
    "START_SPAN",
    "StartMap",
    "WorkspaceMap",
    "choose_start",
    "start_map",
    "workspace_map",
]

FloatArray = NDArray[np.float64]

#: how far the test programme of ``pcmm acquire`` moves each motor from its start, mm (the pre-sequence span,
#: 40 320 microsteps of the T-LSR450B: 20.0 mm)
START_SPAN = 40_320 * 0.49609375e-3
#: the worst single-move tip uncertainty a start's whole session box may have (mm), :func:`choose_start`
DEFAULT_TARGET_TIP_U = 0.1
#: start offsets searched by :func:`start_map`: offsets of pivots b and c from level, mm (pivot a: minus their sum)
START_AXIS = np.arange(-150.0, 151.0, 10.0)
#: the smallest height difference two pivots may reach within a start's session box (mm), :attr:`StartMap.eligible`
MIN_SEPARATION = 20.0
#: the start ``pcmm acquire`` commands by default on the seed geometry: pivots a, b, c this far from level (mm),
#: ``choose_start(start_map(RigidBodyMachine.from_dpkm()))`` (tested): the least tilted start whose whole
#: session box (+-20 mm per motor) keeps every two pivots 20 mm apart and has a worst single-move tip u of at
#: most 0.1 mm (0.098 mm; 0.076 mm at the start itself; the thesis' level start: unbounded)
CONDITIONED_START_OFFSETS: tuple[float, float, float] = (70.0, -70.0, 0.0)


@record
class StartMap:
    """Predicted conditioning of sessions by their start pose (:func:`start_map`; lengths in mm).

    A start is given by its offsets from the level (reference) heights, ``(o_a, o_b, o_c)`` with
    ``o_a = -(o_b + o_c)``: their mean is zero, so the common height (which the lasers never see) stays
    the thesis' and the tip's height with it.  A session from it keeps each motor within ``span`` of its
    start (the pre-sequence span of the test programme): its *box* is the 27 poses ``start + {-span, 0,
    span}^3``.

    Attributes
    ----------
    axis : ndarray, shape (n,)
        The values of ``o_b`` and of ``o_c`` searched.
    offsets : ndarray, shape (n, n, 3)
        ``(o_a, o_b, o_c)`` of every start; ``offsets[j, k]`` has ``o_b = axis[j]``, ``o_c = axis[k]``.
    start_tip_u : ndarray, shape (n, n)
        ``PoseConditioning.tip_u`` at the start (inf: unreachable).
    box_tip_u : ndarray, shape (n, n)
        The largest ``tip_u`` over the box (inf: some box pose outside the travel or the laser range).
    box_ambiguity_ratio : ndarray, shape (n, n)
        The smallest ``PoseConditioning.ambiguity_ratio`` over the box (below 1: a mirror within reach).
    box_separation : ndarray, shape (n, n)
        The smallest height difference of two pivots anywhere in the box, ``min |o_i - o_j| - 2 span``
        (negative: two pivots can be level there).
    tilt : ndarray, shape (n, n)
        Largest height difference between two pivots at the start (how far from the level start).
    span : float
    """

    axis: FloatArray
    offsets: FloatArray
    start_tip_u: FloatArray
    box_tip_u: FloatArray
    box_ambiguity_ratio: FloatArray
    box_separation: FloatArray
    tilt: FloatArray
    span: float

    @property
    def eligible(self) -> NDArray[np.bool_]:
        """Starts whose whole box is reachable and unambiguous and keeps every two pivots apart (n, n).

        Apart: by :data:`MIN_SEPARATION` (20 mm, about what the off-level start ``0 60 -60`` keeps).  The 27 poses of
        the box can miss a pose where two pivots are level, and near it the third pivot's mirror is exact
        and the reading that sees the pair's height difference loses its redundancy: with pivots a and b
        10 mm apart at the start (offsets 50, 40, -90 mm) laser c's redundancy numbers fell to 2e-4-1e-2 and
        the external reliability R reached 18 mm in default sessions, although every tip u stayed below 0.15 mm.
        """
        return (np.isfinite(self.box_tip_u) & (self.box_ambiguity_ratio >= 1.0)
                & (self.box_separation >= MIN_SEPARATION))


def start_map(
    machine: RigidBodyMachine,
    *,
    axis: ArrayLike = START_AXIS,
    span: float = START_SPAN,
    laser_sigma: float = SEED_LASER_SIGMA,
    laser_steps: ArrayLike = SEED_LASER_STEPS,
) -> StartMap:
    """Predicted conditioning of the sessions from every start of a grid (:class:`StartMap`).

    Parameters
    ----------
    machine : RigidBodyMachine
        Its ``reference_heights`` are the level start (the thesis': one encoder count for all motors).
    axis : array_like, shape (n,)
        Offsets of pivots b and c from level to search (mm; default -150 to 150 mm in 10 mm steps).
    span : float
        How far a session moves each motor from its start (mm; default the programme's 20 mm).
    laser_sigma, laser_steps : float, array_like (3,)
        The processing's noise model (:func:`pose_conditioning`).

    Raises
    ------
    InvalidInputError
        An empty or non-finite axis, or a negative span.

    Examples
    --------
    >>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
    >>> found = start_map(RigidBodyMachine.from_dpkm(), axis=[0.0, 60.0], span=20.0)
    >>> found.offsets[1, 0].tolist(), bool(found.box_tip_u[0, 0] > 1e3), bool(found.box_tip_u[1, 0] < 0.2)
    ([-60.0, 60.0, 0.0], True, True)
    """
    values = np.asarray(axis, dtype=float).ravel()
    if values.size == 0 or not np.all(np.isfinite(values)):
        raise InvalidInputError("axis", "finite offsets in mm", repr(axis))
    if not (np.isfinite(span) and span >= 0):
        raise InvalidInputError("span", "a non-negative length in mm", str(span))
    b, c = np.meshgrid(values, values, indexing="ij")
    offsets = np.stack([-(b + c), b, c], axis=-1)
    corners = np.array(np.meshgrid(*[(-span, 0.0, span)] * 3, indexing="ij")).reshape(3, -1).T  # (27, 3)
    starts = machine.reference_heights + offsets.reshape(-1, 3)
    poses = (starts[:, None, :] + corners[None]).reshape(-1, 3)
    conditioning = pose_conditioning(machine, poses, laser_sigma=laser_sigma, laser_steps=laser_steps)
    reachable = reachable_poses(machine, poses, conditioning).reshape(len(starts), -1)
    tip_u = np.where(reachable, conditioning.tip_u.reshape(len(starts), -1), np.inf)
    ratio = conditioning.ambiguity_ratio.reshape(len(starts), -1)
    shape = b.shape
    centre = len(corners) // 2  # the start itself
    return StartMap(
        axis=values, offsets=offsets, start_tip_u=tip_u[:, centre].reshape(shape),
        box_tip_u=tip_u.max(axis=1).reshape(shape), box_ambiguity_ratio=ratio.min(axis=1).reshape(shape),
        box_separation=np.min(np.abs(offsets[..., [0, 1, 2]] - offsets[..., [1, 2, 0]]), axis=-1) - 2.0 * span,
        tilt=(offsets.max(axis=-1) - offsets.min(axis=-1)), span=float(span),
    )


def choose_start(found: StartMap, target_tip_u: float = DEFAULT_TARGET_TIP_U) -> FloatArray:
    """The start offsets ``(3,)`` (mm from level) a session should begin at, from a :class:`StartMap`.

    The rule: of the eligible starts (:attr:`StartMap.eligible`: the whole box reachable, unambiguous, every
    two pivots at least 20 mm apart), and whose worst single-move
    tip uncertainty over the box is at most ``target_tip_u``, the least tilted one (the largest height
    difference between two pivots smallest: the nearest to the thesis' level start, so the tip stays
    nearest its working volume and the most travel is left); of equally tilted ones, the best
    conditioned.  When no start reaches the target, the best-conditioned eligible start.

    Raises
    ------
    InvalidInputError
        A non-positive target, or no eligible start in the map.

    Examples
    --------
    >>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
    >>> found = start_map(RigidBodyMachine.from_dpkm(), axis=np.arange(-80.0, 81.0, 20.0))
    >>> choose_start(found).tolist()
    [80.0, -80.0, 0.0]
    """
    if not target_tip_u > 0:
        raise InvalidInputError("target_tip_u", "a positive length in mm", str(target_tip_u))
    eligible = found.eligible
    if not eligible.any():
        raise InvalidInputError("start map", "at least one start whose session box is reachable, unambiguous and "
                                "keeps the pivots apart", "none")
    good = eligible & (found.box_tip_u <= target_tip_u)
    if good.any():
        tilts = np.where(good, found.tilt, np.inf)
        rank = np.where(tilts == tilts.min(), found.box_tip_u, np.inf)
    else:
        rank = np.where(eligible, found.box_tip_u, np.inf)
    index = np.unravel_index(int(np.argmin(rank)), rank.shape)
    return found.offsets[index].copy()


@record
class WorkspaceMap:
    """Predicted tip uncertainty over a horizontal plane of tip positions (:func:`workspace_map`; mm).

    Attributes
    ----------
    x, y : ndarray, shape (nx,), (ny,)
        Grid of tip positions; ``z`` the plane's height.
    tip_u, ambiguity_ratio : ndarray, shape (nx, ny)
        ``PoseConditioning.tip_u`` and ``.ambiguity_ratio`` (NaN: not reachable).
    heights : ndarray, shape (nx, ny, 3)
        The pivot heights of each tip (NaN: not reachable).
    """

    x: FloatArray
    y: FloatArray
    z: float
    tip_u: FloatArray
    ambiguity_ratio: FloatArray
    heights: FloatArray


def workspace_map(
    machine: RigidBodyMachine,
    *,
    center: ArrayLike | None = None,
    size: float = 300.0,
    points: int = 61,
    laser_sigma: float = SEED_LASER_SIGMA,
    laser_steps: ArrayLike = SEED_LASER_STEPS,
) -> WorkspaceMap:
    """:func:`pose_conditioning` of the tips on a square horizontal grid (unreachable tips: NaN).

    Parameters
    ----------
    center : array_like, shape (3,), optional
        Centre of the square and its height (default: the tip at the reference heights, the level start).
    size : float
        Edge of the square (mm).
    points : int
        Grid points per side (>= 2).

    Examples
    --------
    >>> from pcmm_geo.machine.kinematics.model import RigidBodyMachine
    >>> found = workspace_map(RigidBodyMachine.from_dpkm(), size=100.0, points=3)
    >>> bool(found.tip_u[1, 1] > 100.0), bool(np.nanmin(found.tip_u) < 1.0)  # level in the middle
    (True, True)
    """
    if not (np.isfinite(size) and size > 0):
        raise InvalidInputError("size", "a positive length in mm", str(size))
    if int(points) < 2:
        raise InvalidInputError("points", "at least 2", str(points))
    middle = (machine.forward(heights=machine.reference_heights).tip if center is None
              else as_readings(center, "center").reshape(3))
    x = middle[0] + np.linspace(-size / 2, size / 2, int(points))
    y = middle[1] + np.linspace(-size / 2, size / 2, int(points))
    gx, gy = np.meshgrid(x, y, indexing="ij")
    tips = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, middle[2])], axis=1)
    solution = machine.inverse(tips, check_limits=False)
    heights = np.asarray(solution.heights, dtype=float)
    usable = np.asarray(solution.converged) & np.all(np.isfinite(heights), axis=1)
    tip_u = np.full(len(tips), np.nan)
    ratio = np.full(len(tips), np.nan)
    if usable.any():
        conditioning = pose_conditioning(machine, heights[usable], lasers=np.asarray(solution.lasers)[usable],
                                         laser_sigma=laser_sigma, laser_steps=laser_steps)
        reachable = reachable_poses(machine, heights[usable], conditioning)
        tip_u[np.flatnonzero(usable)[reachable]] = conditioning.tip_u[reachable]
        ratio[np.flatnonzero(usable)[reachable]] = conditioning.ambiguity_ratio[reachable]
        usable[np.flatnonzero(usable)[~reachable]] = False
    heights[~usable] = np.nan
    shape = gx.shape
    return WorkspaceMap(x=x, y=y, z=float(middle[2]), tip_u=tip_u.reshape(shape),
                        ambiguity_ratio=ratio.reshape(shape), heights=heights.reshape(*shape, 3))
