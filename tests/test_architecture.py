"""The package's import graph: no cycles, no upward imports, small folders.

The graph is built from the source with :mod:`ast`, not by importing anything: every
``import`` / ``from ... import`` statement anywhere in a module counts -- at module level,
inside functions and methods, and under ``if TYPE_CHECKING:``.  A function-level import
only delays a cycle, it does not remove it, so the rule "no import cycles" is checked on
all of them.  ``from pcmm_geo.x import y`` is an edge to the module ``pcmm_geo.x.y`` when
that is a module, otherwise to ``pcmm_geo.x``.  A package's lazy PEP 562
re-exports (:mod:`pcmm_geo._lazy`) are read from its type stub ``__init__.pyi``, which spells
each of them as an import (tests/test_typing.py checks the stub and the lazy table agree).  Not
seen (documented limits): other imports by name through :mod:`importlib` and the implicit
import of parent packages' ``__init__``.

Layers (DESIGN.md "Layers", BRIEF "Layout shows the architecture"; rank 0 lowest).  A
module may import modules of its own layer and of lower ranks only; importing a higher rank
is an *upward* import, importing another layer of the same rank a *sideways* import; both
fail.  The most specific prefix of :data:`LAYERS` names a module's layer.
"""

from __future__ import annotations

import ast
import functools
import io
import tokenize
import warnings
from collections.abc import Collection
from pathlib import Path

import pytest

PACKAGE_ROOT = Path(__file__).resolve().parents[1] / "pcmm_geo"

#: layer (module-name prefix) -> rank.  Data flows down: a layer imports lower ranks only.
LAYERS: dict[str, int] = {
    "pcmm_geo.errors": 0,  # the exception tree; imports nothing of the package
    "pcmm_geo": 1,  # the top-level __init__: version and the exception names
    "pcmm_geo.elements": 1,  # the element / criterion spec every layer reads (imports errors only)
    "pcmm_geo.fit": 2,  # geometric fits, skew lines, reference data; no I/O, knows no machine
    "pcmm_geo.io": 2,  # point-cloud, mesh, NIST file formats (fit and io do not import each other)
    "pcmm_geo.thermal": 3,  # expansion, sensors, 20 degC correction (may use fit, io)
    "pcmm_geo.cmm": 3,  # files from external CMMs above fit and io: refit-and-compare, fits as QIF
    "pcmm_geo.machine.kinematics": 4,  # rigid-body model, seed DPKM, trilateration
    "pcmm_geo.acquisition": 5,  # drivers, simulators, sessions, durable logs; imports the kinematics it simulates
    # machine/__init__: the facade re-exporting names of its three sub-layers (lazily; its stub spells them), so it
    # ranks above them; nothing in the package imports it.  (Its deprecation finder _moved is a shim, below.)
    "pcmm_geo.machine": 7,
    "pcmm_geo.machine.calibration": 6,  # ch. 6 and ch. 7 calibration, calibration files
    "pcmm_geo.machine.analysis": 6,  # log processing, sensitivity
    "pcmm_geo.uncertainty": 7,  # GUM, Monte Carlo, calibration covariance, virtual CMM, ISO 14253-1
    "pcmm_geo.artefacts": 8,  # gauge blocks, ISO 10360, CAD comparison
    "pcmm_geo.testing": 9,  # helpers for users' tests
    "pcmm_geo.gdt": 9,  # GD&T: datums, reference frames, characteristics from points and from a CMM's actuals
    "pcmm_geo.ippdme": 9,  # I++ DME server: protocol, sessions, a simulated machine on kinematics and uncertainty
    "pcmm_geo.data": 9,  # scripts that regenerate bundled example data
    "pcmm_geo.plots": 9,  # matplotlib figures of results
    "pcmm_geo.demo": 10,  # the end-to-end demo
    "pcmm_geo.cli": 11,  # the pcmm command only wires; nothing imports it
    "pcmm_geo.__main__": 12,  # ``python -m pcmm_geo``: runs the pcmm command, imported by nothing
}

#: deprecation shims of old import paths: not part of the layered graph (they forward by name)
SHIMS: frozenset[str] = frozenset({"pcmm_geo.machine._moved"})

