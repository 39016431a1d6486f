"""The simulated micro-CMM behind the I++ DME server: kinematics, workspace limits, probing.

Two machines are held:

* the **calibrated** model (:class:`~pcmm_geo.machine.kinematics.model.RigidBodyMachine`), the
  one the controller knows: it turns a commanded tip centre into column heights (inverse
  kinematics, with the workspace limits) and readings back into a reported tip centre
  (forward kinematics, lasers and heights weighted by their standard uncertainties);
* the **true** machine: the calibrated tetrahedron and tip radius moved by one draw of the
  calibration's covariance (``theta + L z`` over
  :data:`~pcmm_geo.uncertainty.calibration.MODEL_PARAMETERS`, the virtual micro-CMM's
  calibration group, :mod:`pcmm_geo.uncertainty.virtual_cmm`), fixed for the server's life.

A probing drives the columns to the heights the calibrated model gives for the commanded tip
centre; the true machine places the physical tip there (its forward kinematics from the
heights); the ball of the true radius touches the workpiece where its centre is that radius
from the surface.  The readings latched at contact are the true lasers plus Gaussian noise
(``laser_sigma``) and the true heights plus encoder noise (``encoder_sigma``), counted in
motor microsteps.  The calibrated forward kinematics turns them into the reported tip centre,
compensated by the calibrated radius against the probing direction.

A pose is flagged *poorly resolved* when the lasers resolve the relative column heights worse
than ``max_tip_uncertainty`` (``laser_sigma`` times the root sum of the inverse squared
non-trivial singular values of d lasers / d heights; the common height is invisible to the
lasers): near the level pose the lasers hardly see the heights, so a log processed from the
lasers (``pcmm process-log``) could not cross-check the columns there.
"""

from __future__ import annotations

import abc
from dataclasses import field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._records import record
from pcmm_geo.acquisition.drivers.zaber import T_LSR450B_MICROSTEP_MM
from pcmm_geo.errors import InvalidInputError, PcmmGeoError
from pcmm_geo.ippdme.workpieces import first_contact

__all__ = ["HOME_RAISE_MM", "MachineBackend", "MachineModel", "MoveRefused", "ProbeResult", "SimulatedMachine",
           "reachable_heights", "tip_uncertainties"]

FloatArray = NDArray[np.float64]
#: the home pose: every column this far above the model's reference (level) heights, mm
HOME_RAISE_MM = 40.0
#: path sampling of the workspace check of a straight move, mm
_PATH_CHECK_MM = 5.0
_ARMS = ("a", "b", "c")


class MoveRefused(Exception):
    """A move or probing the machine does not make: ``number`` is the I++ error (2500, 2504, 1006, 1010, 0503...)."""

    def __init__(self, number: int, detail: str, position: FloatArray | None = None) -> None:
        super().__init__(detail)
        self.number = number
        self.detail = detail
        self.position = position


@record
class MachineModel:
    """What the server knows about its micro-CMM and what it knows of its errors.

    Attributes
    ----------
    machine : RigidBodyMachine
        The calibrated model.
    tip_radius : float
        Calibrated tip radius (mm).
    calibration_covariance : ndarray, shape (28, 28) or None
        Covariance of the model parameters (None: calibration exact, true = calibrated).
    laser_sigma, encoder_sigma : float
        Standard uncertainty of one laser / encoder reading (mm).
    microstep_mm : float
        Count step of the height readings (mm; the Zaber T-LSR450B microstep).
    """

    machine: Any
    tip_radius: float
    calibration_covariance: FloatArray | None = None
    laser_sigma: float = 0.0005
    encoder_sigma: float = 0.0002
    microstep_mm: float = T_LSR450B_MICROSTEP_MM

    @property
    def height_sigma(self) -> float:
        """Standard uncertainty of a height reading with its count step (uniform, ``step / sqrt 12``) (mm)."""
        return float(np.hypot(self.encoder_sigma, self.microstep_mm / np.sqrt(12.0)))


