"""Plots of the end-to-end demonstration (:mod:`pcmm_geo.demo`).

* :func:`plot_tip_errors` -- the tip centre error of every gauge-block contact with the
  calibrated and with the nominal model (log scale: the two differ by three decades).
* :func:`plot_demo_overview` -- one figure with the calibration (thesis fig 7.2) and the tip
  errors side by side.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from pcmm_geo.plots._figure import check_plot_path, new_figure, save_figure

if TYPE_CHECKING:
    from pcmm_geo.machine.calibration.result import TetrahedronCalibration

__all__ = ["draw_tip_errors", "plot_demo_overview", "plot_tip_errors"]

MODEL_MARKERS = {"calibrated": "o", "nominal": "s"}


def draw_tip_errors(axes: Any, tip_errors: Mapping[str, Sequence[ArrayLike]]) -> None:
    """Draw the length of every tip centre error vector (µm) per contact, one line per model.

    Parameters
    ----------
    axes : matplotlib.axes.Axes
    tip_errors : mapping model name -> sequence of arrays (N_face, 3)
        Measured minus true tip centres (mm), face by face, as :class:`~pcmm_geo.demo.DemoResult` holds them.

    Raises
    ------
    ValueError
        An error array is not of shape (N, 3).

    Examples
    --------
    See :func:`plot_tip_errors`.
    """
    for model, per_face in tip_errors.items():
        errors_um = 1000.0 * np.linalg.norm(np.concatenate([np.asarray(e, dtype=float) for e in per_face]), axis=1)
        axes.plot(np.arange(1, len(errors_um) + 1), errors_um, marker=MODEL_MARKERS.get(model, "^"),
                  label=f"{model} model")
    axes.set_yscale("log")
    axes.set_xlabel("contact number (face 1, then face 2)")
    axes.set_ylabel("tip centre error / µm")
    axes.set_title("Gauge-block contacts: tip error of each model")
    axes.legend()


def plot_tip_errors(
    tip_errors: Mapping[str, Sequence[ArrayLike]], path: str | Path, *, overwrite: bool = False
) -> Path:
    """Write the per-contact tip errors of each model (see :func:`draw_tip_errors`).

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    OutputExistsError
        ``path`` exists and ``overwrite`` is False.
    InvalidInputError
        Unsupported suffix.
    OSError
        The folder does not exist or is not writable.

    Examples
    --------
    >>> import os, tempfile
    >>> errors = {"calibrated": [np.full((3, 3), 1e-3)], "nominal": [np.full((3, 3), 1.0)]}
    >>> plot_tip_errors(errors, os.path.join(tempfile.mkdtemp(), "tips.png")).name
    'tips.png'
    """
    check_plot_path(path, overwrite=overwrite)
    figure = new_figure(7.0, 4.0)
    draw_tip_errors(figure.add_subplot(), tip_errors)
    return save_figure(figure, path, overwrite=overwrite)


def plot_demo_overview(
    calibration: TetrahedronCalibration,
    tip_errors: Mapping[str, Sequence[ArrayLike]],
    path: str | Path,
    *,
    overwrite: bool = False,
) -> Path:
    """Write one figure with the calibration in 3-D (fig 7.2) and the tip errors of both models.

    Parameters
    ----------
    calibration : TetrahedronCalibration
        The demo's calibration (:attr:`pcmm_geo.demo.DemoResult.tetrahedron_calibration`).
    tip_errors : mapping
        :attr:`pcmm_geo.demo.DemoResult.tip_errors` (mm).
    path : str or Path
        Destination, ``.png``, ``.svg`` or ``.pdf``.
    overwrite : bool
        Replace an existing file.

    Returns
    -------
    Path

    Raises
    ------
    OutputExistsError
        ``path`` exists and ``overwrite`` is False.
    InvalidInputError
        Unsupported suffix.
    OSError
        The folder does not exist or is not writable.

    Examples
    --------
    >>> import os, tempfile
    >>> from pcmm_geo.demo import run_demo
    >>> result = run_demo()
    >>> path = os.path.join(tempfile.mkdtemp(), "demo.png")
    >>> plot_demo_overview(result.tetrahedron_calibration, result.tip_errors, path).name
    'demo.png'
    """
    from pcmm_geo.plots.machine.calibration import draw_calibration_3d

    check_plot_path(path, overwrite=overwrite)
    figure = new_figure(13.0, 5.5)
    grid = figure.add_gridspec(1, 2, width_ratios=(1.3, 1.0))
    draw_calibration_3d(figure.add_subplot(grid[0, 0], projection="3d"), calibration)
    draw_tip_errors(figure.add_subplot(grid[0, 1]), tip_errors)
    return save_figure(figure, path, overwrite=overwrite)