#: at most this many modules (.py files other than __init__) directly inside any folder of the package (BRIEF)
MAX_MODULES = 12
#: soft limit on a module's code lines: lines holding code, not docstrings, comments or blank lines
#: (docs/architecture.md "Size rules"); at the usual share of documentation this is the BRIEF's ~500 lines,
#: without pushing code out of the module it belongs to when its docstrings grow (References, equations, examples)
SOFT_MAX_CODE_LINES = 400


def module_files(root: Path) -> dict[str, Path]:
    """Dotted module name -> file for every ``.py`` below ``root`` (a package directory)."""
    modules = {}
    for path in sorted(root.rglob("*.py")):
        parts = (root.name, *path.relative_to(root).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        modules[".".join(parts)] = path
    return modules


def _targets(node: ast.Import | ast.ImportFrom, module: str, is_package: bool, known: Collection[str]) -> list[str]:
    if isinstance(node, ast.Import):
        names = [alias.name for alias in node.names]
    else:
        if node.level:
            package = module.split(".") if is_package else module.split(".")[:-1]
            base = package[: len(package) - node.level + 1]
            source = ".".join(base + ([node.module] if node.module else []))
        else:
            source = node.module or ""
        names = [f"{source}.{alias.name}" if f"{source}.{alias.name}" in known else source for alias in node.names]
    resolved = []
    for name in names:
        while name and name not in known:
            name = name.rpartition(".")[0]
        if name:
            resolved.append(name)
    return resolved


def import_graph(root: Path = PACKAGE_ROOT) -> dict[str, set[str]]:
    """Module -> set of the package's modules it imports (anywhere in its source); a fresh copy each call."""
    return {module: set(targets) for module, targets in _parsed_graph(root).items()}


@functools.lru_cache(maxsize=8)
def _parsed_graph(root: Path) -> dict[str, frozenset[str]]:
    """The import graph of the package at ``root``, parsed once per test session (``root`` is a tree no test edits
    while the session runs; the walker's own test writes a new folder)."""
    files = module_files(root)
    graph: dict[str, frozenset[str]] = {}
    for module, path in files.items():
        edges: set[str] = set()
        # a package's type stub (__init__.pyi) spells its lazy re-exports as imports: they are the package's edges
        for source in (path, path.with_suffix(".pyi")):
            if source is path or source.is_file():
                tree = ast.parse(source.read_text(encoding="utf-8"), filename=str(source))
                for node in ast.walk(tree):
                    if isinstance(node, ast.Import | ast.ImportFrom):
                        edges.update(_targets(node, module, path.name == "__init__.py", files))
        edges.discard(module)
        graph[module] = frozenset(edges)
    return graph


def cycle_components(graph: dict[str, set[str]]) -> list[set[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for succ in sorted(graph.get(node, ())):
            if succ not in index:
                visit(succ)
                low[node] = min(low[node], low[succ])
            elif succ in on_stack:
                low[node] = min(low[node], index[succ])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                components.append(component)

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return [set(component) for component in components]


def find_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """One closed import path through each strongly connected component (start repeated at the end)."""
    return [_cycle_path(graph, component) for component in cycle_components(graph)]


def _cycle_path(graph: dict[str, set[str]], component: set[str]) -> list[str]:
    """One closed path through a strongly connected component, start repeated at the end."""
    start = min(component)
    parents: dict[str, str] = {}
    frontier = [start]
    while frontier:  # breadth-first back to start
        nxt = []
        for node in frontier:
            for succ in sorted(graph[node] & component):
                if succ == start:
                    path = [node]
                    while path[-1] != start:
                        path.append(parents[path[-1]])
                    return [*reversed(path), start]
                if succ not in parents:
                    parents[succ] = node
                    nxt.append(succ)
        frontier = nxt
    return sorted(component)


def layer_of(module: str, layers: dict[str, int] = LAYERS) -> str | None:
    """The most specific prefix of ``layers`` that names ``module``'s layer."""
    best = None
    for prefix in layers:
        if (module == prefix or module.startswith(prefix + ".")) and (best is None or len(prefix) > len(best)):
            best = prefix
    return best


def layer_violations(graph: dict[str, set[str]], layers: dict[str, int] = LAYERS) -> list[str]:
    """Upward and sideways imports, one line each."""
    problems = []
    for module, targets in sorted(graph.items()):
        source_layer = layer_of(module, layers)
        for target in sorted(targets):
            target_layer = layer_of(target, layers)
            if source_layer is None or target_layer is None or source_layer == target_layer:
                continue
            if layers[target_layer] > layers[source_layer]:
                problems.append(f"upward: {module} ({source_layer}, rank {layers[source_layer]}) imports {target}"
                                f" ({target_layer}, rank {layers[target_layer]})")
            elif layers[target_layer] == layers[source_layer]:
                problems.append(f"sideways: {module} ({source_layer}) imports {target} ({target_layer}), same rank")
    return problems


def _without_shims(graph: dict[str, set[str]]) -> dict[str, set[str]]:
    return {module: targets - SHIMS for module, targets in graph.items() if module not in SHIMS}


# ---------------------------------------------------------------------------------------------
# the walker itself finds what it must find (a check that cannot fail proves nothing)


def _write_package(root: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    return root / "pkg"


def test_walker_sees_function_level_and_relative_imports_and_cycles(tmp_path: Path) -> None:
    package = _write_package(tmp_path, {
        "pkg/__init__.py": "",
        "pkg/low/__init__.py": "",
        "pkg/low/a.py": "def f():\n    from pkg.high import b\n",  # upward, inside a function
        "pkg/high/__init__.py": "",
        "pkg/high/b.py": "from pkg.high import c\n",  # a submodule named by from-import
        "pkg/high/c.py": "from ..low import a\n",  # relative
        "pkg/high/d.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from pkg.high.c import x\n",
    })
    graph = import_graph(package)
    assert graph["pkg.low.a"] == {"pkg.high.b"}
    assert graph["pkg.high.b"] == {"pkg.high.c"}
    assert graph["pkg.high.c"] == {"pkg.low.a"}
    assert graph["pkg.high.d"] == {"pkg.high.c"}
    assert find_cycles(graph) == [["pkg.high.b", "pkg.high.c", "pkg.low.a", "pkg.high.b"]]
    del graph["pkg.low.a"]
    assert find_cycles(graph) == []
    graph = import_graph(package)
    problems = layer_violations(graph, {"pkg": 0, "pkg.low": 0, "pkg.high": 1})
    assert problems == ["upward: pkg.low.a (pkg.low, rank 0) imports pkg.high.b (pkg.high, rank 1)"]


# ---------------------------------------------------------------------------------------------
# the package


def test_every_module_has_a_layer() -> None:
    unplaced = [module for module in import_graph() if layer_of(module) is None]
    assert unplaced == [], f"add these to LAYERS in {__file__}: {unplaced}"


def test_no_import_cycles() -> None:
    graph = _without_shims(import_graph())
    paths = [_cycle_path(graph, c) for c in cycle_components(graph)]
    assert paths == [], "import cycles:\n" + "\n".join(" -> ".join(path) for path in paths)


def test_no_upward_or_sideways_imports() -> None:
    problems = layer_violations(_without_shims(import_graph()))
    assert problems == [], "\n".join(problems)


@pytest.mark.parametrize(
    ("importer", "imported"),
    [("pcmm_geo.fit.line", "pcmm_geo.machine.kinematics.model"),
     ("pcmm_geo.machine.calibration.tetrahedron", "pcmm_geo.artefacts.gauge_block"),
     ("pcmm_geo.plots.demo", "pcmm_geo.cli.demo"),
     ("pcmm_geo.machine.kinematics.model", "pcmm_geo.acquisition.session"),
     ("pcmm_geo.acquisition.session", "pcmm_geo.machine.calibration.calfile"),
     ("pcmm_geo.machine.analysis.logproc", "pcmm_geo.machine.calibration.result")],
)
def test_the_rules_reject_the_imports_the_brief_forbids(importer: str, imported: str) -> None:
    graph = _without_shims(import_graph())
    graph[importer] = graph[importer] | {imported}
    assert len(layer_violations(graph)) == 1


def test_nothing_outside_the_cli_imports_the_cli() -> None:
    graph = import_graph()
    entry_points = ("pcmm_geo.cli", "pcmm_geo.__main__")  # __main__ is ``python -m pcmm_geo`` = pcmm
    users = sorted(m for m, targets in graph.items() if not m.startswith(entry_points)
                   for t in targets if t.startswith("pcmm_geo.cli"))
    assert users == []


def test_shims_are_only_the_listed_modules() -> None:
    graph = import_graph()
    assert SHIMS <= set(graph)
    assert all(not (targets & SHIMS) for module, targets in graph.items() if module != "pcmm_geo.machine")


def package_folders(root: Path = PACKAGE_ROOT) -> list[Path]:
    """Every folder of the package that holds Python modules (the package root included)."""
    return sorted({path.parent for path in root.rglob("*.py") if "__pycache__" not in path.parts})


def test_every_folder_holds_at_most_a_dozen_modules() -> None:
    folders = package_folders()
    assert PACKAGE_ROOT in folders and PACKAGE_ROOT / "fit" / "zone" in folders  # the walk sees nested packages
    crowded = {}
    for folder in folders:
        modules = sorted(p.name for p in folder.glob("*.py") if p.name != "__init__.py")
        if len(modules) > MAX_MODULES:
            crowded[str(folder.relative_to(PACKAGE_ROOT.parent))] = modules
    assert crowded == {}, f"folders over {MAX_MODULES} modules: {crowded}"


def code_lines(text: str) -> int:
    """How many lines of a module's source hold code: not blank, not only a comment, not in a docstring.

    A docstring is the first statement of the module, a class or a function when it is a string;
    any other string (a table, a message) is code.  A statement spread over several lines counts
    each of them.
    """
    docstrings: set[int] = set()
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value,
                                                                                                    str):
                docstrings.update(range(first.lineno, (first.end_lineno or first.lineno) + 1))
    layout = {tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT, tokenize.ENDMARKER,
              tokenize.ENCODING}
    code: set[int] = set()
    for token in tokenize.generate_tokens(io.StringIO(text).readline):
        if token.type not in layout:
            code.update(line for line in range(token.start[0], token.end[0] + 1) if line not in docstrings)
    return len(code)


def test_code_lines_counts_code_only() -> None:
    text = ('"""Module docstring,\n\ntwo paragraphs."""\n\nimport math  # a comment\n\n# a comment line\n'
            'TABLE = """a string that is data,\nnot a docstring"""\n\n\nclass A:\n    """Doc."""\n\n'
            '    def f(self, x: float) -> float:\n        """Doc\n        on two lines."""\n'
            '        return math.sqrt(\n            x)\n')
    # code: import, TABLE (2 lines), class A, def f, return (2 lines)
    assert code_lines(text) == 7
    assert len(text.splitlines()) == 19


def test_report_long_modules() -> None:
    """Soft target (BRIEF ~500 lines): modules over :data:`SOFT_MAX_CODE_LINES` code lines; a warning, not enforced.

    Code lines, not all lines: a module's documentation (numpydoc sections, References, equations,
    examples) is for reading and must not push code out of the module it belongs to.  A module
    over the limit is a place to look for two ideas to split by meaning (docs/architecture.md).
    """
    long_modules = []
    for module, path in module_files(PACKAGE_ROOT).items():
        text = path.read_text(encoding="utf-8")
        code = code_lines(text)
        if code > SOFT_MAX_CODE_LINES:
            long_modules.append(f"{module} ({code} code lines of {len(text.splitlines())})")
    if long_modules:
        warnings.warn(f"modules over {SOFT_MAX_CODE_LINES} code lines: {long_modules}", UserWarning, stacklevel=1)


FIT_ELEMENT_MODULES = frozenset(
    f"pcmm_geo.fit.{name}"
    for name in ("line", "plane", "circle", "sphere", "cylinder", "cone", "torus", "skew", "batch")
)


def test_fit_kernels_and_zone_solvers_sit_below_the_element_modules() -> None:
    """Inside fit: ``_kernels`` imports only itself; the zone solvers (``fit.zone._*``) import no element module.

    The element modules dispatch ``criterion=`` to the zone solvers and pass their Gaussian start and
    result class in, so the solvers never import them back (this is what keeps fit free of cycles).
    """
    graph = import_graph()
    kernel_imports = sorted(
        f"{module} -> {target}"
        for module, targets in graph.items() if module.startswith("pcmm_geo.fit._kernels")
        for target in targets if target.startswith("pcmm_geo.fit") and not target.startswith("pcmm_geo.fit._kernels")
    )
    assert kernel_imports == []
    solver_imports = sorted(
        f"{module} -> {target}"
        for module, targets in graph.items() if module.startswith("pcmm_geo.fit.zone._")
        for target in targets if target in FIT_ELEMENT_MODULES
    )
    assert solver_imports == []
    assert {"pcmm_geo.fit.zone._linear", "pcmm_geo.fit.zone._round", "pcmm_geo.fit.zone._axial"} <= set(graph)


#: ceiling of :func:`private_cross_imports` (issue 33: 31 in its review, 11 by layer the round after, 0 now)
MAX_PRIVATE_CROSS_IMPORTS = 0
#: statements not counted yet, each with its reason; the set can only shrink
PENDING_PRIVATE_IMPORTS: dict[str, str] = {}


def _owner(target: list[str], modules: dict[str, Path]) -> str | None:
    """The package a private name belongs to: what precedes its first ``_name`` segment (a module's: its package)."""
    for index, part in enumerate(target):
        if part.startswith("_") and not part.startswith("__"):
            owner = ".".join(target[:index])
            path = modules.get(owner)
            return owner if path is None or path.name == "__init__.py" else owner.rpartition(".")[0]
    return None


def private_cross_imports(root: Path = PACKAGE_ROOT) -> list[str]:
    """Import statements that reach a private module or name (``_x``) of a package the importer is not inside.

    ``from pcmm_geo.io._text import excerpt`` in ``pcmm_geo.machine...`` counts (``_text`` is
    ``pcmm_geo.io``'s).  Private parts stay private to their layer (:data:`LAYERS`): the element
    modules of ``fit`` dispatching into ``fit.zone._round`` or sharing ``fit._kernels._core`` do not
    count (one layer, whose inner order a test of its own keeps), ``pcmm_geo.artefacts`` reaching
    into ``fit._kernels._core`` does; nor do a package's own private modules, and the top-level
    ``pcmm_geo._x`` helpers shared by all.  One entry per statement.
    """
    modules = module_files(root)
    found = []
    for module, path in modules.items():
        package = module if path.name == "__init__.py" else module.rpartition(".")[0]
        layer = layer_of(module)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
                targets = [f"{node.module}.{alias.name}" for alias in node.names]
            else:
                continue
            owners = {_owner(target.split("."), modules) for target in targets if target.startswith(root.name + ".")}
            if any(owner and package != owner and not package.startswith(owner + ".")
                   and not (layer and layer_of(owner) == layer) for owner in owners):
                found.append(f"{module}:{node.lineno}")
    return found


def test_private_cross_package_imports_do_not_grow(tmp_path: Path) -> None:
    root = _write_package(tmp_path, {
        "pkg/__init__.py": "", "pkg/_shared.py": "", "pkg/io/__init__.py": "", "pkg/io/_text.py": "",
        "pkg/io/reader.py": "from pkg.io._text import a", "pkg/fit/__init__.py": "", "pkg/fit/_core.py": "",
        "pkg/fit/line.py": "from pkg.fit._core import _h\nfrom pkg.io._text import b", "pkg/cmm/__init__.py": "",
        "pkg/cmm/refit.py": "from pkg.fit._core import x\nfrom pkg.fit.line import _private\nfrom pkg._shared import y",
    })
    assert sorted(private_cross_imports(root)) == ["pkg.cmm.refit:1", "pkg.cmm.refit:2", "pkg.fit.line:2"]
    found = private_cross_imports()
    counted = [entry for entry in found if entry.partition(":")[0] not in PENDING_PRIVATE_IMPORTS]
    assert len(counted) <= MAX_PRIVATE_CROSS_IMPORTS, counted
    stale = set(PENDING_PRIVATE_IMPORTS) - {entry.partition(":")[0] for entry in found}
    assert stale == set(), f"no private import left in {stale}: drop them from PENDING_PRIVATE_IMPORTS"
