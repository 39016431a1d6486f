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


@pytest.fixture(scope="session")
def calibration_file(tmp_path_factory) -> object:
    """A calibration file as ``pcmm calibrate --out`` writes it, with its covariance (demo probings, seed 7)."""
    import numpy as np

    from pcmm_geo.demo import CALIBRATION_LASERS, DemoSettings, simulate_probings, true_machine
    from pcmm_geo.machine.calibration import calibrate_tetrahedron, save_calibration
    from pcmm_geo.uncertainty.calibration import calibration_covariance

    settings = DemoSettings(seed=7)
    probings = simulate_probings(true_machine(settings), settings, np.random.default_rng(7))
    cal = calibrate_tetrahedron(probings, CALIBRATION_LASERS)
    covariance = calibration_covariance(probings, CALIBRATION_LASERS, probing_sigma=0.0005, laser_sigma=0.0005)
    return save_calibration(cal, tmp_path_factory.mktemp("cal") / "cal.json", covariance=covariance)
