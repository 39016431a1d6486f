"""The library side of ``pcmm acquire``: open the five devices as one session, run a move programme.

:func:`open_session` connects the Zaber chain, lasers a, b, c (ILD1302, ILD1302, ILD1420 as in
the seed) and the Arduino probe on the given ports and returns an
:class:`~pcmm_geo.acquisition.session.AcquisitionSession`; every device is entered on the
caller's :class:`contextlib.ExitStack`, so the ports close however the session ends.

:func:`run_random_programme` is the seeded test programme of ``pcmm acquire``: motor 1 approaches
the artefact with probability 0.4, otherwise a random motor moves a random way; once the probe
touches, only the retreat of the touching motor is allowed (thesis 3.6), and no move leaves the
pre-sequence span around the start position.

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

__all__ = ["ARMS", "DEVICE_PORTS", "open_session", "run_random_programme"]

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
    config = SessionConfig(settle_time=settle_time)
    if clock is not None:
        return AcquisitionSession(motors, lasers, probe, None, config, sleep=clock.sleep, clock=clock)
    return AcquisitionSession(motors, lasers, probe, None, config)


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
    start, limit = session.config.start_position, session.config.presequence_span
    for done in range(1, moves + 1):
        steps = int(rng.integers(step_max // 2, step_max + 1))
        if session.contact_move is not None:
            motor, direction = session.contact_move[0], -session.contact_move[1]
        elif rng.random() < 0.4:
            motor, direction = 1, 1
        else:
            motor, direction = int(rng.integers(1, 4)), int(rng.choice((-1, 1)))
        offset = session.positions[motor] - start
        if session.contact_move is None and abs(offset + direction * steps) > limit:
            direction = -1 if offset > 0 else 1
        session.move(motor, direction * steps)
        if on_move is not None:
            on_move(done)
