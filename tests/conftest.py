"""Shared pytest fixtures for pcmm_geo."""

from __future__ import annotations

from pathlib import Path

import pytest

DATA_DIR = Path(__file__).parent / "data"


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """Folder of the test data bundled with the repository."""
    return DATA_DIR
