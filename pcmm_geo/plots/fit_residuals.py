"""Residual plots of a Gaussian fit, laid out the way the element is inspected.

Each point's signed orthogonal residual (positive outside / along the normal) is drawn
where the point lies on the element, in the unit :func:`~pcmm_geo.plots._figure.length_unit`
picks from the residuals (nm, µm or mm):

- line: residual against the position along the line;
- plane: in-plane map (two in-plane coordinates, colour = residual);
- circle: residual against the angle round the centre, and a polar deviation plot whose
  rings carry the deviation values (the fitted circle is the ring at 0);
- sphere: azimuth x elevation map;
- cylinder, cone: unrolled map, angle round the axis x height along the axis;
- torus: angle round the axis x angle round the tube.

Maps use a diverging colour scale symmetric about zero, so white is "on the element".
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pcmm_geo.elements import AXIAL, Element, element_of
from pcmm_geo.plots._figure import (
    check_plot_path,
    length_unit,
    new_figure,
    polar_deviation_axes,
    save_figure,
    three_digits,
)

if TYPE_CHECKING:
    from pcmm_geo.fit import FitResult

__all__ = ["draw_sphere_map", "plot_fit_residuals"]


def _frame(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors completing ``axis`` to a right-handed orthonormal frame (e1, e2, axis)."""
    axis = axis / np.linalg.norm(axis)
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    first = helper - (helper @ axis) * axis
    first /= np.linalg.norm(first)
    return first, np.cross(axis, first)


