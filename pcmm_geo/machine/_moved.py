"""Deprecated import paths of the modules that moved out of the flat ``pcmm_geo.machine`` (one release).

Until release 0.2 ``pcmm_geo.machine`` was one folder of modules.  Its modules now live in
:mod:`pcmm_geo.machine.kinematics`, :mod:`pcmm_geo.machine.calibration`,
:mod:`pcmm_geo.machine.analysis` and :mod:`pcmm_geo.acquisition`; the numerical calibration
(ch. 6) later moved on from ``pcmm_geo.machine.calibration`` to
:mod:`pcmm_geo.machine.calibration.numerical`.  Importing an old path
(``import pcmm_geo.machine.dpkm``, ``from pcmm_geo.machine.drivers.zaber import ZaberChain``)
still works for one release: a meta-path finder, installed when :mod:`pcmm_geo.machine` is
imported, serves a small alias module whose names are the new module's objects, and emits a
:class:`DeprecationWarning` naming the new path.  No file exists at the old paths, so the old
names cannot shadow the new packages (``pcmm_geo.machine.calibration`` is now a package).

The import-graph test lists this module as a shim: it imports the new paths only by name
(``importlib``), so it adds no edge, cycle or upward import to the package's graph.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import types
import warnings
from collections.abc import Sequence
from typing import Any

#: old module path -> new module path (every module that left the flat ``pcmm_geo.machine``)
MOVED: dict[str, str] = {
    "pcmm_geo.machine.model": "pcmm_geo.machine.kinematics.model",
    "pcmm_geo.machine.model_parts": "pcmm_geo.machine.kinematics.model_parts",
    "pcmm_geo.machine.dpkm": "pcmm_geo.machine.kinematics.dpkm",
    "pcmm_geo.machine.trilateration": "pcmm_geo.machine.kinematics.trilateration",
    "pcmm_geo.machine._pose_solver": "pcmm_geo.machine.kinematics._pose_solver",
    "pcmm_geo.machine.seed_forms": "pcmm_geo.machine.kinematics.seed_forms",
    "pcmm_geo.machine.calibration_columns": "pcmm_geo.machine.calibration.columns",
    "pcmm_geo.machine.calibration_datum": "pcmm_geo.machine.calibration.datum",
    "pcmm_geo.machine.calibration_geometry": "pcmm_geo.machine.calibration.geometry",
    "pcmm_geo.machine.calibration_io": "pcmm_geo.machine.calibration.probings",
    "pcmm_geo.machine.calibration_noise": "pcmm_geo.machine.calibration.noise",
    "pcmm_geo.machine.calibration_result": "pcmm_geo.machine.calibration.result",
    "pcmm_geo.machine.calibration_seed": "pcmm_geo.machine.calibration.seed",
    "pcmm_geo.machine.calfile": "pcmm_geo.machine.calibration.calfile",
    "pcmm_geo.machine.numcal": "pcmm_geo.machine.calibration.numerical.numcal",
    "pcmm_geo.machine.numcal_data": "pcmm_geo.machine.calibration.numerical.numcal_data",
    "pcmm_geo.machine.identifiability": "pcmm_geo.machine.calibration.numerical.identifiability",
    # issue 16: the numerical calibration left the full calibration/ folder for its own sub-package
    "pcmm_geo.machine.calibration.numcal": "pcmm_geo.machine.calibration.numerical.numcal",
    "pcmm_geo.machine.calibration.numcal_data": "pcmm_geo.machine.calibration.numerical.numcal_data",
    "pcmm_geo.machine.calibration.identifiability": "pcmm_geo.machine.calibration.numerical.identifiability",
    "pcmm_geo.machine.logproc": "pcmm_geo.machine.analysis.logproc",
    "pcmm_geo.machine.logproc_rows": "pcmm_geo.machine.analysis.logproc.rows",
    # issue 22: log processing became the sub-package pcmm_geo.machine.analysis.logproc
    "pcmm_geo.machine.analysis.logproc_rows": "pcmm_geo.machine.analysis.logproc.rows",
    "pcmm_geo.machine.analysis.logproc_synthesis": "pcmm_geo.machine.analysis.logproc.synthesis",
    "pcmm_geo.machine.analysis.logproc_uncertainty": "pcmm_geo.machine.analysis.logproc.uncertainty",
    "pcmm_geo.machine.analysis.logproc_closure": "pcmm_geo.machine.analysis.logproc.gate",
    "pcmm_geo.machine.sensitivity": "pcmm_geo.machine.analysis.sensitivity",
    "pcmm_geo.machine.session": "pcmm_geo.acquisition.session",
    "pcmm_geo.machine.acqlog": "pcmm_geo.acquisition.acqlog",
    "pcmm_geo.machine.drivers": "pcmm_geo.acquisition.drivers",
    "pcmm_geo.machine.drivers._port": "pcmm_geo.acquisition.drivers._port",
    "pcmm_geo.machine.drivers.lasers": "pcmm_geo.acquisition.drivers.lasers",
    "pcmm_geo.machine.drivers.probe": "pcmm_geo.acquisition.drivers.probe",
    "pcmm_geo.machine.drivers.zaber": "pcmm_geo.acquisition.drivers.zaber",
    "pcmm_geo.machine.simulators": "pcmm_geo.acquisition.simulators",
    "pcmm_geo.machine.simulators.cmm": "pcmm_geo.acquisition.simulators.cmm",
    "pcmm_geo.machine.simulators.devices": "pcmm_geo.acquisition.simulators.devices",
    "pcmm_geo.machine.simulators.faults": "pcmm_geo.acquisition.simulators.faults",
    "pcmm_geo.machine.simulators.pty": "pcmm_geo.acquisition.simulators.pty",
}

#: names an old module offered that now live in another new module: old path -> {name: new module}
EXTRA_NAMES: dict[str, dict[str, str]] = {
    "pcmm_geo.machine.dpkm": {"seed_machine": "pcmm_geo.machine.kinematics.model"},
}

_PACKAGES = frozenset({"pcmm_geo.machine.drivers", "pcmm_geo.machine.simulators"})


class _AliasLoader(importlib.abc.Loader):
    def __init__(self, new_name: str) -> None:
        self.new_name = new_name

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> types.ModuleType | None:
        return None  # default module object, filled by exec_module

    def exec_module(self, module: types.ModuleType) -> None:
        old_name = module.__name__
        warnings.warn(
            f"{old_name} is deprecated and will be removed in pcmm_geo 0.3; import {self.new_name} instead",
            DeprecationWarning,
            stacklevel=2,  # the importing line: warnings skips the frames of importlib._bootstrap
        )
        new = importlib.import_module(self.new_name)
        names = {key: value for key, value in vars(new).items() if not key.startswith("__")}
        for name, where in EXTRA_NAMES.get(old_name, {}).items():
            names[name] = getattr(importlib.import_module(where), name)
        vars(module).update(names)
        module.__doc__ = f"Deprecated alias of :mod:`{self.new_name}`."
        if hasattr(new, "__all__"):
            module.__all__ = list(new.__all__)

        def __getattr__(name: str) -> Any:  # names set on the new module later (submodules)
            return getattr(new, name)

        module.__getattr__ = __getattr__  # type: ignore[method-assign]


class _MovedFinder(importlib.abc.MetaPathFinder):
    def find_spec(
        self, fullname: str, path: Sequence[str] | None, target: types.ModuleType | None = None
    ) -> importlib.machinery.ModuleSpec | None:
        new_name = MOVED.get(fullname)
        if new_name is None:
            return None
        return importlib.machinery.ModuleSpec(
            fullname, _AliasLoader(new_name), is_package=fullname in _PACKAGES
        )


def install() -> None:
    """Put the finder of the old paths on :data:`sys.meta_path` (once)."""
    if not any(isinstance(finder, _MovedFinder) for finder in sys.meta_path):
        sys.meta_path.append(_MovedFinder())
