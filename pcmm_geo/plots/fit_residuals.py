"""Residual plot of a Gaussian fit: signed orthogonal distance of every point from the element."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pcmm_geo.plots._figure import check_plot_path, new_figure, save_figure

if TYPE_CHECKING:
    from pcmm_geo.fit import FitResult

__all__ = ["plot_fit_residuals"]


def plot_fit_residuals(result: FitResult, path: str | Path, *, element: str, overwrite: bool = False) -> Path:
    """Write a bar chart of the fit residuals (µm) in point order, with rms and form in the title.

    Parameters
    ----------
    result : FitResult
        Any fit result of :mod:`pcmm_geo.fit` (``residuals`` in mm, shape (N,)).
    path : str or Path
        Destination, ``.png``, ``.svg`` or ``.pdf``.
    element : str
        Element name for the title (``"sphere"``, ...).
    overwrite : bool
        Replace an existing file.

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
    >>> from pcmm_geo.fit import fit_circle
    >>> angles = np.linspace(0.0, 2 * np.pi, 12, endpoint=False)
    >>> circle = fit_circle(np.c_[np.cos(angles), np.sin(angles) + 0.001 * np.cos(3 * angles)])
    >>> plot_fit_residuals(circle, os.path.join(tempfile.mkdtemp(), "r.png"), element="circle").name
    'r.png'
    """
    check_plot_path(path, overwrite=overwrite)
    residuals_um = 1000.0 * np.asarray(result.residuals, dtype=float).ravel()
    figure = new_figure(7.0, 3.5)
    axes = figure.add_subplot()
    index = np.arange(1, len(residuals_um) + 1)
    axes.bar(index, residuals_um, width=1.0 if len(residuals_um) > 50 else 0.8, color="tab:blue")
    axes.axhline(0.0, color="black", linewidth=0.8)
    axes.set_xlabel("point")
    axes.set_ylabel("residual / µm")
    axes.set_title(f"{element} fit: n {result.n}, rms {1000.0 * result.rms:.3g} µm, "
                   f"form {1000.0 * result.form:.3g} µm")
    return save_figure(figure, path, overwrite=overwrite)
