"""Deprecated names kept for one release (0.2.0 -> removed in 0.3.0).

pcmm_geo 0.2.0 spells ``center`` everywhere in its public API (``tip_center``,
``face_centers``, ...).  The 0.1 spellings still work for one release and emit a
:class:`DeprecationWarning` naming the replacement.  Three tools cover every kind of name:

* :func:`renamed_fields` -- a class decorator: the old attribute reads the new one and the
  constructor accepts the old keyword;
* :func:`renamed_parameters` -- a function decorator: the old keyword is accepted;
* :func:`module_aliases` -- a module ``__getattr__`` resolving old module-level names.

:data:`DEPRECATED_ALIASES` records every alias (the API-naming test reads it).

Examples
--------
>>> import warnings
>>> from dataclasses import dataclass
>>> @renamed_fields(tip_centre="tip_center")
... @dataclass(frozen=True)
... class Probe:
...     tip_center: float
>>> with warnings.catch_warnings(record=True) as caught:
...     warnings.simplefilter("always")
...     value = Probe(tip_centre=2.0).tip_centre
>>> value, caught[0].category.__name__
(2.0, 'DeprecationWarning')
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ["DEPRECATED_ALIASES", "module_aliases", "renamed_fields", "renamed_parameters", "warn_deprecated"]

T = TypeVar("T")

#: ``(owner qualified name, old name) -> new name`` for every deprecated alias
DEPRECATED_ALIASES: dict[tuple[str, str], str] = {}

_REMOVED_IN = "0.3.0"


def warn_deprecated(old: str, new: str, *, stacklevel: int = 3) -> None:
    """Emit the :class:`DeprecationWarning` of a renamed name ``old`` -> ``new``."""
    warnings.warn(
        f"{old} is deprecated since pcmm_geo 0.2.0 and will be removed in {_REMOVED_IN}; use {new}",
        DeprecationWarning,
        stacklevel=stacklevel,
    )


class _Alias:
    """Read-only attribute ``old`` that returns attribute ``new`` with a deprecation warning."""

    def __init__(self, owner: str, old: str, new: str) -> None:
        self.owner, self.old, self.new = owner, old, new
        self.__doc__ = f"Deprecated alias of ``{new}`` (removed in {_REMOVED_IN})."

    def __get__(self, obj: Any, objtype: type | None = None) -> Any:
        if obj is None:
            return self
        warn_deprecated(f"{self.owner}.{self.old}", f"{self.owner}.{self.new}")
        return getattr(obj, self.new)


def _translate(where: str, renamed: dict[str, str], kwargs: dict[str, Any]) -> dict[str, Any]:
    for old, new in renamed.items():
        if old in kwargs:
            if new in kwargs:
                raise TypeError(f"{where}: got both {old!r} (deprecated) and {new!r}; pass {new!r} only")
            warn_deprecated(f"{where}({old}=...)", f"{new}=...", stacklevel=4)
            kwargs[new] = kwargs.pop(old)
    return kwargs


def renamed_fields(**old_to_new: str) -> Callable[[type[T]], type[T]]:
    """Class decorator: deprecated attribute aliases and constructor keywords ``old=new``.

    Parameters
    ----------
    **old_to_new : str
        ``old_name="new_name"`` pairs; ``new_name`` is an attribute, field or property.
    """

    def decorate(cls: type[T]) -> type[T]:
        owner = cls.__qualname__
        for old, new in old_to_new.items():
            setattr(cls, old, _Alias(owner, old, new))
            DEPRECATED_ALIASES[(f"{cls.__module__}.{owner}", old)] = new
        init = cls.__init__

        @functools.wraps(init)
        def __init__(self: Any, *args: Any, **kwargs: Any) -> None:
            init(self, *args, **_translate(owner, old_to_new, kwargs))

        cls.__init__ = __init__  # type: ignore[misc]
        return cls

    return decorate


def renamed_parameters(**old_to_new: str) -> Callable[[Callable[..., T]], Callable[..., T]]:
    """Function decorator: accept the deprecated keyword ``old`` for parameter ``new``.

    Examples
    --------
    >>> import warnings
    >>> @renamed_parameters(centre="center")
    ... def shift(center=0.0):
    ...     return center + 1
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")
    ...     shift(centre=1.0)
    2.0
    """

    def decorate(function: Callable[..., T]) -> Callable[..., T]:
        for old, new in old_to_new.items():
            DEPRECATED_ALIASES[(f"{function.__module__}.{function.__qualname__}", old)] = new

        @functools.wraps(function)
        def wrapper(*args: Any, **kwargs: Any) -> T:
            return function(*args, **_translate(function.__qualname__, old_to_new, kwargs))

        return wrapper

    return decorate


def module_aliases(module: str, namespace: dict[str, Any], **old_to_new: str) -> Callable[[str], Any]:
    """A module ``__getattr__`` resolving deprecated module-level names ``old`` to ``new``.

    Use as ``__getattr__ = module_aliases(__name__, globals(), old_name="new_name")``.
    """
    for old, new in old_to_new.items():
        DEPRECATED_ALIASES[(module, old)] = new

    def __getattr__(name: str) -> Any:
        if name in old_to_new:
            warn_deprecated(f"{module}.{name}", f"{module}.{old_to_new[name]}")
            return namespace[old_to_new[name]]
        raise AttributeError(f"module {module!r} has no attribute {name!r}")

    return __getattr__
