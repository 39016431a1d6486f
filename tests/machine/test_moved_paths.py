"""The flat ``pcmm_geo.machine`` paths of before the re-housing still import, with a DeprecationWarning.

This is the only test that may use the old paths; every other test imports the new ones.
"""

from __future__ import annotations

import importlib
import subprocess
import sys
import warnings

import pytest

from pcmm_geo.machine._moved import EXTRA_NAMES, MOVED

# importing pcmm_geo.machine.drivers.zaber also imports (and warns about) the old package path
pytestmark = pytest.mark.filterwarnings(r"ignore:pcmm_geo\.machine\.(drivers|simulators) is deprecated")


def _forget(name: str) -> None:
    for key in [k for k in sys.modules if k == name or k.startswith(name + ".")]:
        del sys.modules[key]
    parent, _, child = name.rpartition(".")
    if parent in sys.modules and child in vars(sys.modules[parent]):
        delattr(sys.modules[parent], child)  # the import system set it; a later import must find the module anew


@pytest.mark.parametrize(("old", "new"), sorted(MOVED.items()))
def test_old_path_warns_and_offers_the_same_objects(old: str, new: str) -> None:
    new_module = importlib.import_module(new)
    _forget(old)
    try:
        with pytest.warns(DeprecationWarning, match=rf"{old} is deprecated .* import {new} instead"):
            old_module = importlib.import_module(old)
        public = getattr(new_module, "__all__", None) or [n for n in vars(new_module) if not n.startswith("_")]
        assert public or hasattr(new_module, "__path__"), new  # only the packages drivers/, simulators/ are empty
        for name in public:
            assert getattr(old_module, name) is getattr(new_module, name), name
        for name, where in EXTRA_NAMES.get(old, {}).items():
            assert getattr(old_module, name) is getattr(importlib.import_module(where), name)
    finally:
        _forget(old)


def test_from_import_of_old_paths() -> None:
    for name in ("pcmm_geo.machine.drivers", "pcmm_geo.machine.dpkm", "pcmm_geo.machine.calfile"):
        _forget(name)
    try:
        with pytest.warns(DeprecationWarning, match="pcmm_geo.acquisition.drivers.zaber"):
            from pcmm_geo.machine.drivers.zaber import ZaberChain
        from pcmm_geo.acquisition.drivers.zaber import ZaberChain as new_chain

        assert ZaberChain is new_chain
        with pytest.warns(DeprecationWarning, match="pcmm_geo.machine.kinematics.dpkm"):
            from pcmm_geo.machine import dpkm
        from pcmm_geo.machine.kinematics.model import seed_machine

        assert dpkm.seed_machine is seed_machine  # moved to the model to break the dpkm <-> model cycle
        with pytest.warns(DeprecationWarning, match="pcmm_geo.machine.calibration.calfile"):
            from pcmm_geo.machine.calfile import load_calibration
        from pcmm_geo.machine.calibration import load_calibration as new_load

        assert load_calibration is new_load
    finally:
        for name in ("pcmm_geo.machine.drivers", "pcmm_geo.machine.dpkm", "pcmm_geo.machine.calfile"):
            _forget(name)


def test_the_warning_points_at_the_importing_line(tmp_path) -> None:
    script = tmp_path / "user_script.py"
    script.write_text("import pcmm_geo.machine.sensitivity\n", encoding="utf-8")
    result = subprocess.run([sys.executable, "-W", "always::DeprecationWarning", str(script)],
                            capture_output=True, text=True, check=True)
    assert "user_script.py:1: DeprecationWarning: pcmm_geo.machine.sensitivity is deprecated" in result.stderr


def test_machine_names_and_new_paths_import_without_warnings() -> None:
    code = (
        "import warnings; warnings.simplefilter('error')\n"
        "import pcmm_geo.machine as m\n"
        "names = [getattr(m, n) for n in m.__all__]\n"
        "from pcmm_geo.machine.calibration import calibrate_tetrahedron, save_calibration, load_calibration\n"
        "import pcmm_geo.acquisition.session, pcmm_geo.acquisition.simulators.cmm\n"
        "import pcmm_geo.machine.analysis.logproc, pcmm_geo.machine.kinematics.dpkm\n"
        "print(len(names))\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert int(result.stdout) == len(importlib.import_module("pcmm_geo.machine").__all__)


def test_unknown_names_still_fail() -> None:
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("pcmm_geo.machine.no_such_module")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(AttributeError, match="no_such_name"):
            importlib.import_module("pcmm_geo.machine").no_such_name  # noqa: B018