@record
class ProbeResult:
    """One probing: reported surface point and tip (calibrated model), readings, truth and flags (mm)."""

    point: FloatArray
    tip: FloatArray
    direction: FloatArray
    lasers: FloatArray
    heights: FloatArray
    effective_radius: float
    tip_uncertainty: float
    laser_only_tip_uncertainty: float
    poorly_resolved: bool
    true_tip: FloatArray
    retract_position: FloatArray = field(repr=False, default_factory=lambda: np.zeros(3))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields; ``true_tip_mm`` only where the truth is known (the simulated machine)."""
        out = {
            "point_mm": self.point.tolist(), "tip_mm": self.tip.tolist(), "ijk": self.direction.tolist(),
            "lasers_mm": self.lasers.tolist(), "heights_mm": self.heights.tolist(),
            "effective_radius_mm": self.effective_radius, "tip_uncertainty_mm": self.tip_uncertainty,
            "laser_only_tip_uncertainty_mm": self.laser_only_tip_uncertainty,
            "poorly_resolved": self.poorly_resolved,
        }
        if np.all(np.isfinite(self.true_tip)):
            out["true_tip_mm"] = self.true_tip.tolist()
        return out


class MachineBackend(abc.ABC):
    """The machine an I++ session drives: the simulated micro-CMM or the real one on its drivers.

    The session and command code (:mod:`pcmm_geo.ippdme.session`, :mod:`pcmm_geo.ippdme.commands`)
    is one protocol implementation for both; it reads ``position`` (the commanded tip centre,
    machine frame, mm), ``homed``, ``home_position`` and ``model`` and calls the coroutines below,
    which receive the session for its motion hooks (``session.motion``, ``session.run_blocking``)
    and its transcript (``session.record``).  Refusals are :class:`MoveRefused` with the spec's
    error number; the session answers them.
    """

    model: MachineModel
    position: FloatArray
    home_position: FloatArray
    homed: bool

    @abc.abstractmethod
    async def home(self, session: Any, speed: float) -> None:
        """Home the machine and bring the tip to :attr:`home_position`; ``homed`` is then True."""

    @abc.abstractmethod
    async def travel(self, session: Any, target: FloatArray, speed: float, *, check: bool = True) -> None:
        """Move the tip centre in a straight line to ``target`` at ``speed`` mm/s (2500 / 2504 refusals)."""

    @abc.abstractmethod
    async def measure(self, session: Any, nominal: FloatArray, direction: FloatArray, *, approach: float,
                      search: float, retract: float, speed: float) -> ProbeResult:
        """Single-point probing from the approach point (spec §6.3.2.13); 1006 when no surface is found."""

    async def read_position(self, session: Any) -> FloatArray:
        """The tip centre as the machine reports it now (machine frame, mm)."""
        return np.asarray(self.position, dtype=float).copy()

    def describe(self) -> dict[str, Any]:
        """JSON-ready description for the transcript header."""
        return {"backend": type(self).__name__}


def tip_uncertainties(model: MachineModel, lasers: FloatArray, heights: FloatArray, tips: FloatArray
                      ) -> tuple[FloatArray, FloatArray]:
    """``(N,)`` tip standard uncertainty from all readings; the lasers' resolution of the relative heights (mm).

    The first is the calibrated forward kinematics' propagation of the reading uncertainties
    (``laser_sigma``, :attr:`MachineModel.height_sigma`, central differences of the reported tip);
    the second is ``laser_sigma`` times the root sum of the inverse squared non-trivial singular
    values of d lasers / d heights (the common height is invisible to the lasers: parallel
    columns), infinite where the lasers do not see the relative heights at all.
    """
    step = 1e-4
    total = np.zeros(len(tips))
    for j in range(6):
        dl, dh = lasers.copy(), heights.copy()
        (dl if j < 3 else dh)[:, j % 3] += step
        sigma = model.laser_sigma if j < 3 else model.height_sigma
        total += np.sum(((reported_tip(model, dl, dh) - tips) / step * sigma) ** 2, axis=-1)
    base = np.asarray(model.machine.forward(heights=heights, lasers_hint=lasers, check_limits=False).lasers)
    jac = np.empty((len(tips), 3, 3))
    for j in range(3):
        dh = heights.copy()
        dh[:, j] += step
        moved = model.machine.forward(heights=dh, lasers_hint=lasers, check_limits=False).lasers
        jac[:, :, j] = (np.asarray(moved) - base) / step
    relative = np.eye(3) - 1.0 / 3.0
    singular = np.linalg.svd(jac @ relative, compute_uv=False)[:, :2]
    with np.errstate(divide="ignore"):
        alone = model.laser_sigma * np.sqrt(np.sum(1.0 / singular ** 2, axis=-1))
    ok = np.isfinite(alone)
    return np.sqrt(total), np.where(ok, alone, np.inf)


def reachable_heights(model: MachineModel, tips: ArrayLike, *, check: bool = True) -> FloatArray:
    """Column heights ``(..., 3)`` of tip centres by the calibrated inverse kinematics; unreachable: 2500.

    ``check=False`` solves without the workspace limits (points already checked).  Both machines
    (simulated and on the drivers) command their moves through it.
    """
    try:
        solution = model.machine.inverse(np.asarray(tips, dtype=float), check_limits=check)
    except PcmmGeoError as exc:
        raise MoveRefused(2500, str(exc).splitlines()[0][:200]) from None
    if not np.all(solution.converged):
        raise MoveRefused(2500, "no pose of the machine reaches the target")
    return np.asarray(solution.heights, dtype=float)


def reported_tip(model: MachineModel, lasers: FloatArray, heights: FloatArray) -> FloatArray:
    """Tip centres ``(N, 3)`` from readings ``(N, 3)``, ``(N, 3)``: calibrated forward kinematics (2500 if unsolved)."""
    solution = model.machine.forward(lasers=lasers, heights=heights, laser_sigma=model.laser_sigma,
                                     height_sigma=model.height_sigma, check_limits=False)
    if not np.all(solution.converged):
        raise MoveRefused(2500, "the readings do not solve the kinematics")
    return np.asarray(solution.tip, dtype=float)


def _perturbed(machine: Any, delta: FloatArray) -> Any:
    """The model with its tetrahedron moved by ``delta`` (24 slider + 3 tip-centre parameters, mm / unit)."""
    data = machine.to_dict()
    tetra = data["tetrahedron"]
    for i, arm in enumerate(_ARMS):
        slider = tetra["sliders"][arm]
        part = delta[8 * i:8 * i + 8]
        slider["point"] = (np.asarray(slider["point"]) + part[0:3]).tolist()
        slider["direction"] = (np.asarray(slider["direction"]) + part[3:6]).tolist()
        slider["laser_scale"] = float(slider["laser_scale"] + part[6])
        slider["laser_offset"] = float(slider["laser_offset"] + part[7])
    tetra["tip_centre"] = (np.asarray(tetra["tip_centre"]) + delta[24:27]).tolist()
    return type(machine).from_dict(data)


class SimulatedMachine(MachineBackend):
    """The micro-CMM an I++ client drives: commanded tip centre, homing, moves and probings.

    Parameters
    ----------
    model : MachineModel
    workpieces : list
        Objects with ``distance(points) -> (N,)`` (:mod:`pcmm_geo.ippdme.workpieces`).
    seed : int
        Seeds the true machine's draw and every reading's noise (same seed and commands:
        same points).
    max_tip_uncertainty : float
        Laser-only tip uncertainty (mm) above which a pose is flagged poorly resolved.
    """

    def __init__(self, model: MachineModel, workpieces: list[Any] | None = None, *, seed: int = 0,
                 max_tip_uncertainty: float = 1.0) -> None:
        if not max_tip_uncertainty > 0:
            raise InvalidInputError("max_tip_uncertainty", "a positive length in mm", repr(max_tip_uncertainty))
        self.model = model
        self.workpieces = list(workpieces or [])
        self.max_tip_uncertainty = float(max_tip_uncertainty)
        self.rng = np.random.default_rng(seed)
        calibrated = model.machine
        self.true_radius = float(model.tip_radius)
        if model.calibration_covariance is not None:
            cov = np.asarray(model.calibration_covariance, dtype=float)
            values, vectors = np.linalg.eigh(0.5 * (cov + cov.T))
            delta = (vectors * np.sqrt(np.clip(values, 0.0, None))) @ self.rng.standard_normal(28)
            self.true_machine = _perturbed(calibrated, delta)
            self.true_radius += float(delta[27])
        else:
            self.true_machine = calibrated
        reference = np.asarray(calibrated.reference_heights, dtype=float)
        self.home_position = self._forward_tip(calibrated, reference + HOME_RAISE_MM)
        self.position = self._forward_tip(calibrated, reference)
        self.homed = False

    # ------------------------------------------------------------------ kinematics
    @staticmethod
    def _forward_tip(machine: Any, heights: FloatArray) -> FloatArray:
        solution = machine.forward(heights=heights, lasers_hint=machine.reference_lasers, check_limits=False)
        return np.asarray(solution.tip, dtype=float).reshape(3)

    def heights_for(self, tips: ArrayLike, *, check: bool = True) -> FloatArray:
        """Column heights ``(..., 3)`` the controller commands for tip centres, refusing unreachable ones (2500).

        ``check=False`` solves without the workspace limits (points already checked).
        """
        return reachable_heights(self.model, tips, check=check)

    def check_path(self, start: FloatArray, end: FloatArray) -> FloatArray:
        """Refuse (2500) a straight move whose path leaves the workspace (checked every 5 mm); the end's heights."""
        heights = self.heights_for(np.asarray(end, dtype=float)[None])  # the target first: a far one costs one solve
        # both ends reachable: the path is within the workspace's size (a few hundred mm), so few samples
        count = min(400, max(2, int(np.ceil(np.linalg.norm(end - start) / _PATH_CHECK_MM)) + 1))
        self.heights_for(start + np.linspace(0.0, 1.0, count)[:, None] * (end - start))
        return heights[0]

    def collision(self, start: FloatArray, end: FloatArray) -> FloatArray | None:
        """Where a straight move's ball first touches a workpiece (None: free path)."""
        s = first_contact(self.workpieces, start, end, self.true_radius)
        if s is None or (s == 0.0 and np.linalg.norm(end - start) == 0):
            return None
        if s == 0.0:
            # already touching: moving away is free, pushing in is a collision
            probe = start + 1e-3 * (end - start) / max(float(np.linalg.norm(end - start)), 1e-12)
            if min(w.distance(probe[None])[0] for w in self.workpieces) > min(
                    w.distance(start[None])[0] for w in self.workpieces):
                return None
        return start + s * (end - start)

    # ------------------------------------------------------------------ probing
    def probe(self, nominal: FloatArray, direction: FloatArray, approach: float, search: float,
              retract: float) -> ProbeResult:
        """Single-point probing (spec §6.3.2.13): approach, search against ``direction``, latch, retract.

        ``nominal`` is the nominal surface point and ``direction`` the outward unit probing
        normal (machine frame).  Raises :class:`MoveRefused` (2500 unreachable approach or
        contact, 1006 no surface on the search path, with the position where the machine stopped).
        """
        n = np.asarray(direction, dtype=float)
        start = nominal + n * (float(self.model.tip_radius) + approach)
        if np.linalg.norm(self.position - start) > 1e-9:
            self.check_path(self.position, start)
        result = self.probe_many(np.asarray(nominal, float)[None], n[None], approach, search)[0]
        if isinstance(result, MoveRefused):
            self.position = result.position if result.position is not None else start
            raise result
        self.position = result.tip_commanded
        retract_to = self.position + n * retract if retract >= 0 else start
        return replace(result.result, retract_position=retract_to)

    def probe_many(self, nominals: FloatArray, directions: FloatArray, approach: float,
                   search: float, *, diagnostics: bool = True) -> list[Any]:
        """Probings of ``N`` nominal points ``(N, 3)`` along outward unit ``directions`` ``(N, 3)``, batched.

        Returns per point the probing (``.result``, a :class:`ProbeResult`; ``.tip_commanded``) or the
        :class:`MoveRefused` it met.  The machine's
        position is not changed (the caller moves it); the noise is drawn in point order.
        ``diagnostics=False`` skips the tip uncertainties (NaN, never flagged): same points, faster.
        """
        r_cal = float(self.model.tip_radius)
        starts = nominals + directions * (r_cal + approach)
        ends = nominals + directions * (r_cal - search)
        c0 = nominals + directions * r_cal
        out: list[Any] = [None] * len(nominals)
        try:
            # physical minus commanded tip centre: smooth, constant to ~1e-5 mm over a search path
            shift = self._true_pose(self.heights_for(c0, check=False))[0] - c0
        except MoveRefused as exc:
            return [exc] * len(nominals)
        commanded = np.empty_like(c0)
        found = np.zeros(len(c0), dtype=bool)
        for i in range(len(c0)):
            s = first_contact(self.workpieces, starts[i] + shift[i], ends[i] + shift[i], self.true_radius)
            if s is None:
                out[i] = MoveRefused(1006, "no surface along the search path", ends[i])
            else:
                commanded[i] = starts[i] + s * (ends[i] - starts[i])
                found[i] = True
        if not found.any():
            return out
        index = np.nonzero(found)[0]
        try:
            heights = self.heights_for(commanded[index])
        except MoveRefused as exc:
            for i in index:
                out[i] = exc
            return out
        true_tip, true_lasers = self._true_pose(heights)
        lasers, read_heights = self._read(true_lasers, heights)
        tips = self._reported_tip(lasers, read_heights)
        if diagnostics:
            u_both, u_lasers = self._tip_uncertainties(lasers, read_heights, tips)
        else:
            u_both = u_lasers = np.full(len(tips), np.nan)
        for k, i in enumerate(index):
            result = ProbeResult(
                point=tips[k] - r_cal * directions[i], tip=tips[k], direction=directions[i], lasers=lasers[k],
                heights=read_heights[k], effective_radius=r_cal, tip_uncertainty=float(u_both[k]),
                laser_only_tip_uncertainty=float(u_lasers[k]),
                poorly_resolved=bool(u_lasers[k] > self.max_tip_uncertainty or np.isinf(u_lasers[k])),
                true_tip=true_tip[k],
            )
            out[i] = _Probed(result, commanded[i])
        return out

    def _read(self, true_lasers: FloatArray, heights: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Readings of a pose: lasers with noise, heights with encoder noise counted in microsteps (mm)."""
        m = self.model
        lasers = true_lasers + self.rng.normal(0.0, m.laser_sigma, true_lasers.shape)
        counts = np.round((heights + self.rng.normal(0.0, m.encoder_sigma, heights.shape)) / m.microstep_mm)
        return lasers, counts * m.microstep_mm

    def readings(self, tip: FloatArray, heights: FloatArray | None = None) -> tuple[FloatArray, FloatArray]:
        """Laser and height readings ``(3,), (3,)`` (mm) at a commanded tip centre (its heights if known)."""
        if heights is None:
            h = self.heights_for(np.asarray(tip, dtype=float)[None], check=False)
        else:
            h = np.asarray(heights, dtype=float).reshape(1, 3)
        return tuple(r[0] for r in self._read(self._true_pose(h)[1], h))  # type: ignore[return-value]

    def _true_pose(self, heights: FloatArray) -> tuple[FloatArray, FloatArray]:
        solution = self.true_machine.forward(heights=heights, lasers_hint=self.model.machine.reference_lasers,
                                             check_limits=False)
        return np.asarray(solution.tip, dtype=float), np.asarray(solution.lasers, dtype=float)

    def _reported_tip(self, lasers: FloatArray, heights: FloatArray) -> FloatArray:
        return reported_tip(self.model, lasers, heights)

    def _tip_uncertainties(self, lasers: FloatArray, heights: FloatArray, tips: FloatArray
                           ) -> tuple[FloatArray, FloatArray]:
        return tip_uncertainties(self.model, lasers, heights, tips)

    # ------------------------------------------------------------------ the backend interface
    async def home(self, session: Any, speed: float) -> None:
        """Travel to the home pose (no workspace or collision check: the machine's own homing path)."""
        await self.travel(session, self.home_position, speed, check=False)
        self.homed = True

    async def travel(self, session: Any, target: FloatArray, speed: float, *, check: bool = True) -> None:
        """Straight move in simulated time; ``check``: refuse a path leaving the workspace (2500, no motion), stop at
        the first contact with a workpiece (2504 Collision)."""
        start = self.position.copy()
        target = np.asarray(target, dtype=float)
        hit = None
        heights = None
        if check:
            heights = self.check_path(start, target)
            hit = self.collision(start, target)
        end = target if hit is None else hit
        await session.motion(start, end, speed)
        try:  # the readings after the move, as a Table 3.2 row of the acquisition log would hold them
            lasers, read = self.readings(end, heights if hit is None else None)
            readings = {"lasers_mm": lasers.tolist(), "heights_mm": read.tolist()}
        except MoveRefused:
            readings = {}
        session.record("move", from_mm=start.tolist(), to_mm=end.tolist(), collision=hit is not None, **readings)
        if hit is not None:
            raise MoveRefused(2504, "the probe touched the workpiece during the move")

    async def measure(self, session: Any, nominal: FloatArray, direction: FloatArray, *, approach: float,
                      search: float, retract: float, speed: float) -> ProbeResult:
        """:meth:`probe`, then the search's time at the probing speed passes (abortable)."""
        start = self.position.copy()
        result = self.probe(nominal, direction, approach, search, retract)
        await session.wait(float(np.linalg.norm(self.position - start)) / speed)
        return result

    def describe(self) -> dict[str, Any]:
        return {"backend": "simulated", "workpieces": [w.describe() for w in self.workpieces],
                "max_tip_uncertainty_mm": self.max_tip_uncertainty}


@record
class _Probed:
    result: ProbeResult
    tip_commanded: FloatArray
