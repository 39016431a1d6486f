"""Helpers for users' own tests of fitting software: compare elements, make reference data.

* :func:`fit_deviations` - how far a fitted element is from a reference element, measured
  geometrically (axis and normal directions up to sign, points compared across the axis
  or plane rather than along it, cone radius compared at the same axial station).
* :func:`assert_fit_close` - raise ``AssertionError`` listing every deviation over tolerance.
* :func:`make_reference_data` - data with a known least-squares solution
  (re-exported from :mod:`pcmm_geo.fit.reference`).
* :func:`nist_pairs`, :func:`fit_nist_pair` - NIST reference pairs and the matching pcmm_geo fit.

Examples
--------
>>> from pcmm_geo.fit import fit_sphere
>>> data = make_reference_data("sphere", n_points=30, form=0.01, offset=800.0, rng=1)
>>> assert_fit_close(fit_sphere(data.points), data)
>>> sorted(fit_deviations(fit_sphere(data.points), data))
['center', 'radius']
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from pcmm_geo.errors import InvalidInputError
from pcmm_geo.fit.reference import ReferenceDataSet, make_reference_data
from pcmm_geo.fit.skew import angle_between
from pcmm_geo.io.nist import NistPair, iter_nist_pairs, read_nist_pair

__all__ = [
    "ReferenceDataSet",
    "assert_fit_close",
    "fit_deviations",
    "fit_nist_pair",
    "make_reference_data",
    "nist_pairs",
    "read_nist_pair",
]

_DIRECTION_NAMES = ("direction", "normal", "axis")
_SIZE_NAMES = ("radius", "major_radius", "minor_radius")


def _angle_between(first: ArrayLike, second: ArrayLike, *, signed: bool) -> float:
    """Angle between two directions (2-D or 3-D), rad; with ``signed=False`` the sign of either is ignored."""
    a = np.asarray(first, dtype=float)
    b = np.asarray(second, dtype=float)
    if a.size == 2:  # a 2-D direction is the 3-D one in the z = 0 plane
        a, b = np.append(a, 0.0), np.append(b, 0.0)
    angle = float(angle_between(a, b))
    return angle if signed else min(angle, float(np.pi) - angle)


def _distance_to_line(point: ArrayLike, line_point: ArrayLike, direction: ArrayLike) -> float:
    offset = np.asarray(point, dtype=float) - np.asarray(line_point, dtype=float)
    d = np.asarray(direction, dtype=float)
    d = d / np.linalg.norm(d)
    return float(np.linalg.norm(offset - (offset @ d) * d))


def _reference_parameters(reference: Any) -> tuple[dict[str, Any], str | None]:
    if isinstance(reference, (ReferenceDataSet, NistPair)):
        return dict(reference.parameters), reference.element
    if isinstance(reference, Mapping):
        return dict(reference), None
    raise InvalidInputError(
        "reference", "a ReferenceDataSet, NistPair or mapping of parameters", type(reference).__name__
    )


def _get(result: Any, name: str) -> Any:
    if isinstance(result, Mapping):
        if name not in result:
            raise InvalidInputError("result", f"an element with {name!r}", f"keys {sorted(result)}")
        return result[name]
    if not hasattr(result, name):
        raise InvalidInputError("result", f"an element with attribute {name!r}", type(result).__name__)
    return getattr(result, name)


def fit_deviations(result: Any, reference: Any) -> dict[str, float]:
    """Geometric deviations of a fitted element from a reference element.

    Parameters
    ----------
    result : fit result or mapping
        Anything with the contract attributes (``center``, ``radius``, ``axis``...).
    reference : ReferenceDataSet, NistPair or mapping
        Reference parameters under the contract names; which keys it has decides what is
        compared.

    Returns
    -------
    dict of str to float
        One entry per compared quantity (mm or rad):

        - ``direction`` / ``normal`` / ``axis``: angle between the directions, sign ignored
          (cone ``axis``: signed, apex -> opening);
        - ``point``: distance of the reference point from the fitted line / axis (lines,
          cylinders, cones) or plane (planes);
        - ``center``: distance between centres;
        - ``radius``, ``major_radius``, ``minor_radius``, ``half_angle``: absolute differences;
        - ``radius_at_point`` (cone): fitted radius at the reference point's axial station
          minus the reference radius there.

    Raises
    ------
    InvalidInputError
        ``result`` lacks an attribute the reference needs, or ``reference`` is not usable.

    Examples
    --------
    >>> import numpy as np
    >>> reference = {"point": np.zeros(3), "axis": np.array([0.0, 0.0, 1.0]), "radius": 5.0}
    >>> fitted = {"point": np.array([0.0, 1e-6, 3.0]), "axis": np.array([0.0, 0.0, -1.0]), "radius": 5.0}
    >>> {k: round(v, 12) + 0.0 for k, v in fit_deviations(fitted, reference).items()}
    {'axis': 0.0, 'point': 1e-06, 'radius': 0.0}
    """
    params, element = _reference_parameters(reference)
    deviations: dict[str, float] = {}
    is_cone = "half_angle" in params or element == "cone"
    direction_name = next((name for name in _DIRECTION_NAMES if name in params), None)
    if direction_name is not None:
        deviations[direction_name] = _angle_between(
            _get(result, direction_name), params[direction_name], signed=is_cone
        )
    if "point" in params:
        fitted_point = np.asarray(_get(result, "point"), dtype=float)
        if direction_name == "normal":
            normal = np.asarray(_get(result, "normal"), dtype=float)
            offset = np.asarray(params["point"], dtype=float) - fitted_point
            deviations["point"] = abs(float(offset @ normal) / float(np.linalg.norm(normal)))
        elif direction_name is not None:
            deviations["point"] = _distance_to_line(params["point"], fitted_point, _get(result, direction_name))
    if "center" in params:
        offset = np.asarray(_get(result, "center"), dtype=float) - np.asarray(params["center"], dtype=float)
        deviations["center"] = float(np.linalg.norm(offset))
    for name in _SIZE_NAMES:
        if name in params:
            deviations[name] = abs(float(_get(result, name)) - float(params[name]))
    if is_cone:
        half_angle = float(_get(result, "half_angle"))
        deviations["half_angle"] = abs(half_angle - float(params["half_angle"]))
        axis = np.asarray(_get(result, "axis"), dtype=float)
        axis = axis / np.linalg.norm(axis)
        station = float((np.asarray(params["point"], dtype=float) - _get(result, "point")) @ axis)
        fitted_radius = float(_get(result, "radius_at_point")) + station * np.tan(half_angle)
        deviations["radius_at_point"] = abs(fitted_radius - float(params["radius_at_point"]))
    return deviations


def assert_fit_close(
    result: Any,
    reference: Any,
    *,
    position_mm: float = 1e-9,
    angle_rad: float = 1e-9,
) -> None:
    """Assert that a fitted element matches a reference element geometrically.

    Positions and sizes must agree within ``position_mm`` and directions / angles within
    ``angle_rad`` (see :func:`fit_deviations` for what is measured).

    Parameters
    ----------
    result : fit result or mapping
    reference : ReferenceDataSet, NistPair or mapping
    position_mm : float
        Tolerance of positions and sizes, mm.
    angle_rad : float
        Tolerance of directions and the cone half angle, rad.

    Raises
    ------
    AssertionError
        Listing every quantity out of tolerance with its deviation.
    InvalidInputError
        The result does not have the attributes the reference needs.

    Examples
    --------
    >>> import numpy as np
    >>> reference = {"center": np.zeros(3), "radius": 2.0}
    >>> assert_fit_close({"center": np.array([0, 0, 1e-12]), "radius": 2.0}, reference)
    >>> try:
    ...     assert_fit_close({"center": np.zeros(3), "radius": 2.001}, reference)
    ... except AssertionError as exc:
    ...     print(exc)
    element differs from reference: radius 0.001 > 1e-09 mm
    """
    failures = []
    for name, deviation in fit_deviations(result, reference).items():
        angular = name in _DIRECTION_NAMES or name == "half_angle"
        limit, unit = (angle_rad, "rad") if angular else (position_mm, "mm")
        if not deviation <= limit:
            failures.append(f"{name} {deviation:.6g} > {limit:.6g} {unit}")
    if failures:
        raise AssertionError("element differs from reference: " + "; ".join(failures))


def nist_pairs(folder: str | Path) -> Iterator[NistPair]:
    """All NIST reference pairs below ``folder`` (see :func:`pcmm_geo.io.nist.iter_nist_pairs`).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> list(nist_pairs(tempfile.mkdtemp()))
    []
    """
    return iter_nist_pairs(folder)


def fit_nist_pair(pair: NistPair) -> Any:
    """Fit a NIST pair's points with the matching pcmm_geo fit, the way NIST defines it.

    Lines (2-D pairs included) are fitted in 3-D; circles with ``method="projected"``
    (plane first, then the circle of the projected points), as NIST did.

    Returns
    -------
    fit result
        ``LineFit``, ``PlaneFit``, ``CircleFit``, ``SphereFit``, ``CylinderFit`` or ``ConeFit``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp()) / "Sphere"
    >>> folder.mkdir()
    >>> _ = (folder / "s.ds").write_text("4\\n1 0 0\\n-1 0 0\\n0 1 0\\n0 0 1\\n")
    >>> _ = (folder / "s.fit").write_text("0\\n0\\n0\\n2\\n")
    >>> pair = read_nist_pair(folder / "s.ds")
    >>> assert_fit_close(fit_nist_pair(pair), pair)
    """
    from pcmm_geo import fit

    if pair.element in ("line2d", "line3d"):
        return fit.fit_line(pair.points)
    if pair.element in ("circle2d", "circle3d"):
        return fit.fit_circle(pair.points, method="projected")
    return getattr(fit, f"fit_{pair.element}")(pair.points)  # plane, sphere, cylinder, cone
