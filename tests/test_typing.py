"""Public names type checkers can see: the lazy re-exports (:mod:`pcmm_geo._lazy`) and their stubs.

A package's ``__init__.py`` names its public objects in a table ``_LAZY`` (name -> sub-module)
loaded on first access; its ``__init__.pyi`` spells the same names as imports for mypy, pyright
and IDEs.  Here: every stub lists exactly its package's public names from the sub-modules of the
table (so the two cannot drift), the names stay lazy, and mypy -- run on a small file using the
public API -- sees real types, not ``Any``, for every re-exported name.
"""

from __future__ import annotations

import ast
import importlib
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import pcmm_geo

PACKAGE_ROOT = Path(pcmm_geo.__file__).resolve().parent
REPO_ROOT = Path(__file__).resolve().parents[1]


def lazy_packages() -> list[str]:
    """Every package whose ``__init__.py`` re-exports names through :func:`pcmm_geo._lazy.attach`."""
    found = []
    for path in sorted(PACKAGE_ROOT.rglob("__init__.py")):
        if "attach(__name__" in path.read_text(encoding="utf-8"):
            found.append(".".join(("pcmm_geo", *path.parent.relative_to(PACKAGE_ROOT).parts)))
    return found


def stub_exports(text: str) -> tuple[dict[str, str | None], list[str]]:
    """Names a stub exports -> the sub-module they come from (``None``: declared in the stub), and its faults.

    Only ``from .sub import name as name`` re-exports a name to a type checker (PEP 484); a bare
    ``from .sub import name`` or an absolute import is reported as a fault.
    """
    exports: dict[str, str | None] = {}
    faults = []
    for node in ast.parse(text).body:
        if isinstance(node, ast.ImportFrom):
            for alias in node.names:
                if node.level != 1 or alias.asname != alias.name:
                    faults.append(f"line {node.lineno}: {alias.name} is not re-exported as `from .sub import x as x`")
                    continue
                exports[alias.name] = node.module if node.module is not None else alias.name
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            exports[node.target.id] = None
        elif not (isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant)):  # the docstring
            faults.append(f"line {node.lineno}: unexpected statement in a re-export stub")
    return exports, faults


def stub_mismatches(text: str, lazy: dict[str, str], public: list[str]) -> list[str]:
    """How a stub differs from its package: the lazy table ``lazy`` and the package's ``__all__`` ``public``."""
    exports, problems = stub_exports(text)
    problems += [f"{name}: public but not in the stub" for name in sorted(set(public) - set(exports))]
    problems += [f"{name}: in the stub but not public" for name in sorted(set(exports) - set(public))]
    problems += [f"{name}: the table says .{lazy[name]}, the stub .{exports[name]}"
                 for name in sorted(set(lazy) & set(exports)) if exports[name] != lazy[name]]
    return problems


def test_the_lazy_packages_are_found() -> None:
    packages = lazy_packages()
    assert {"pcmm_geo.fit", "pcmm_geo.io", "pcmm_geo.machine", "pcmm_geo.plots"} <= set(packages)
    assert len(packages) >= 12


def test_no_package_writes_its_own_module_getattr() -> None:
    """One mechanism: a package ``__init__`` gets ``__getattr__`` from ``attach``, never a hand-written one."""
    handwritten = [str(path.relative_to(PACKAGE_ROOT)) for path in PACKAGE_ROOT.rglob("__init__.py")
                   if re.search(r"^def __(getattr|dir)__", path.read_text(encoding="utf-8"), re.MULTILINE)]
    assert handwritten == []


@pytest.mark.parametrize("package", lazy_packages())
def test_each_stub_lists_exactly_its_packages_public_names(package: str) -> None:
    module = importlib.import_module(package)
    stub = Path(module.__file__).with_suffix(".pyi")  # type: ignore[arg-type]
    assert stub.is_file(), f"{package} has lazy names but no {stub.name}"
    problems = stub_mismatches(stub.read_text(encoding="utf-8"), module._LAZY, module.__all__)
    assert problems == [], f"{stub}: {problems}; `python tools/lazy_stubs.py` writes the stub from the table"
    assert set(module._LAZY) <= set(module.__all__) <= set(dir(module))


def test_the_stub_check_catches_a_drifted_stub() -> None:
    lazy = {"fit_sphere": "sphere", "SphereFit": "sphere", "reference": "reference"}
    good = '"""Stub."""\nfrom . import reference as reference\nfrom .sphere import SphereFit as SphereFit\n' \
           "from .sphere import fit_sphere as fit_sphere\nTOL: float\n"
    assert stub_mismatches(good, lazy, [*lazy, "TOL"]) == []
    drifted = ("from .plane import fit_sphere as fit_sphere\nfrom .sphere import SphereFit\n"
               "from .cone import fit_cone as fit_cone\n")
    assert stub_mismatches(drifted, lazy, [*lazy, "TOL"]) == [
        "line 2: SphereFit is not re-exported as `from .sub import x as x`",
        "SphereFit: public but not in the stub",
        "TOL: public but not in the stub",
        "reference: public but not in the stub",
        "fit_cone: in the stub but not public",
        "fit_sphere: the table says .sphere, the stub .plane",
    ]


