"""Reference data with known least-squares solutions (null-space method).

Software for coordinate metrology is tested (ISO 10360-6, the NPL and PTB test
services) with data sets whose Gaussian solution is known in advance.  The
null-space method builds them:

1. choose the element, the *reference solution*;
2. sample foot points on it (whole element or a partial feature: arc, cap, section);
3. form the Jacobian ``J`` (``M x P``) of the orthogonal-distance residuals with respect
   to a minimal set of element parameters, at the reference element;
4. take an orthonormal basis ``B`` of the null space of ``J^T`` (the residual vectors that
   the parameters cannot absorb), combine its columns with seeded random coefficients and
   scale the result ``e`` so that its range ``max(e) - min(e)`` equals the requested form;
5. move every foot point along its unit surface normal by its residual.

Then ``J^T e = 0``: the gradient of the sum of squares vanishes at the reference
element, which (for form errors small against the curvature) is therefore the exact
Gaussian solution of the moved points.  Where ``J`` depends on the moved points (cone,
torus, 3-D circle) steps 3-5 are repeated with ``J`` evaluated at the moved points until
``|J^T e| <= 1e-14 |J| |e|``.  Finally a seeded random rotation and an offset are applied
(residuals are invariant under rigid motions).

The 3-D line and 3-D circle have two residual components per point (the two
perpendicular offsets of a line; the in-plane radial and the axial offset of a circle),
so their ``residuals`` have shape ``(N, 2)``; the form is the range of all ``2 N``
values.  ``"circle3d_projected"`` is the NIST convention instead: the points' least-squares
plane is the circle's plane and the circle is the 2-D least-squares circle of the points
projected on it.

Examples
--------
>>> import numpy as np
>>> data = make_reference_data("sphere", n_points=20, radius=10.0, form=0.01, offset=500.0, rng=1)
>>> data.points.shape, round(float(np.ptp(data.residuals)), 12)
((20, 3), 0.01)
>>> distances = np.linalg.norm(data.points - data.parameters["center"], axis=1) - 10.0
>>> bool(np.allclose(distances, data.residuals, atol=1e-12))
True
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.elements import ELEMENTS as FIT_ELEMENTS
from pcmm_geo.elements import SPECS
from pcmm_geo.errors import ConvergenceError, DegenerateGeometryError, InvalidInputError, TooFewPointsError
from pcmm_geo.fit._reference.elements import (
    ELEMENTS,
    MIN_POINTS,
    ReferenceDataSet,
    StandardElement,
    build_standard_element,
)
from pcmm_geo.fit._reference.io import read_reference_data, write_nist_pair, write_reference_data

__all__ = [
    "ELEMENTS",
    "MIN_POINTS",
    "ReferenceDataSet",
    "data_kind",
    "first_order_residual",
    "make_reference_data",
    "random_rotation",
    "read_reference_data",
    "write_nist_pair",
    "write_reference_data",
]

FloatArray = NDArray[np.float64]

#: relative size of ``J^T e`` accepted as "zero" (the iteration stops below it)
FIRST_ORDER_TOLERANCE = 1e-14
_MAX_ITERATIONS = 50


def random_rotation(rng: np.random.Generator, dims: int = 3) -> FloatArray:
    """Uniformly distributed proper rotation matrix ``(dims, dims)`` (QR of a Gaussian matrix).

    Examples
    --------
    >>> rotation = random_rotation(np.random.default_rng(0))
    >>> bool(np.allclose(rotation @ rotation.T, np.eye(3))), round(float(np.linalg.det(rotation)), 12)
    (True, 1.0)
    """
    q, r = np.linalg.qr(rng.standard_normal((dims, dims)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q


def first_order_residual(jacobian: FloatArray, residuals: FloatArray) -> float:
    """Relative size of the gradient ``|J^T e| / (|J| |e|)`` (0 when ``e = 0``).

    Examples
    --------
    >>> first_order_residual(np.array([[1.0], [1.0]]), np.array([0.5, -0.5]))
    0.0
    """
    e = residuals.ravel(order="F") if residuals.ndim == 2 else residuals
    scale = float(np.linalg.norm(jacobian) * np.linalg.norm(e))
    return float(np.linalg.norm(jacobian.T @ e) / scale) if scale > 0 else 0.0


def _random_null_vector(jacobian: FloatArray, rng: np.random.Generator, element: str) -> FloatArray | None:
    """Random vector of the null space of ``J^T`` (None when ``J`` is square: no redundancy).

    With ``Q`` an orthonormal basis of range(J) (reduced QR) and ``B`` one of its orthogonal
    complement, ``B c`` with Gaussian ``c`` has the distribution of ``r - Q Q^T r`` with a
    Gaussian ``r``; the latter needs no ``M x M`` matrix, so a million points are cheap.
    """
    rows, n_param = jacobian.shape
    q, r = np.linalg.qr(jacobian)
    diag = np.abs(np.diag(r))
    if diag.min() <= 1e-10 * diag.max():
        raise DegenerateGeometryError(element, "the sampled points do not determine the element (rank-deficient J)")
    if rows <= n_param:
        return None
    vector = rng.standard_normal(rows)
    for _ in range(2):  # the second pass removes the rounding left by the first
        vector = vector - q @ (q.T @ vector)
    return vector


def _scaled(residuals: FloatArray, form: float) -> FloatArray:
    spread = float(np.ptp(residuals))
    return residuals * (form / spread) if spread > 0 else residuals * 0.0


def _apply(standard: StandardElement, residuals: FloatArray) -> FloatArray:
    components = residuals.reshape(standard.move_directions.shape[0], -1)
    return standard.foot_points + np.einsum("kn,knd->nd", components, standard.move_directions)


def _null_space_residuals(standard: StandardElement, form: float, rng: np.random.Generator, element: str) -> FloatArray:
    """Residual vector ``e`` (component-major, ``(K N,)``) with ``J(points)^T e = 0`` and range ``form``."""
    jac = standard.jacobian(standard.foot_points)
    null_vector = _random_null_vector(jac, rng, element)
    if null_vector is None:
        if form > 0:
            raise InvalidInputError(
                "form",
                f"0 for {element} with the minimum of {MIN_POINTS[element]} points (no redundancy)",
                repr(form),
            )
        return np.zeros(jac.shape[0])
    residuals = _scaled(null_vector, form)
    if not standard.iterative or form == 0:
        return residuals
    for _ in range(_MAX_ITERATIONS):
        jac = standard.jacobian(_apply(standard, residuals))
        if first_order_residual(jac, residuals) <= FIRST_ORDER_TOLERANCE:
            return residuals
        # project onto the null space of J(moved)^T, keep the requested range
        correction, *_ = np.linalg.lstsq(jac, residuals, rcond=None)
        residuals = _scaled(residuals - jac @ correction, form)
    raise ConvergenceError(element, _MAX_ITERATIONS, "null-space residuals did not settle; reduce the form error")


def _projected_circle_residuals(
    standard: StandardElement, form: float, rng: np.random.Generator, element: str
) -> FloatArray:
    """Plane-then-circle (NIST) variant: in-plane residuals null for the 2-D circle, axial for the plane."""
    foot = standard.foot_points
    n = len(foot)
    radial_dirs = standard.move_directions[0]
    circle_jac = np.column_stack([-radial_dirs[:, 0], -radial_dirs[:, 1], -np.ones(n)])
    radial = _random_null_vector(circle_jac, rng, "circle2d")
    radial = np.zeros(n) if radial is None else radial
    moved = foot + radial[:, None] * radial_dirs
    axial = _random_null_vector(_plane_rows(moved), rng, "plane")
    axial = np.zeros(n) if axial is None else axial
    residuals = np.concatenate([radial, axial])
    if form > 0 and not np.ptp(residuals) > 0:
        raise InvalidInputError("form", f"0 for {element} with {n} points (no redundancy)", repr(form))
    residuals = _scaled(residuals, form)
    # scaling the radial part moves the in-plane coordinates of the plane's Jacobian: re-project
    for _ in range(_MAX_ITERATIONS):
        plane_jac = _plane_rows(foot + residuals[:n, None] * radial_dirs)
        if first_order_residual(plane_jac, residuals[n:]) <= FIRST_ORDER_TOLERANCE:
            return residuals
        correction, *_ = np.linalg.lstsq(plane_jac, residuals[n:], rcond=None)
        residuals = _scaled(np.concatenate([residuals[:n], residuals[n:] - plane_jac @ correction]), form)
    raise ConvergenceError(element, _MAX_ITERATIONS, "plane residuals did not settle; reduce the form error")


def _plane_rows(points: FloatArray) -> FloatArray:
    """Jacobian of plane residuals (offset, two tilts) for the plane z = 0."""
    return np.column_stack([-np.ones(len(points)), -points[:, 0], -points[:, 1]])


def _as_rng(rng: int | np.random.Generator | None) -> np.random.Generator:
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None or isinstance(rng, (int, np.integer)):
        return np.random.default_rng(0 if rng is None else int(rng))
    raise InvalidInputError("rng", "an int seed or a numpy Generator", type(rng).__name__)


#: element names shared with the fits (``fit_line`` ...) and ``pcmm fit`` -> the data-set kind, by dimension
_SHARED_NAMES = {("line", 2): "line2d", ("line", 3): "line3d", ("circle", 2): "circle2d", ("circle", 3): "circle3d"}


def data_kind(element: str, dims: int | None = None, method: str = "gaussian") -> str:
    """The data-set kind (one of :data:`ELEMENTS`) of an element named as the fits name it.

    ``"line"`` and ``"circle"`` are 3-D unless ``dims=2`` (as ``pcmm fit line|circle`` without
    ``--two-d``); ``method="projected"`` is the NIST 3-D circle (plane, then 2-D circle).  A kind
    (``"line2d"``, ``"circle3d_projected"``, ...) is returned as it is.

    Raises
    ------
    InvalidInputError
        Unknown element, ``dims`` other than 2 or 3, ``dims=2`` for an element that is 3-D
        only, or ``method`` other than ``"gaussian"`` / ``"projected"`` (circle only).

    Examples
    --------
    >>> data_kind("line"), data_kind("circle", dims=2), data_kind("circle", method="projected")
    ('line3d', 'circle2d', 'circle3d_projected')
    """
    if dims not in (None, 2, 3):
        raise InvalidInputError("dims", "2 or 3", repr(dims))
    if method not in ("gaussian", "projected"):
        raise InvalidInputError("method", "'gaussian' or 'projected'", repr(method))
    if element in FIT_ELEMENTS and 2 in SPECS[element].dims:  # line, circle: planar or spatial
        kind = _SHARED_NAMES[(element, dims or 3)]
    elif element in MIN_POINTS:
        kind = element
        if dims is not None and dims != (2 if element.endswith("2d") else 3):
            raise InvalidInputError("dims", f"{2 if element.endswith('2d') else 3} for {element}", repr(dims))
    else:
        raise InvalidInputError("element", f"one of {', '.join(FIT_ELEMENTS)} (or a kind: {', '.join(ELEMENTS)})",
                                repr(element))
    if method == "projected":
        if kind != "circle3d":
            raise InvalidInputError("method", "'gaussian' (method='projected' is the NIST 3-D circle only)",
                                    f"'projected' for {kind}")
        kind = "circle3d_projected"
    return kind


def make_reference_data(
    element: str,
    *,
    dims: int | None = None,
    method: str = "gaussian",
    n_points: int | None = None,
    form: float = 0.0,
    radius: float = 10.0,
    length: float = 20.0,
    arc: float = 2 * np.pi,
    cap: float = np.pi,
    half_angle: float = np.pi / 6,
    minor_radius: float = 3.0,
    tube_arc: float = 2 * np.pi,
    offset: float = 0.0,
    rotate: bool = True,
    rng: int | np.random.Generator | None = 0,
) -> ReferenceDataSet:
    """Make a data set whose least-squares element is known exactly (null-space method).

    Parameters
    ----------
    element : str
        As the fits name it: ``"line"``, ``"plane"``, ``"circle"``, ``"sphere"``, ``"cylinder"``,
        ``"cone"`` or ``"torus"`` (see :func:`data_kind`); or a data-set kind of :data:`ELEMENTS`
        (``"line2d"``, ``"line3d"``, ``"circle2d"``, ``"circle3d"``, ``"circle3d_projected"``, ...),
        which the returned set's ``element`` holds.
    dims : {2, 3}, optional
        Line and circle: planar (``(N, 2)`` points) or spatial; default 3.
    method : {"gaussian", "projected"}
        Circle: the 3-D circle of orthogonal distances, or the NIST convention (``"projected"``).
    n_points : int, optional
        Number of points; default ``max(4 * minimum, 20)``.  The minimum
        (:data:`MIN_POINTS`) is allowed only with ``form = 0``.
    form : float
        Range (max - min) of the residual values, mm (>= 0).  Keep it small against the
        radii of curvature so the reference stays the global optimum.
    radius : float
        Circle / sphere / cylinder radius, cone radius at the section's mid-height, torus
        major radius, mm.
    length : float
        Line length, plane square side, cylinder / cone section height, mm.
    arc : float
        Angle covered around the axis (circle, cylinder, cone, torus), rad; ``2 pi`` = full.
    cap : float
        Sphere: largest polar angle from the pole, rad (``pi`` = whole sphere, ``pi / 2`` =
        hemisphere).
    half_angle : float
        Cone half apex angle, rad, in (0, pi/2).
    minor_radius : float
        Torus tube radius, mm (< ``radius``).
    tube_arc : float
        Torus: angle covered around the tube, rad, centred on the outer equator.
    offset : float
        Distance of the element's centre / axis point from the origin, mm (random direction).
    rotate : bool
        Apply a seeded random rotation (otherwise axis / normal along +z, 2-D line along +x).
    rng : int or numpy.random.Generator
        Seed or generator for sampling, residual mix, rotation and offset direction.

    Returns
    -------
    ReferenceDataSet

    Raises
    ------
    InvalidInputError
        Unknown element or ``dims``, negative form, sizes out of range, ``form > 0`` with the minimum
        point count.
    TooFewPointsError
        Fewer points than the element needs.
    DegenerateGeometryError
        The sampled points do not determine the element (e.g. an arc far too small).
    ConvergenceError
        The iteration for cone / torus / 3-D circle did not settle (form too large).

    Examples
    --------
    >>> data = make_reference_data("cylinder", n_points=30, radius=5.0, arc=np.pi / 2, form=0.001, rng=3)
    >>> data.parameters["radius"], data.points.shape
    (5.0, (30, 3))
    >>> circle = make_reference_data("circle", dims=2, n_points=3, rotate=False)
    >>> (np.round(circle.points, 12) + 0.0).tolist()[0]
    [10.0, 0.0]
    """
    element = data_kind(element, dims, method)
    minimum = MIN_POINTS[element]
    if n_points is None:
        n_points = max(4 * minimum, 20)
    if not isinstance(n_points, (int, np.integer)) or isinstance(n_points, bool):
        raise InvalidInputError("n_points", "an integer", type(n_points).__name__)
    if n_points < minimum:
        raise TooFewPointsError(element, minimum, int(n_points))
    if not (np.isfinite(form) and form >= 0):
        raise InvalidInputError("form", "a finite form error >= 0 (mm)", repr(form))
    if not (np.isfinite(offset) and offset >= 0):
        raise InvalidInputError("offset", "a finite distance >= 0 (mm)", repr(offset))
    generator = _as_rng(rng)
    seed_text = rng if isinstance(rng, (int, np.integer)) or rng is None else "generator"
    standard = build_standard_element(
        element,
        int(n_points),
        radius=float(radius),
        length=float(length),
        arc=float(arc),
        cap=float(cap),
        half_angle=float(half_angle),
        minor_radius=float(minor_radius),
        tube_arc=float(tube_arc),
        rng=generator,
    )
    if element == "circle3d_projected":
        stacked = _projected_circle_residuals(standard, float(form), generator, element)
    else:
        stacked = _null_space_residuals(standard, float(form), generator, element)
    moved = _apply(standard, stacked)
    components = stacked.reshape(standard.move_directions.shape[0], -1)
    residuals = components[0].copy() if components.shape[0] == 1 else components.T.copy()
    dims = moved.shape[1]
    rotation = random_rotation(generator, dims) if rotate else np.eye(dims)
    direction = generator.standard_normal(dims)
    translation = offset * direction / np.linalg.norm(direction)
    points = moved @ rotation.T + translation
    foot_points = standard.foot_points @ rotation.T + translation
    parameters = _world_parameters(element, standard, rotation, translation, points)
    sampling = {
        "n_points": int(n_points),
        "form": float(form),
        "radius": float(radius),
        "length": float(length),
        "arc": float(arc),
        "cap": float(cap),
        "half_angle": float(half_angle),
        "minor_radius": float(minor_radius),
        "tube_arc": float(tube_arc),
        "offset": float(offset),
        "rotate": bool(rotate),
        "seed": seed_text,
    }
    return ReferenceDataSet(element, points, parameters, residuals, foot_points, sampling)


def _world_parameters(
    element: str,
    standard: StandardElement,
    rotation: FloatArray,
    translation: FloatArray,
    points: FloatArray,
) -> dict[str, Any]:
    """Reference element in the machine frame, under the fit-result contract names."""
    axis = rotation[:, -1] if rotation.shape[0] == 3 else rotation[:, 0]
    centroid = points.mean(axis=0)
    size = standard.size
    if element in ("line2d", "line3d"):
        return {"point": centroid, "direction": axis.copy()}
    if element == "plane":
        return {"point": centroid, "normal": axis.copy()}
    if element == "circle2d":
        return {"center": translation.copy(), "radius": size["radius"]}
    if element in ("circle3d", "circle3d_projected"):
        return {"center": translation.copy(), "normal": axis.copy(), "radius": size["radius"]}
    if element == "sphere":
        return {"center": translation.copy(), "radius": size["radius"]}
    axial_position = float((centroid - translation) @ axis)
    axis_point = translation + axial_position * axis
    if element == "cylinder":
        return {"point": axis_point, "axis": axis.copy(), "radius": size["radius"]}
    if element == "cone":
        half_angle = size["half_angle"]
        apex = translation - size["radius"] / np.tan(half_angle) * axis
        return {
            "apex": apex,
            "axis": axis.copy(),
            "half_angle": half_angle,
            "point": axis_point,
            "radius_at_point": float(size["radius"] + axial_position * np.tan(half_angle)),
        }
    return {
        "center": translation.copy(),
        "axis": axis.copy(),
        "major_radius": size["radius"],
        "minor_radius": size["minor_radius"],
    }
