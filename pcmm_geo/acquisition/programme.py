"""The library side of ``pcmm acquire``: open the five devices as one session, run a move programme.

:func:`open_session` connects the Zaber chain, lasers a, b, c (ILD1302, ILD1302, ILD1420 as in
the seed) and the Arduino probe on the given ports and returns an
:class:`~pcmm_geo.acquisition.session.AcquisitionSession`; every device is entered on the
caller's :class:`contextlib.ExitStack`, so the ports close however the session ends.

:func:`run_random_programme` is the seeded test programme of ``pcmm acquire``: motor 1 approaches
the artefact with probability 0.4, otherwise a random motor moves a random way; once the probe
touches, only the retreat of the touching motor is allowed (thesis 3.6), and no move leaves the
pre-sequence span around its motor's start position.  :func:`plan_random_programme` gives the same
programme's moves before any device is touched, as they are while the probe touches nothing (the
path ``pcmm acquire`` predicts the tip uncertainty along; after a contact the run retreats, within
the same span).

Use (``tests/acquisition/test_acq_programme.py`` runs this on the simulated rig)::

    with contextlib.ExitStack() as stack:
        rig = stack.enter_context(SimulatedRig(SimulatedMicroCMM(seed=1), seed=1))
        session = open_session(rig.ports, stack, timeout=0.1, move_timeout=1.0, settle_time=0.0)
        session.log = stack.enter_context(AcquisitionLog.create(path, metadata))
        session.prepare(presequence=False)
        run_random_programme(session, moves=5, step_mm=2.0, seed=1)
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Mapping
from typing import Any

from pcmm_geo.acquisition.session import AcquisitionSession, SessionConfig
from pcmm_geo.errors import InvalidInputError

__all__ = ["ARMS", "DEVICE_PORTS", "open_session", "plan_random_programme", "run_random_programme",
           "start_offsets_usteps"]

#: laser / arm labels, in the order of the session's lasers
ARMS = ("a", "b", "c")
#: port names :func:`open_session` needs
DEVICE_PORTS = ("zaber", "laser_a", "laser_b", "laser_c", "probe")


def open_session(
    ports: Mapping[str, Any],
    stack: contextlib.ExitStack,
    *,
    timeout: float = 0.5,
    move_timeout: float = 60.0,
    probe_mode: str = "pin",
    settle_time: float = 2.6,
    clock: Any = None,
    start_offsets: tuple[int, int, int] = (0, 0, 0),
) -> AcquisitionSession:
    """Connect the five devices on ``ports`` and return a session on them.

    Parameters
    ----------
    ports : mapping
        Port name or pyserial URL for each of :data:`DEVICE_PORTS`.
    stack : contextlib.ExitStack
        Each device is entered on it (ports close when the stack unwinds).
    timeout, move_timeout : float
        Device reply timeout and Zaber move timeout, s (the drivers' defaults).
    probe_mode : {"pin", "text"}
        Arduino firmware mode.
    settle_time : float
        Settling wait after each move, s (seed 2.6 s, thesis 3.5).
    clock : VirtualClock, optional
        The simulated clock of virtual ports (:class:`~pcmm_geo.acquisition.simulators.cmm.SimulatedRig`
        with ``transport="virtual"``): settling, retry backoff and ``elapsed`` then use simulated
        time, so a seeded run repeats exactly and costs no wall time.
    start_offsets : tuple of int
        Offset of each motor's start from the seed's start position, microsteps
        (:attr:`SessionConfig.start_offsets`; default: the level start).

    Returns
    -------
    AcquisitionSession
        Without a log; set ``session.log`` before :meth:`~AcquisitionSession.prepare`.

    Raises
    ------
    InvalidInputError
        A port of :data:`DEVICE_PORTS` is missing.
    DeviceError
        A device does not answer (from the drivers).
    """
    from pcmm_geo.acquisition.drivers.lasers import LaserSensor
    from pcmm_geo.acquisition.drivers.probe import ProbeReader
    from pcmm_geo.acquisition.drivers.zaber import ZaberChain

    missing = [name for name in DEVICE_PORTS if not ports.get(name)]
    if missing:
        raise InvalidInputError("ports", f"a port for each of {list(DEVICE_PORTS)}", f"none for {missing}")
    motors = stack.enter_context(ZaberChain(ports["zaber"], timeout=timeout, move_timeout=move_timeout))
    lasers = [
        stack.enter_context(
            LaserSensor(ports[f"laser_{arm}"], model="ILD1420" if arm == "c" else "ILD1302", name=f"laser_{arm}",
                        timeout=timeout)
        )
        for arm in ARMS
    ]
    probe = stack.enter_context(ProbeReader(ports["probe"], mode=probe_mode, timeout=timeout))
    config = SessionConfig(settle_time=settle_time, start_offsets=tuple(start_offsets))  # type: ignore[arg-type]
    if clock is not None:
        return AcquisitionSession(motors, lasers, probe, None, config, sleep=clock.sleep, clock=clock)
    return AcquisitionSession(motors, lasers, probe, None, config)


def start_offsets_usteps(offsets_mm: Any, microstep_mm: float) -> tuple[int, int, int]:
    """Offsets of the three motors' starts in whole microsteps, from mm (nearest microstep).

    Examples
    --------
    >>> start_offsets_usteps((0.0, 60.0, -60.0), 6.35 / 12800)
    (0, 120945, -120945)
    """
    values = [float(v) for v in offsets_mm]
    if len(values) != 3 or not all(abs(v) < 1e4 for v in values):
        raise InvalidInputError("offsets_mm", "three finite offsets in mm", repr(offsets_mm))
    a, b, c = (round(v / microstep_mm) for v in values)
    return a, b, c


def _next_move(rng: Any, positions: Mapping[int, int], contact_move: tuple[int, int] | None,
               starts: tuple[int, int, int], limit: int, step_max: int) -> tuple[int, int]:
    """The programme's next ``(motor, signed microsteps)`` (the draws of :func:`run_random_programme`)."""
    steps = int(rng.integers(step_max // 2, step_max + 1))
    if contact_move is not None:
        motor, direction = contact_move[0], -contact_move[1]
    elif rng.random() < 0.4:
        motor, direction = 1, 1
    else:
        motor, direction = int(rng.integers(1, 4)), int(rng.choice((-1, 1)))
    offset = positions[motor] - starts[motor - 1]
    if contact_move is None and abs(offset + direction * steps) > limit:
        direction = -1 if offset > 0 else 1
    return motor, direction * steps


def plan_random_programme(
    moves: int,
    *,
    step_usteps: int,
    seed: int = 0,
    start_positions: tuple[int, int, int] = (247_500, 247_500, 247_500),
    span: int = 40_320,
) -> list[tuple[int, int]]:
    """The moves ``(motor, signed microsteps)`` :func:`run_random_programme` makes while the probe touches nothing.

    Parameters
    ----------
    moves : int
        Number of moves.
    step_usteps : int
        Largest motor step, microsteps (:func:`run_random_programme`'s ``step_mm`` in microsteps).
    seed : int
        Seed of the programme.
    start_positions : tuple of int
        Start of motors 1, 2, 3 (:attr:`SessionConfig.start_positions`).
    span : int
        The pre-sequence span no move leaves (:attr:`SessionConfig.presequence_span`).

    Examples
    --------
    >>> plan_random_programme(3, step_usteps=8063, seed=1)
    [(2, -5939), (1, -4612), (2, -7535)]
    """
    import numpy as np

    rng = np.random.default_rng(seed)
    positions = {motor: start for motor, start in zip((1, 2, 3), start_positions, strict=True)}
    planned = []
    for _ in range(moves):
        motor, steps = _next_move(rng, positions, None, start_positions, span, max(2, int(step_usteps)))
        positions[motor] += steps
        planned.append((motor, steps))
    return planned


def run_random_programme(
    session: AcquisitionSession,
    moves: int,
    *,
    step_mm: float = 4.0,
    seed: int = 0,
    on_move: Callable[[int], None] | None = None,
) -> None:
    """Seeded move programme: approach with motor 1, retreat after contact, random moves otherwise.

    Parameters
    ----------
    session : AcquisitionSession
        Prepared (homed, at the start position) and with a log.
    moves : int
        Number of moves.
    step_mm : float
        Largest motor step, mm; each step is drawn between half of it and all of it.
    seed : int
        Seed of the programme.
    on_move : callable, optional
        Called with the number of moves done after each move (progress).
    """
    import numpy as np

    rng = np.random.default_rng(seed)
    step_max = max(2, session.motors.to_microsteps(step_mm))
    starts, limit = session.config.start_positions, session.config.presequence_span
    for done in range(1, moves + 1):
        motor, steps = _next_move(rng, session.positions, session.contact_move, starts, limit, step_max)
        session.move(motor, steps)
        if on_move is not None:
            on_move(done)
