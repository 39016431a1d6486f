"""The must-show numbers of the import graph, for this tree or any commit: ``docs/architecture.md`` quotes them.

Computed from the source with :mod:`ast` by the functions of ``tests/test_architecture.py``
(loaded from this checkout, so the figures and the test count the same way), over the package of
this checkout or of a commit (``--rev``, unpacked with ``git archive`` into a temporary folder):

* modules, packages (folders with an ``__init__.py``), module-to-module import edges and
  layer-to-layer edges (:data:`LAYERS` of the test);
* import cycles (strongly connected components of more than one module; deprecation shims left
  out, as the test does), upward and sideways imports between layers;
* upward imports inside ``fit/``: ``fit._kernels`` importing the rest of ``fit``, or a zone solver
  (``fit.zone._*``) importing an element module (the order the test keeps inside the layer);
* private cross-package imports (:func:`private_cross_imports` of the test, one per statement);
* the largest folders (modules directly inside) and modules by code lines (not docstrings,
  comments or blank lines; :func:`code_lines` of the test).

Usage::

    python tools/architecture_figures.py                 # this checkout
    python tools/architecture_figures.py --rev 1ff52b2   # a commit (its pcmm_geo/, this test's rules)
    python tools/architecture_figures.py --json
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import subprocess
import sys
import tarfile
import tempfile
from collections import Counter
from pathlib import Path
from types import ModuleType
from typing import Any

REPO = Path(__file__).resolve().parents[1]


def architecture_test() -> ModuleType:
    """``tests/test_architecture.py`` of this checkout, loaded as a module."""
    spec = importlib.util.spec_from_file_location("_architecture_test", REPO / "tests" / "test_architecture.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def figures(root: Path) -> dict[str, Any]:
    """The numbers of the package at ``root`` (a ``pcmm_geo`` folder)."""
    arch = architecture_test()
    graph = arch.import_graph(root)
    layered = {m: t - arch.SHIMS for m, t in graph.items() if m not in arch.SHIMS}
    layer_edges: Counter[tuple[str, str]] = Counter()
    for module, targets in layered.items():
        source = arch.layer_of(module)
        for layer in {arch.layer_of(t) for t in targets} - {source, None}:
            layer_edges[(str(source), str(layer))] += 1
    fit_up = sorted(
        f"{m} -> {t}" for m, targets in graph.items() for t in targets
        if (m.startswith("pcmm_geo.fit._kernels") and t.startswith("pcmm_geo.fit")
            and not t.startswith("pcmm_geo.fit._kernels"))
        or (m.startswith("pcmm_geo.fit.zone._") and t in arch.FIT_ELEMENT_MODULES)
    )
    folders = {}
    for folder in arch.package_folders(root):
        count = sum(1 for p in folder.glob("*.py") if p.name != "__init__.py")
        folders[str(folder.relative_to(root.parent))] = count
    sizes = {module: (arch.code_lines(path.read_text(encoding="utf-8")),
                      len(path.read_text(encoding="utf-8").splitlines()))
             for module, path in arch.module_files(root).items()}
    private = arch.private_cross_imports(root)
    return {
        "modules": len(graph),
        "packages": sum(1 for _ in root.rglob("__init__.py")),
        "import_edges": sum(len(t) for t in graph.values()),
        "layer_edges": len(layer_edges),
        "cycles": len(arch.cycle_components(layered)),
        "layer_violations": len(arch.layer_violations(layered)),
        "upward_inside_fit": fit_up,
        "private_cross_imports": private,
        "folders_at_cap": sorted(f for f, n in folders.items() if n >= arch.MAX_MODULES),
        "largest_folders": sorted(folders.items(), key=lambda item: -item[1])[:6],
        "longest_modules_by_code": sorted(([m, *s] for m, s in sizes.items()), key=lambda row: -row[1])[:5],
        "modules_over_500_lines": sorted(m for m, (_, total) in sizes.items() if total > 500),
        "modules_over_code_limit": sorted(m for m, (code, _) in sizes.items() if code > arch.SOFT_MAX_CODE_LINES),
    }


def package_at(rev: str, into: Path) -> Path:
    """Unpack ``pcmm_geo/`` of commit ``rev`` into ``into`` and return its path."""
    archive = subprocess.run(["git", "-C", str(REPO), "archive", rev, "pcmm_geo"], check=True,
                             capture_output=True).stdout
    with tempfile.TemporaryFile() as handle:
        handle.write(archive)
        handle.seek(0)
        with tarfile.open(fileobj=handle) as tar:
            tar.extractall(into, filter="data")
    return into / "pcmm_geo"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rev", help="measure this commit's pcmm_geo/ instead of the checkout's")
    parser.add_argument("--json", action="store_true", help="print JSON")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        root = package_at(args.rev, Path(tmp)) if args.rev else REPO / "pcmm_geo"
        result = figures(root)
    if args.json:
        print(json.dumps(result, indent=1))
        return 0
    print(f"tree: {args.rev or 'checkout'}")
    for key, value in result.items():
        if isinstance(value, list) and value and not isinstance(value[0], str):
            print(f"{key}:")
            for row in value:
                print("  " + "  ".join(map(str, row)))
        elif isinstance(value, list):
            print(f"{key}: {len(value)}" + ("".join(f"\n  {v}" for v in value)))
        else:
            print(f"{key}: {value}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
