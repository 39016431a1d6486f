"""Independent multi-start reference for the axial fits, and the sparse data sets they are scanned on.

The reference shares no code with :mod:`pcmm_geo.fit`: it runs MINPACK's Levenberg-Marquardt
(``scipy.optimize.leastsq``, analytic Jacobian, no re-centring)
from many starting axes -- a Fibonacci lattice on the hemisphere, the principal axes and
the generating element -- and keeps the least sum of squares.  Used by
``tests/fit/test_robustness.py`` (a few hundred sets) and ``benchmarks/fit_robustness.py``
(thousands).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

FloatArray = np.ndarray


def fibonacci_hemisphere(count: int) -> FloatArray:
    """``count`` unit vectors spread over the upper hemisphere, shape (count, 3)."""
    k = np.arange(count) + 0.5
    z = 1.0 - k / count
    phi = k * np.pi * (3.0 - np.sqrt(5.0))
    s = np.sqrt(1.0 - z * z)
    return np.c_[s * np.cos(phi), s * np.sin(phi), z]


def _frame(direction: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    d = direction / np.linalg.norm(direction)
    helper = np.eye(3)[int(np.argmin(np.abs(d)))]
    e1 = np.cross(d, helper)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(d, e1), d


def _kasa(xy: FloatArray) -> tuple[float, float, float]:
    design = np.c_[2 * xy, np.ones(len(xy))]
    sol = np.linalg.lstsq(design, (xy**2).sum(axis=1), rcond=None)[0]
    return float(sol[0]), float(sol[1]), float(np.sqrt(max(sol[2] + sol[0] ** 2 + sol[1] ** 2, 1e-12)))


@dataclass(frozen=True)
class Reference:
    """Least sum of squares found by the multi-start reference and the axis of that minimum."""

    cost: float
    axis: FloatArray


def _run(
    residual: Callable[[FloatArray], FloatArray], x0: FloatArray, jacobian: Callable[[FloatArray], FloatArray]
) -> tuple[float, FloatArray] | None:
    from scipy.optimize import leastsq  # MINPACK's lmder, called directly (least_squares(method="lm") adds overhead)

    try:
        x = leastsq(residual, x0, Dfun=jacobian, full_output=True, xtol=1e-15, ftol=1e-15, gtol=1e-15, maxfev=4000)[0]
    except (ValueError, TypeError, np.linalg.LinAlgError):
        return None
    r = residual(x)
    if not np.all(np.isfinite(r)):
        return None
    return float(r @ r), x


def _axial_terms(local: FloatArray, p: FloatArray, centre: FloatArray) -> tuple[FloatArray, ...]:
    """Distances of ``local`` points from the axis through ``centre`` along ``(p[0], p[1], 1)``, with derivatives.

    Returns ``d``, ``norm`` (of ``(a, b, 1)``), ``h`` (along the axis), ``w`` (perpendicular vector),
    ``rho = |w|`` and ``unit = w / rho``.  With ``d = (a, b, 1) / norm``: ``drho/dcentre = -unit``,
    ``drho/da = -h unit_x / norm``, ``dh/dcentre = -d``, ``dh/da = w_x / norm`` (and ``b`` with ``y``).
    """
    norm = np.sqrt(1 + p[0] ** 2 + p[1] ** 2)
    d = np.array([p[0], p[1], 1.0]) / norm
    rel = local - centre
    h = rel @ d
    w = rel - h[:, None] * d
    rho = np.sqrt(np.einsum("ij,ij->i", w, w))
    unit = w / np.where(rho > 0, rho, 1.0)[:, None]
    return d, norm, h, w, rho, unit


def _axis_of(frame: tuple[FloatArray, FloatArray, FloatArray], a: float, b: float) -> FloatArray:
    d = frame[2] + a * frame[0] + b * frame[1]
    return d / np.linalg.norm(d)


def _start_axes(points: FloatArray, truth_axis: FloatArray | None, count: int) -> list[FloatArray]:
    centred = points - points.mean(axis=0)
    vt = np.linalg.svd(centred, full_matrices=False)[2]
    axes = [*vt, *fibonacci_hemisphere(count)]
    if truth_axis is not None:
        axes.insert(0, truth_axis)
    return axes


def cylinder_reference(points: FloatArray, truth_axis: FloatArray | None = None, count: int = 60) -> Reference:
    """Multi-start least-squares cylinder: least cost over ``count`` lattice axes, principal axes and the truth."""
    centroid = points.mean(axis=0)
    best: Reference | None = None
    for start_axis in _start_axes(points, truth_axis, count):
        frame = _frame(start_axis)
        local = (points - centroid) @ np.array(frame).T
        x0, y0, r0 = _kasa(local[:, :2])

        def residual(p: FloatArray, local: FloatArray = local) -> FloatArray:
            d = np.array([p[2], p[3], 1.0]) / np.sqrt(1 + p[2] ** 2 + p[3] ** 2)
            rel = local - np.array([p[0], p[1], 0.0])
            return np.linalg.norm(np.cross(rel, d), axis=1) - p[4]

        def jacobian(p: FloatArray, local: FloatArray = local) -> FloatArray:
            _, norm, h, _, _, unit = _axial_terms(local, p[2:4], np.array([p[0], p[1], 0.0]))
            return np.column_stack([-unit[:, 0], -unit[:, 1], -h * unit[:, 0] / norm, -h * unit[:, 1] / norm,
                                    -np.ones(len(h))])

        run = _run(residual, np.array([x0, y0, 0.0, 0.0, r0]), jacobian)
        if run is not None and (best is None or run[0] < best.cost):
            best = Reference(run[0], _axis_of(frame, run[1][2], run[1][3]))
    assert best is not None
    return best


def cone_reference(points: FloatArray, truth_axis: FloatArray | None = None, count: int = 60) -> Reference:
    """Multi-start least-squares cone (NIST residual ``(rho - r - h tan a) cos a``)."""
    centroid = points.mean(axis=0)
    best: Reference | None = None
    for start_axis in _start_axes(points, truth_axis, count):
        frame = _frame(start_axis)
        local = (points - centroid) @ np.array(frame).T
        x, y, z = local.T
        design = np.c_[2 * x, 2 * y, np.ones_like(x), z, z * z]
        cx, cy, c, e, f = np.linalg.lstsq(design, x * x + y * y, rcond=None)[0]
        slope = np.copysign(np.sqrt(f), e) if f > 0 else 0.0
        r0 = abs(e) / (2 * np.sqrt(f)) if f > 0 else np.sqrt(max(c + cx * cx + cy * cy, 1e-12))

        def residual(p: FloatArray, local: FloatArray = local) -> FloatArray:
            d = np.array([p[2], p[3], 1.0]) / np.sqrt(1 + p[2] ** 2 + p[3] ** 2)
            rel = local - np.array([p[0], p[1], 0.0])
            h = rel @ d
            rho = np.linalg.norm(rel - h[:, None] * d, axis=1)
            return (rho - p[4]) * np.cos(p[5]) - h * np.sin(p[5])

        def jacobian(p: FloatArray, local: FloatArray = local) -> FloatArray:
            d, norm, h, w, rho, unit = _axial_terms(local, p[2:4], np.array([p[0], p[1], 0.0]))
            cos, sin = np.cos(p[5]), np.sin(p[5])
            return np.column_stack([-unit[:, 0] * cos + d[0] * sin, -unit[:, 1] * cos + d[1] * sin,
                                    (-h * unit[:, 0] * cos - w[:, 0] * sin) / norm,
                                    (-h * unit[:, 1] * cos - w[:, 1] * sin) / norm,
                                    np.full(len(h), -cos), -(rho - p[4]) * sin - h * cos])

        for start in (np.array([cx, cy, 0, 0, r0, np.arctan(slope)]), np.array([cx, cy, 0, 0, r0, -np.arctan(slope)])):
            run = _run(residual, start.astype(float), jacobian)
            if run is not None and (best is None or run[0] < best.cost):
                best = Reference(run[0], _axis_of(frame, run[1][2], run[1][3]))
    assert best is not None
    return best


def torus_reference(
    points: FloatArray,
    truth_axis: FloatArray | None = None,
    truth_center: FloatArray | None = None,
    count: int = 60,
) -> Reference:
    """Multi-start least-squares torus: every start axis, axis position from a projected circle (and the truth's)."""
    centroid = points.mean(axis=0)
    best: Reference | None = None
    for index, start_axis in enumerate(_start_axes(points, truth_axis, count)):
        frame = _frame(start_axis)
        local = (points - centroid) @ np.array(frame).T
        positions = [_kasa(local[:, :2])[:2]]
        if index == 0 and truth_center is not None:
            positions.insert(0, tuple(((truth_center - centroid) @ np.array(frame).T)[:2]))
        for cx, cy in positions:
            rho = np.hypot(local[:, 0] - cx, local[:, 1] - cy)
            major, z0, minor = _kasa(np.c_[rho, local[:, 2]])

            def residual(p: FloatArray, local: FloatArray = local) -> FloatArray:
                d = np.array([p[3], p[4], 1.0]) / np.sqrt(1 + p[3] ** 2 + p[4] ** 2)
                rel = local - p[:3]
                h = rel @ d
                rho = np.linalg.norm(rel - h[:, None] * d, axis=1)
                return np.hypot(rho - p[5], h) - p[6]

            def jacobian(p: FloatArray, local: FloatArray = local) -> FloatArray:
                d, norm, h, w, rho, unit = _axial_terms(local, p[3:5], p[:3])
                tube = np.where(np.hypot(rho - p[5], h) > 0, np.hypot(rho - p[5], h), 1.0)
                along_rho, along_h = (rho - p[5]) / tube, h / tube  # d(tube) = along_rho d(rho) + along_h d(h)
                return np.column_stack([-(along_rho[:, None] * unit + along_h[:, None] * d),
                                        (-along_rho * h * unit[:, 0] + along_h * w[:, 0]) / norm,
                                        (-along_rho * h * unit[:, 1] + along_h * w[:, 1]) / norm,
                                        -along_rho, -np.ones(len(h))])

            run = _run(residual, np.array([cx, cy, z0, 0.0, 0.0, major, minor]), jacobian)
            if run is not None and (best is None or run[0] < best.cost):
                best = Reference(run[0], _axis_of(frame, run[1][3], run[1][4]))
    assert best is not None
    return best


def _rotation(rng: np.random.Generator) -> FloatArray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


@dataclass(frozen=True)
class Case:
    """One sparse data set with its generating axis (machine frame)."""

    points: FloatArray
    axis: FloatArray
    center: FloatArray


def sparse_case(kind: str, rng: np.random.Generator, n: int, *, arc_deg: float = 360.0, form: float = 0.05) -> Case:
    """Random sparse data on a cylinder (R 5, L 20), cone (r 3..8 over L 10..20) or torus (R 30, r 6).

    Points lie on the surface plus uniform noise of range ``form`` along the normal; the
    element is rotated randomly and moved about 100 mm from the origin.  ``arc_deg``
    restricts the angle about the axis (half circumference, partial torus).
    """
    rotation = _rotation(rng)
    shift = rng.uniform(-100, 100, 3)
    noise = form * (rng.random(n) - 0.5)
    angle = np.radians(arc_deg) * rng.random(n)
    if kind == "cylinder":
        height = 20.0 * rng.random(n)
        radial = 5.0 + noise
        local = np.c_[radial * np.cos(angle), radial * np.sin(angle), height]
    elif kind == "cone":
        half = np.radians(rng.uniform(8, 35))
        length = rng.uniform(10, 20)
        height = length * rng.random(n)
        radius = 3.0 + height * np.tan(half)
        rho = radius + noise / np.cos(half)
        local = np.c_[rho * np.cos(angle), rho * np.sin(angle), height]
    elif kind == "torus":
        tube = 2 * np.pi * rng.random(n)
        minor = 6.0 + noise
        rho = 30.0 + minor * np.cos(tube)
        local = np.c_[rho * np.cos(angle), rho * np.sin(angle), minor * np.sin(tube)]
    else:
        raise ValueError(kind)
    return Case(points=local @ rotation.T + shift, axis=rotation[:, 2], center=shift)


def reference_for(kind: str, case: Case, count: int = 60) -> Reference:
    """The multi-start reference minimum of ``case``."""
    if kind == "cylinder":
        return cylinder_reference(case.points, case.axis, count)
    if kind == "cone":
        return cone_reference(case.points, case.axis, count)
    return torus_reference(case.points, case.axis, case.center, count)
