"""Write each lazy package's type stub ``__init__.pyi`` from its ``_LAZY`` table (pcmm_geo._lazy).

A new public name is one line in the package's ``_LAZY`` table; this writes the matching
``from .sub import name as name`` line into the stub (lines of names not in the table -- eager
imports, annotated constants -- are kept as they are), then sorts the imports with ruff.
``tests/test_typing.py`` fails while a stub and its table disagree.

Usage::

    python tools/lazy_stubs.py            # rewrite the stubs
    python tools/lazy_stubs.py --check    # only report the stubs that would change (exit 1)
"""

from __future__ import annotations

import argparse
import ast
import importlib
import shutil
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def stub_text(package: str, lazy: dict[str, str], old: str) -> str:
    """The stub of ``package``: the kept lines of its ``old`` stub plus one import per lazy name."""
    kept = []
    if old:
        lines = old.splitlines()
        for node in ast.parse(old).body:
            names = [alias.asname or alias.name for alias in node.names] if isinstance(node, ast.ImportFrom) else []
            is_docstring = isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant)
            if not is_docstring and not (names and set(names) <= set(lazy)):
                kept.append("\n".join(lines[node.lineno - 1 : node.end_lineno]))
    imports = []
    for name, module in sorted(lazy.items(), key=lambda item: (item[1], item[0])):
        head, _, last = module.rpartition(".")
        if name == last:  # a sub-module re-exported
            imports.append(f"from .{head} import {name} as {name}" if head else f"from . import {name} as {name}")
        else:
            imports.append(f"from .{module} import {name} as {name}")
    doc = f'"""Type stub of :mod:`{package}`: lazy public names, real types (pcmm_geo._lazy)."""'
    return "\n".join([doc, "", *imports, *kept]) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="write nothing; exit 1 if a stub would change")
    args = parser.parse_args(argv)
    root = REPO / "pcmm_geo"
    changed = []
    for init in sorted(root.rglob("__init__.py")):
        if "attach(__name__" not in init.read_text(encoding="utf-8"):
            continue
        package = ".".join(("pcmm_geo", *init.parent.relative_to(root).parts))
        stub = init.with_suffix(".pyi")
        old = stub.read_text(encoding="utf-8") if stub.is_file() else ""
        new = stub_text(package, importlib.import_module(package)._LAZY, old)
        ruff = shutil.which("ruff") or str(Path(sys.executable).with_name("ruff"))
        sorted_new = subprocess.run([ruff, "check", "--select", "I", "--fix-only", "--quiet", "--stdin-filename",
                                     str(stub), "-"], input=new, capture_output=True, text=True, check=True).stdout
        sorted_new = subprocess.run([ruff, "format", "--quiet", "--stdin-filename", str(stub), "-"],
                                    input=sorted_new, capture_output=True, text=True, check=True).stdout
        if sorted_new != old:
            changed.append(str(stub.relative_to(REPO)))
            if not args.check:
                stub.write_text(sorted_new, encoding="utf-8")
    print(("would change: " if args.check else "written: ") + (", ".join(changed) or "nothing"))
    return 1 if args.check and changed else 0


if __name__ == "__main__":
    sys.exit(main())
