"""Sphinx configuration: API reference from the numpydoc docstrings and the user guide.

Build (what ``tests/test_docs.py`` runs inside ``./dev test``)::

    python -m sphinx -b html -W --keep-going -n docs docs/_build/html

No network is used: no intersphinx; references to numpy / scipy / Python types in docstrings
are plain text (``numpydoc_xref_param_type`` off) and signatures carry no type hints.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

_SOURCE = Path(__file__).resolve().parents[1]
if (_SOURCE / "pcmm_geo" / "__init__.py").exists():  # a clone: document this tree
    sys.path.insert(0, str(_SOURCE))

import pcmm_geo  # noqa: E402

project = "pcmm_geo"
author = "pcmm_geo developers"
copyright = "2026, pcmm_geo developers"
release = pcmm_geo.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
]
source_suffix = {".rst": "restructuredtext"}
exclude_patterns = ["_build", "*.md"]
root_doc = "index"

autosummary_generate = True
autosummary_imported_members = False
autodoc_typehints = "none"  # the numpydoc sections state types, shapes and units
# members defined in each module (not re-exports, which would be described twice), documented or not
autodoc_default_options = {"members": True, "undoc-members": True, "ignore-module-all": True}
autodoc_member_order = "bysource"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

nitpicky = True
# Documented exceptions only: objects Sphinx cannot resolve without fetching other projects' inventories.
nitpick_ignore_regex = [
    (r"py:.*", r"(numpy|np|scipy|trimesh|open3d|matplotlib|serial|dask|pathlib)\..*"),
]


def _skip_deprecated_aliases(app: Any, what: str, name: str, obj: object, skip: bool, options: Any) -> bool | None:
    """Deprecated 0.1 spellings (``tip_centre``...) stay out of the reference; the CHANGELOG lists them."""
    from pcmm_geo._deprecation import _Alias

    return True if isinstance(obj, _Alias) else None


def _exists(target: str, module: str | None, cls: str | None) -> bool:
    """True when ``target`` names a real Python object, seen from ``module`` (and ``cls``) like Python would."""
    import importlib

    bases = [f"{module}.{cls}" if module and cls else None, module, ""]
    for base in filter(lambda b: b is not None, bases):
        parts = (f"{base}.{target}" if base else target).split(".")
        for cut in range(len(parts), 0, -1):
            try:
                obj = importlib.import_module(".".join(parts[:cut]))
            except ImportError:
                continue
            try:
                for attribute in parts[cut:]:
                    obj = getattr(obj, attribute)
            except AttributeError:
                break
            return True
    return False


def _resolve_reference(app: Any, env: Any, node: Any, contnode: Any) -> Any:
    """Resolve what Sphinx' python domain cannot, without ever accepting a name that does not exist.

    1. A short or re-exported name (``:class:`FittedSphere``` written in another module,
       ``pcmm_geo.fit.fit_sphere`` for ``pcmm_geo.fit.sphere.fit_sphere``) links to the one documented
       object with that name (unique match only).
    2. A real object that has no page (module constants, private helpers, the standard library)
       is shown as plain text.
    Anything else stays a warning, which ``-W`` makes fatal: a broken reference fails the build.
    """
    from sphinx.util.nodes import make_refnode

    if node.get("refdomain") != "py":
        return None
    target = node["reftarget"].lstrip("~.")
    objects = env.get_domain("py").objects
    candidates = sorted(name for name in objects if name == target or name.endswith("." + target))
    if not candidates and "." in target:  # a re-export: pcmm_geo.fit.fit_sphere -> pcmm_geo.fit.sphere.fit_sphere
        package, last = target.rsplit(".", 1)
        candidates = sorted(name for name in objects if name.startswith(package + ".") and name.endswith("." + last))
    if len(candidates) == 1:
        entry = objects[candidates[0]]
        return make_refnode(app.builder, node["refdoc"], entry.docname, entry.node_id, contnode, candidates[0])
    if _exists(target, node.get("py:module"), node.get("py:class")):
        return contnode
    return None


def setup(app: Any) -> None:
    app.connect("autodoc-skip-member", _skip_deprecated_aliases)
    app.connect("missing-reference", _resolve_reference)


html_theme = "alabaster"
html_title = f"pcmm_geo {release}"
html_static_path: list[str] = []
