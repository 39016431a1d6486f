"""Deprecated names kept for one release (0.2.0 -> removed in 0.3.0).

pcmm_geo 0.2.0 spells ``center`` everywhere in its public API (``tip_center``,
``face_centers``, ...).  The 0.1 spellings still work for one release and emit a
:class:`DeprecationWarning` naming the replacement.  Three tools cover every kind of name:

* :func:`renamed_fields` -- a class decorator: the old attribute reads the new one and the
  constructor accepts the old keyword;
* :func:`renamed_parameters` -- a function decorator: the old keyword is accepted;
* :func:`module_aliases` -- a module ``__getattr__`` resolving old module-level names;
* :class:`NamedValues` -- an array that was a dict: ``std_errors`` is an array in
  ``parameter_names`` order like ``parameters``; ``std_errors["radius"]``, ``.items()`` ... of the
  0.1 dict still answer, with a :class:`DeprecationWarning`.

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
from collections.abc import Callable, Iterator, Sequence
from typing import Any, TypeVar

import numpy as np

__all__ = ["DEPRECATED_ALIASES", "NamedValues", "module_aliases", "renamed_fields", "renamed_parameters",
           "warn_deprecated"]

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


class NamedValues(np.ndarray):
    """An array of values in ``names`` order (last axis) that also answers the dict it replaces, deprecated.

    ``values[..., j]`` belongs to ``names[j]``, as ``parameters`` and ``covariance`` are ordered
    by ``parameter_names``.  The 0.1 dict interface -- ``values["radius"]``, ``"radius" in
    values``, ``keys()``, ``values()``, ``items()``, ``get()`` -- still works for one release and
    warns; iterating runs over the array (the dict iterated over its names).  Arithmetic gives
    plain arrays.

    Parameters
    ----------
    values : array_like, shape (..., P)
    names : sequence of str, length P
    owner : str
        How the attribute is spelled in warnings, e.g. ``"SphereFit.std_errors"``.

    Examples
    --------
    >>> import warnings
    >>> u = NamedValues([0.1, 0.2], ("center_x", "radius"), "SphereFit.std_errors")
    >>> float(u[1])
    0.2
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     old = u["radius"]
    >>> old, caught[0].category.__name__
    (0.2, 'DeprecationWarning')
    """

    _names: tuple[str, ...]
    _owner: str

    def __new__(cls, values: Any, names: Sequence[str], owner: str) -> NamedValues:
        array = np.asarray(values, dtype=float)
        if array.ndim == 0 or array.shape[-1] != len(names):
            raise ValueError(f"expected values with a last axis of {len(names)} (one per name), got {array.shape}")
        obj = array.view(cls)
        obj._names, obj._owner = tuple(names), owner
        return obj

    def __array_finalize__(self, obj: Any) -> None:
        self._names = getattr(obj, "_names", ())
        self._owner = getattr(obj, "_owner", "")

    def __array_wrap__(self, array: Any, context: Any = None, return_scalar: bool = False) -> Any:
        result = np.asarray(array)  # results of arithmetic are plain arrays (or scalars)
        return result[()] if return_scalar else result

    def _warn(self, old: str) -> None:
        owner = self._owner or "std_errors"
        warn_deprecated(f"{owner}{old} (a dict until 0.1)",
                        f"{owner} as an array in parameter_names order, e.g. "
                        f"{owner.rsplit('.', 1)[-1]}[parameter_names.index(name)]", stacklevel=4)

    def _column(self, name: str) -> Any:
        try:
            column = self._names.index(name)
        except ValueError:
            raise KeyError(name) from None
        value = self.view(np.ndarray)[..., column]
        return float(value) if value.ndim == 0 else value.copy()

    def __getitem__(self, key: Any) -> Any:
        if isinstance(key, str):
            self._warn(f"[{key!r}]")
            return self._column(key)
        result = super().__getitem__(key)
        return result.view(np.ndarray) if isinstance(result, np.ndarray) else result

    def __contains__(self, key: object) -> bool:
        if isinstance(key, str):
            self._warn(".__contains__")
            return key in self._names
        return bool(super().__contains__(key))

    def keys(self) -> list[str]:
        """Deprecated: the names (``parameter_names``)."""
        self._warn(".keys()")
        return list(self._names)

    def values(self) -> list[Any]:  # type: ignore[override]
        """Deprecated: the values in name order (``list(array)``)."""
        self._warn(".values()")
        return [self._column(name) for name in self._names]

    def items(self) -> Iterator[tuple[str, Any]]:  # type: ignore[override]
        """Deprecated: ``(name, value)`` pairs (``zip(parameter_names, array)``)."""
        self._warn(".items()")
        return iter([(name, self._column(name)) for name in self._names])

    def get(self, name: str, default: Any = None) -> Any:
        """Deprecated: the value of ``name`` or ``default``."""
        self._warn(".get()")
        return self._column(name) if name in self._names else default

    def __reduce__(self) -> Any:
        return (NamedValues, (np.asarray(self), self._names, self._owner))

    def __repr__(self) -> str:
        return repr(np.asarray(self))