def test_names_load_on_first_access_and_are_then_plain_attributes() -> None:
    code = textwrap.dedent("""
        import sys
        import pcmm_geo.fit, pcmm_geo.machine
        before = sorted(m for m in ("pcmm_geo.fit.sphere", "pcmm_geo.fit.reference",
                                    "pcmm_geo.machine.kinematics.model") if m in sys.modules)
        function = pcmm_geo.fit.fit_sphere
        assert "pcmm_geo.fit.sphere" in sys.modules and vars(pcmm_geo.fit)["fit_sphere"] is function
        assert function is sys.modules["pcmm_geo.fit.sphere"].fit_sphere
        assert pcmm_geo.fit.reference is sys.modules["pcmm_geo.fit.reference"]  # a sub-module re-exported
        assert "seed_machine" in dir(pcmm_geo.machine) and "seed_machine" in pcmm_geo.machine.__all__
        try:
            pcmm_geo.machine.no_such_name
        except AttributeError as error:
            print(before, error)
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[] module 'pcmm_geo.machine' has no attribute 'no_such_name'"


#: a typed use of the main public functions: must type-check, except the one line marked ``# wrong``
TYPED_USE = '''
import numpy as np
import numpy.typing as npt

from pcmm_geo.elements import Criterion
from pcmm_geo.fit import CylinderFit, PlaneFit, SphereFit, fit_cylinder, fit_plane, fit_sphere
from pcmm_geo.io import read_points
from pcmm_geo.machine import RigidBodyMachine, seed_machine, trilaterate


def sphere_on_plane(path: str) -> tuple[float, float]:
    points: npt.NDArray[np.float64] = read_points(path)
    sphere: SphereFit = fit_sphere(points, radius=None)
    plane: PlaneFit = fit_plane(points)
    cylinder: CylinderFit = fit_cylinder(points)
    height = float(np.dot(sphere.center - plane.point, plane.normal))
    return sphere.radius + cylinder.radius, height


def tip(lengths: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    machine: RigidBodyMachine = seed_machine()
    del machine
    return trilaterate(np.eye(3), lengths).point


def minimum_zone(points: npt.NDArray[np.float64]) -> Criterion:
    return fit_cylinder(points, criterion="chebyshev").criterion  # a Criterion, not any str


radius_as_text: str = fit_sphere(np.zeros((4, 3))).radius  # wrong
'''


@pytest.mark.slow
def test_mypy_sees_every_public_name_with_its_real_type(tmp_path: Path) -> None:
    pytest.importorskip("mypy", reason="mypy comes with the test extra")
    names = [(package, name) for package in lazy_packages() for name in importlib.import_module(package).__all__]
    lines = [*TYPED_USE.splitlines(), *(f"import {package}" for package in lazy_packages())]
    first_reveal = len(lines) + 1
    lines += [f"reveal_type({package}.{name})" for package, name in names]
    source = tmp_path / "use_the_api.py"
    source.write_text("\n".join(lines) + "\n", encoding="utf-8")
    wrong_line = lines.index(next(line for line in lines if line.endswith("# wrong"))) + 1
    # silent: the library's own modules are analysed for their types, their own errors are not the question
    # here; the cache (git-ignored) makes later runs take well under a second instead of ~10 s of CPU.
    # MYPYPATH names the tree the tests import: mypy cannot follow an editable install's import hook
    # (setuptools' finder), where it would see pcmm_geo as missing and every name as Any
    import pcmm_geo

    tree = Path(pcmm_geo.__file__).resolve().parents[1]
    env = dict(os.environ) if tree.name in ("site-packages", "dist-packages") else {**os.environ, "MYPYPATH": str(tree)}
    out = subprocess.run(
        [sys.executable, "-m", "mypy", "--follow-imports=silent", "--no-error-summary", "--hide-error-context",
         "--cache-dir", str(REPO_ROOT / ".mypy_cache"), "--python-version", "3.11", str(source)],
        capture_output=True, text=True, cwd=tmp_path, env=env,
    )
    reveals = re.findall(r":(\d+): note: Revealed type is \"(.*)\"", out.stdout)
    assert len(reveals) == len(names), out.stdout[-2000:] + out.stderr[-2000:]
    assert [int(line) for line, _ in reveals] == list(range(first_reveal, first_reveal + len(names)))
    untyped = [f"{package}.{name}" for (package, name), (_, kind) in zip(names, reveals, strict=True) if kind == "Any"]
    assert untyped == []
    errors = [line for line in out.stdout.splitlines() if ": error:" in line]
    assert len(errors) == 1 and f":{wrong_line}: error: Incompatible types in assignment" in errors[0], errors
    assert '"float", variable has type "str"' in errors[0]
    assert out.returncode == 1  # mypy's "errors found": the wrong line, nothing else
