"""The geometric elements and fit criteria, once: one frozen table every layer reads.

Each element pcmm_geo fits (``fit_<name>``), generates reference data for, offsets for the probe
radius, writes as a QIF feature, plots or offers on the command line is one row of
:data:`SPECS`: its fit parameters with their kinds, the size parameter, how the probe-compensated
surface is formed, the field holding its axis or normal, the fit criteria it supports and its
form characteristic.  The fits, the reference generator, probe compensation, the QIF writer, the
plots and the ``pcmm`` command take their element sets and their dispatch from here, so a new
element is one row here plus its fit (``tests/test_elements.py`` checks every consumer against
the table and each row against its fit's result fields).

Besides the seven fitted elements the table holds the QIF ``point`` feature: the writer and the
refit of a CMM file know it, nothing fits it.

Names for type checkers: :data:`Element` (a fitted element), :data:`Criterion` (a fit
criterion) and :data:`FeatureType` (a feature type of the QIF writer).  Strings arriving from
outside are checked by :func:`check_element` / :func:`check_criterion`, which raise
:class:`~pcmm_geo.errors.InvalidInputError` ("expected one of ..., got ...").

Units: lengths in mm, angles in radians, directions as unit vectors.

Examples
--------
>>> from pcmm_geo.elements import ELEMENTS, spec
>>> ELEMENTS
('line', 'plane', 'circle', 'sphere', 'cylinder', 'cone', 'torus')
>>> s = spec("cylinder")
>>> s.result, s.size, s.offset, s.axis_field, s.form
('CylinderFit', 'radius', 'radial', 'axis', 'cylindricity')
>>> [p.name for p in s.parameters]
['point', 'axis', 'radius']
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Literal, cast, get_args

from pcmm_geo.errors import InvalidInputError

__all__ = [
    "AXIAL",
    "CRITERIA",
    "ELEMENTS",
    "FEATURE_TYPES",
    "SIZED_FEATURES",
    "SPECS",
    "Criterion",
    "Element",
    "ElementSpec",
    "FeatureType",
    "Parameter",
    "check_criterion",
    "check_element",
    "element_of",
    "spec",
]

#: a geometric element pcmm_geo fits (``fit_<name>``)
Element = Literal["line", "plane", "circle", "sphere", "cylinder", "cone", "torus"]
#: a fit criterion: Gaussian least squares, minimum zone (Chebyshev), minimum circumscribed, maximum inscribed
Criterion = Literal["gaussian", "chebyshev", "mcc", "mic"]
#: a feature type the QIF writer writes (the refit of a CMM file reads the same types)
FeatureType = Literal["circle", "cylinder", "sphere", "plane", "line", "point", "cone"]
#: what a parameter is: a position (mm), a unit direction, a length (mm) or an angle (rad)
ParameterKind = Literal["position", "direction", "length", "angle"]
#: how the probe-compensated surface of an element is formed (see :class:`ElementSpec`)
Offset = Literal["radial", "conical", "normal", "points", "none"]

#: unit of each parameter kind
UNITS: dict[str, str] = {"position": "mm", "direction": "1", "length": "mm", "angle": "rad"}


@dataclass(frozen=True)
class Parameter:
    """One parameter of an element: a field of its fit result.

    Attributes
    ----------
    name : str
        Field name of the fit result (``center``, ``axis``, ``radius``, ...).
    kind : {"position", "direction", "length", "angle"}
        A point (shape ``(D,)``, mm), a unit vector (shape ``(D,)``), a length (mm) or an angle (rad).
    shown : bool
        The fit's summary (:meth:`pcmm_geo.fit.FitResult.summary`, the ``pcmm fit`` table, the
        repr) displays it.  False only for a cone's ``radius_at_point``, the radius at its
        reference point, which ``summary(complete=True)`` adds for the QIF writer's diameter.
    """

    name: str
    kind: ParameterKind
    shown: bool = True

    @property
    def unit(self) -> str:
        """``"mm"``, ``"rad"`` or ``"1"`` (a unit vector)."""
        return UNITS[self.kind]


@dataclass(frozen=True)
class ElementSpec:
    """What every layer needs to know of one element (a row of :data:`SPECS`).

    Attributes
    ----------
    name : str
        The element's name (``"cylinder"``), as the fits (``fit_cylinder``), the reference
        generator, the QIF writer and the ``pcmm`` command spell it.
    result : str or None
        Class name of its fit result in :mod:`pcmm_geo.fit` (``"CylinderFit"``); None for the
        QIF point, which nothing fits.
    parameters : tuple of Parameter
        The fit result's geometric fields, in order.
    dims : tuple of int
        Dimensions of the points it is fitted to (``(2, 3)`` for lines and circles).
    size : str or None
        The result field whose double is the element's diameter (``"radius"``; the cone's
        ``"radius_at_point"``); None for elements without one diameter (line, plane, point,
        torus).
    offset : {"radial", "conical", "normal", "points", "none"}
        The probe-compensated surface (:func:`pcmm_geo.fit.compensate_probe`): ``"radial"`` the
        same centre / axis with the radius moved by the probe radius (``+ r`` internal, ``- r``
        external); ``"conical"`` the parallel cone (apex moved along the axis by ``r / sin(alpha)``);
        ``"normal"`` the element shifted by ``r`` against its outward normal (plane, line);
        ``"points"`` each point moved against its own normal
        (:func:`pcmm_geo.fit.compensate_points`); ``"none"`` not supported.
    axis_field : str or None
        The result field holding the element's orientation (``"axis"``, ``"normal"``,
        ``"direction"``); None for a sphere or a point.
    location_field : str or None
        The result field holding its position (``"center"`` or ``"point"``; a cone's ``point``
        is where ``radius_at_point`` is measured).
    orientation : {"normal", "direction"} or None
        How a QIF feature of this type spells its orientation (a circle and a plane by their
        normal, axial features and lines by their direction).
    criteria : tuple of str
        The fit criteria the element supports (:data:`Criterion`).
    form : str or None
        ISO form characteristic its minimum zone evaluates (ISO 1101, ISO 12180/12181/12780/12781).
    qif : bool
        The QIF writer has a feature record for it.
    """

    name: str
    result: str | None
    parameters: tuple[Parameter, ...]
    dims: tuple[int, ...]
    size: str | None
    offset: Offset
    axis_field: str | None
    location_field: str | None
    orientation: Literal["normal", "direction"] | None
    criteria: tuple[Criterion, ...]
    form: str | None
    qif: bool

    @property
    def fitted(self) -> bool:
        """The element has a fit (``fit_<name>``)."""
        return self.result is not None

    @property
    def axial(self) -> bool:
        """Its orientation is an axis of revolution (cylinder, cone, torus)."""
        return self.axis_field == "axis"

    @property
    def placement_fields(self) -> tuple[str, ...]:
        """The QIF placement of a feature of this type: ``location`` and its ``normal`` or ``direction``."""
        return ("location",) if self.orientation is None else ("location", self.orientation)

    @property
    def nominal_fields(self) -> tuple[str, ...]:
        """What a QIF nominal of this type must give: its placement, a diameter if sized, its angles.

        >>> spec("cone").nominal_fields
        ('location', 'direction', 'diameter', 'half_angle')
        """
        sized = ("diameter",) if self.size is not None else ()
        return (*self.placement_fields, *sized, *(p.name for p in self.parameters if p.kind == "angle"))


def _p(name: str, kind: ParameterKind, shown: bool = True) -> Parameter:
    return Parameter(name, kind, shown)


_ALL: tuple[Criterion, ...] = ("gaussian", "chebyshev", "mcc", "mic")
_ZONE: tuple[Criterion, ...] = ("gaussian", "chebyshev")
_POINT: ParameterKind = "position"
_DIRECTION: ParameterKind = "direction"
_LENGTH: ParameterKind = "length"
_ANGLE: ParameterKind = "angle"

_ROWS = (
    ElementSpec("line", "LineFit", (_p("point", _POINT), _p("direction", _DIRECTION)), dims=(2, 3),
                size=None, offset="normal", axis_field="direction", location_field="point",
                orientation="direction", criteria=_ZONE, form="straightness", qif=True),
    ElementSpec("plane", "PlaneFit", (_p("point", _POINT), _p("normal", _DIRECTION)), dims=(3,),
                size=None, offset="normal", axis_field="normal", location_field="point",
                orientation="normal", criteria=_ZONE, form="flatness", qif=True),
    ElementSpec("circle", "CircleFit", (_p("center", _POINT), _p("radius", _LENGTH), _p("normal", _DIRECTION)),
                dims=(2, 3), size="radius", offset="radial", axis_field="normal", location_field="center",
                orientation="normal", criteria=_ALL, form="roundness", qif=True),
    ElementSpec("sphere", "SphereFit", (_p("center", _POINT), _p("radius", _LENGTH)), dims=(3,),
                size="radius", offset="radial", axis_field=None, location_field="center",
                orientation=None, criteria=_ALL, form="sphericity", qif=True),
    ElementSpec("cylinder", "CylinderFit", (_p("point", _POINT), _p("axis", _DIRECTION), _p("radius", _LENGTH)),
                dims=(3,), size="radius", offset="radial", axis_field="axis", location_field="point",
                orientation="direction", criteria=_ALL, form="cylindricity", qif=True),
    ElementSpec("cone", "ConeFit", (_p("apex", _POINT), _p("axis", _DIRECTION), _p("half_angle", _ANGLE),
                                    _p("point", _POINT), _p("radius_at_point", _LENGTH, shown=False)),
                dims=(3,), size="radius_at_point", offset="conical", axis_field="axis", location_field="point",
                orientation="direction", criteria=_ZONE, form="conicity", qif=True),
    ElementSpec("torus", "TorusFit", (_p("center", _POINT), _p("axis", _DIRECTION), _p("major_radius", _LENGTH),
                                      _p("minor_radius", _LENGTH)),
                dims=(3,), size=None, offset="none", axis_field="axis", location_field="center",
                orientation="direction", criteria=("gaussian",), form=None, qif=False),
    ElementSpec("point", None, (_p("location", _POINT),), dims=(3,),
                size=None, offset="points", axis_field=None, location_field=None,
                orientation=None, criteria=(), form=None, qif=True),
)
#: every element, by name (the seven fitted elements in :data:`ELEMENTS` order, then the QIF point); read-only
SPECS: Mapping[str, ElementSpec] = MappingProxyType({row.name: row for row in _ROWS})

#: the fitted elements (``fit_<name>``), in the order the fits, the reference generator and ``pcmm fit`` list them
ELEMENTS: tuple[Element, ...] = cast("tuple[Element, ...]", tuple(s.name for s in SPECS.values() if s.fitted))
#: the fit criteria
CRITERIA: tuple[Criterion, ...] = get_args(Criterion)
#: the feature types the QIF writer writes, in the order its messages list them
FEATURE_TYPES: tuple[FeatureType, ...] = get_args(FeatureType)
#: QIF feature types with a diameter and a material side (``InternalExternal``)
SIZED_FEATURES: tuple[FeatureType, ...] = tuple(t for t in FEATURE_TYPES if SPECS[t].size is not None)
#: elements with an axis of revolution
AXIAL: tuple[Element, ...] = tuple(e for e in ELEMENTS if SPECS[e].axial)

_BY_RESULT = {s.result: s.name for s in SPECS.values() if s.result is not None}


def spec(name: str) -> ElementSpec:
    """The row of :data:`SPECS` for ``name``.

    Raises
    ------
    InvalidInputError
        ``name`` is no element of the table.
    """
    row = SPECS.get(name) if isinstance(name, str) else None
    if row is None:
        raise InvalidInputError("element", "one of " + ", ".join(SPECS), repr(name))
    return row


def check_element(value: object, what: str = "element", allowed: Iterable[str] = ELEMENTS) -> Element:
    """``value`` if it names one of ``allowed`` (default: the fitted elements).

    Raises
    ------
    InvalidInputError
        Naming ``what``: "expected one of line, plane, ..., got 'cube'".
    """
    names = tuple(allowed)
    if not isinstance(value, str) or value not in names:
        raise InvalidInputError(what, "one of " + ", ".join(names), repr(value))
    return cast("Element", value)


def check_criterion(value: object, what: str = "criterion", allowed: Iterable[str] = CRITERIA) -> Criterion:
    """``value`` if it names one of ``allowed`` (default: every criterion).

    Raises
    ------
    InvalidInputError
        Naming ``what``: "expected one of 'gaussian', 'chebyshev', 'mcc', 'mic', got 'l1'".
    """
    names = tuple(allowed)
    if not isinstance(value, str) or value not in names:
        raise InvalidInputError(what, "one of " + ", ".join(repr(c) for c in names), repr(value))
    return cast("Criterion", value)


def element_of(result: object) -> Element | None:
    """The element a fit result is of (by its class, :attr:`ElementSpec.result`), None for other objects.

    >>> class SphereFit: ...
    >>> element_of(SphereFit()), element_of(3.0)
    ('sphere', None)
    """
    return cast("Element | None", _BY_RESULT.get(type(result).__name__))
