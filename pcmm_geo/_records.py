"""Result records: frozen dataclasses that hold arrays, one rule for their equality and repr.

A record is declared with :func:`record` instead of ``@dataclass(frozen=True)``::

    @record
    class Refit:
        points: FloatArray
        location: FloatArray | None = None

It is a frozen dataclass with two differences from the default:

* **identity equality and hash** (``eq=False``): ``a == b`` is ``a is b`` and ``hash(a)`` is the
  object's identity.  The generated ``==`` compares the fields as a tuple, which for two records
  holding distinct arrays of more than one element raises ``ValueError`` ("truth value of an
  array ... is ambiguous"), answers by exact float equality for one-element arrays and ``True``
  for arrays shared by identity; records are results, compared by the numbers a caller picks
  (``np.allclose(a.center, b.center)``).
* **a bounded repr** (:func:`record_repr`) that shows only the fields that apply, in the manner of
  lmfit's and shapely's reprs: ``None``, ``NaN`` placeholders, empty containers and unchanged
  scalar defaults are left out; an array of more than :data:`SHOWN_VALUES` values is shown by
  shape and dtype (``points=<(50, 3) float64>``), a short vector by its values; long strings and
  containers are cut.  Its length does not grow with the number of points.

A class that writes its own ``__repr__`` (or inherits a hand-written one, as the fit results
inherit :class:`~pcmm_geo.fit.FitResult`'s) keeps it; a class that defines ``__eq__`` keeps that
(value equality by design, such as :class:`~pcmm_geo.machine.kinematics.MachineLimits`).
"""

from __future__ import annotations

import dataclasses
import inspect
import math
from collections.abc import Callable, Mapping
from typing import Any, NamedTuple, TypeVar, dataclass_transform, overload

import numpy as np

__all__ = ["SHOWN_VALUES", "SummaryRow", "is_record", "record", "record_repr", "short_value"]

T = TypeVar("T", bound=type)

#: arrays with at most this many values (and at most one dimension) are shown by value, larger ones by shape
SHOWN_VALUES = 4
#: items of a tuple / list / dict shown before ``...``
SHOWN_ITEMS = 4
#: characters of a string shown before ``...``
SHOWN_CHARS = 80


class SummaryRow(NamedTuple):
    """One displayed parameter of a result: a row of its ``summary()`` (plain data any layer can pass on).

    The rows render the element spec's parameters (:data:`pcmm_geo.elements.SPECS`), the one
    choice of what a result shows: the ``pcmm fit`` table prints them, the QIF export takes the
    location, orientation, diameter, angles and their uncertainties from them (selected by the
    spec's fields), the fit plots' texts take their values from them, and the fit results' repr
    shows them grouped by ``quantity``.

    Attributes
    ----------
    name : str
        Row name, a component spelled ``quantity_x`` (``"center_x"``, ``"radius"``, ``"apex_angle_deg"``).
    value : float
        In ``unit``.
    u : float
        Standard uncertainty (k = 1) in ``unit``; NaN when the result gives none.
    unit : str
        ``"mm"``, ``"rad"``, ``"deg"`` or ``"1"`` (a unit vector's component).
    quantity : str
        The field the row shows (``"center"`` for ``center_x``; the name itself for a scalar).
    derived : bool
        Computed from other rows for reading (a diameter from its radius, an apex angle in degrees),
        not a field of the result.
    """

    name: str
    value: float
    u: float
    unit: str
    quantity: str
    derived: bool = False


