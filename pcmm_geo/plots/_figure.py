"""Figure creation and saving shared by the plot modules.

Figures are built with :class:`matplotlib.figure.Figure` directly (no ``pyplot``), so no
global backend is switched and nothing stays open after saving: the file format follows
the suffix and is rendered by matplotlib's Agg canvas for raster formats.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from pcmm_geo._optional import require
from pcmm_geo.errors import InvalidInputError, OutputExistsError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: file suffixes a plot may be written as
PLOT_SUFFIXES = (".png", ".svg", ".pdf")
#: resolution of raster plots (dots per inch)
PLOT_DPI = 110
#: colours of arms a, b, c in every plot
ARM_COLOURS = {"a": "tab:blue", "b": "tab:orange", "c": "tab:green"}


def check_plot_path(path: str | Path, *, overwrite: bool = False) -> Path:
    """Validate a plot destination before any work is done.

    Parameters
    ----------
    path : str or Path
        Destination; the suffix (``.png``, ``.svg`` or ``.pdf``) chooses the format.
    overwrite : bool
        Allow replacing an existing file.

    Returns
    -------
    Path

    Raises
    ------
    InvalidInputError
        Unsupported suffix.
    OutputExistsError
        ``path`` exists and ``overwrite`` is False.

    Examples
    --------
    >>> check_plot_path("residuals.png").suffix
    '.png'
    """
    from pcmm_geo._atomic import may_overwrite

    target = Path(path)
    if target.suffix.lower() not in PLOT_SUFFIXES:
        raise InvalidInputError("plot file", f"a name ending in {', '.join(PLOT_SUFFIXES)}", repr(str(target)))
    if target.exists() and not may_overwrite(target, overwrite):  # a command's --overwrite-plot counts too
        raise OutputExistsError(str(target))
    return target


def new_figure(width: float, height: float) -> Figure:
    """A figure of ``width`` x ``height`` inches with constrained layout (imports matplotlib)."""
    Figure = require("matplotlib.figure").Figure

    return Figure(figsize=(width, height), layout="constrained")


def save_figure(figure: Figure, path: str | Path, *, overwrite: bool = False) -> Path:
    """Write ``figure`` to ``path``; never replaces a file unless ``overwrite`` is True.

    Missing folders of ``path`` are created (``--plot out/run1/fit.png`` works in a fresh tree).

    The file is opened in exclusive-create mode when ``overwrite`` is False, so a file that
    appears between the check and the write is not clobbered either; a partly written file
    is removed when rendering fails.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    InvalidInputError
        Unsupported suffix.
    OutputExistsError
        ``path`` exists and ``overwrite`` is False.
    OSError
        The folder cannot be created or is not writable.

    Examples
    --------
    >>> import os, tempfile
    >>> figure = new_figure(2, 2)
    >>> _ = figure.add_subplot().plot([0, 1], [1, 0])
    >>> save_figure(figure, os.path.join(tempfile.mkdtemp(), "line.png")).name
    'line.png'
    """
    from pcmm_geo._atomic import write_atomic

    target = check_plot_path(path, overwrite=overwrite)  # write_atomic creates missing folders
    return write_atomic(target, lambda stream: figure.savefig(stream, format=target.suffix[1:].lower(), dpi=PLOT_DPI),
                        overwrite=overwrite)


def equal_3d_limits(axes: Any, points: Any, margin: float = 0.05) -> None:
    """Give 3-D ``axes`` the same scale on x, y and z around ``points`` (N, 3), mm."""
    import numpy as np

    cloud = np.asarray(points, dtype=float).reshape(-1, 3)
    low, high = cloud.min(axis=0), cloud.max(axis=0)
    middle = 0.5 * (low + high)
    half = 0.5 * float(np.max(high - low)) * (1.0 + margin) or 1.0
    axes.set_xlim(middle[0] - half, middle[0] + half)
    axes.set_ylim(middle[1] - half, middle[1] + half)
    axes.set_zlim(middle[2] - half, middle[2] + half)
    axes.set_box_aspect((1.0, 1.0, 1.0))


def length_unit(values_mm: Any) -> tuple[float, str]:
    """Scale factor and unit name to show lengths given in mm: ``mm``, ``µm`` or ``nm``.

    The unit follows the largest magnitude among the finite values: 1 mm and above stays in
    mm, from 1 µm up to 1 mm is shown in µm, below 1 µm in nm (all-zero or empty: µm), so
    that tick labels carry at most three digits before the decimal point.

    Parameters
    ----------
    values_mm : array_like
        Lengths in mm (any shape; NaN and inf are ignored).

    Returns
    -------
    factor : float
        Multiply mm by this to get the unit (1, 1e3 or 1e6).
    unit : str
        ``"mm"``, ``"µm"`` or ``"nm"``.

    Examples
    --------
    >>> length_unit([0.0021, -0.004])
    (1000.0, 'µm')
    >>> length_unit([2.5, 0.1])
    (1.0, 'mm')
    >>> length_unit([3e-7])
    (1000000.0, 'nm')
    """
    import numpy as np

    values = np.abs(np.asarray(values_mm, dtype=float)).ravel()
    values = values[np.isfinite(values)]
    largest = float(values.max()) if values.size else 0.0
    if largest >= 1.0:
        return 1.0, "mm"
    if largest >= 1e-3 or largest == 0.0:
        return 1000.0, "µm"
    return 1e6, "nm"


def three_digits(value: float, *, sign: bool = False) -> str:
    """``value`` with three significant digits, trailing zeros kept, no dangling point.

    Examples
    --------
    >>> three_digits(2.0), three_digits(193.159), three_digits(0.0575), three_digits(-1.5, sign=True)
    ('2.00', '193', '0.0575', '-1.50')
    """
    text = format(value, "+#.3g" if sign else "#.3g")
    return text.rstrip(".") if "e" not in text else text
