"""Text files for reference data sets (pcmm_geo format and NIST-style ``.ds`` / ``.fit``).

pcmm_geo reference format (``.ref``), UTF-8 text::

    # pcmm_geo reference data set 1
    # element = "cylinder"
    # parameter point = [1.5, 2.0, -3.25]
    # parameter axis = [0.0, 0.0, 1.0]
    # parameter radius = 10.0
    # sampling = {"n_points": 3, "form": 0.0, ...}
    # columns = x y z e
    1.5 12.0 -3.25 0.0
    ...

Header lines start with ``#`` and hold ``key = JSON value``; then one row per point:
the coordinates (2 or 3) followed by the residual(s) (1, or 2 for line3d and the
3-D circles), written with 17 significant digits so a round trip is exact.

NIST style: ``NAME.ds`` (point count, then ``x<TAB>y<TAB>z`` rows) and ``NAME.fit``
(one number per line, lengths in mm, angles in degrees, see :mod:`pcmm_geo.io.nist`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from pcmm_geo._atomic import write_atomic
from pcmm_geo.errors import FileFormatError, InvalidInputError
from pcmm_geo.fit._reference.elements import ReferenceDataSet

__all__ = ["read_reference_data", "write_nist_pair", "write_reference_data"]

_MAGIC = "# pcmm_geo reference data set 1"
_TWO_COMPONENT = ("line3d", "circle3d", "circle3d_projected")


def _check_target(path: Path, overwrite: bool) -> None:
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path}: exists; pass overwrite=True to replace it")


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def write_reference_data(dataset: ReferenceDataSet, path: str | Path, *, overwrite: bool = False) -> Path:
    """Write ``dataset`` in the pcmm_geo reference format (see module docstring).

    Parameters
    ----------
    dataset : ReferenceDataSet
    path : str or Path
    overwrite : bool
        Replace an existing file (default: refuse).

    Returns
    -------
    Path

    Raises
    ------
    FileExistsError
        ``path`` exists and ``overwrite`` is False.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from pcmm_geo.fit.reference import make_reference_data
    >>> data = make_reference_data("sphere", n_points=8, form=0.01, rng=2)
    >>> path = write_reference_data(data, pathlib.Path(tempfile.mkdtemp()) / "s.ref")
    >>> back = read_reference_data(path)
    >>> bool((back.points == data.points).all()), back.parameters["radius"]
    (True, 10.0)
    """
    path = Path(path)
    _check_target(path, overwrite)
    dims = dataset.points.shape[1]
    coordinate_names = ["x", "y", "z"][:dims]
    residual_names = ["e1", "e2"] if dataset.residuals.ndim == 2 else ["e"]
    lines = [_MAGIC, f"# element = {json.dumps(dataset.element)}"]
    for name, value in dataset.parameters.items():
        lines.append(f"# parameter {name} = {json.dumps(_jsonable(value))}")
    lines.append(f"# sampling = {json.dumps({k: _jsonable(v) for k, v in dataset.sampling.items()})}")
    lines.append(f"# columns = {' '.join(coordinate_names + residual_names)}")
    residual_columns = dataset.residuals.reshape(len(dataset.points), -1)
    for point, residual in zip(dataset.points, residual_columns, strict=True):
        lines.append(" ".join(f"{value:.17g}" for value in (*point, *residual)))
    write_atomic(path, "\n".join(lines) + "\n", overwrite=overwrite)
    return path


def read_reference_data(path: str | Path) -> ReferenceDataSet:
    """Read a file written by :func:`write_reference_data`.

    Raises
    ------
    FileFormatError
        Missing magic line, bad header, a row with the wrong number of values
        (message gives path and line).

    Examples
    --------
    See :func:`write_reference_data`.
    """
    path = Path(path)
    text_lines = path.read_text(encoding="utf-8").splitlines()
    if not text_lines or text_lines[0].strip() != _MAGIC:
        raise FileFormatError(str(path), f"expected first line {_MAGIC!r}", 1)
    element: str | None = None
    parameters: dict[str, Any] = {}
    sampling: dict[str, Any] = {}
    columns: list[str] = []
    rows: list[list[float]] = []
    for number, raw in enumerate(text_lines[1:], start=2):
        line = raw.strip()
        if not line:
            continue
        if line.startswith("#"):
            key, sep, value = line[1:].partition("=")
            if not sep:
                raise FileFormatError(str(path), f"expected 'key = value' in the header, got {raw!r}", number)
            key = key.strip()
            try:
                decoded = json.loads(value) if key != "columns" else value.split()
            except json.JSONDecodeError as exc:
                raise FileFormatError(str(path), f"expected a JSON value for {key!r}: {exc.msg}", number) from None
            if key == "element":
                element = str(decoded)
            elif key.startswith("parameter "):
                name = key.removeprefix("parameter ").strip()
                parameters[name] = np.array(decoded, dtype=float) if isinstance(decoded, list) else float(decoded)
            elif key == "sampling":
                sampling = dict(decoded)
            elif key == "columns":
                columns = list(decoded)
            continue
        if not columns:
            raise FileFormatError(str(path), "expected a '# columns = ...' header before the data", number)
        fields = line.split()
        if len(fields) != len(columns):
            raise FileFormatError(str(path), f"expected {len(columns)} values, got {len(fields)}", number)
        try:
            values = [float(field) for field in fields]
        except ValueError:
            raise FileFormatError(str(path), f"expected numbers, got {line!r}", number) from None
        if not all(math.isfinite(v) for v in values):
            raise FileFormatError(str(path), f"expected finite numbers, got {line!r}", number)
        rows.append(values)
    if element is None:
        raise FileFormatError(str(path), "expected an '# element = ...' header line")
    table = np.array(rows, dtype=float).reshape(len(rows), len(columns))
    dims = sum(1 for name in columns if name in ("x", "y", "z"))
    points = table[:, :dims]
    residuals = table[:, dims:]
    residuals = residuals[:, 0] if residuals.shape[1] == 1 else residuals
    return ReferenceDataSet(element, points, parameters, residuals, points.copy(), sampling)


def _nist_fit_values(dataset: ReferenceDataSet) -> list[float]:
    p = dataset.parameters
    element = dataset.element
    if element in ("line2d", "line3d"):
        point, direction = _as3(p["point"]), _as3(p["direction"])
        return [*point, *direction]
    if element == "plane":
        return [*p["point"], *p["normal"]]
    if element == "circle2d":
        return [*_as3(p["center"]), 0.0, 0.0, 1.0, 2 * p["radius"]]
    if element in ("circle3d", "circle3d_projected"):
        return [*p["center"], *p["normal"], 2 * p["radius"]]
    if element == "sphere":
        return [*p["center"], 2 * p["radius"]]
    if element == "cylinder":
        return [*p["point"], *p["axis"], 2 * p["radius"]]
    if element == "cone":
        half_angle = p["half_angle"]
        s_distance = p["radius_at_point"] * math.cos(half_angle)
        return [*p["point"], *p["axis"], s_distance, math.degrees(2 * half_angle)]
    raise InvalidInputError("dataset.element", "an element NIST covers (not a torus)", repr(element))


def _as3(vector: Any) -> list[float]:
    values = [float(v) for v in np.asarray(vector, dtype=float)]
    return values + [0.0] * (3 - len(values))


def write_nist_pair(
    dataset: ReferenceDataSet, folder: str | Path, name: str, *, overwrite: bool = False
) -> tuple[Path, Path]:
    """Write ``dataset`` as a NIST-style pair ``folder/NAME.ds`` + ``folder/NAME.fit``.

    2-D data get ``z = 0``.  The cone is written NIST's way (axis point, axis towards
    growing radius, perpendicular distance ``s = r cos(alpha)``, full apex angle in
    degrees).  Put the pair in a folder named after the element type (``Sphere``,
    ``Cone``, ...) so :func:`pcmm_geo.io.nist.read_nist_pair` can read it back.

    Returns
    -------
    (Path, Path)
        The data and fit files.

    Raises
    ------
    InvalidInputError
        A torus (NIST has no torus format).
    FileExistsError
        A target exists and ``overwrite`` is False.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from pcmm_geo.fit.reference import make_reference_data
    >>> folder = pathlib.Path(tempfile.mkdtemp()) / "Sphere"
    >>> ds, fit = write_nist_pair(make_reference_data("sphere", rng=1), folder, "s1")
    >>> ds.name, fit.read_text().splitlines()[-1]
    ('s1.ds', '20')
    """
    folder = Path(folder)
    values = _nist_fit_values(dataset)
    data_path, fit_path = folder / f"{name}.ds", folder / f"{name}.fit"
    for target in (data_path, fit_path):
        _check_target(target, overwrite)
    folder.mkdir(parents=True, exist_ok=True)
    rows = [str(len(dataset.points))]
    rows += ["\t".join(f"{v:.17g}" for v in _as3(point)) for point in dataset.points]
    write_atomic(data_path, "\n".join(rows) + "\n", overwrite=overwrite)
    fit_path.write_text("\n".join(f"{float(v):.17g}" for v in values) + "\n", encoding="utf-8")
    return data_path, fit_path