@overload
def record(cls: T, /) -> T: ...
@overload
def record(*, kw_only: bool = False) -> Callable[[T], T]: ...
@dataclass_transform(frozen_default=True, eq_default=False)  # type checkers see the generated __init__
def record(cls: T | None = None, /, *, kw_only: bool = False) -> T | Callable[[T], T]:
    """Declare a result record: a frozen dataclass with identity equality and a bounded repr.

    Parameters
    ----------
    cls : type, optional
        The class (``@record``); omitted when options are given (``@record(kw_only=True)``).
    kw_only : bool
        Keyword-only fields, as in :func:`dataclasses.dataclass`.

    Returns
    -------
    type
        ``cls`` made a frozen dataclass (``eq=False``: ``==`` and ``hash`` by identity unless the
        class defines ``__eq__`` itself), with :func:`record_repr` unless the class or a base writes
        its own ``__repr__``.
    """

    def wrap(klass: T) -> T:
        if not _has_written_repr(klass):
            klass.__repr__ = record_repr  # type: ignore[assignment]
        made: T = dataclasses.dataclass(frozen=True, eq=False, repr=False, kw_only=kw_only)(klass)  # type: ignore[assignment]
        made.__pcmm_record__ = True  # type: ignore[attr-defined]
        return made

    return wrap if cls is None else wrap(cls)


def is_record(obj: Any) -> bool:
    """True for a class declared with :func:`record` (or an instance of one)."""
    klass = obj if isinstance(obj, type) else type(obj)
    return bool(klass.__dict__.get("__pcmm_record__", False))


def _has_written_repr(klass: type) -> bool:
    """A ``__repr__`` written by hand in the class or a base (not object's, not one dataclasses generated)."""
    for base in klass.__mro__[:-1]:
        method = base.__dict__.get("__repr__")
        if method is None:
            continue
        if method is record_repr:
            return False
        generated = inspect.unwrap(method).__code__.co_filename == "<string>"  # dataclasses' exec'd source
        return not generated
    return False


def record_repr(self: Any) -> str:
    """``Name(field=value, ...)`` with the fields that apply, arrays by shape when large (bounded length)."""
    shown = []
    for item in dataclasses.fields(self):
        if not item.repr:
            continue
        value = getattr(self, item.name)
        if not _applies(value, item):
            continue
        shown.append(f"{item.name}={short_value(value)}")
    return f"{type(self).__name__}({', '.join(shown)})"


def _applies(value: Any, item: dataclasses.Field[Any]) -> bool:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return False
    if isinstance(value, tuple | list | dict) and not value:
        return False
    default = item.default
    return not (isinstance(value, bool | str | int | float) and type(value) is type(default) and value == default)


def short_value(value: Any, depth: int = 0) -> str:
    """A bounded text of one value, as :func:`record_repr` shows it (for hand-written reprs of records)."""
    if isinstance(value, np.ndarray):
        return _array(value)
    if isinstance(value, np.generic):
        return repr(value.item())
    if isinstance(value, bool | int | float | type(None)):
        return repr(value)
    if isinstance(value, str):
        return repr(value) if len(value) <= SHOWN_CHARS else repr(value[:SHOWN_CHARS]) + "..."
    if depth >= 2:
        return f"<{type(value).__name__}>"
    if isinstance(value, Mapping):
        items = [f"{k!r}: {short_value(v, depth + 1)}" for k, v in list(value.items())[:SHOWN_ITEMS]]
        return "{" + ", ".join(items) + (", ..." if len(value) > SHOWN_ITEMS else "") + "}"
    if isinstance(value, tuple | list):
        items = [short_value(v, depth + 1) for v in value[:SHOWN_ITEMS]]
        more = f", ... ({len(value)} items)" if len(value) > SHOWN_ITEMS else ("," if len(value) == 1 else "")
        opening, closing = ("(", ")") if isinstance(value, tuple) else ("[", "]")
        return opening + ", ".join(items) + more + closing
    text = repr(value)
    return text if len(text) <= 4 * SHOWN_CHARS else f"<{type(value).__name__}>"


def _array(value: np.ndarray) -> str:
    if value.ndim == 0:
        return repr(value.item())
    if value.ndim == 1 and value.size <= SHOWN_VALUES and value.dtype.kind in "biuf":
        return repr([float(v) for v in value]) if value.dtype.kind == "f" else repr(value.tolist())
    return f"<{value.shape} {value.dtype}>"
