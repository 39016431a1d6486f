"""The real micro-CMM behind the I++ DME server: the calibrated model driving the acquisition drivers.

:class:`DriverMachine` is the :class:`~pcmm_geo.ippdme.machine.MachineBackend` of ``pcmm serve``
with ports: the Zaber chain moves the three columns
(:class:`~pcmm_geo.acquisition.drivers.zaber.ZaberChain`), lasers a, b, c are read through
:class:`~pcmm_geo.acquisition.drivers.lasers.LaserSensor` and the TP8 touch probe's trigger
through :class:`~pcmm_geo.acquisition.drivers.probe.ProbeReader` (the Arduino's pin level or
``safe`` / ``stop`` lines, thesis 3.4), all as ``pcmm acquire`` opens them
(:func:`~pcmm_geo.acquisition.programme.open_session`).

* **Columns and heights.**  A column stands at the calibrated model's reference height when its
  motor is at ``reference_position_usteps`` (the seed's start count, 247 500 microsteps, as
  ``pcmm acquire`` and ``pcmm process-log`` take it): ``height = reference_height + (count -
  reference_count) * microstep``.
* **Home** homes the stages (each drives to its home sensor at the bottom of its travel;
  :meth:`AcquisitionSession.home`), then raises the tip to the home pose of the simulated backend
  (every column :data:`~pcmm_geo.ippdme.machine.HOME_RAISE_MM` above its reference height) by the
  stepped move below.  The homing path must be clear: put the part on the table after homing, or
  away from the tip's vertical line (thesis Appendix A places the gauge block after homing too).
* **GoTo** is a coordinated stepped move: the straight tip path is cut into steps of at most
  ``move_step_mm``; each step's tip centre goes through the calibrated inverse kinematics (the
  workspace limits refuse an unreachable path with 2500 before anything moves) and the three
  motors are moved to its counts one after the other; the probe is polled after every step, and a
  trigger on the way (after the probe was free) stops the move with 2504 Collision.
* **Get** reads the lasers and the motor counts and reports the calibrated forward kinematics'
  tip centre (lasers and heights weighted by their standard uncertainties).
* **PtMeas** is a stepped search along the probing direction: from the approach point towards
  ``Search`` mm below the nominal surface in steps of ``search_step_mm``, polling the trigger;
  at the first trigger it backs off ``back_off_mm`` along the direction (the motors whose step
  moves the tip away from the surface first, so a held axis cannot push the probe in), checks
  that the probe is free, and re-approaches in steps of ``fine_step_mm``; the lasers and the
  counts read at the second trigger give the tip centre through the calibrated forward kinematics
  and the point is compensated by the calibrated tip radius against the probing direction.  No
  trigger over the search: 1006 Surface not found.  The point is flagged poorly resolved as the
  simulated backend flags it (:func:`~pcmm_geo.ippdme.machine.tip_uncertainties`).
* **Device failures** map to the spec's errors: a port that fails or a device that stops
  answering after the retries is 0503 Controller communications failure (the machine is then not
  homed: its position is no longer known; Home again once the link is back), a stage refusing a
  target 2500, a stage that does not reach its count 2502 Axis position error, a laser streaming
  error values 2503 Scale read head failure, a failure while homing 1005 Error during home.  The
  server stays up and keeps answering.

The stages move at their own speed setting: the I++ ``Speed`` / ``Accel`` values are accepted
and reported but not sent to the stages in this version.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.errors import DeviceError, DeviceProtocolError, DeviceTimeoutError, InvalidInputError
from pcmm_geo.ippdme.machine import (
    HOME_RAISE_MM,
    MachineBackend,
    MachineModel,
    MoveRefused,
    ProbeResult,
    reachable_heights,
    reported_tip,
    tip_uncertainties,
)

__all__ = ["REFERENCE_POSITION_USTEPS", "DriverMachine", "StepSettings", "open_driver_machine"]

FloatArray = NDArray[np.float64]
T = TypeVar("T")
#: the seed's start count (Appendix A step 20): the columns at the model's reference heights
REFERENCE_POSITION_USTEPS = 247_500


def _transient(error: DeviceError) -> bool:
    """Whether repeating a device call may succeed: a timeout, a garbled reply, a busy stage (Zaber 255), a laser's
    momentary error value (ILD1302 16370-16383, ILD1420 262075-262082); not a failed port or a refused command."""
    if isinstance(error, (DeviceTimeoutError, DeviceProtocolError)):
        return True
    code = getattr(error, "code", None)
    return code is not None and (code == 255 or 16370 <= code <= 16383 or 262075 <= code <= 262082)


class _Stopped(Exception):
    """The session asked the blocking work to stop (AbortE, client gone)."""


@dataclass(frozen=True)
class StepSettings:
    """How the server moves the real columns (mm, microsteps).

    Attributes
    ----------
    move_step_mm : float
        Largest tip step of a free move (GoTo, Home, retract).
    search_step_mm : float
        Tip step of the first (coarse) search; also the farthest the re-approach goes past the first trigger.
    fine_step_mm : float
        Tip step of the re-approach: the resolution of the trigger position along the direction.
    back_off_mm : float
        Retreat along the probing direction after the first trigger; the re-approach goes this far plus two
        fine steps.  A polled trigger is seen up to one search step late (the probe's overtravel), so on a real
        probe it must exceed ``search_step_mm`` (the default does); the simulated stages stop at the contact.
    reference_position_usteps : int
        Motor count at which a column stands at the calibrated model's reference height.
    max_retries : int
        Retries of a device call after transient faults (timeouts, garbled replies, busy).
    """

    move_step_mm: float = 1.0
    search_step_mm: float = 0.25
    fine_step_mm: float = 0.01
    back_off_mm: float = 0.3
    reference_position_usteps: int = REFERENCE_POSITION_USTEPS
    max_retries: int = 4

    def __post_init__(self) -> None:
        for name in ("move_step_mm", "search_step_mm", "fine_step_mm", "back_off_mm"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise InvalidInputError(name, "a positive length in mm", repr(value))
        if self.fine_step_mm > min(self.search_step_mm, self.back_off_mm):
            raise InvalidInputError("fine_step_mm", f"at most search_step_mm and back_off_mm "
                                    f"({self.search_step_mm}, {self.back_off_mm})", repr(self.fine_step_mm))
        if not (isinstance(self.max_retries, int) and self.max_retries >= 0):
            raise InvalidInputError("max_retries", "a non-negative integer", repr(self.max_retries))


class DriverMachine(MachineBackend):
    """The micro-CMM on its drivers (see the module notes).

    Parameters
    ----------
    model : MachineModel
        The calibrated model (``laser_sigma`` and ``encoder_sigma`` weight the readings).
    devices : AcquisitionSession
        The five devices as :func:`pcmm_geo.acquisition.programme.open_session` opens them
        (``motors``, ``lasers``, ``probe``, ``home()``, ``confirmed_position()``).
    settings : StepSettings, optional
    max_tip_uncertainty : float
        Laser-only tip uncertainty above which a point is flagged poorly resolved (as the simulated backend).
    sleep : callable
        Wait between retries (a simulated clock's ``sleep`` with virtual ports).
    """

    def __init__(self, model: MachineModel, devices: Any, *, settings: StepSettings | None = None,
                 max_tip_uncertainty: float = 1.0, sleep: Callable[[float], None] = time.sleep) -> None:
        if not max_tip_uncertainty > 0:
            raise InvalidInputError("max_tip_uncertainty", "a positive length in mm", repr(max_tip_uncertainty))
        self.model = model
        self.devices = devices
        self.settings = settings or StepSettings()
        self.max_tip_uncertainty = float(max_tip_uncertainty)
        self._sleep = sleep
        self._lock = threading.Lock()
        self.microstep_mm = float(devices.motors.microstep_mm)
        reference = np.asarray(model.machine.reference_heights, dtype=float)
        self.home_position = self._tip_of_heights(reference + HOME_RAISE_MM)
        self.homed = False
        self.touching = False
        self.counts = np.full(3, self.settings.reference_position_usteps, dtype=np.int64)
        self.position = self._tip_of_heights(reference)
        self.fault: str | None = None

    # ------------------------------------------------------------------ units and kinematics
    def heights_of(self, counts: Any) -> FloatArray:
        """Column heights (mm) of motor counts ``(..., 3)``."""
        reference = np.asarray(self.model.machine.reference_heights, dtype=float)
        steps = np.asarray(counts, dtype=float) - self.settings.reference_position_usteps
        return reference + steps * self.microstep_mm

    def counts_of(self, heights: Any) -> NDArray[np.int64]:
        """Nearest motor counts ``(..., 3)`` of column heights (mm)."""
        reference = np.asarray(self.model.machine.reference_heights, dtype=float)
        steps = (np.asarray(heights, dtype=float) - reference) / self.microstep_mm
        return np.rint(steps + self.settings.reference_position_usteps).astype(np.int64)

    def _tip_of_heights(self, heights: Any) -> FloatArray:
        machine = self.model.machine
        solution = machine.forward(heights=np.asarray(heights, dtype=float), lasers_hint=machine.reference_lasers,
                                   check_limits=False)
        return np.asarray(solution.tip, dtype=float).reshape(np.shape(heights))

    def _plan(self, start: FloatArray, end: FloatArray, step: float, check: bool) -> tuple[FloatArray, Any]:
        """Tip centres ``(K, 3)`` every ``step`` mm from ``start`` (excluded) to ``end`` and their motor counts."""
        count = max(1, math.ceil(float(np.linalg.norm(end - start)) / step - 1e-9))
        tips = start + np.arange(1, count + 1)[:, None] / count * (end - start)
        return tips, self.counts_of(reachable_heights(self.model, tips, check=check))

    # ------------------------------------------------------------------ device calls
    def _call(self, function: Callable[..., T], *args: Any) -> T:
        """``function(*args)``, retried on transient faults with a doubling wait (10 ms .. 0.32 s)."""
        for attempt in range(self.settings.max_retries + 1):
            try:
                return function(*args)
            except DeviceError as exc:
                if not _transient(exc) or attempt == self.settings.max_retries:
                    raise
                self._sleep(min(0.01 * 2 ** attempt, 0.32))
        raise AssertionError("unreachable")  # pragma: no cover

    def _refusal(self, exc: DeviceError, *, homing: bool = False) -> MoveRefused:
        """The spec's error for a device failure (see the module notes); the position is no longer trusted."""
        code = getattr(exc, "code", None)
        device = str(getattr(exc, "device", ""))
        detail = str(exc).splitlines()[0][:300]
        if isinstance(exc, DeviceTimeoutError) or code is None:
            number = 503
        elif homing:
            number = 1005
        elif device.startswith("zaber"):
            number = 2500 if code in (20, 21) else 2502
        elif device.startswith("laser"):
            number = 2503
        else:
            number = 503
        if number in (503, 1005):
            self.homed = False
            self.fault = detail
        return MoveRefused(number, detail, self.position.copy())

    def _probe(self) -> bool:
        return bool(self._call(self.devices.probe.read).contact)

    def _confirm(self) -> NDArray[np.int64]:
        counts = np.array([self.devices.confirmed_position(motor) for motor in (1, 2, 3)], dtype=np.int64)
        self.counts = counts
        return counts

    def _readings(self) -> tuple[FloatArray, FloatArray]:
        """Laser distances and column heights now (mm), counts confirmed."""
        lasers = np.array([self._call(laser.read).distance for laser in self.devices.lasers], dtype=float)
        return lasers, self.heights_of(self._confirm())

    def _sync_position(self) -> None:
        """The commanded tip of where the motors are (after a stop between step targets)."""
        self.position = self._tip_of_heights(self.heights_of(self._confirm()))

    def _order(self, counts: NDArray[np.int64], direction: FloatArray) -> list[int]:
        """Motors by decreasing tip motion along ``direction`` of their part of the step to ``counts``.

        Moving them in this order from a touching pose, the tip leaves the surface with the first
        motor and stays off (partial sums of decreasing terms with a positive total are positive).
        """
        here = self.heights_of(self.counts)
        moved = np.repeat(here[None], 3, axis=0)
        for motor in range(3):
            moved[motor, motor] = self.heights_of(counts)[motor]
        gains = (self._tip_of_heights(moved) - self._tip_of_heights(here)) @ direction
        return [int(i) for i in np.argsort(-gains, kind="stable")]

    def _run(self, tips: FloatArray, counts: NDArray[np.int64], stop: threading.Event, *,
             direction: FloatArray | None = None) -> bool:
        """Step through ``counts`` ``(K, 3)``; True at a trigger met after the probe was free (position synced).

        ``direction`` (unit, the tip's motion) orders the motors for a move that starts touching.
        """
        free = not self.touching
        order = [0, 1, 2] if direction is None or free else self._order(counts[0], direction)
        for k in range(len(counts)):
            if stop.is_set():
                raise _Stopped
            stalled = False
            for motor in order:
                target = int(counts[k, motor])
                if target == int(self.counts[motor]):
                    continue
                final = self._call(self.devices.motors.move_absolute, motor + 1, target)
                if final != target:  # a stop short of the target, or a garbled reply: ask until two answers agree
                    final = self.devices.confirmed_position(motor + 1)
                self.counts[motor] = final
                if final != target:
                    stalled = True
                    break
            contact = self._probe()
            self.touching = contact
            if contact and (free or stalled):
                self._sync_position()
                return True
            if stalled:
                self._sync_position()
                raise MoveRefused(2502, f"a column stopped short of its target count ({target} microsteps)",
                                  self.position.copy())
            free = free or not contact
            self.position = tips[k].copy()
        final_counts = self.counts.copy()
        if np.any(self._confirm() != final_counts):
            self._sync_position()
            raise MoveRefused(2502, "a column is not where its motor reported it", self.position.copy())
        return False

    def _blocking(self, work: Callable[[threading.Event], Any], *,
                  homing: bool = False) -> Callable[[threading.Event], Any]:
        """``work`` under the device lock, device failures as the spec's errors, a stop as None."""

        def run(stop: threading.Event) -> Any:
            with self._lock:
                try:
                    return work(stop)
                except _Stopped:
                    return None
                except DeviceError as exc:
                    raise self._refusal(exc, homing=homing) from None

        return run

    def _record_move(self, session: Any, start: FloatArray, collision: bool, **extra: Any) -> None:
        session.record("move", from_mm=start.tolist(), to_mm=self.position.tolist(), collision=collision,
                       counts_usteps=self.counts.tolist(), heights_mm=self.heights_of(self.counts).tolist(), **extra)

    # ------------------------------------------------------------------ the backend interface
    async def home(self, session: Any, speed: float) -> None:
        start = self.position.copy()

        def work(stop: threading.Event) -> bool:
            self.homed = False
            self.devices.home()
            self.fault = None
            self.touching = self._probe()
            self._sync_position()
            start[:] = self.position
            tips, counts = self._plan(self.position, self.home_position, self.settings.move_step_mm, False)
            return self._run(tips, counts, stop, direction=None)

        hit = await session.run_blocking(self._blocking(work, homing=True))
        self._record_move(session, start, bool(hit), homing=True)
        if hit:
            raise MoveRefused(1005, "the probe triggered on the way to the home pose (clear the homing path)")
        self.homed = True

    async def travel(self, session: Any, target: FloatArray, speed: float, *, check: bool = True) -> None:
        start = self.position.copy()
        target = np.asarray(target, dtype=float)
        if float(np.linalg.norm(target - start)) <= 1e-9:
            return
        tips, counts = self._plan(start, target, self.settings.move_step_mm, check)
        direction = (target - start) / float(np.linalg.norm(target - start))

        def work(stop: threading.Event) -> tuple[bool, list[float]]:
            hit = self._run(tips, counts, stop, direction=direction)
            lasers = [self._call(laser.read).distance for laser in self.devices.lasers]
            return hit, lasers

        outcome = await session.run_blocking(self._blocking(work))
        hit, lasers = outcome if outcome is not None else (False, None)
        self._record_move(session, start, hit, **({} if lasers is None else {"lasers_mm": lasers}))
        if hit:
            raise MoveRefused(2504, "the probe triggered during the move")

    async def measure(self, session: Any, nominal: FloatArray, direction: FloatArray, *, approach: float,
                      search: float, retract: float, speed: float) -> ProbeResult:
        s = self.settings
        radius = float(self.model.tip_radius)
        n = np.asarray(direction, dtype=float)
        start = self.position.copy()
        end = nominal + n * (radius - search)
        tips, counts = self._plan(start, end, s.search_step_mm, True)  # the whole search within the workspace

        def work(stop: threading.Event) -> tuple[FloatArray, FloatArray]:
            if not self._run(tips, counts, stop):
                raise MoveRefused(1006, "no trigger along the search path", self.position.copy())
            first = self.position.copy()
            back_tips, back_counts = self._plan(first, first + n * s.back_off_mm, s.back_off_mm, False)
            self._run(back_tips, back_counts, stop, direction=n)
            if self.touching:
                raise MoveRefused(1011, "the probe stays triggered after backing off", self.position.copy())
            back = self.position.copy()
            fine_end = back - n * (s.back_off_mm + 2.0 * s.fine_step_mm)
            fine_tips, fine_counts = self._plan(back, fine_end, s.fine_step_mm, False)
            if not self._run(fine_tips, fine_counts, stop):
                raise MoveRefused(1006, "no trigger on the re-approach", self.position.copy())
            return self._readings()

        readings = await session.run_blocking(self._blocking(work))
        lasers, heights = readings
        tip = reported_tip(self.model, lasers[None], heights[None])
        u_both, u_lasers = tip_uncertainties(self.model, lasers[None], heights[None], tip)
        retract_to = self.position + n * retract if retract >= 0 else start
        return ProbeResult(
            point=tip[0] - radius * n, tip=tip[0], direction=n, lasers=lasers, heights=heights,
            effective_radius=radius, tip_uncertainty=float(u_both[0]), laser_only_tip_uncertainty=float(u_lasers[0]),
            poorly_resolved=bool(u_lasers[0] > self.max_tip_uncertainty or np.isinf(u_lasers[0])),
            true_tip=np.full(3, np.nan), retract_position=retract_to,
        )

    async def read_position(self, session: Any) -> FloatArray:
        """The tip centre from the lasers and the motor counts read now (calibrated forward kinematics)."""
        readings = await session.run_blocking(self._blocking(lambda stop: self._readings()))
        if readings is None:
            return self.position.copy()
        lasers, heights = readings
        return reported_tip(self.model, lasers[None], heights[None])[0]

    def describe(self) -> dict[str, Any]:
        s = self.settings
        return {"backend": "drivers", "move_step_mm": s.move_step_mm, "search_step_mm": s.search_step_mm,
                "fine_step_mm": s.fine_step_mm, "back_off_mm": s.back_off_mm,
                "reference_position_usteps": s.reference_position_usteps, "microstep_mm": self.microstep_mm,
                "max_tip_uncertainty_mm": self.max_tip_uncertainty}


def open_driver_machine(model: MachineModel, ports: Any, stack: Any, *, timeout: float = 0.5,
                        move_timeout: float = 60.0, probe_mode: str = "pin", clock: Any = None,
                        settings: StepSettings | None = None, max_tip_uncertainty: float = 1.0) -> DriverMachine:
    """Open the five devices on ``ports`` (keys of :data:`pcmm_geo.acquisition.programme.DEVICE_PORTS`) and serve them.

    The devices are entered on ``stack`` (``contextlib.ExitStack``: the ports close when it
    unwinds).  The model's laser uncertainty is widened by the coarser laser's count step
    (ILD1302: 200 mm * 1.02 / 16368 = 12.5 um, uniform: 3.6 um standard) since the readings are
    whole counts; ``clock`` is the simulated clock of virtual ports (retry waits in simulated time).

    Raises
    ------
    InvalidInputError
        A port is missing.
    DeviceError
        A port cannot be opened.
    """
    from dataclasses import replace

    from pcmm_geo.acquisition.drivers.lasers import ILD1302_FULL_SCALE, MEASURING_RANGE_MM
    from pcmm_geo.acquisition.programme import open_session

    devices = open_session(ports, stack, timeout=timeout, move_timeout=move_timeout, probe_mode=probe_mode,
                           settle_time=0.0, clock=clock)
    count_mm = MEASURING_RANGE_MM * 1.02 / ILD1302_FULL_SCALE
    served = replace(model, laser_sigma=float(np.hypot(model.laser_sigma, count_mm / np.sqrt(12.0))),
                     microstep_mm=float(devices.motors.microstep_mm))
    sleep = clock.sleep if clock is not None else time.sleep
    return DriverMachine(served, devices, settings=settings, max_tip_uncertainty=max_tip_uncertainty, sleep=sleep)
