"""Fixtures of the acquisition tests: simulators on real pseudo-terminals, leak checks."""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Iterator

import pytest

from pcmm_geo.acquisition.simulators.pty import PtyServer, SimulatedDevice


def _open_fds() -> int:
    return len(os.listdir("/proc/self/fd")) if os.path.isdir("/proc/self/fd") else 0


@pytest.fixture(autouse=True)
def no_leaks() -> Iterator[None]:
    """Every test must stop its simulator threads and close every descriptor it opened."""
    before = _open_fds()
    yield
    alive = [t.name for t in threading.enumerate() if t.name == "pcmm-pty-sim"]
    assert alive == [], f"simulator threads still running: {alive}"
    assert _open_fds() <= before, f"file descriptors leaked: {before} -> {_open_fds()}"


@pytest.fixture
def serve() -> Iterator[Callable[..., PtyServer]]:
    """``serve(device, ...)`` starts a PtyServer that is closed when the test ends."""
    servers: list[PtyServer] = []

    def start(*devices: SimulatedDevice) -> PtyServer:
        server = PtyServer(list(devices))
        servers.append(server)
        return server

    yield start
    for server in servers:
        server.close()
    assert [f for server in servers for f in server.failures] == []
