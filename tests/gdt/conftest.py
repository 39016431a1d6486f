"""Shared fixtures of the GD&T tests: the constructed part of ``pcmm_geo/data/examples/gdt``."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import pytest

EXAMPLE_DIR = Path(__file__).parents[2] / "pcmm_geo" / "data" / "examples" / "gdt"


def load_maker() -> ModuleType:
    """The example's generator script as a module (it defines the constructed parts' exact answers)."""
    name = "make_gdt_example"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, EXAMPLE_DIR / "make_gdt_example.py")
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


@pytest.fixture(scope="session")
def maker() -> ModuleType:
    return load_maker()
