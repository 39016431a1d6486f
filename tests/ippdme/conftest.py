"""Fixtures of the I++ DME server tests: the calibrated micro-CMM (computed once) and a server on a free port."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest


@pytest.fixture(scope="session")
def calibrated() -> tuple[Any, float, Any, np.ndarray]:
    """The demo's calibrated machine, tip radius, calibration covariance and working-volume centre."""
    from pcmm_geo.demo import demo_calibrated_machine

    return demo_calibrated_machine()


@pytest.fixture(scope="session")
def model(calibrated: tuple[Any, float, Any, np.ndarray]) -> Any:
    from pcmm_geo.ippdme.machine import MachineModel

    machine, radius, covariance, _ = calibrated
    return MachineModel(machine, radius, covariance.model_covariance()[1])


@pytest.fixture(scope="session")
def center(calibrated: tuple[Any, float, Any, np.ndarray]) -> np.ndarray:
    return np.asarray(calibrated[3], dtype=float)


@contextlib.contextmanager
def running_server(model: Any, workpieces: list[Any], *, seed: int = 0, transcript: Any = None,
                   time_scale: float = 0.0, write_timeout: float = 10.0) -> Iterator[Any]:
    """A server thread on a free localhost port with a simulated machine."""
    from pcmm_geo.ippdme.machine import SimulatedMachine
    from pcmm_geo.ippdme.server import ServerThread
    from pcmm_geo.ippdme.session import ServerState
    from pcmm_geo.ippdme.transcript import Transcript

    machine = SimulatedMachine(model, workpieces, seed=seed)
    transcript = transcript if transcript is not None else Transcript(None, {})
    with ServerThread(ServerState.create(machine), transcript, time_scale=time_scale,
                      write_timeout=write_timeout) as server:
        server.machine = machine
        yield server