def _angles_heights(points: np.ndarray, origin: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Angle round ``axis`` (deg, 0..360) and height along it (mm) of each point."""
    first, second = _frame(np.asarray(axis, dtype=float))
    rel = points - origin
    angle = np.degrees(np.arctan2(rel @ second, rel @ first)) % 360.0
    return angle, rel @ (axis / np.linalg.norm(axis))


def _as_3d(points: np.ndarray) -> np.ndarray:
    return np.c_[points, np.zeros(len(points))] if points.shape[1] == 2 else points


def _vector3(value: Any) -> np.ndarray:
    vector = np.asarray(value, dtype=float).ravel()
    return np.r_[vector, 0.0] if vector.size == 2 else vector


def _map(figure: Any, axes: Any, x: np.ndarray, y: np.ndarray, shown: np.ndarray, unit: str) -> None:
    limit = float(np.max(np.abs(shown))) or 1.0
    dots = axes.scatter(x, y, c=shown, cmap="RdBu_r", vmin=-limit, vmax=limit, s=max(8.0, 60.0 - 0.05 * len(x)),
                        edgecolors="0.3", linewidths=0.3)
    figure.colorbar(dots, ax=axes, label=f"residual / {unit}")


def draw_sphere_map(figure: Any, axes: Any, points: np.ndarray, center: np.ndarray, shown: np.ndarray,
                    unit: str) -> None:
    """Residuals ``shown`` (already in ``unit``) of ``points`` (N, 3) on an azimuth x elevation map about ``center``."""
    rel = points - center
    azimuth = np.degrees(np.arctan2(rel[:, 1], rel[:, 0])) % 360.0
    elevation = np.degrees(np.arcsin(np.clip(rel[:, 2] / np.linalg.norm(rel, axis=1), -1.0, 1.0)))
    _map(figure, axes, azimuth, elevation, shown, unit)
    axes.set_xlim(-6.0, 366.0)  # a little beyond the range: points at 0/360 deg and the poles stay whole
    axes.set_ylim(-96.0, 96.0)
    axes.set_xticks(np.arange(0, 361, 45))
    axes.set_yticks(np.arange(-90, 91, 30))
    axes.set_xlabel("azimuth (from +x round +z) / deg")
    axes.set_ylabel("elevation / deg")
    axes.grid(alpha=0.3)


def _draw_circle(figure: Any, result: Any, points: np.ndarray, shown: np.ndarray, unit: str) -> None:
    normal = _vector3(result.normal) if getattr(result, "normal", None) is not None else np.array([0.0, 0, 1])
    center = _vector3(result.center)
    angle, _ = _angles_heights(points, center, normal)
    order = np.argsort(angle)
    left = figure.add_subplot(1, 2, 1)
    left.axhline(0.0, color="black", linewidth=0.8)
    left.plot(angle[order], shown[order], color="tab:blue", linewidth=0.8, marker="o", markersize=3)
    left.set_xlim(0.0, 360.0)
    left.set_xticks(np.arange(0, 361, 45))
    left.set_xlabel("angle round the centre / deg")
    left.set_ylabel(f"residual / {unit}")
    left.grid(alpha=0.3)
    polar = figure.add_subplot(1, 2, 2, projection="polar")
    to_radius = polar_deviation_axes(polar, shown, unit, reference="fitted circle (0)")
    theta = np.radians(angle[order])
    polar.plot(np.r_[theta, theta[:1]], to_radius(np.r_[shown[order], shown[order][:1]]), color="tab:red",
               linewidth=1.0, marker=".", markersize=3, label="measured")
    step = np.diff(polar.get_yticks()[:2])[0]
    polar.set_title(f"deviation from the fitted circle, rings every {step:g} {unit}", fontsize=9)
    polar.legend(loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=2, fontsize=7)


def plot_fit_residuals(
    result: FitResult, path: str | Path, *, points: Any, element: Element | None = None, overwrite: bool = False
) -> Path:
    """Write the residual plot of a fit, laid out by element (see the module docstring).

    Parameters
    ----------
    result : FitResult
        Any fit result of :mod:`pcmm_geo.fit` (``residuals`` in mm, shape (N,)).
    path : str or Path
        Destination, ``.png``, ``.svg`` or ``.pdf``.
    points : array_like, shape (N, 3) or (N, 2)
        The fitted points (mm), in the order of ``result.residuals``.
    element : str, optional
        Element name for the title; default from the result type (``"sphere"``, ...).
    overwrite : bool
        Replace an existing file.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    InvalidInputError
        Unsupported suffix, or ``points`` does not match the residuals.
    OutputExistsError
        ``path`` exists and ``overwrite`` is False.
    OSError
        The folder does not exist or is not writable.

    Examples
    --------
    >>> import os, tempfile
    >>> from pcmm_geo.fit import fit_circle
    >>> angles = np.linspace(0.0, 2 * np.pi, 12, endpoint=False)
    >>> points = np.c_[np.cos(angles), np.sin(angles) + 0.001 * np.cos(3 * angles)]
    >>> circle = fit_circle(points)
    >>> plot_fit_residuals(circle, os.path.join(tempfile.mkdtemp(), "r.png"), points=points).name
    'r.png'
    """
    from pcmm_geo.errors import InvalidInputError

    check_plot_path(path, overwrite=overwrite)
    residuals = np.asarray(result.residuals, dtype=float).ravel()
    cloud = np.asarray(points, dtype=float)
    if cloud.ndim != 2 or cloud.shape[1] not in (2, 3) or len(cloud) != len(residuals):
        raise InvalidInputError("points", f"shape ({len(residuals)}, 3) matching the residuals",
                                f"shape {cloud.shape}")
    kind = element or element_of(result) or "element"
    factor, unit = length_unit(residuals)
    shown = factor * residuals
    cloud3 = _as_3d(cloud)
    figure = new_figure(11.0 if kind == "circle" else 8.0, 4.8)
    if kind == "circle":
        _draw_circle(figure, result, cloud3, shown, unit)
    elif kind == "line":
        direction = _vector3(result.direction)
        along = (cloud3 - _vector3(result.point)) @ (direction / np.linalg.norm(direction))
        order = np.argsort(along)
        axes = figure.add_subplot()
        axes.axhline(0.0, color="black", linewidth=0.8)
        axes.plot(along[order], shown[order], marker="o", markersize=3, linewidth=0.8)
        axes.set_xlabel("position along the line / mm")
        axes.set_ylabel(f"residual / {unit}")
        axes.grid(alpha=0.3)
    elif kind == "plane":
        first, second = _frame(_vector3(result.normal))
        rel = cloud3 - _vector3(result.point)
        axes = figure.add_subplot()
        _map(figure, axes, rel @ first, rel @ second, shown, unit)
        axes.set_aspect("equal", adjustable="datalim")
        axes.set_xlabel("in-plane u / mm")
        axes.set_ylabel("in-plane v / mm")
    elif kind == "sphere":
        draw_sphere_map(figure, figure.add_subplot(), cloud3, _vector3(result.center), shown, unit)
    elif kind in AXIAL:  # cylinder, cone, torus: unrolled around the axis
        origin = _vector3(result.apex if kind == "cone" else (result.center if kind == "torus" else result.point))
        axis = _vector3(result.axis)
        angle, height = _angles_heights(cloud3, origin, axis)
        axes = figure.add_subplot()
        if kind == "torus":
            radial = np.linalg.norm(cloud3 - origin - np.outer(height, axis / np.linalg.norm(axis)), axis=1)
            tube = np.degrees(np.arctan2(height, radial - float(result.major_radius))) % 360.0
            _map(figure, axes, angle, tube, shown, unit)
            axes.set_ylim(-6.0, 366.0)
            axes.set_ylabel("angle round the tube / deg")
        else:
            _map(figure, axes, angle, height, shown, unit)
            axes.set_ylabel("height along the axis from the " + ("apex" if kind == "cone" else "axis point")
                            + " / mm")
        axes.set_xlim(-6.0, 366.0)
        axes.set_xticks(np.arange(0, 361, 45))
        axes.set_xlabel("angle round the axis / deg")
        axes.grid(alpha=0.3)
    else:
        raise InvalidInputError("element", "line, plane, circle, sphere, cylinder, cone or torus", repr(kind))
    figure.suptitle(f"{kind} fit residuals: n {result.n}, rms {three_digits(factor * result.rms)} {unit}, "
                    f"form {three_digits(factor * result.form)} {unit}")
    return save_figure(figure, path, overwrite=overwrite)
