"""Files of the ISO 10360-6 harness: element parameters (CSV / JSON) and NIST reference pairs.

Element-parameter files (references or a tested software's results) use one schema:

* CSV with header ``name,element,x,y,z,i,j,k,size,size2,half_angle``: location, direction,
  radius (a cone's radius at the location), torus minor radius, cone half-angle (rad);
  empty cells where a value does not apply; ``#`` comment lines allowed;
* JSON: a list (or ``{"cases": [...]}``) of objects with ``name``, ``element``,
  ``location``, ``direction``, ``size``, ``size2``, ``half_angle``.

NIST reference pairs: a folder whose sub-folders are named after the element (``Plane``,
``Sphere``, ``Cylinder``, ``Cone``, ``Line2d``/``Line3d``, ``Circle2d``/``Circle3d``) and hold
``<name>.ds`` (point count, then x y z triples) with ``<name>.fit`` (NIST's numbers:
diameters, cone apex angle in degrees, the cone's orthogonal distance from the axis point to
the surface).  They are read by :func:`pcmm_geo.io.nist.iter_nist_pairs` and converted to
the harness schema (radii, half-angle, radius at the axis point).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pcmm_geo.artefacts.iso10360_6 import ElementParameters, ReferenceCase
from pcmm_geo.artefacts.table import cell_float, cell_text, read_rows
from pcmm_geo.errors import FileFormatError, InvalidInputError
from pcmm_geo.io.nist import NistPair, iter_nist_pairs

__all__ = ["load_reference_cases", "read_element_parameters"]

FloatArray = NDArray[np.float64]

def _nist_case(pair: NistPair) -> ReferenceCase:
    """Convert a NIST pair (read by :mod:`pcmm_geo.io.nist`) to the harness schema."""
    par = pair.parameters
    kind = pair.element
    if kind in ("line2d", "line3d"):
        ref = ElementParameters("line", par["point"], par["direction"])
    elif kind == "plane":
        ref = ElementParameters("plane", par["point"], par["normal"])
    elif kind in ("circle2d", "circle3d"):
        ref = ElementParameters("circle", par["center"], par["normal"], size=float(par["radius"]))
    elif kind == "sphere":
        ref = ElementParameters("sphere", par["center"], size=float(par["radius"]))
    elif kind == "cylinder":
        ref = ElementParameters("cylinder", par["point"], par["axis"], size=float(par["radius"]))
    else:  # cone: radius at the reported axis point = s / cos(half angle)
        ref = ElementParameters("cone", par["point"], par["axis"], size=float(par["radius_at_point"]),
                                half_angle=float(par["half_angle"]))
    planar = pair.constant_axis if kind in ("line2d", "circle2d") else None
    return ReferenceCase(pair.name, ref, np.asarray(pair.points, dtype=float), circle_method="projected",
                         planar_axis=planar)


def load_reference_cases(path: str | Path) -> list[ReferenceCase]:
    """Reference cases from a directory of NIST pairs or from an element-parameter file (CSV/JSON).

    Raises
    ------
    FileFormatError
        Malformed files, or a directory without complete pairs.
    OSError
        Missing path.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp()) / "Sphere"
    >>> folder.mkdir()
    >>> _ = (folder / "s1.ds").write_text("4\\n1 0 0\\n-1 0 0\\n0 1 0\\n0 0 1\\n")
    >>> _ = (folder / "s1.fit").write_text("0\\n0\\n0\\n2\\n")
    >>> [c.reference.size for c in load_reference_cases(folder.parent)]
    [1.0]
    """
    root = Path(path)
    if root.is_dir():
        cases = [_nist_case(pair) for pair in iter_nist_pairs(root)]
        if not cases:
            raise FileFormatError(str(root), "no NIST reference pairs (<Element>/<name>.ds + .fit) found")
        return cases
    if not root.exists():
        raise FileNotFoundError(f"{root}: no such file or directory")
    return [ReferenceCase(name, params) for name, params in read_element_parameters(root).items()]


def _vector(path: Path, where: str, value: object) -> FloatArray | None:
    if value is None:
        return None
    arr = np.asarray(value, dtype=float)
    if arr.shape != (3,):
        raise FileFormatError(str(path), f"{where}: expected 3 numbers, got {value!r}")
    return arr


def read_element_parameters(path: str | Path) -> dict[str, ElementParameters]:
    """Element parameters by case name from a CSV or JSON file (schema in the module docstring).

    Raises
    ------
    FileFormatError
        Malformed file, unknown element, missing values, duplicate names.
    OSError
        Unreadable file.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "r.json"
    >>> _ = f.write_text('[{"name": "p", "element": "plane", "location": [0, 0, 1], "direction": [0, 0, 2]}]')
    >>> read_element_parameters(f)["p"].direction.tolist()
    [0.0, 0.0, 1.0]
    """
    file = Path(path)
    out: dict[str, ElementParameters] = {}
    if file.suffix.lower() == ".json":
        from pcmm_geo.io.text import JsonNode, read_json_file

        data = read_json_file(file)
        root = JsonNode(data, str(file))
        items = root["cases"] if isinstance(data, dict) else root
        if not isinstance(items.value, list):
            raise items.fail('a list of cases or {"cases": [...]}')
        for index, item in enumerate(items.list()):
            name = item.object()["name"].string()
            where = f"case {index}"

            def optional_vector(key: str, case: JsonNode = item) -> FloatArray | None:
                node = case.get(key)
                return None if node is None else node.vector(3)

            def optional_number(key: str, case: JsonNode = item) -> float:
                node = case.get(key)
                return math.nan if node is None else node.number()

            try:
                params = ElementParameters(
                    item["element"].string().lower(),
                    optional_vector("location"),  # type: ignore[arg-type]
                    optional_vector("direction"),
                    size=optional_number("size"),
                    size2=optional_number("size2"),
                    half_angle=optional_number("half_angle"),
                )
            except InvalidInputError as exc:
                raise FileFormatError(str(file), f"{where} ({name}): {exc}") from None
            if name in out:
                raise FileFormatError(str(file), f"{item.where}.name: duplicate case name {name!r}")
            out[name] = params
    else:
        columns = ("name", "element", "x", "y", "z", "i", "j", "k", "size", "size2", "half_angle")
        for line, row in read_rows(file, columns):
            name = cell_text(file, line, row, "name")
            loc = np.array([cell_float(file, line, row, a) for a in "xyz"])
            direction = np.array([cell_float(file, line, row, a, allow_empty=True) for a in "ijk"])
            try:
                params = ElementParameters(
                    cell_text(file, line, row, "element").lower(),
                    loc,
                    None if np.all(np.isnan(direction)) else direction,
                    size=cell_float(file, line, row, "size", allow_empty=True),
                    size2=cell_float(file, line, row, "size2", allow_empty=True),
                    half_angle=cell_float(file, line, row, "half_angle", allow_empty=True),
                )
            except InvalidInputError as exc:
                raise FileFormatError(str(file), f"case {name}: {exc}", line=line) from None
            if name in out:
                raise FileFormatError(str(file), f"duplicate case name {name!r}", line=line)
            out[name] = params
    if not out:
        raise FileFormatError(str(file), "no cases")
    return out
