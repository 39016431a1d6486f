"""Lazy re-exports of a package's public names (PEP 562), one mechanism for every package.

A package ``__init__.py`` names each public object and the sub-module that defines it::

    _LAZY = {"fit_sphere": "sphere", "AxisRegion": "zone.axial.region"}
    __getattr__, __dir__, __all__ = attach(__name__, _LAZY)

The first access ``package.fit_sphere`` imports ``package.sphere`` and caches the object in the
package namespace; importing the package itself stays cheap.  A name equal to the last part of
its sub-module (``"reference": "reference"``) exports the sub-module itself.

Type checkers and IDEs do not run ``__getattr__``: next to each such ``__init__.py`` an
``__init__.pyi`` stub spells the same names as ``from .sphere import fit_sphere as fit_sphere``
(the typing test checks the stub and the table list exactly the same names and sources, and the
architecture test counts the stub's imports as edges of the package's import graph).
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["attach"]


def attach(package: str, lazy: Mapping[str, str]) -> tuple[Callable[[str], Any], Callable[[], list[str]], list[str]]:
    """The ``__getattr__``, ``__dir__`` and ``__all__`` of a package with lazily imported public names.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    lazy : mapping of str to str
        Public name -> sub-module defining it, relative to ``package`` (``"kinematics.model"``).

    Returns
    -------
    __getattr__, __dir__ : callables
        Module-level hooks (PEP 562); an unknown name raises :class:`AttributeError`.
    __all__ : list of str
        The lazy names, sorted.
    """
    table = dict(lazy)

    def __getattr__(name: str) -> Any:
        module_name = table.get(name)
        if module_name is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module = importlib.import_module(f"{package}.{module_name}")
        value = module if module_name.rpartition(".")[2] == name else getattr(module, name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(table))

    return __getattr__, __dir__, sorted(table)
