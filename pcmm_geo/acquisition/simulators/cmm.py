"""The simulated micro-CMM: rigid-body kinematics, a gauge block, and all five devices on ptys.

:class:`SimulatedMicroCMM` turns Zaber motor positions into pivot heights
(``height_i = reference_height_i + (usteps_i - start_position) * microstep``), solves the
rigid-body forward kinematics (:meth:`pcmm_geo.machine.kinematics.model.RigidBodyMachine.forward` with
heights only) for the laser readings and the probe-tip center, and reports probe contact when
the 2 mm ball tip (radius 1 mm, thesis 3.1) touches a simulated gauge block.  A move that would
push the tip into the block stops at the first contact microstep, as the machine's controller
stops the stages when the probe triggers.

Optional defects observed in the seed (chapter 6):

* ``dead_spot`` (mm, seed ~4 mm): the tetrahedron only follows a pivot once the pivot has moved
  more than this from where the tetrahedron last settled (play / stiction at the sliders);
* ``settle_scatter`` (mm, seed Table 6.7: 0.45 mm range): after every move each laser gains a
  new random offset, uniform in ``±settle_scatter / 2``;
* ``laser_noise`` (mm): Gaussian noise on every reported value (seeded).

:class:`SimulatedRig` starts the Zaber chain, lasers a, b (ILD1302), laser c (ILD1420) and the
probe Arduino on pseudo-terminals, each with its own seeded fault plan.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pcmm_geo._deprecation import renamed_fields, renamed_parameters
from pcmm_geo._records import record
from pcmm_geo.acquisition.drivers.zaber import T_LSR450B_MICROSTEP_MM
from pcmm_geo.acquisition.simulators.devices import LaserStreamSim, ProbeSim, ZaberChainSim
from pcmm_geo.acquisition.simulators.faults import RECOVERABLE_FAULTS, FaultPlan
from pcmm_geo.acquisition.simulators.pty import PtyServer, VirtualClock, VirtualPort
from pcmm_geo.errors import InvalidInputError

__all__ = ["OFF_LEVEL_START_OFFSETS", "START_POSITION", "GaugeBlock", "SimulatedMicroCMM", "SimulatedRig",
           "simulated_truth"]

#: the seed's default motor position, microsteps (Appendix A step 20)
START_POSITION = 247_500
#: start heights relative to the reference (level) heights that keep the pivots >= 20 mm apart in height over
#: the programme's +-20 mm pre-sequence span (a well-conditioned session; not the thesis' level start), mm
OFF_LEVEL_START_OFFSETS = (0.0, 60.0, -60.0)
TIP_RADIUS_MM = 1.0  # 2 mm ball tip (thesis 3.1)
_PATH_STEP_USTEPS = 200  # sampling of a move's path for contact, ~0.1 mm of pivot travel


@renamed_fields(centre="center")
@record
class GaugeBlock:
    """A rectangular block: ``center`` (3,) mm, ``size`` (3,) mm along its own axes, ``axes`` (3, 3) rows.

    Contact test: the tip sphere touches the block when ``max_f (x - p_f) . n_f <= radius`` over
    the six faces (exact opposite a face; slightly generous near edges and corners).
    """

    center: NDArray[np.float64]
    size: NDArray[np.float64]
    axes: NDArray[np.float64]

    @classmethod
    @renamed_parameters(centre="center")
    def aligned(cls, center: ArrayLike, size: ArrayLike = (9.0, 100.0, 35.0)) -> GaugeBlock:
        """Block with its edges along the machine axes (default 100 mm gauge block, 35 x 9 mm section)."""
        centre_arr = np.asarray(center, dtype=float)
        size_arr = np.asarray(size, dtype=float)
        if centre_arr.shape != (3,) or size_arr.shape != (3,) or not np.all(size_arr > 0):
            raise InvalidInputError("gauge block", "center (3,) and positive size (3,) in mm", f"{center}, {size}")
        return cls(centre_arr, size_arr, np.eye(3))

    def clearance(self, points: ArrayLike) -> NDArray[np.float64]:
        """Largest signed face distance of points ``(..., 3)`` (<= 0 inside the block), mm."""
        local = (np.asarray(points, dtype=float) - self.center) @ self.axes.T
        return np.max(np.abs(local) - self.size / 2.0, axis=-1)


class SimulatedMicroCMM:
    """Motor positions -> laser readings and probe state through the rigid-body model.

    Parameters
    ----------
    machine : RigidBodyMachine, optional
        Default :meth:`RigidBodyMachine.from_dpkm` (the seed geometry).
    microstep_mm : float
        Zaber microstep, mm.
    start_position : int
        Motor position (microsteps) at which the pivots sit at ``start_heights``.
    start_heights : array_like, shape (3,), optional
        Pivot heights (mm) at ``start_position``; default the model's reference heights, i.e.
        the *level* pose, as in the thesis (6.3: "each pivot point was starting at the same
        vertical point", one encoder count for all motors).  Near level the lasers hardly see
        the heights and processed points have millimetre uncertainties
        (:mod:`pcmm_geo.machine.analysis.logproc.uncertainty`); an off-level start such as
        ``reference_heights + OFF_LEVEL_START_OFFSETS`` keeps a session well conditioned.
    laser_noise, dead_spot, settle_scatter : float
        Defect model parameters, mm (see module docstring); 0 disables each.
    seed : int
        Seed of the noise generator.
    """

    def __init__(
        self,
        machine: Any = None,
        *,
        microstep_mm: float = T_LSR450B_MICROSTEP_MM,
        start_position: int = START_POSITION,
        start_heights: ArrayLike | None = None,
        laser_noise: float = 0.0,
        dead_spot: float = 0.0,
        settle_scatter: float = 0.0,
        seed: int = 0,
    ) -> None:
        if machine is None:
            from pcmm_geo.machine.kinematics.model import RigidBodyMachine

            machine = RigidBodyMachine.from_dpkm()
        for name, value in (("laser_noise", laser_noise), ("dead_spot", dead_spot), ("settle_scatter", settle_scatter)):
            if not (np.isfinite(value) and value >= 0):
                raise InvalidInputError(name, "a non-negative length in mm", repr(value))
        self.machine = machine
        self.microstep_mm = float(microstep_mm)
        self.start_position = int(start_position)
        if start_heights is None:
            self.start_heights = np.asarray(machine.reference_heights, dtype=float).copy()
        else:
            self.start_heights = np.asarray(start_heights, dtype=float)
            if self.start_heights.shape != (3,) or not np.all(np.isfinite(self.start_heights)):
                raise InvalidInputError("start_heights", "three finite heights in mm", repr(start_heights))
        self.laser_noise = float(laser_noise)
        self.dead_spot = float(dead_spot)
        self.settle_scatter = float(settle_scatter)
        self.rng = np.random.default_rng(seed)
        self.gauge_block: GaugeBlock | None = None
        self.positions = np.full(3, self.start_position, dtype=np.int64)
        self._settled_heights = self.heights_for(self.positions)
        tip, lasers, converged = self._solve(self._settled_heights[None, :], machine.reference_lasers)
        self._lasers = lasers[0]
        self._tip = tip[0]
        self._reachable = bool(converged[0])
        self._offsets = np.zeros(3)

    # ------------------------------------------------------------------ state
    def heights_for(self, positions: ArrayLike) -> NDArray[np.float64]:
        """Pivot height readings (mm) for motor positions ``(..., 3)`` in microsteps."""
        steps = np.asarray(positions, dtype=float) - self.start_position
        return self.start_heights + steps * self.microstep_mm

    @property
    def tip(self) -> NDArray[np.float64]:
        """Current probe-tip center, machine frame, mm."""
        return self._tip.copy()

    @property
    def true_lasers(self) -> NDArray[np.float64]:
        """Noise-free laser readings of the current pose, mm (before offsets and noise)."""
        return self._lasers.copy()

    def laser(self, arm_index: int) -> float | None:
        """Reported reading of laser ``arm_index`` (0, 1, 2), mm; None when out of reach (error value)."""
        if not self._reachable:
            return None
        value = self._lasers[arm_index] + self._offsets[arm_index]
        if self.laser_noise > 0:
            value += self.rng.normal(0.0, self.laser_noise)
        return float(value)

    def contact(self) -> bool:
        """Whether the tip ball touches the gauge block."""
        return self.gauge_block is not None and bool(self.gauge_block.clearance(self._tip) <= TIP_RADIUS_MM)

    def place_gauge_block(self, block: GaugeBlock) -> None:
        """Put a gauge block in the work area (the operator's step 17 of Appendix A)."""
        self.gauge_block = block

    def block_next_to_tip(self, gap: float = 3.0, axis: int = 0, side: float = -1.0) -> GaugeBlock:
        """A 100 mm gauge block whose face is ``gap`` mm (ball surface to face) from the tip along ``axis``."""
        size = np.array([9.0, 100.0, 35.0])
        center = self._tip.copy()
        center[axis] += side * (TIP_RADIUS_MM + gap + size[axis] / 2.0)
        return GaugeBlock.aligned(center, size)

    # ------------------------------------------------------------------ motion
    def _solve(
        self, heights: NDArray[np.float64], hint: ArrayLike | None = None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[Any]]:
        """Tips, lasers and reachability for heights ``(K, 3)``.

        The model is solved without its limits (a simulated motor may be driven anywhere); a
        pose counts as reachable only where every laser reading lies in the machine's measuring
        range, as a real sensor reports an error value beyond it.
        """
        hint = np.broadcast_to(self._lasers if hint is None else hint, heights.shape)
        solution = self.machine.forward(heights=heights, lasers_hint=hint, check_limits=False)
        lasers = np.asarray(solution.lasers)
        limits = getattr(self.machine, "limits", None)
        reachable = np.asarray(solution.converged)
        if limits is not None:
            low, high = limits.laser_range[:, 0], limits.laser_range[:, 1]
            reachable = reachable & np.all((lasers >= low) & (lasers <= high), axis=-1)
        return np.asarray(solution.tip), lasers, reachable

    def move(self, device: int, start: int, target: int) -> int:
        """Move motor ``device`` (1..3) from ``start`` towards ``target``; returns where it stops.

        The path is sampled every ~0.1 mm; the first sample in contact is refined by bisection to
        the first contact microstep.  Already in contact, a move deeper into the block does not
        move at all.
        """
        index = device - 1
        count = max(2, abs(target - start) // _PATH_STEP_USTEPS + 2)
        path = np.unique(np.round(np.linspace(start, target, count)).astype(np.int64))
        if target < start:
            path = path[::-1]
        final = target
        if self.gauge_block is not None and len(path) > 1:
            positions = np.repeat(self.positions[None, :], len(path), axis=0)
            positions[:, index] = path
            tips, _, converged = self._solve(self._effective_heights(positions))
            clear = np.where(converged, self.gauge_block.clearance(tips) - TIP_RADIUS_MM, np.inf)
            if clear[0] <= 0 and clear[1] < clear[0] - 1e-9:
                final = start  # in contact and pushing deeper: the stage is held
            else:
                # already touching and moving away: look for a new contact only once free again
                free = np.nonzero(clear > 0)[0]
                first_free = int(free[0]) if len(free) else len(path)
                hits = first_free + np.nonzero(clear[first_free:] <= 0)[0]
                if len(hits):
                    final = self._first_contact(index, int(path[hits[0] - 1]), int(path[hits[0]]))
        self.positions[index] = final
        self._settle()
        return final

    def _first_contact(self, index: int, free: int, touching: int) -> int:
        assert self.gauge_block is not None
        while abs(touching - free) > 1:
            middle = (free + touching) // 2
            positions = self.positions.copy()
            positions[index] = middle
            tip, _, _ = self._solve(self._effective_heights(positions[None, :]))
            if self.gauge_block.clearance(tip[0]) <= TIP_RADIUS_MM:
                touching = middle
            else:
                free = middle
        return touching

    def _effective_heights(self, positions: NDArray[np.int64]) -> NDArray[np.float64]:
        """Heights the tetrahedron follows: with a dead spot, only pivots moved beyond it count."""
        heights = self.heights_for(positions)
        if self.dead_spot <= 0:
            return heights
        stuck = np.abs(heights - self._settled_heights) <= self.dead_spot
        return np.where(stuck, self._settled_heights, heights)

    def _settle(self) -> None:
        heights = self._effective_heights(self.positions[None, :])[0]
        self._settled_heights = heights
        tip, lasers, converged = self._solve(heights[None, :])
        self._reachable = bool(converged[0])
        if self._reachable:
            self._tip, self._lasers = tip[0], lasers[0]
        if self.settle_scatter > 0:
            self._offsets = self.rng.uniform(-self.settle_scatter / 2, self.settle_scatter / 2, size=3)


class SimulatedRig:
    """The whole simulated machine on five pseudo-terminals (Zaber chain, lasers a-c, probe).

    Parameters
    ----------
    cmm : SimulatedMicroCMM, optional
        Default: the seed geometry without defects.
    fault_rate : float
        Probability of a fault per Zaber reply / per stream window of the other devices.
    fault_kinds : sequence of str
        Kinds to inject (default: all recoverable ones).
    seed : int
        Seeds the fault plans (each device gets its own stream).
    probe_mode : {"pin", "text"}
        Arduino firmware mode.
    transport : {"pty", "virtual"}
        ``"pty"``: real pseudo-terminals served by a thread in real time (realistic, but timing
        depends on the host); ``"virtual"``: in-process :class:`VirtualPort` objects on one
        :class:`VirtualClock`, so a seed reproduces the same faults, retries and rows on any host.

    Attributes
    ----------
    ports : dict str -> str or VirtualPort
        tty paths (or virtual ports) under keys ``zaber``, ``laser_a``, ``laser_b``, ``laser_c``, ``probe``.
    clock : VirtualClock or None
        The simulated clock of the virtual transport (None with ptys).
    faults : dict str -> FaultPlan
        Per device, with injected-fault counts.

    Examples
    --------
    >>> with SimulatedRig() as rig:
    ...     sorted(rig.ports)
    ['laser_a', 'laser_b', 'laser_c', 'probe', 'zaber']
    """

    DEVICE_KEYS = ("zaber", "laser_a", "laser_b", "laser_c", "probe")

    def __init__(
        self,
        cmm: SimulatedMicroCMM | None = None,
        *,
        fault_rate: float = 0.0,
        fault_kinds: Sequence[str] = RECOVERABLE_FAULTS,
        seed: int = 0,
        probe_mode: str = "pin",
        silence: float = 0.3,
        transport: str = "pty",
    ) -> None:
        if transport not in ("pty", "virtual"):
            raise InvalidInputError("transport", "'pty' or 'virtual'", repr(transport))
        self.cmm = cmm if cmm is not None else SimulatedMicroCMM(seed=seed)
        self.faults = {
            key: FaultPlan(fault_rate, fault_kinds, seed=int(np.random.SeedSequence([seed, i]).generate_state(1)[0]))
            for i, key in enumerate(self.DEVICE_KEYS)
        }
        start = {d: int(self.cmm.positions[d - 1]) for d in (1, 2, 3)}
        self.zaber = ZaberChainSim(3, faults=self.faults["zaber"], mover=self.cmm.move, initial_positions=start)
        self.lasers = [
            LaserStreamSim(
                (lambda i=i: self.cmm.laser(i)), model="ILD1420" if arm == "c" else "ILD1302",
                faults=self.faults[f"laser_{arm}"], silence=silence, name=f"laser_{arm}",
            )
            for i, arm in enumerate("abc")
        ]
        self.probe = ProbeSim(self.cmm.contact, mode=probe_mode, faults=self.faults["probe"], silence=silence)
        devices = [self.zaber, *self.lasers, self.probe]
        self.clock: VirtualClock | None = None
        self.server: PtyServer | None = None
        self.ports: dict[str, Any]
        if transport == "virtual":
            self.clock = VirtualClock()
            self.ports = {key: VirtualPort(device, self.clock, name=key)
                          for key, device in zip(self.DEVICE_KEYS, devices, strict=True)}
        else:
            self.server = PtyServer(devices)
            self.ports = dict(zip(self.DEVICE_KEYS, self.server.port_names, strict=True))

    @property
    def injected_faults(self) -> dict[str, int]:
        """Total injected faults per kind over all devices."""
        totals: dict[str, int] = {}
        for plan in self.faults.values():
            for kind, count in plan.counts.items():
                totals[kind] = totals.get(kind, 0) + count
        return totals

    def gauge_block_beside_tip(self, gap: float = 3.0) -> GaugeBlock:
        """The 100 mm gauge block ``gap`` mm beside the current tip, not placed (thread-safe)."""
        with self.zaber.lock:
            return self.cmm.block_next_to_tip(gap)

    def place_gauge_block(self, gap: float = 3.0, *, block: GaugeBlock | None = None) -> GaugeBlock:
        """Place ``block``, by default a 100 mm gauge block ``gap`` mm beside the current tip (thread-safe).

        A session resumed at another pose places the block it computed at the start pose
        (:meth:`gauge_block_beside_tip`), where the first session put it.
        """
        with self.zaber.lock:
            block = self.cmm.block_next_to_tip(gap) if block is None else block
            self.cmm.place_gauge_block(block)
        return block

    def close(self) -> None:
        """Stop the simulators and close the ptys (or the virtual ports)."""
        if self.server is not None:
            self.server.close()
        else:
            for port in self.ports.values():
                port.close()

    def __enter__(self) -> SimulatedRig:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def simulated_truth(path: str | Path) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(heights (N, 3), tips (N, 3))`` of every data row of a simulated acquisition log: the simulator's truth.

    The heights follow from the logged motor positions and the log's ``start_heights_mm`` at its
    start positions (``start_positions_usteps``, one per motor, else ``start_position_usteps`` for
    all; written by ``pcmm acquire --simulate``); the tips from the seed
    machine's forward kinematics, as the simulator computed them (no dead spot: a session with
    ``--defects`` has other truth).  This is the independent truth that processed logs are tested
    against.

    Raises
    ------
    FileFormatError
        The file is not an acquisition log of the simulated machine (no ``start_heights_mm``).
    """
    from pcmm_geo.acquisition.acqlog import read_log
    from pcmm_geo.errors import FileFormatError

    contents = read_log(path)
    metadata = contents.metadata
    if "start_heights_mm" not in metadata or "start_position_usteps" not in metadata:
        raise FileFormatError(str(path), "expected an acquisition log of the simulated machine (start_heights_mm, "
                              "start_position_usteps), got none")
    simulator = SimulatedMicroCMM(start_position=int(metadata["start_position_usteps"]),
                                  start_heights=[float(v) for v in metadata["start_heights_mm"].split()])
    positions = np.array([row.pos_usteps for row in contents.rows], dtype=float)
    if "start_positions_usteps" in metadata:  # each motor's own start (a commanded start, pcmm acquire)
        starts = np.array([float(v) for v in metadata["start_positions_usteps"].split()])
        positions = positions - starts + simulator.start_position
    heights = simulator.heights_for(positions)
    machine = simulator.machine
    hint = np.broadcast_to(machine.reference_lasers, heights.shape)
    return heights, np.asarray(machine.forward(heights=heights, lasers_hint=hint).tip)
