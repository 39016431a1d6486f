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


def nice_step(span: float, divisions: int = 4) -> float:
    """The smallest step of 1, 2 or 5 x 10^k that covers ``span`` in at most ``divisions`` steps.

    Examples
    --------
    >>> nice_step(8.69), nice_step(0.3), nice_step(0.0)
    (5.0, 0.1, 1.0)
    """
    import math

    if not (math.isfinite(span) and span > 0):
        return 1.0
    raw = span / divisions
    power = 10.0 ** math.floor(math.log10(raw))
    for factor in (1.0, 2.0, 5.0, 10.0):
        if factor * power >= raw * (1 - 1e-12):
            return factor * power
    return 10.0 * power  # pragma: no cover - the loop always returns


def polar_deviation_axes(axes: Any, deviations: Any, unit: str, *, reference: str) -> Any:
    """Scale polar ``axes`` for a deviation profile: labelled rings, the reference circle at 0.

    A deviation ``d`` (in ``unit``) is drawn at the radius ``r = base + d``, with ``base``
    chosen so that the rings stay clear of the centre; every ring carries its deviation
    value (``-2``, ``0``, ``+2 µm``), so a point's deviation is read off the rings like a
    roundness chart's.  Returns the function ``d -> r`` to plot with.

    Parameters
    ----------
    axes : matplotlib polar Axes
    deviations : array_like
        The deviations that will be drawn (``unit``).
    unit : str
    reference : str
        Name of the circle at deviation 0 (``"fitted circle"``), drawn and given to the legend.

    Examples
    --------
    >>> figure = new_figure(3, 3)
    >>> axes = figure.add_subplot(projection="polar")
    >>> to_radius = polar_deviation_axes(axes, [-3.1, 4.2], "µm", reference="fitted circle")
    >>> [label.get_text() for label in axes.get_yticklabels()]
    ['-4', '-2', '0', '+2', '+4', '+6 µm']
    >>> float(to_radius(2.0) - to_radius(0.0))
    2.0
    """
    import numpy as np

    values = np.asarray(deviations, dtype=float)
    values = values[np.isfinite(values)]
    low_value, high_value = (float(values.min()), float(values.max())) if values.size else (-1.0, 1.0)
    step = nice_step(max(high_value - low_value, 1e-300), divisions=5)
    low = step * np.floor(low_value / step - 1e-9)
    high = step * np.ceil(high_value / step + 1e-9)
    base = 1.2 * (high - low)  # the profile's band takes the outer half of the radius

    def to_radius(deviation: Any) -> Any:
        return base + (np.asarray(deviation, dtype=float) - low)

    levels = np.arange(low, high + 0.5 * step, step)
    labels = ["0" if abs(v) < 1e-9 * step else f"{v:+.10g}" for v in levels]
    labels[-1] += f" {unit}"
    axes.set_rgrids(to_radius(levels), labels, angle=22.5, fontsize=7, color="0.2")
    for text in axes.get_yticklabels():  # legible over the profile
        text.set_bbox({"facecolor": "white", "edgecolor": "none", "alpha": 0.75, "pad": 0.6})
    axes.set_ylim(0.0, float(to_radius(high)) + 0.15 * step)
    theta = np.linspace(0.0, 2 * np.pi, 361)
    axes.plot(theta, np.full_like(theta, float(to_radius(0.0))), color="black", linewidth=1.0, label=reference)
    axes.grid(True, color="0.8", linewidth=0.6)
    return to_radius


def data_under_legends(figure: Figure) -> list[str]:
    """What data each legend of ``figure`` covers: line vertices, markers, bars, spans (empty: none).

    Draws the figure (Agg), then tests, for every legend, the visible data of every 2-D axes
    in display coordinates: line vertices and points along each segment, scatter offsets and
    the extents of patches (bars, spans).  Used by the tests: a legend covers no data.

    Examples
    --------
    >>> figure = new_figure(3, 2)
    >>> axes = figure.add_subplot()
    >>> _ = axes.plot([0, 1], [0, 1], label="line")
    >>> _ = axes.legend(loc="upper left")
    >>> data_under_legends(figure)
    []
    >>> _ = axes.plot([0.0, 0.1], [0.98, 1.0], label="under the legend")
    >>> _ = axes.legend(loc="upper left")
    >>> data_under_legends(figure)[0].startswith("axes 0: line 'under the legend'")
    True
    """
    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(figure).draw()
    renderer = figure.canvas.get_renderer()
    legends = [(a.get_legend(), [a]) for a in figure.axes if a.get_legend() is not None]
    legends += [(legend, list(figure.axes)) for legend in figure.legends]
    found = []

    def inside(points: Any, box: Any, clip: Any) -> bool:
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        points = points[np.all(np.isfinite(points), axis=1)]
        visible = ((points[:, 0] >= clip.x0) & (points[:, 0] <= clip.x1) & (points[:, 1] >= clip.y0)
                   & (points[:, 1] <= clip.y1))
        points = points[visible]
        return bool(np.any((points[:, 0] > box.x0) & (points[:, 0] < box.x1) & (points[:, 1] > box.y0)
                           & (points[:, 1] < box.y1)))

    for legend, axes_list in legends:
        box = legend.get_window_extent(renderer).expanded(0.98, 0.96)
        for index, axes in ((figure.axes.index(a), a) for a in axes_list):
            if getattr(axes, "name", "") == "3d":
                continue
            clip = axes.get_window_extent(renderer)
            for line in axes.lines:
                xy = line.get_transform().transform(np.asarray(line.get_xydata(), dtype=float))
                if len(xy) >= 2 and len(xy) <= 5000:  # points along every segment, not only the vertices
                    steps = np.linspace(0.0, 1.0, 25)[:, None, None]
                    xy = (xy[:-1] + steps * (xy[1:] - xy[:-1])).reshape(-1, 2)
                if line.get_visible() and inside(xy, box, clip):
                    found.append(f"axes {index}: line {line.get_label()!r} under the legend")
            for collection in axes.collections:
                offsets = collection.get_offset_transform().transform(collection.get_offsets())
                if collection.get_visible() and len(offsets) and inside(offsets, box, clip):
                    found.append(f"axes {index}: markers {collection.get_label()!r} under the legend")
            for patch in axes.patches:
                extent = patch.get_window_extent(renderer)
                overlap = (min(extent.x1, box.x1, clip.x1) - max(extent.x0, box.x0, clip.x0),
                           min(extent.y1, box.y1, clip.y1) - max(extent.y0, box.y0, clip.y0))
                if patch.get_visible() and overlap[0] > 1 and overlap[1] > 1:
                    found.append(f"axes {index}: patch {patch.get_label()!r} under the legend")
                    break
    return found
