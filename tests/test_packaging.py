"""Packaging conventions: light core, extras named in errors, project files, ``python -m pcmm_geo``."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

import pcmm_geo
from pcmm_geo import MissingDependencyError, PcmmGeoError
from pcmm_geo._optional import OPTIONAL_MODULES, available, require

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = ROOT / "pyproject.toml"


def _pyproject() -> dict:  # type: ignore[type-arg]
    return tomllib.loads(PYPROJECT.read_text(encoding="utf-8"))


def test_core_dependencies_are_numpy_and_scipy_only() -> None:
    project = _pyproject()["project"]
    names = sorted(dep.split(">")[0].split("=")[0].split("[")[0] for dep in project["dependencies"])
    assert names == ["numpy", "scipy"]


def test_every_optional_module_is_in_its_extra_and_all_has_them_all() -> None:
    extras = _pyproject()["project"]["optional-dependencies"]
    for module, (package, extra) in OPTIONAL_MODULES.items():
        assert any(dep.startswith(package) for dep in extras[extra]), (module, extra)
    everything = extras["all"][0]
    for extra in {extra for _, extra in OPTIONAL_MODULES.values()}:
        assert extra in everything
    for needed in ("docs", "test", "bench"):
        assert needed in extras


def test_build_system_and_license_files() -> None:
    data = _pyproject()
    assert "setuptools>=77" in data["build-system"]["requires"]
    assert data["project"]["license"] == "MIT"
    assert "MIT License" in (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert "pcmm_geo developers" in (ROOT / "LICENSE").read_text(encoding="utf-8")
    citation = (ROOT / "CITATION.cff").read_text(encoding="utf-8")
    assert "A critical investigation into the accuracy of a parallel mechanism coordinate measuring machine" in citation
    assert "Stellenbosch University" in citation
    changelog = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    assert "## [0.2.0] - Unreleased" in changelog and "### Deprecated" in changelog


def test_importing_the_core_loads_no_optional_package() -> None:
    code = (
        "import sys, pcmm_geo, pcmm_geo.fit, pcmm_geo.machine, pcmm_geo.thermal, pcmm_geo.artefacts, pcmm_geo.io;"
        "from pcmm_geo.fit import fit_sphere, fit_cylinder;"
        "import pcmm_geo.artefacts.gauge_block, pcmm_geo.artefacts.cad_compare, pcmm_geo.io.meshes, pcmm_geo.cli;"
        f"print(sorted(m for m in {sorted(OPTIONAL_MODULES)!r} if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.strip() == "[]"


@pytest.mark.parametrize(("module", "extra", "package"), [
    ("trimesh", "cad", "trimesh"), ("open3d", "cad", "open3d"), ("serial", "acquire", "pyserial"),
    ("matplotlib", "plots", "matplotlib"), ("rich", "progress", "rich"), ("dask", "dask", "dask[array]"),
])
def test_missing_extra_is_a_typed_error_naming_the_extra(
    monkeypatch: pytest.MonkeyPatch, module: str, extra: str, package: str
) -> None:
    monkeypatch.setitem(sys.modules, module, None)  # what an install without the extra looks like to import
    with pytest.raises(MissingDependencyError) as caught:
        require(f"{module}.submodule" if module == "matplotlib" else module, purpose="the test")
    error = caught.value
    assert isinstance(error, PcmmGeoError) and isinstance(error, ImportError)
    assert (error.extra, error.package, error.name) == (extra, package, module)
    assert str(error) == (
        f"the test needs {package}, which is not installed; install the extra with: pip install 'pcmm_geo[{extra}]'"
    )
    assert not available(module)


def test_library_functions_name_the_extra(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    from pcmm_geo.acquisition.drivers._port import open_port
    from pcmm_geo.io.meshes import nominal_mesh
    from pcmm_geo.io.points import write_points

    monkeypatch.setitem(sys.modules, "trimesh", None)
    monkeypatch.setitem(sys.modules, "open3d", None)
    monkeypatch.setitem(sys.modules, "serial", None)
    with pytest.raises(MissingDependencyError, match=r"pip install 'pcmm_geo\[cad\]'") as mesh_error:
        nominal_mesh("box:1x2x3")
    assert "pcmm_geo.io.meshes" in mesh_error.value.purpose
    with pytest.raises(MissingDependencyError, match=r"pcmm_geo\[cad\]"):
        write_points(tmp_path / "cloud.ply", np.zeros((3, 3)))
    with pytest.raises(MissingDependencyError, match=r"pcmm_geo\[acquire\]"):
        open_port("/dev/ttyUSB_none", device="laser", baudrate=9600, timeout=0.1)


def test_unknown_modules_keep_their_plain_import_error() -> None:
    with pytest.raises(ModuleNotFoundError) as caught:
        require("pcmm_geo_no_such_module")
    assert not isinstance(caught.value, MissingDependencyError)


def test_progress_bar_is_optional(monkeypatch: pytest.MonkeyPatch) -> None:
    import argparse

    from pcmm_geo.cli import _progress

    monkeypatch.setitem(sys.modules, "rich", None)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert _progress.progress_wanted(argparse.Namespace(json=False)) is False


def test_python_dash_m_runs_the_pcmm_command() -> None:
    help_text = subprocess.run([sys.executable, "-m", "pcmm_geo", "--help"], capture_output=True, text=True,
                               check=True, cwd=ROOT).stdout
    assert help_text.startswith("usage: pcmm")
    version = subprocess.run([sys.executable, "-m", "pcmm_geo", "--version"], capture_output=True, text=True,
                             check=True, cwd=ROOT).stdout
    assert version.strip() == f"pcmm_geo {pcmm_geo.__version__}"
    failed = subprocess.run([sys.executable, "-m", "pcmm_geo", "fit", "sphere", str(ROOT / "no-such-file.csv")],
                            capture_output=True, text=True, cwd=ROOT)
    assert failed.returncode == 2 and "no-such-file.csv" in failed.stderr


def test_extras_table_names_real_tests() -> None:
    """Every entry of conftest.EXTRAS_NEEDED names an existing test module (and function): a stale entry
    would silently stop marking a test."""
    import ast
    import importlib.util

    spec = importlib.util.spec_from_file_location("tests_root_conftest", ROOT / "tests" / "conftest.py")
    assert spec is not None and spec.loader is not None
    conftest = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(conftest)
    EXTRAS_NEEDED = conftest.EXTRAS_NEEDED

    extras = set(_pyproject()["project"]["optional-dependencies"])
    for key, extra in EXTRAS_NEEDED.items():
        assert extra in extras, key
        module, _, function = key.partition("::")
        function = function.partition("[")[0]
        path = ROOT / "tests" / module
        assert path.is_file(), key
        if function:
            names = {node.name for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
                     if isinstance(node, ast.FunctionDef)}
            assert function in names, key
